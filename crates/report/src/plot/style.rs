//! Colours, marker shapes and dash patterns, in the order series get them.

use plotters::style::RGBColor;

/// Okabe–Ito colours (colour-blind safe), without yellow and black.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
];
/// Histogram bars.
pub(super) const BAR: RGBColor = RGBColor(86, 150, 200);
/// Reference lines without a series colour.
pub(super) const REF: RGBColor = RGBColor(90, 90, 90);
/// Approximate width of one legend character in pixels (15 px sans-serif, generous).
pub(super) const CHAR_WIDTH_PX: f64 = 8.0;

/// Marker shapes, in the order series get them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Marker {
    Circle,
    Triangle,
    Square,
    Diamond,
    OpenCircle,
    OpenTriangle,
    OpenSquare,
    OpenDiamond,
}

const MARKERS: [Marker; 8] = [
    Marker::Circle,
    Marker::Triangle,
    Marker::Square,
    Marker::Diamond,
    Marker::OpenCircle,
    Marker::OpenTriangle,
    Marker::OpenSquare,
    Marker::OpenDiamond,
];

/// Dash patterns `(dash, gap)` in pixels, in the order series get them; `(0, 0)` is solid.
const DASHES: [(u32, u32); 4] = [(0, 0), (9, 5), (3, 4), (16, 5)];

pub(super) fn color_of(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

pub(super) fn marker_of(i: usize) -> Marker {
    MARKERS[i % MARKERS.len()]
}

pub(super) fn dash_of(i: usize) -> (u32, u32) {
    DASHES[i % DASHES.len()]
}
