//! The plotting layer's tests: the SVG text, ticks, markers, bars, CDF steps and errors.

use super::*;

/// Checks the document frame and returns the contents of every `<text>` element.
fn texts(svg: &str) -> Vec<String> {
    assert!(svg.starts_with("<svg"));
    assert!(svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
    svg.split("<text")
        .skip(1)
        .map(|t| {
            t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()]
                .trim()
                .to_string()
        })
        .collect()
}

fn has(texts: &[String], want: &str) -> bool {
    texts.iter().any(|t| t == want)
}

fn sweep_like(log_x: bool) -> Figure {
    let xs = [1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e6];
    let mut f = Figure::new("T", "μ0 (damping, log scale)", "iterations");
    f.x_scale = if log_x { Scale::Log } else { Scale::Linear };
    f.x_ticks = Some(xs.to_vec());
    f.dodge = true;
    for name in ["Levenberg", "Marquardt"] {
        let mut s = Series::new(
            name,
            xs.iter().map(|&x| (x, 3.0)).collect(),
            Style::LineMarkers,
        );
        s.bars = vec![(2.5, 3.5); xs.len()];
        f.series.push(s);
    }
    f.refs.push(RefLine::horizontal("paper: 3", 3.0));
    f
}

/// Centres of the filled circles (the first series' markers) in the SVG.
fn circles(svg: &str) -> Vec<(f64, f64)> {
    svg.lines()
        .filter(|l| l.starts_with("<circle"))
        .map(|l| {
            let attr = |a: &str| -> f64 {
                let i = l.find(&format!(" {a}=\"")).unwrap() + a.len() + 3;
                l[i..i + l[i..].find('"').unwrap()].parse().unwrap()
            };
            (attr("cx"), attr("cy"))
        })
        .collect()
}

#[test]
fn log_x_axis_spreads_log_spaced_values_and_labels_every_tick() {
    let svg = figure_svg(&sweep_like(true)).unwrap();
    let t = texts(&svg);
    for label in [
        "1e-9",
        "1e-6",
        "0.001",
        "1",
        "1000",
        "1e6",
        "μ0 (damping, log scale)",
        "iterations",
        "Levenberg",
        "Marquardt",
        "paper: 3",
        "T",
    ] {
        assert!(has(&t, label), "missing {label:?}");
    }
    // y ticks are labelled too.
    assert!(has(&t, "3"), "{t:?}");
    // The six points of a series sit at equal spacing (a linear axis would put five of
    // them at the same pixel).
    let c = circles(&svg);
    let xs: Vec<f64> = c.iter().take(6).map(|p| p.0).collect();
    let d: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(d.iter().all(|&x| x > 80.0), "{xs:?}");
    assert!(d.iter().all(|&x| (x - d[0]).abs() <= 2.0), "{d:?}");
    let lin = circles(&figure_svg(&sweep_like(false)).unwrap());
    assert!(
        (lin[0].0 - lin[3].0).abs() <= 1.0,
        "a linear axis squashes them: {lin:?}"
    );
}

#[test]
fn equal_curves_stay_distinct() {
    let svg = figure_svg(&sweep_like(true)).unwrap();
    // Series 0 has filled circles, series 1 filled triangles, dodged sideways.
    let circles = circles(&svg);
    assert_eq!(circles.len(), 6 + 1, "six markers and one legend sample");
    let triangles: Vec<&str> = svg.lines().filter(|l| l.starts_with("<polygon")).collect();
    assert!(triangles.len() > 6);
    // Different dash patterns: the second series is drawn in dashes (many short lines).
    let orange = format!(
        "#{:02X}{:02X}{:02X}",
        PALETTE[1].0, PALETTE[1].1, PALETTE[1].2
    );
    assert!(
        svg.lines()
            .filter(|l| l.starts_with("<polyline") && l.contains(&orange))
            .count()
            > 20
    );
    // Dodged: the first marker of series 0 is 6 px left of where no dodge puts it.
    let mut plain = sweep_like(true);
    plain.dodge = false;
    let undodged = super::tests::circles(&figure_svg(&plain).unwrap());
    assert!(
        (undodged[0].0 - circles[0].0 - 3.0).abs() <= 1.0,
        "{undodged:?} {circles:?}"
    );
}

#[test]
fn error_bars_are_drawn() {
    let svg = figure_svg(&sweep_like(true)).unwrap();
    let blue = format!(
        "#{:02X}{:02X}{:02X}",
        PALETTE[0].0, PALETTE[0].1, PALETTE[0].2
    );
    // One polyline per bar (caps and stem), 1 px wide, per series.
    let bars = svg
        .lines()
        .filter(|l| {
            l.starts_with("<polyline") && l.contains(&blue) && l.contains("stroke-width=\"1\"")
        })
        .count();
    assert_eq!(bars, 6);
}

#[test]
fn scale_auto() {
    assert_eq!(Scale::auto([1e-9, 1.0, 1e6]), Scale::Log);
    assert_eq!(Scale::auto([8.0, 150.0]), Scale::Linear);
    assert_eq!(Scale::auto([1.0, 100.0]), Scale::Log);
    assert_eq!(Scale::auto([0.0, 100.0]), Scale::Linear);
    assert_eq!(Scale::auto([]), Scale::Linear);
}

#[test]
fn a_sub_decade_log_axis_still_has_labelled_ticks() {
    let mut f = Figure::new("t", "x", "error (mm)");
    f.y_scale = Scale::Log;
    f.series.push(Series::new(
        "a",
        vec![(1.0, 0.34), (2.0, 0.45)],
        Style::LineMarkers,
    ));
    let t = texts(&figure_svg(&f).unwrap());
    let numeric = t
        .iter()
        .filter(|s| s.parse::<f64>().is_ok_and(|v| (0.3..0.5).contains(&v)))
        .count();
    assert!(numeric >= 2, "{t:?}");
}

#[test]
fn crowded_explicit_ticks_are_thinned() {
    let mut f = Figure::new("t", "poses", "e");
    let xs = [8.0, 11.0, 12.0, 13.0, 15.0, 20.0, 30.0, 50.0, 100.0, 150.0];
    f.x_ticks = Some(xs.to_vec());
    f.series.push(Series::new(
        "a",
        xs.iter().map(|&x| (x, 1.0)).collect(),
        Style::Markers,
    ));
    let t = texts(&figure_svg(&f).unwrap());
    assert!(has(&t, "8") && has(&t, "150") && has(&t, "50"));
    assert!(!has(&t, "11") || !has(&t, "12"), "{t:?}");
}

#[test]
fn cdf_steps_reach_one_hundred_percent() {
    let f = cdf_figure(
        "c",
        "e (mm)",
        &[("a".into(), vec![0.3, 0.1, 0.2])],
        Vec::new(),
    )
    .unwrap();
    let p = &f.series[0].points;
    assert_eq!(p.first(), Some(&(0.1, 0.0)));
    assert_eq!(p.last(), Some(&(0.3, 100.0)));
    assert!(p.windows(2).all(|w| w[1].0 >= w[0].0 && w[1].1 >= w[0].1));
    assert!(cdf_figure("c", "e", &[("a".into(), vec![])], Vec::new()).is_err());
}

#[test]
fn bad_input_is_an_error_naming_the_series() {
    let mut f = sweep_like(true);
    f.series[1].points[2].1 = f64::NAN;
    assert!(
        matches!(figure_svg(&f), Err(PlotError::NonFinite { series, index: 2, .. }) if series == "Marquardt")
    );
    let mut f = sweep_like(true);
    f.series[0].points[0].0 = -1.0;
    assert!(matches!(
        figure_svg(&f),
        Err(PlotError::InvalidValue { index: 0, .. })
    ));
    let mut f = sweep_like(true);
    f.series[0].bars.pop();
    assert!(matches!(
        figure_svg(&f),
        Err(PlotError::LengthMismatch {
            expected: 6,
            got: 5,
            ..
        })
    ));
    let mut f = sweep_like(true);
    f.series[0].points.clear();
    assert!(matches!(figure_svg(&f), Err(PlotError::Empty { .. })));
    assert!(matches!(panels_svg(&[], 500), Err(PlotError::Empty { .. })));
    assert!(matches!(
        histogram_svg("t", "x", "n", &[], &[]),
        Err(PlotError::Empty { .. })
    ));
    assert!(matches!(
        histogram_svg("t", "x", "n", &[(0.0, 1.0, 1), (2.0, 2.0, 2)], &[]),
        Err(PlotError::InvalidValue { index: 1, .. })
    ));
}

#[test]
fn text_is_escaped_and_output_deterministic() {
    let mut f = sweep_like(true);
    f.title = "a < b & c".into();
    let svg = figure_svg(&f).unwrap();
    assert!(texts(&svg).contains(&"a &lt; b &amp; c".to_string()));
    assert_eq!(svg, figure_svg(&f).unwrap());
}

#[test]
fn rebin_equal_width_and_conserves_counts() {
    let bins = rebin(&[(0.0, 2), (1.0, 1), (2.5, 4), (4.0, 3), (10.0, 5)], 5);
    assert_eq!(
        bins.iter().map(|b| b.2).collect::<Vec<_>>(),
        vec![3, 4, 3, 0, 5]
    );
    assert_eq!((bins[0].0, bins[4].1), (0.0, 10.0));
    let one = rebin(&[(2.0, 3), (2.0, 4)], 5);
    assert_eq!(
        one.iter().map(|b| b.2).collect::<Vec<_>>(),
        vec![0, 0, 7, 0, 0]
    );
    assert!(rebin(&[], 4).is_empty() && rebin(&[(1.0, 1)], 0).is_empty());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    #[test]
    fn rebin_properties(
        values in proptest::collection::vec((-1e3f64..1e3, 0u64..100), 1..40),
        n in 1usize..30,
    ) {
        let bins = rebin(&values, n);
        proptest::prop_assert_eq!(bins.len(), n);
        let total: u64 = values.iter().map(|v| v.1).sum();
        proptest::prop_assert_eq!(bins.iter().map(|b| b.2).sum::<u64>(), total);
        let mut reversed = values.clone();
        reversed.reverse();
        proptest::prop_assert_eq!(rebin(&reversed, n), bins);
    }
}
