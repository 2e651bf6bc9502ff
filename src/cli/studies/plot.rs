//! The studies' plots: scatter and line charts written as SVG by `plotters` (SVG backend, no
//! font files: text is emitted as SVG `<text>` and laid out by the viewer).
//!
//! Logarithmic axes are drawn by plotting `log10` of the data on a linear axis whose tick
//! labels show `10^v`; points that cannot be shown (non-finite, or ≤ 0 on a log axis) are
//! left out and counted in the legend.

use plotters::prelude::*;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesStyle {
    /// Points joined by lines, in the given order.
    Line,
    /// Points only.
    Points,
}

/// One named series of `(x, y)` points.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: SeriesStyle,
}

impl Series {
    /// A series drawn as joined points.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            style: SeriesStyle::Line,
        }
    }

    /// A series drawn as points.
    pub fn points(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            style: SeriesStyle::Points,
        }
    }

    /// The Pareto front of `points` when both coordinates are to be minimised: the points no
    /// other point beats in both, sorted by `x`, drawn as a line.
    pub fn pareto_front(label: impl Into<String>, points: &[(f64, f64)]) -> Self {
        let mut sorted: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut front: Vec<(f64, f64)> = Vec::new();
        for p in sorted {
            if front.last().is_none_or(|last| p.1 < last.1) {
                front.push(p);
            }
        }
        Self::line(label, front)
    }
}

/// A chart: title, axis labels, optional log axes, series.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis (with units).
    pub x_label: String,
    /// Label of the y axis (with units).
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The data.
    pub series: Vec<Series>,
}

impl Figure {
    /// A figure with linear axes and no series.
    pub fn new(title: impl Into<String>, x_label: &str, y_label: &str) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_x: false,
            log_y: false,
            series: Vec::new(),
        }
    }

    /// Sets logarithmic axes.
    pub fn log(mut self, x: bool, y: bool) -> Self {
        self.log_x = x;
        self.log_y = y;
        self
    }

    /// Adds a series.
    pub fn with(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Maps a data point to plot coordinates, if it can be shown.
    fn project(&self, (x, y): (f64, f64)) -> Option<(f64, f64)> {
        let axis = |v: f64, log: bool| match log {
            true if v > 0.0 => Some(v.log10()),
            true => None,
            false => Some(v),
        };
        let p = (axis(x, self.log_x)?, axis(y, self.log_y)?);
        (p.0.is_finite() && p.1.is_finite()).then_some(p)
    }

    /// The chart as an SVG document.
    pub fn svg(&self) -> Result<String, String> {
        let projected: Vec<(Vec<(f64, f64)>, usize)> = self
            .series
            .iter()
            .map(|s| {
                let shown: Vec<(f64, f64)> =
                    s.points.iter().filter_map(|&p| self.project(p)).collect();
                let hidden = s.points.len() - shown.len();
                (shown, hidden)
            })
            .collect();
        let all = || projected.iter().flat_map(|(p, _)| p.iter());
        let range = |coord: fn(&(f64, f64)) -> f64| {
            let lo = all().map(coord).fold(f64::INFINITY, f64::min);
            let hi = all().map(coord).fold(f64::NEG_INFINITY, f64::max);
            if !lo.is_finite() {
                return (0.0, 1.0);
            }
            let pad = if hi > lo {
                0.06 * (hi - lo)
            } else {
                0.5 * lo.abs().max(1e-12)
            };
            (lo - pad, hi + pad)
        };
        let (x0, x1) = range(|p| p.0);
        let (y0, y1) = range(|p| p.1);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (800, 500)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| e.to_string())?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", 18))
                .margin(15)
                .x_label_area_size(45)
                .y_label_area_size(80)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| e.to_string())?;
            let label = |log: bool| {
                move |v: &f64| {
                    if log {
                        format_number(10f64.powf(*v))
                    } else {
                        format_number(*v)
                    }
                }
            };
            let x_format = label(self.log_x);
            let y_format = label(self.log_y);
            chart
                .configure_mesh()
                .x_desc(axis_title(&self.x_label, self.log_x))
                .y_desc(axis_title(&self.y_label, self.log_y))
                .x_label_formatter(&x_format)
                .y_label_formatter(&y_format)
                .draw()
                .map_err(|e| e.to_string())?;
            for (k, (series, (points, hidden))) in self.series.iter().zip(&projected).enumerate() {
                let colour = Palette99::pick(k).to_rgba();
                let legend = if *hidden > 0 {
                    format!("{} ({hidden} not shown)", series.label)
                } else {
                    series.label.clone()
                };
                if series.style == SeriesStyle::Line {
                    chart
                        .draw_series(LineSeries::new(
                            points.iter().copied(),
                            colour.stroke_width(2),
                        ))
                        .map_err(|e| e.to_string())?;
                }
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                    .map_err(|e| e.to_string())?
                    .label(legend)
                    .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
            }
            if !self.series.is_empty() {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .draw()
                    .map_err(|e| e.to_string())?;
            }
            root.present().map_err(|e| e.to_string())?;
        }
        Ok(svg)
    }
}

fn axis_title(label: &str, log: bool) -> String {
    if log {
        format!("{label} (log scale)")
    } else {
        label.to_owned()
    }
}

/// Tick labels: three significant digits, scientific outside [10⁻³, 10⁵).
fn format_number(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let unit = 10f64.powi(a.log10().floor() as i32 - 2);
    let rounded = (v / unit).round() * unit;
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{rounded:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_have_three_significant_digits() {
        assert_eq!(format_number(1258.9254), "1260");
        assert_eq!(format_number(0.0063096), "0.00631");
        assert_eq!(format_number(2.5), "2.5");
        assert_eq!(format_number(1.0), "1");
        assert_eq!(format_number(3.16227e5), "3.16e5");
    }

    #[test]
    fn pareto_front_keeps_the_undominated_points() {
        let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (5.0, 1.0)];
        let front = Series::pareto_front("front", &pts);
        assert_eq!(front.points, vec![(1.0, 5.0), (2.0, 3.0), (4.0, 1.0)]);
    }

    #[test]
    fn svg_has_the_title_and_one_marker_per_shown_point() {
        let fig = Figure::new("t & test", "x", "y")
            .log(true, false)
            .with(Series::line(
                "a",
                vec![(1.0, 1.0), (10.0, 2.0), (-1.0, 3.0)],
            ));
        let svg = fig.svg().unwrap();
        assert!(svg.starts_with("<svg"));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("t &amp; test"));
        assert!(svg.contains("a (1 not shown)"));
        // Two data markers and one legend marker.
        assert_eq!(svg.matches("<circle").count(), 3);
    }
}
