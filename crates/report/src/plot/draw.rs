//! Drawing with plotters: a figure or stacked panels into one SVG ([`figure_svg`],
//! [`panels_svg`]), each panel's mesh, series, error bars, markers, category labels,
//! reference lines and legend.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::figure::{Figure, HEIGHT, LegendAt, PlotError, Style, WIDTH};
use super::layout::{LEGEND_ROW_PX, Prepared, ROUGH_PLOT_WIDTH_PX, prepare};
use super::style::{BAR, CHAR_WIDTH_PX, Marker, REF, color_of, dash_of, marker_of};
use super::ticks::Coord;

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<Coord, Coord>>;

/// A single-panel figure as SVG ([`WIDTH`]×[`HEIGHT`]).
///
/// # Errors
/// [`PlotError::Empty`] if there is no series or a series has no points,
/// [`PlotError::NonFinite`] / [`PlotError::InvalidValue`] naming the series and index,
/// [`PlotError::LengthMismatch`] if a series' bars do not match its points.
pub fn figure_svg(fig: &Figure) -> Result<String, PlotError> {
    panels_svg(std::slice::from_ref(fig), HEIGHT)
}

/// Panels stacked vertically in one SVG of [`WIDTH`]×`height`, each with its own axes.
///
/// # Errors
/// As [`figure_svg`], for any panel; [`PlotError::Empty`] if there are no panels.
pub fn panels_svg(panels: &[Figure], height: u32) -> Result<String, PlotError> {
    if panels.is_empty() {
        return Err(PlotError::empty("the list of panels"));
    }
    let panel_h = height as f64 / panels.len() as f64;
    let prepared: Vec<Prepared> = panels
        .iter()
        .map(|f| prepare(f, panel_h))
        .collect::<Result<_, _>>()?;
    render(height, |root| {
        let areas = root.split_evenly((panels.len(), 1));
        for ((area, fig), p) in areas.iter().zip(panels).zip(&prepared) {
            draw_panel(root, area, fig, p)?;
        }
        Ok(())
    })
}

/// Draws into a fresh white [`WIDTH`]×`height` SVG and returns its text.
fn render(
    height: u32,
    draw: impl FnOnce(&Area<'_>) -> Result<(), PlotError>,
) -> Result<String, PlotError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(PlotError::backend)?;
        draw(&root)?;
        root.present().map_err(PlotError::backend)?;
    }
    Ok(svg)
}

// plotters' SVG backend writes font sizes divided by 1.24 (its pixel-to-point factor): these
// give 17, 15 and 13.3 px in the SVG.
fn title_font() -> TextStyle<'static> {
    ("sans-serif", 21.08).into_font().into()
}

fn axis_font() -> TextStyle<'static> {
    ("sans-serif", 18.6).into_font().into()
}

fn tick_font() -> TextStyle<'static> {
    ("sans-serif", 16.49).into_font().into()
}

fn build<'a, 'b>(
    _root: &Area<'b>,
    area: &'a Area<'b>,
    fig: &Figure,
    p: &Prepared,
) -> Result<Chart<'a, 'b>, PlotError> {
    let mut builder = ChartBuilder::on(area);
    if !fig.title.is_empty() {
        builder.caption(&fig.title, title_font());
    }
    let mut chart = builder
        .margin(12)
        .margin_right(25)
        .x_label_area_size(p.x_area)
        .y_label_area_size(80)
        .build_cartesian_2d(p.x.clone(), p.y.clone())
        .map_err(PlotError::backend)?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(fig.x_title.as_str())
        .y_desc(fig.y_title.as_str())
        .axis_desc_style(axis_font())
        .label_style(tick_font())
        .light_line_style(TRANSPARENT)
        .bold_line_style(RGBColor(225, 225, 225).stroke_width(1));
    if fig.x_categories.is_some() {
        mesh.disable_x_mesh();
    }
    mesh.draw().map_err(PlotError::backend)?;
    Ok(chart)
}

fn draw_panel<'b>(
    root: &Area<'b>,
    area: &Area<'b>,
    fig: &Figure,
    p: &Prepared,
) -> Result<(), PlotError> {
    let mut chart = build(root, area, fig, p)?;
    if !fig.bins.is_empty() {
        draw_bins(&mut chart, fig, p)?;
    }
    draw_refs(&mut chart, fig)?;
    let n = fig.series.len();
    for (i, s) in fig.series.iter().enumerate() {
        let color = color_of(i);
        // Sideways shift of this series' markers, in pixels.
        let dx = if fig.dodge && n > 1 {
            (i as f64 - (n - 1) as f64 / 2.0) * 6.0
        } else {
            0.0
        };
        let px: Vec<(i32, i32)> = s
            .points
            .iter()
            .map(|pt| {
                let (x, y) = chart.backend_coord(pt);
                ((x as f64 + dx).round() as i32, y)
            })
            .collect();
        if matches!(s.style, Style::LineMarkers | Style::Line) {
            // In pixels, through the dodged markers (every point is inside the axes).
            let style = color.stroke_width(2);
            let d = dash_of(i);
            if d.0 == 0 {
                root.draw(&PathElement::new(px.clone(), style))
                    .map_err(PlotError::backend)?;
            } else {
                root.draw(&DashedPathElement::new(px.clone(), d.0, d.1, style))
                    .map_err(PlotError::backend)?;
            }
        }
        if !s.bars.is_empty() {
            let ylo = 10f64.powf(p.y.lo);
            for (k, &(lo, hi)) in s.bars.iter().enumerate() {
                let lo = if p.y.log { lo.max(ylo) } else { lo };
                let (_, plo) = chart.backend_coord(&(s.points[k].0, lo));
                let (_, phi) = chart.backend_coord(&(s.points[k].0, hi));
                let x = px[k].0;
                let style = color.stroke_width(1);
                root.draw(&PathElement::new(
                    vec![
                        (x - 4, plo),
                        (x + 4, plo),
                        (x, plo),
                        (x, phi),
                        (x - 4, phi),
                        (x + 4, phi),
                    ],
                    style,
                ))
                .map_err(PlotError::backend)?;
            }
        }
        if s.style != Style::Line {
            let r = if s.points.len() > 300 { 2 } else { 4 };
            for &q in &px {
                draw_marker(root, q, marker_of(i), color, r)?;
            }
        }
    }
    if let Some(c) = &fig.x_categories {
        let style = tick_font();
        let label_style = if p.rotate_categories {
            style
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Right, VPos::Center))
        } else {
            style.pos(Pos::new(HPos::Center, VPos::Top))
        };
        let y0 = 10f64.powf(p.y.lo);
        let y_at = if p.y.log { y0 } else { p.y.lo };
        for (i, label) in c.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64, y_at));
            root.draw(&PathElement::new(vec![(px, py), (px, py + 5)], BLACK))
                .map_err(PlotError::backend)?;
            root.draw(&Text::new(
                label.as_str(),
                (px, py + 8),
                label_style.clone(),
            ))
            .map_err(PlotError::backend)?;
        }
    }
    draw_legend(root, &chart, fig)
}

/// The histogram bars of `fig`, separated by a pixel on each side where a bar is at least
/// 6 px wide (the data's extent, bins and reference lines, per bin) on a linear axis.
fn draw_bins(chart: &mut Chart<'_, '_>, fig: &Figure, p: &Prepared) -> Result<(), PlotError> {
    let bins = &fig.bins;
    let refs = fig.refs.iter().map(|r| r.at);
    let lo = bins.iter().map(|b| b.0).fold(f64::INFINITY, f64::min);
    let hi = bins.iter().map(|b| b.1).fold(f64::NEG_INFINITY, f64::max);
    let lo = refs.clone().fold(lo, f64::min);
    let hi = refs.fold(hi, f64::max);
    let gap = u32::from(
        (hi - lo) / (p.x.hi - p.x.lo) * ROUGH_PLOT_WIDTH_PX / bins.len() as f64 >= 6.0 && !p.x.log,
    );
    chart
        .draw_series(bins.iter().map(|&(lo, hi, count)| {
            let mut bar = Rectangle::new([(lo, 0.0), (hi, count as f64)], BAR.filled());
            bar.set_margin(0, 0, gap, gap);
            bar
        }))
        .map_err(PlotError::backend)?;
    Ok(())
}

fn draw_line(
    chart: &mut Chart<'_, '_>,
    points: &[(f64, f64)],
    color: RGBColor,
    dash: (u32, u32),
    width: u32,
) -> Result<(), PlotError> {
    let style = color.stroke_width(width);
    if dash.0 == 0 {
        chart
            .draw_series(LineSeries::new(points.iter().copied(), style))
            .map_err(PlotError::backend)?;
    } else {
        chart
            .draw_series(DashedLineSeries::new(
                points.iter().copied(),
                dash.0,
                dash.1,
                style,
            ))
            .map_err(PlotError::backend)?;
    }
    Ok(())
}

fn draw_refs(chart: &mut Chart<'_, '_>, fig: &Figure) -> Result<(), PlotError> {
    let (xr, yr) = (chart.x_range(), chart.y_range());
    for r in &fig.refs {
        let color = r.color_of.map_or(REF, color_of);
        let pts = if r.vertical {
            vec![(r.at, yr.start), (r.at, yr.end)]
        } else {
            vec![(xr.start, r.at), (xr.end, r.at)]
        };
        draw_line(chart, &pts, color, (7, 5), 2)?;
    }
    Ok(())
}

fn draw_marker(
    root: &Area<'_>,
    (x, y): (i32, i32),
    m: Marker,
    color: RGBColor,
    r: i32,
) -> Result<(), PlotError> {
    let fill = color.filled();
    let stroke = color.stroke_width(2);
    let tri = |r: i32| vec![(x, y - r - 1), (x - r - 1, y + r), (x + r + 1, y + r)];
    let sq = |r: i32| {
        vec![
            (x - r, y - r),
            (x + r, y - r),
            (x + r, y + r),
            (x - r, y + r),
        ]
    };
    let dia = |r: i32| {
        vec![
            (x, y - r - 1),
            (x + r + 1, y),
            (x, y + r + 1),
            (x - r - 1, y),
        ]
    };
    let closed = |mut v: Vec<(i32, i32)>| {
        v.push(v[0]);
        v
    };
    match m {
        Marker::Circle => root.draw(&Circle::new((x, y), r, fill)),
        Marker::OpenCircle => root.draw(&Circle::new((x, y), r, stroke)),
        Marker::Triangle => root.draw(&Polygon::new(tri(r), fill)),
        Marker::OpenTriangle => root.draw(&PathElement::new(closed(tri(r)), stroke)),
        Marker::Square => root.draw(&Polygon::new(sq(r), fill)),
        Marker::OpenSquare => root.draw(&PathElement::new(closed(sq(r)), stroke)),
        Marker::Diamond => root.draw(&Polygon::new(dia(r), fill)),
        Marker::OpenDiamond => root.draw(&PathElement::new(closed(dia(r)), stroke)),
    }
    .map_err(PlotError::backend)
}

/// The legend: a white box in the chosen corner, one row per named series (line sample in
/// its dash pattern, marker) and per reference line.
fn draw_legend(root: &Area<'_>, chart: &Chart<'_, '_>, fig: &Figure) -> Result<(), PlotError> {
    /// Label, colour, marker, dash pattern.
    type Row = (String, RGBColor, Option<Marker>, Option<(u32, u32)>);
    let mut rows: Vec<Row> = Vec::new();
    for (i, s) in fig.series.iter().enumerate() {
        if s.name.is_empty() {
            continue;
        }
        let marker = (s.style != Style::Line).then(|| marker_of(i));
        let dash = (s.style != Style::Markers).then(|| dash_of(i));
        rows.push((s.name.clone(), color_of(i), marker, dash));
    }
    for r in fig.refs.iter().filter(|r| !r.label.is_empty()) {
        rows.push((
            r.label.clone(),
            r.color_of.map_or(REF, color_of),
            None,
            Some((7, 5)),
        ));
    }
    if rows.is_empty() {
        return Ok(());
    }
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let longest = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0) as f64;
    let w = (longest * CHAR_WIDTH_PX) as i32 + 56;
    let row = LEGEND_ROW_PX as i32;
    let h = row * rows.len() as i32 + 12;
    let x1 = xr.end - 8;
    let x0 = (x1 - w).max(xr.start + 4);
    let (y0, _y1) = match fig.legend {
        LegendAt::UpperRight => (yr.start + 8, yr.start + 8 + h),
        LegendAt::LowerRight => (yr.end - 8 - h, yr.end - 8),
    };
    root.draw(&Rectangle::new(
        [(x0, y0), (x1, y0 + h)],
        WHITE.mix(0.9).filled(),
    ))
    .map_err(PlotError::backend)?;
    root.draw(&Rectangle::new(
        [(x0, y0), (x1, y0 + h)],
        RGBColor(160, 160, 160).stroke_width(1),
    ))
    .map_err(PlotError::backend)?;
    for (k, (label, color, marker, dash)) in rows.iter().enumerate() {
        let y = y0 + 17 + row * k as i32;
        let (sx0, sx1) = (x0 + 8, x0 + 40);
        if let Some(d) = dash {
            let style = color.stroke_width(2);
            if d.0 == 0 {
                root.draw(&PathElement::new(vec![(sx0, y), (sx1, y)], style))
                    .map_err(PlotError::backend)?;
            } else {
                root.draw(&DashedPathElement::new(
                    vec![(sx0, y), (sx1, y)],
                    d.0,
                    d.1,
                    style,
                ))
                .map_err(PlotError::backend)?;
            }
        }
        if let Some(m) = marker {
            draw_marker(root, ((sx0 + sx1) / 2, y), *m, *color, 4)?;
        }
        root.draw(&Text::new(
            label.as_str(),
            (x0 + 48, y),
            tick_font().pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(PlotError::backend)?;
    }
    Ok(())
}
