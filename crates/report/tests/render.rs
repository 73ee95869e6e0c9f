//! Every committed SVG (`results/`, `docs/`) and every SVG inside a committed HTML report
//! renders with a real SVG renderer (resvg) and has data in its plot area.
//!
//! resvg needs fonts for `<text>`: the system's fonts are loaded (and DejaVu Sans or Liberation
//! Sans, when present, is the `sans-serif` family). Without any font the text is skipped by
//! the renderer, but the document must still parse and the data (lines, markers, bars) must
//! still be drawn, which is what the pixel count checks: pixels of a clearly coloured
//! (non-grey) hue left of the legend column, where only data is drawn in colour.
//!
//! `KINCAL_PNG_DIR=/some/dir cargo test -p report --test render` also writes each rendering
//! as PNG there, to look at; `KINCAL_RESULTS_DIR=DIR` checks DIR instead of `results/`.

use std::path::{Path, PathBuf};

fn options() -> resvg::usvg::Options<'static> {
    let mut opt = resvg::usvg::Options::default();
    let db = opt.fontdb_mut();
    db.load_system_fonts();
    for family in ["DejaVu Sans", "Liberation Sans", "Noto Sans"] {
        let query = resvg::usvg::fontdb::Query {
            families: &[resvg::usvg::fontdb::Family::Name(family)],
            ..Default::default()
        };
        if db.query(&query).is_some() {
            db.set_sans_serif_family(family);
            break;
        }
    }
    opt
}

/// Rasterises `svg`; panics naming `what` on a parse error. Returns (width, height, RGBA).
fn rasterise(svg: &str, what: &str, opt: &resvg::usvg::Options<'_>) -> resvg::tiny_skia::Pixmap {
    let tree = resvg::usvg::Tree::from_str(svg, opt)
        .unwrap_or_else(|e| panic!("{what}: the SVG does not parse: {e}"));
    let size = tree.size().to_int_size();
    assert!(
        size.width() >= 100 && size.height() >= 100,
        "{what}: tiny canvas {size:?}"
    );
    let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height()).expect("pixmap");
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::default(),
        &mut pixmap.as_mut(),
    );
    pixmap
}

/// Clearly coloured pixels in the left 70 % of the canvas below the title band: data, not
/// text, axes, grid or legend (all grey or black, or in the right-hand legend column).
fn data_pixels(p: &resvg::tiny_skia::Pixmap) -> usize {
    let (w, h) = (p.width() as usize, p.height() as usize);
    let data = p.data();
    let mut n = 0;
    for y in 40..h {
        for x in 0..(w * 7 / 10) {
            let i = 4 * (y * w + x);
            let (r, g, b) = (data[i] as i32, data[i + 1] as i32, data[i + 2] as i32);
            if (r - g).abs() + (g - b).abs() + (b - r).abs() > 90 {
                n += 1;
            }
        }
    }
    n
}

fn svgs_in_html(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = html;
    while let Some(start) = rest.find("<svg ") {
        let end = rest[start..].find("</svg>").expect("unterminated <svg>") + start + 6;
        out.push(rest[start..end].to_string());
        rest = &rest[end..];
    }
    out
}

fn files(dir: &Path, ext: &str, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files(&p, ext, out);
        } else if p.extension().is_some_and(|e| e == ext) {
            out.push(p);
        }
    }
}

fn check(svg: &str, what: &str, opt: &resvg::usvg::Options<'_>, png: Option<&Path>) {
    let pixmap = rasterise(svg, what, opt);
    let n = data_pixels(&pixmap);
    if let Some(dir) = png {
        let name = what.replace(['/', '#'], "_").replace(".svg", "") + ".png";
        pixmap.save_png(dir.join(name)).expect("writing the PNG");
    }
    assert!(n >= 150, "{what}: the plot area is empty ({n} data pixels)");
}

#[test]
fn every_committed_svg_and_html_report_renders_with_data_in_the_plot() {
    let root = std::env::var_os("KINCAL_RESULTS_DIR").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../results"),
        PathBuf::from,
    );
    let png = std::env::var_os("KINCAL_PNG_DIR").map(PathBuf::from);
    if let Some(d) = &png {
        std::fs::create_dir_all(d).unwrap();
    }
    let opt = options();
    let mut svgs = Vec::new();
    files(&root, "svg", &mut svgs);
    // The plots the documentation shows (docs/img), unless another directory was asked for.
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs");
    if std::env::var_os("KINCAL_RESULTS_DIR").is_none() {
        files(&docs, "svg", &mut svgs);
    }
    let mut htmls = Vec::new();
    files(&root, "html", &mut htmls);
    assert!(!svgs.is_empty(), "no SVG under {}", root.display());
    for path in &svgs {
        let text = std::fs::read_to_string(path).unwrap();
        let what = path
            .strip_prefix(&root)
            .or_else(|_| path.strip_prefix(&docs))
            .unwrap()
            .display()
            .to_string();
        check(&text, &what, &opt, png.as_deref());
    }
    for path in &htmls {
        let text = std::fs::read_to_string(path).unwrap();
        let what = path.strip_prefix(&root).unwrap().display().to_string();
        assert!(text.starts_with("<!DOCTYPE html>"), "{what}");
        assert!(!text.contains("<script"), "{what}: has a script");
        assert!(
            !text.contains("https://") && !text.contains("src=\"http"),
            "{what}: refers to the network"
        );
        let inner = svgs_in_html(&text);
        assert!(!inner.is_empty(), "{what}: no inline plot");
        for (k, svg) in inner.iter().enumerate() {
            check(svg, &format!("{what}#{k}"), &opt, png.as_deref());
        }
    }
}

#[test]
fn the_check_catches_an_empty_plot_and_a_broken_svg() {
    let opt = options();
    // Axes and title only: no data.
    let mut fig = report::Figure::new("empty", "x (mm)", "y (mm)");
    fig.series.push(report::Series::new(
        "",
        vec![(0.0, 0.0), (1.0, 1.0)],
        report::Style::Line,
    ));
    let svg = report::plot::figure_svg(&fig).unwrap();
    // The invisible frame series of a histogram is drawn; a real empty plot would be white,
    // so blank out its one line to check the counter.
    let blank = svg.replace("#0072B2", "#FFFFFF");
    assert!(data_pixels(&rasterise(&blank, "blank", &opt)) < 150);
    assert!(data_pixels(&rasterise(&svg, "line", &opt)) >= 150);
    assert!(resvg::usvg::Tree::from_str("<svg width=\"10\" height=\"10\"><path d=", &opt).is_err());
}

#[test]
fn the_identify_plots_render() {
    let opt = options();
    let e = |n: usize, s: f64| -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let t = i as f64;
                [
                    s * (t * 0.7).sin(),
                    s * (t * 1.3).cos(),
                    s * 0.5 * (t * 0.4).sin(),
                ]
            })
            .collect()
    };
    let (ib, ia, vb, va) = (e(100, 2.5), e(100, 0.3), e(1395, 2.8), e(1395, 0.35));
    let d = report::calibration::plots::IdentifyPlotData {
        robot: "UR10",
        identification_before_mm: &ib,
        identification_after_mm: &ia,
        validation_before_mm: Some(&vb),
        validation_after_mm: Some(&va),
        outlier_threshold: Some((0.5, 3.0)),
        outliers: &[7],
        outlier_labels: &[],
    };
    let png = std::env::var_os("KINCAL_PNG_DIR").map(PathBuf::from);
    for (file, svg) in report::calibration::plots::identify_plots(&d).unwrap() {
        check(&svg, &format!("identify-{file}"), &opt, png.as_deref());
    }
}

/// The outputs of a real-data calibration (the UR10 of data/ur10-ipa, every 15th row): the
/// files in writing order, `report.html` with every plot inline (captioned with its file name)
/// and nothing else, the plots the README and docs/reports.md show are this run's bytes, and
/// the console summary.
#[test]
fn the_ur10_calibration_renders() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let request = calibrate::IdentifyRequest {
        split: calibrate::Split::Every {
            every: 15,
            offset: 0,
        },
        ..calibrate::IdentifyRequest::new(
            root.join("scenarios/robots/ur10.json"),
            root.join("data/ur10-ipa/series-b-joint-configurations.csv"),
        )
    };
    let cal = calibrate::run(&request).unwrap();
    let rendered = report::calibration::render(&cal).unwrap();
    let names: Vec<&str> = rendered.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "identified.json",
            "registered-nominal.json",
            "parameters.json",
            "report.md",
            "report.html",
            "pose-errors.svg",
            "error-cdf.svg",
            "residuals-per-axis.svg",
            "outliers.svg",
            "outliers.csv",
        ]
    );
    // report.html holds every plot inline (captioned with its file name), nothing else.
    let html = &rendered[4].1;
    assert_eq!(html.matches("<svg ").count(), 4);
    for (name, svg) in &rendered[5..rendered.len() - 1] {
        assert!(svg.starts_with("<svg"), "{name}");
        assert!(html.contains(&format!("<code>{name}</code>")), "{name}");
    }
    // The README and docs/reports.md show two of these plots: they are this run's bytes.
    for name in ["pose-errors.svg", "error-cdf.svg"] {
        let shown = root.join("docs/img").join(format!("ur10-{name}"));
        let svg = &rendered.iter().find(|(n, _)| n == name).unwrap().1;
        assert!(
            std::fs::read_to_string(&shown).unwrap() == *svg,
            "{} differs from the {name} of `kincal identify --robot scenarios/robots/ur10.json \
             --data data/ur10-ipa/series-b-joint-configurations.csv --every 15`: copy it there",
            shown.display()
        );
    }
    assert!(report::calibration::summary(&cal).contains("validation: 1395 poses"));
}
