//! What a figure is: one panel's series, reference lines, axes and legend ([`Figure`]), and
//! why one cannot be drawn ([`PlotError`]).

/// Width of every figure, in pixels.
pub const WIDTH: u32 = 800;
/// Height of a single-panel figure, in pixels.
pub const HEIGHT: u32 = 500;

/// Why a plot could not be drawn.
#[derive(Debug, Clone, thiserror::Error)]
pub enum PlotError {
    /// There is nothing to plot.
    #[error("nothing to plot: {what} is empty")]
    Empty {
        /// Which input was empty.
        what: String,
    },
    /// A value is NaN or infinite.
    #[error("non-finite value {value:?} in series `{series}` at index {index}")]
    NonFinite {
        /// The series (or input) holding the value.
        series: String,
        /// Position of the value in its series (0-based).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// Two inputs that must pair up element by element have different lengths.
    #[error("length mismatch: {what} has {got} entries, expected {expected}")]
    LengthMismatch {
        /// Which input has the wrong length.
        what: String,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// A finite value that the plot still cannot represent (a negative standard deviation,
    /// a non-positive value on a log axis, a bin whose upper edge is not above its lower
    /// edge).
    #[error("invalid value {value:?} in series `{series}` at index {index}: {reason}")]
    InvalidValue {
        /// The series (or input) holding the value.
        series: String,
        /// Position of the value in its series (0-based).
        index: usize,
        /// The offending value.
        value: f64,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The plotting backend failed.
    #[error("plot backend failed: {0}")]
    Backend(String),
}

impl PlotError {
    /// [`PlotError::Empty`] for `what`.
    pub(super) fn empty(what: &str) -> PlotError {
        PlotError::Empty { what: what.into() }
    }

    /// [`PlotError::Backend`] with the backend's message.
    pub(super) fn backend<E: std::fmt::Display>(e: E) -> PlotError {
        PlotError::Backend(e.to_string())
    }
}

/// Linear or logarithmic axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    Linear,
    /// Base-10 logarithmic; every value on it must be positive.
    Log,
}

impl Scale {
    /// [`Scale::Log`] when every value is positive and the largest is at least 100 times the
    /// smallest (log-spaced values such as a damping sweep), else [`Scale::Linear`].
    pub fn auto(values: impl IntoIterator<Item = f64>) -> Scale {
        let (mut lo, mut hi, mut any) = (f64::INFINITY, 0.0f64, false);
        for v in values {
            if v <= 0.0 || !v.is_finite() {
                return Scale::Linear;
            }
            lo = lo.min(v);
            hi = hi.max(v);
            any = true;
        }
        if any && hi >= 100.0 * lo {
            Scale::Log
        } else {
            Scale::Linear
        }
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// Line through the points, with a marker at each (sweep curves).
    LineMarkers,
    /// Markers only (independent poses).
    Markers,
    /// Line only (an empirical CDF, drawn as steps by its caller).
    Line,
}

/// One named series of points.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text, in words.
    pub name: String,
    /// `(x, y)` points, drawn in the order given.
    pub points: Vec<(f64, f64)>,
    /// Empty, or one `(low, high)` error bar per point.
    pub bars: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
}

impl Series {
    /// A series without error bars.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Series {
            name: name.into(),
            points,
            bars: Vec::new(),
            style,
        }
    }
}

/// A labelled reference line.
#[derive(Clone, Debug, PartialEq)]
pub struct RefLine {
    /// Legend text, e.g. "paper: 0.340 mm".
    pub label: String,
    /// Where it is (y for a horizontal line, x for a vertical one).
    pub at: f64,
    /// Vertical (at an x value) or horizontal (at a y value).
    pub vertical: bool,
    /// `Some(i)`: the colour of series `i`; `None`: dark grey.
    pub color_of: Option<usize>,
}

impl RefLine {
    /// A horizontal grey line at `y`.
    pub fn horizontal(label: impl Into<String>, y: f64) -> Self {
        RefLine {
            label: label.into(),
            at: y,
            vertical: false,
            color_of: None,
        }
    }

    /// A vertical grey line at `x`.
    pub fn vertical(label: impl Into<String>, x: f64) -> Self {
        RefLine {
            label: label.into(),
            at: x,
            vertical: true,
            color_of: None,
        }
    }

    /// The same line in the colour of series `i`.
    pub fn colored(mut self, i: usize) -> Self {
        self.color_of = Some(i);
        self
    }
}

/// Where the legend goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LegendAt {
    /// Upper right corner (headroom is added above the data).
    UpperRight,
    /// Lower right corner, for data that leave it empty (a CDF); no headroom is added.
    LowerRight,
}

/// Everything one panel shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Title above the plot (may be empty for the lower panels of a multi-panel figure).
    pub title: String,
    /// x axis title, in words with unit.
    pub x_title: String,
    /// y axis title, in words with unit.
    pub y_title: String,
    /// x scale.
    pub x_scale: Scale,
    /// y scale.
    pub y_scale: Scale,
    /// Explicit x ticks (e.g. the sweep's values); `None`: 1-2-5 ticks.
    pub x_ticks: Option<Vec<f64>>,
    /// Category labels at x = 0, 1, …, n − 1 (parameter names); replaces the x ticks.
    pub x_categories: Option<Vec<String>>,
    /// Start a linear y axis at zero (counts, errors).
    pub y_from_zero: bool,
    /// Shift the markers of series `i` sideways so that coinciding points stay distinct.
    pub dodge: bool,
    /// Histogram bars, one per `(lo, hi, count)` bin: filled from zero, under the reference
    /// lines and the series (see [`histogram_svg`](super::histogram_svg)).
    pub bins: Vec<(f64, f64, u64)>,
    /// The series.
    pub series: Vec<Series>,
    /// Reference lines (drawn dashed, listed in the legend).
    pub refs: Vec<RefLine>,
    /// Legend corner.
    pub legend: LegendAt,
}

impl Figure {
    /// An empty linear figure with the given titles.
    pub fn new(
        title: impl Into<String>,
        x_title: impl Into<String>,
        y_title: impl Into<String>,
    ) -> Self {
        Figure {
            title: title.into(),
            x_title: x_title.into(),
            y_title: y_title.into(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            x_ticks: None,
            x_categories: None,
            y_from_zero: false,
            dodge: false,
            bins: Vec::new(),
            series: Vec::new(),
            refs: Vec::new(),
            legend: LegendAt::UpperRight,
        }
    }
}
