//! `densepack plot KIND`: SVG figures of a packing or of a run.
//!
//! Drawn with plotters' SVG backend without a font feature: text is written as SVG `<text>`
//! elements (sans-serif) that the viewer renders, so no font file or fontconfig is needed to
//! make a figure. Every figure is rendered in memory and written atomically; bad input
//! (unreadable file, unknown curve, plane outside the container, ...) exits with code 2 and
//! writes nothing.

use clap::{Args, Subcommand, ValueEnum};
use densepack::analysis::{
    section, section_axes, size_histogram, SectionCut, SectionOutline, SievePoint,
};
use densepack::io::packing::{write_atomically, Packing, ParticleRecord};
use densepack::protocol::take_phase::GradingSpec;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Arguments of `plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    #[command(subcommand)]
    kind: PlotKind,
}

/// The figures `plot` draws.
#[derive(Subcommand, Debug)]
enum PlotKind {
    /// Sieve curve (mass passing) of the packing's particles against a grading curve.
    Sieve {
        /// Packing file (JSON).
        packing: PathBuf,
        /// Grading curve: a DIN 1045-2 name (A8 … C16), fuller:Q:D_MAX, or a TOML file with a
        /// `grading` table (a scene file works). Default: the curve of the scene the packing
        /// was made from (its provenance).
        #[arg(long)]
        grading: Option<String>,
        /// Cut-off diameter of the comparison (default: the scene's d_min with the scene's
        /// curve, else the smallest particle).
        #[arg(long)]
        d_min: Option<f64>,
        /// Output SVG file (written atomically).
        #[arg(long)]
        out: PathBuf,
    },
    /// Histogram of the particle sizes (sieve diameters), bins equal in ln d.
    Sizes {
        /// Packing file (JSON).
        packing: PathBuf,
        /// Number of bins, 1..=1000.
        #[arg(long, default_value_t = 20)]
        bins: usize,
        /// Output SVG file (written atomically).
        #[arg(long)]
        out: PathBuf,
    },
    /// Section of the packing by the plane AXIS = AT: cut particles as discs (spheres),
    /// ellipses (ellipsoids) or polygons (cylinders) coloured by size, periodic images
    /// included, container outline.
    Section {
        /// Packing file (JSON).
        packing: PathBuf,
        /// Normal of the plane.
        #[arg(long, value_enum, default_value_t = AxisArg::Z)]
        axis: AxisArg,
        /// Position of the plane on the axis (inside the container, packing units).
        #[arg(long)]
        at: f64,
        /// Output SVG file (written atomically).
        #[arg(long)]
        out: PathBuf,
    },
    /// Radial distribution function g(r) of a sphere packing over r/(r_i + r_j), with the
    /// contact distance 1 and the split second peak's √3 and 2 marked (`densepack analyse`
    /// prints the peaks).
    Gr {
        /// Packing file (JSON).
        packing: PathBuf,
        /// Number of bins over the range (as `analyse --gr-bins`).
        #[arg(long = "gr-bins", default_value_t = densepack::analysis::structure::DEFAULT_GR_BINS)]
        bins: usize,
        /// Largest r/(r_i + r_j) (as `analyse --gr-range`).
        #[arg(long = "gr-range", default_value_t = densepack::analysis::structure::DEFAULT_GR_RANGE)]
        range: f64,
        /// Output SVG file (written atomically).
        #[arg(long)]
        out: PathBuf,
    },
    /// Packing fraction, reduced pressure and gap Δd over simulated time, from the log that
    /// `densepack run SCENE --out P --run-log RUNLOG` writes.
    Convergence {
        /// Run log (JSON lines).
        run_log: PathBuf,
        /// Output SVG file (written atomically).
        #[arg(long)]
        out: PathBuf,
    },
}

/// Axis normal to a section plane.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum AxisArg {
    X,
    Y,
    Z,
}

/// A failed plot: exit code 2 for bad input, 1 for a failed write.
enum PlotError {
    Input(String),
    Write(String),
}

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for PlotError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        PlotError::Write(format!("drawing failed: {e}"))
    }
}

/// Runs `plot`.
pub fn run(args: &PlotArgs) -> ExitCode {
    let (out, input) = match &args.kind {
        PlotKind::Sieve { out, packing, .. }
        | PlotKind::Sizes { out, packing, .. }
        | PlotKind::Section { out, packing, .. }
        | PlotKind::Gr { out, packing, .. } => (out, ("packing", packing.as_path())),
        PlotKind::Convergence { out, run_log } => (out, ("run log", run_log.as_path())),
    };
    let result = super::paths::check_outputs(&[("--out", out)], &[input])
        .map_err(PlotError::Input)
        .and_then(|()| render(&args.kind))
        .and_then(|svg| {
            write_atomically(out, |w| std::io::Write::write_all(w, svg.as_bytes()))
                .map_err(|e| PlotError::Write(format!("{}: {e}", out.display())))
        });
    match result {
        Ok(()) => {
            outln!("wrote {}", out.display());
            ExitCode::SUCCESS
        }
        Err(PlotError::Input(e)) => {
            errln!("error: {e}");
            ExitCode::from(2)
        }
        Err(PlotError::Write(e)) => {
            errln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// The SVG text of a figure.
fn render(kind: &PlotKind) -> Result<String, PlotError> {
    match kind {
        PlotKind::Sieve {
            packing,
            grading,
            d_min,
            ..
        } => {
            let packing = read_packing(packing)?;
            let (name, d_min, points, worst) = match grading {
                Some(text) => super::verify::sieve_against(&packing, text, *d_min),
                None => sieve_of_own_curve(&packing, *d_min),
            }
            .map_err(PlotError::Input)?;
            sieve_svg(&name, d_min, &points, worst)
        }
        PlotKind::Sizes { packing, bins, .. } => {
            if !(1..=1000).contains(bins) {
                return Err(PlotError::Input(format!(
                    "--bins = {bins}: must be in 1..=1000"
                )));
            }
            sizes_svg(&read_packing(packing)?, *bins)
        }
        PlotKind::Section {
            packing, axis, at, ..
        } => {
            let packing = read_packing(packing)?;
            let axis = *axis as usize;
            if !at.is_finite() {
                return Err(PlotError::Input(format!("--at = {at}: must be finite")));
            }
            section_svg(&packing, axis, *at)
        }
        PlotKind::Gr {
            packing,
            bins,
            range,
            ..
        } => {
            use densepack::analysis::structure::{check_gr, radial_distribution};
            let input =
                |e: densepack::analysis::structure::StructureError| PlotError::Input(e.to_string());
            check_gr(*bins, *range).map_err(input)?;
            let packing = read_packing(packing)?;
            let g = radial_distribution(&packing, *bins, *range).map_err(input)?;
            gr_svg(&g, packing.particles.len())
        }
        PlotKind::Convergence { run_log, .. } => convergence_svg(&read_run_log(run_log)?),
    }
}

/// g(r) as a line over r/(r_i + r_j), with dashed marks at 1, √3 and 2.
fn gr_svg(
    g: &densepack::analysis::structure::RadialDistribution,
    particles: usize,
) -> Result<String, PlotError> {
    let highest = g.g.iter().copied().fold(0.0, f64::max);
    // The contact peak of a jammed packing is a δ-like spike: cap the axis so that the
    // split second peak stays visible, and say so in the caption.
    let top = highest.clamp(1.5, 6.0);
    let range = g.centres.last().map_or(1.0, |c| c + 0.5 * g.bin_width);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, FIGURE).into_drawing_area();
        root.fill(&WHITE)?;
        let caption = format!(
            "g(r): {particles} particles, {} references{}",
            g.references,
            if highest > top {
                format!(", contact peak {highest:.0} (cut)")
            } else {
                String::new()
            }
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", TITLE))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..range, 0.0..1.05 * top)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .label_style(LABELS)
            .axis_desc_style(LABELS)
            .x_label_formatter(&|x| short(*x))
            .x_desc("r / (r_i + r_j)")
            .y_desc("g(r)")
            .y_label_formatter(&|y| short(*y))
            .draw()?;
        for mark in [1.0, 3f64.sqrt(), 2.0] {
            if mark <= range {
                chart.draw_series(DashedLineSeries::new(
                    [(mark, 0.0), (mark, 1.05 * top)],
                    4,
                    4,
                    BLACK.mix(0.4).into(),
                ))?;
            }
        }
        chart.draw_series(LineSeries::new(
            g.centres
                .iter()
                .zip(&g.g)
                .map(|(&x, &y)| (x, y.min(1.05 * top))),
            DATA.stroke_width(2),
        ))?;
        root.present()?;
    }
    Ok(svg)
}

fn read_packing(path: &Path) -> Result<Packing, PlotError> {
    Packing::read(path).map_err(|e| PlotError::Input(e.to_string()))
}

/// The sieve curve against the grading curve of the scene the packing was made from.
fn sieve_of_own_curve(
    packing: &Packing,
    d_min: Option<f64>,
) -> Result<(String, f64, Vec<SievePoint>, f64), String> {
    let particles = packing
        .provenance
        .as_ref()
        .and_then(|p| p.scene.get("particles"));
    let spec = particles
        .and_then(|p| p.get("grading"))
        .filter(|g| !g.is_null())
        .ok_or("the packing's scene has no grading curve: give one with --grading")?;
    let spec: GradingSpec = serde_json::from_value(spec.clone())
        .map_err(|e| format!("the packing's scene grading: {e}"))?;
    let curve = spec
        .build()
        .map_err(|e| format!("the packing's scene grading: {e}"))?;
    let scene_d_min = particles
        .and_then(|p| p.get("d_min"))
        .and_then(|d| d.as_f64());
    super::verify::sieve_against_curve(packing, &curve, spec.describe(), d_min.or(scene_d_min))
}

/// Size of every figure but the section (pixels).
const FIGURE: (u32, u32) = (800, 560);
/// Title font size.
const TITLE: u32 = 22;
/// Axis labels and descriptions.
const LABELS: (&str, u32) = ("sans-serif", 14);

/// A number with at most 4 significant digits and no trailing zeros.
fn short(x: f64) -> String {
    let text = format!("{x:.4}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    text.to_string()
}
/// The colour of data drawn against a reference (sieve curve, histogram bars).
const DATA: RGBColor = RGBColor(0xC0, 0x39, 0x2B);
/// Histogram bars.
const BARS: RGBColor = RGBColor(0x46, 0x82, 0xB4);

fn sieve_svg(
    name: &str,
    d_min: f64,
    points: &[SievePoint],
    worst: f64,
) -> Result<String, PlotError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, FIGURE).into_drawing_area();
        root.fill(&WHITE)?;
        let d_max = points.last().map_or(2.0 * d_min, |p| p.size);
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("Sieve curve against {name}"), ("sans-serif", TITLE))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d((d_min..d_max).log_scale().base(2.0), 0.0..100.0)?;
        chart
            .configure_mesh()
            .label_style(LABELS)
            .axis_desc_style(LABELS)
            .x_label_formatter(&|d| short(*d))
            .x_desc("sieve size (packing units)")
            .y_desc("passing (% of particle volume)")
            .draw()?;
        chart
            .draw_series(LineSeries::new(
                points.iter().map(|p| (p.size, 100.0 * p.target)),
                BLACK.stroke_width(2),
            ))?
            .label("target grading curve")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        chart
            .draw_series(LineSeries::new(
                points.iter().map(|p| (p.size, 100.0 * p.passing)),
                DATA.stroke_width(2),
            ))?
            .label(format!(
                "packing (d_min = {d_min:.4}, largest deviation {:.1} %)",
                100.0 * worst
            ))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], DATA.stroke_width(2)));
        chart.draw_series(
            points
                .iter()
                .map(|p| Circle::new((p.size, 100.0 * p.passing), 3, DATA.filled())),
        )?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(("sans-serif", 15))
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}

fn sizes_svg(packing: &Packing, bins: usize) -> Result<String, PlotError> {
    let histogram = size_histogram(packing, bins);
    let (Some(first), Some(last)) = (histogram.first(), histogram.last()) else {
        return Err(PlotError::Input("the packing has no particles".into()));
    };
    let title = format!("Particle sizes: {} particles", packing.particles.len());
    let (lo, hi) = (first.lo, last.hi);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, FIGURE).into_drawing_area();
        root.fill(&WHITE)?;
        // A log axis labels the powers of 2 only: over less than two octaves it may have
        // none, so a narrow size range gets a linear axis.
        if hi < 4.0 * lo {
            draw_size_bars(&root, lo..hi, &histogram, title)?;
        } else {
            draw_size_bars(&root, (lo..hi).log_scale().base(2.0), &histogram, title)?;
        }
        root.present()?;
    }
    Ok(svg)
}

/// The histogram's bars on `root`, over the x axis `x` (linear or logarithmic in size).
fn draw_size_bars<X>(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    x: X,
    histogram: &[densepack::analysis::SizeBin],
    title: String,
) -> Result<(), PlotError>
where
    X: plotters::coord::ranged1d::AsRangedCoord<Value = f64>,
    X::CoordDescType: plotters::coord::ranged1d::ValueFormatter<f64>,
{
    let highest = histogram.iter().map(|b| b.count).max().unwrap_or(1) as f64;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", TITLE))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(x, 0.0..1.08 * highest)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .label_style(LABELS)
        .axis_desc_style(LABELS)
        .x_label_formatter(&|d| short(*d))
        .x_desc("sieve diameter (packing units)")
        .y_desc("particles per bin")
        .y_label_formatter(&|y| format!("{y:.0}"))
        .draw()?;
    chart.draw_series(
        histogram
            .iter()
            .filter(|b| b.count > 0)
            .map(|b| Rectangle::new([(b.lo, 0.0), (b.hi, b.count as f64)], BARS.filled())),
    )?;
    Ok(())
}

/// Longest side of a section's plotting area (pixels).
const SECTION_SIDE: f64 = 720.0;
/// Vertices of the polygon drawn for an ellipse.
const ELLIPSE_VERTICES: usize = 72;

fn section_svg(packing: &Packing, axis: usize, at: f64) -> Result<String, PlotError> {
    let cut = section(packing, axis, at).map_err(|e| PlotError::Input(e.to_string()))?;
    let names = ['x', 'y', 'z'];
    let [h, v] = section_axes(axis);
    let (lo, hi) = match &cut.outline {
        SectionOutline::Rectangle { min, max } => (*min, *max),
        SectionOutline::Circle { center, radius } => (
            [center[0] - radius, center[1] - radius],
            [center[0] + radius, center[1] + radius],
        ),
    };
    let (width, height) = (hi[0] - lo[0], hi[1] - lo[1]);
    if !(width > 0.0 && height > 0.0) {
        return Err(PlotError::Input(format!(
            "--at = {at}: the plane only touches the container (section of zero area)"
        )));
    }
    // One scale on both axes: the plotting area has the container's aspect ratio.
    let scale = SECTION_SIDE / width.max(height);
    let (plot_w, plot_h) = ((scale * width).round(), (scale * height).round());
    let (margin, left, bottom, title, bar) = (15u32, 60u32, 45u32, 40u32, 130u32);
    let size = (
        margin + left + plot_w as u32 + margin + bar,
        title + plot_h as u32 + bottom + margin,
    );
    let sizes: Vec<f64> = packing
        .particles
        .iter()
        .map(ParticleRecord::sieve_diameter)
        .collect();
    let smallest = sizes.iter().copied().fold(f64::INFINITY, f64::min);
    let largest = sizes.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let one_size = largest <= smallest;
    let largest = if largest > smallest {
        largest
    } else {
        smallest * (1.0 + 1e-9) + f64::MIN_POSITIVE
    };
    let colour =
        |particle: usize| ViridisRGB.get_color_normalized(sizes[particle], smallest, largest);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE)?;
        let (main, colour_bar) = root.split_horizontally(size.0 - bar);
        let plot_area = main.margin(title, margin, margin, margin);
        let mut chart = ChartBuilder::on(&plot_area)
            .x_label_area_size(bottom)
            .y_label_area_size(left)
            .build_cartesian_2d(lo[0]..hi[0], lo[1]..hi[1])?;
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let pixels_per_unit =
            0.5 * ((xs.end - xs.start) as f64 / width + (ys.end - ys.start) as f64 / height);
        for c in &cut.cuts {
            let style = colour(c.particle()).filled();
            match c {
                SectionCut::Disc { center, radius, .. } => {
                    chart.draw_series(std::iter::once(Circle::new(
                        (center[0], center[1]),
                        (radius * pixels_per_unit).round() as u32,
                        style,
                    )))?;
                }
                SectionCut::Polygon { vertices, .. } => {
                    chart.draw_series(std::iter::once(Polygon::new(
                        vertices.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>(),
                        style,
                    )))?;
                }
                SectionCut::Ellipse {
                    center,
                    semi_axes: [a, b],
                    angle,
                    ..
                } => {
                    let (s, co) = angle.sin_cos();
                    let vertices = (0..ELLIPSE_VERTICES).map(|k| {
                        let phi = std::f64::consts::TAU * k as f64 / ELLIPSE_VERTICES as f64;
                        let (u, w) = (a * phi.cos(), b * phi.sin());
                        (center[0] + co * u - s * w, center[1] + s * u + co * w)
                    });
                    chart.draw_series(std::iter::once(Polygon::new(
                        vertices.collect::<Vec<_>>(),
                        style,
                    )))?;
                }
            }
        }
        // Periodic images reach past the container: cover everything outside its bounding
        // rectangle, then draw the axes and the outline on top.
        let (x0, y1) = chart.backend_coord(&(lo[0], lo[1]));
        let (x1, y0) = chart.backend_coord(&(hi[0], hi[1]));
        let (w, hgt) = (size.0 as i32, size.1 as i32);
        for [a, b] in [
            [(0, 0), (w, y0)],
            [(0, y1), (w, hgt)],
            [(0, y0), (x0, y1)],
            [(x1, y0), (w, y1)],
        ] {
            root.draw(&Rectangle::new([a, b], WHITE.filled()))?;
        }
        chart
            .configure_mesh()
            .disable_mesh()
            .label_style(LABELS)
            .axis_desc_style(LABELS)
            .x_desc(format!("{} (packing units)", names[h]))
            .y_desc(format!("{} (packing units)", names[v]))
            .draw()?;
        match &cut.outline {
            SectionOutline::Rectangle { min, max } => {
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(min[0], min[1]), (max[0], max[1])],
                    BLACK.stroke_width(2),
                )))?;
            }
            SectionOutline::Circle { center, radius } => {
                chart.draw_series(std::iter::once(Circle::new(
                    (center[0], center[1]),
                    (radius * pixels_per_unit).round() as u32,
                    BLACK.stroke_width(2),
                )))?;
            }
        }
        main.draw_text(
            &format!(
                "Section {} = {at}: {} cuts of {} particles",
                names[axis],
                cut.cuts.len(),
                packing.particles.len()
            ),
            &("sans-serif", TITLE).into_text_style(&main),
            (margin as i32 + left as i32, 8),
        )?;
        if one_size {
            // Every particle has the same size: one swatch and one label, not a bar whose
            // ticks all print the same number.
            let swatch = colour_bar.margin(title, bottom, 10, 0);
            let (w, h) = swatch.dim_in_pixel();
            let side = (w.min(h) as i32).min(40);
            swatch.draw(&Rectangle::new(
                [(0, 0), (side, side)],
                ViridisRGB
                    .get_color_normalized(smallest, smallest, largest)
                    .filled(),
            ))?;
            swatch.draw_text(
                &format!("size {}", short(smallest)),
                &LABELS.into_text_style(&swatch),
                (0, side + 8),
            )?;
        } else {
            draw_colour_bar(&colour_bar, smallest, largest, title, bottom)?;
        }
        root.present()?;
    }
    Ok(svg)
}

/// A vertical colour bar from `smallest` to `largest` size (viridis, as the section).
fn draw_colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    smallest: f64,
    largest: f64,
    top: u32,
    bottom: u32,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    const STEPS: usize = 64;
    let mut bar = ChartBuilder::on(&area.margin(top, bottom, 10, 0))
        .y_label_area_size(85)
        .build_cartesian_2d(0.0..1.0, smallest..largest)?;
    bar.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .label_style(LABELS)
        .axis_desc_style(LABELS)
        .y_label_formatter(&|d| short(*d))
        .y_desc("size (sieve diameter)")
        .y_labels(6)
        .draw()?;
    let step = (largest - smallest) / STEPS as f64;
    bar.draw_series((0..STEPS).map(|k| {
        let lo = smallest + step * k as f64;
        Rectangle::new(
            [(0.0, lo), (1.0, lo + step)],
            ViridisRGB
                .get_color_normalized(lo + 0.5 * step, smallest, largest)
                .filled(),
        )
    }))?;
    Ok(())
}

/// One progress record of a run log.
struct Tick {
    /// Simulated time since the run's first logged stage began.
    time: f64,
    packing_fraction: f64,
    reduced_pressure: Option<f64>,
    gap: Option<f64>,
}

/// Reads a run log (`densepack run --run-log`): a tick per progress record, its time the
/// stage time plus the simulated times of the stages logged before, and a tick per stage
/// record for the state the stage ended in.
fn read_run_log(path: &Path) -> Result<Vec<Tick>, PlotError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| PlotError::Input(format!("{}: {e}", path.display())))?;
    let bad = |line: usize, what: &str| {
        PlotError::Input(format!(
            "{}:{line}: {what} (a run log holds the JSON lines `densepack run --run-log` writes)",
            path.display()
        ))
    };
    let mut ticks = Vec::new();
    let mut offset = 0.0;
    for (k, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let record: serde_json::Value =
            serde_json::from_str(line).map_err(|e| bad(k + 1, &format!("not JSON: {e}")))?;
        match record.get("type").and_then(|t| t.as_str()) {
            Some("progress") => {
                let number = |key: &str| record.get(key).and_then(|x| x.as_f64());
                let (Some(stage_time), Some(packing_fraction)) =
                    (number("stage_time"), number("packing_fraction"))
                else {
                    return Err(bad(
                        k + 1,
                        "a progress record needs stage_time and packing_fraction",
                    ));
                };
                ticks.push(Tick {
                    time: offset + stage_time,
                    packing_fraction,
                    reduced_pressure: number("reduced_pressure").filter(|z| *z > 0.0),
                    gap: number("gap"),
                });
            }
            Some("stage") => {
                // The stage's end state (progress records stop at its last barrier).
                let number = |key: &str| record.pointer(key).and_then(|x| x.as_f64());
                let (Some(duration), Some(packing_fraction)) = (
                    number("/report/simulated_time"),
                    number("/report/packing_fraction"),
                ) else {
                    return Err(bad(
                        k + 1,
                        "a stage record needs report.simulated_time and report.packing_fraction",
                    ));
                };
                offset += duration;
                ticks.push(Tick {
                    time: offset,
                    packing_fraction,
                    reduced_pressure: number("/report/reduced_pressure").filter(|z| *z > 0.0),
                    gap: None,
                });
            }
            _ => return Err(bad(k + 1, "not a progress or stage record")),
        }
    }
    if ticks.is_empty() {
        return Err(PlotError::Input(format!(
            "{}: no progress records (write a run log with `densepack run SCENE --out P --run-log FILE`)",
            path.display()
        )));
    }
    Ok(ticks)
}

/// `[lo, hi]` widened by 5 % (or around a single value), so that no range is empty.
fn padded(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    });
    let pad = (0.05 * (hi - lo)).max(1e-6 * hi.abs()).max(1e-300);
    (lo - pad, hi + pad)
}

fn convergence_svg(ticks: &[Tick]) -> Result<String, PlotError> {
    let pressures: Vec<(f64, f64)> = ticks
        .iter()
        .filter_map(|t| t.reduced_pressure.map(|z| (t.time, z)))
        .collect();
    let gaps: Vec<(f64, f64)> = ticks
        .iter()
        .filter_map(|t| t.gap.map(|g| (t.time, g)))
        .collect();
    let panels = 1 + usize::from(!pressures.is_empty()) + usize::from(!gaps.is_empty());
    let (t0, t1) = padded(ticks.iter().map(|t| t.time));
    let t0 = t0.max(0.0);
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (FIGURE.0, 300 * panels as u32)).into_drawing_area();
        root.fill(&WHITE)?;
        let areas = root.split_evenly((panels, 1));
        let mut areas = areas.iter();
        let chart = |area| {
            let mut builder = ChartBuilder::on(area);
            builder
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(75);
            builder
        };
        let area = areas.next().expect("one panel at least");
        let (p0, p1) = padded(ticks.iter().map(|t| t.packing_fraction));
        let mut phi = chart(area)
            .caption("packing fraction φ", ("sans-serif", 18))
            .build_cartesian_2d(t0..t1, p0..p1)?;
        phi.configure_mesh()
            .label_style(LABELS)
            .axis_desc_style(LABELS)
            .x_desc("simulated time")
            .y_desc("φ")
            .draw()?;
        phi.draw_series(LineSeries::new(
            ticks.iter().map(|t| (t.time, t.packing_fraction)),
            BLUE.stroke_width(2),
        ))?;
        if !pressures.is_empty() {
            let area = areas.next().expect("a pressure panel");
            // log₁₀ Z on a linear axis: Z spans 1 to 10¹² in a run to jamming, a factor
            // of 2 in a short one, and plotters' log axis has no ticks for the latter.
            let (z0, z1) = padded(pressures.iter().map(|p| p.1.log10()));
            let mut z = chart(area)
                .caption("reduced pressure Z = pV/(NkT)", ("sans-serif", 18))
                .build_cartesian_2d(t0..t1, z0..z1)?;
            z.configure_mesh()
                .label_style(LABELS)
                .axis_desc_style(LABELS)
                .x_desc("simulated time")
                .y_desc("log₁₀ Z")
                .draw()?;
            z.draw_series(LineSeries::new(
                pressures.iter().map(|&(t, z)| (t, z.log10())),
                RED.stroke_width(2),
            ))?;
        }
        if !gaps.is_empty() {
            let area = areas.next().expect("a gap panel");
            let (_, g1) = padded(gaps.iter().map(|g| g.1));
            let mut gap = chart(area)
                .caption(
                    "gap Δd between the grains at their true sizes",
                    ("sans-serif", 18),
                )
                .build_cartesian_2d(t0..t1, 0.0..g1.max(1e-300))?;
            gap.configure_mesh()
                .label_style(LABELS)
                .axis_desc_style(LABELS)
                .x_desc("simulated time")
                .y_desc("Δd (packing units)")
                .draw()?;
            gap.draw_series(LineSeries::new(gaps.iter().copied(), GREEN.stroke_width(2)))?;
        }
        root.present()?;
    }
    Ok(svg)
}
