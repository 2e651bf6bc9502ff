//! Ellipsoid studies (paper 004, Ghossein & Lévesque 2013): the cost and accuracy of the two
//! collision predictors on random pairs ([`predictor`]), and the paper's Table 2 cases beside
//! densepack with both predictors ([`table2`]), the isotropy of the packings against N
//! (Fig. 6, [`isotropy`]), and the cost laws of Figs. 7–9: CPU time against N, the volume
//! fraction and the aspect ratio with fitted exponents beside the paper's
//! ([`cost_against_n`], [`cost_against_fraction`], [`cost_against_aspect`]).
//!
//! Accuracy is judged by the independent check: the Perram–Wertheim contact scale of
//! [`densepack::verify::contact_scale`] at each predicted contact (< 1 would be an overlap), and
//! for whole runs the smallest gap that [`densepack::verify`] finds in the written packing. The
//! contact tolerance (scene key `particles.ellipsoid.contact_tolerance`, default 10⁻¹² of the
//! smallest semi-axis) is swept in [`predictor`]: time per prediction and worst overlap on the
//! pairs, and a whole jamming run per tolerance (`tolerance_runs`).

use super::{mean_sd, median, slope, spread, Figure, Series, StudyContext, StudyOutput, Table};
use densepack::io::scene::Scene;
use densepack::run::run_scene;
use densepack::shape::ellipsoid::{predict_ellipsoid_pair, Predictor, Spin, CONTACT_TOLERANCE};
use densepack::shape::{Ellipsoid, Vec3};
use densepack::verify::contact_scale;
use nalgebra::{Matrix3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Instant;

/// Both predictors with their scene names.
pub const PREDICTORS: [(Predictor, &str); 2] = [
    (Predictor::SeparatingAxis, "separating_axis"),
    (Predictor::Characteristic, "characteristic"),
];

/// Two equal ellipsoids in relative motion: `b` sits at `dr` from `a` and moves at `dv`
/// relative to it; both spin.
pub struct Pair {
    /// The shape of both.
    pub a: Ellipsoid,
    /// Orientation and angular velocity of the first.
    pub sa: Spin,
    /// Orientation and angular velocity of the second.
    pub sb: Spin,
    /// Centre offset at time 0.
    pub dr: Vec3,
    /// Relative velocity.
    pub dv: Vec3,
}

fn normal3<R: Rng>(rng: &mut R) -> Vec3 {
    Vec3::new(
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
    )
}

fn m_of(q: &UnitQuaternion<f64>, axes: &Vec3) -> [[f64; 3]; 3] {
    let r = q.to_rotation_matrix();
    let m = r.matrix() * Matrix3::from_diagonal(&axes.component_mul(axes)) * r.matrix().transpose();
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

impl Pair {
    /// The Perram–Wertheim contact scale at time `tau` by the independent check
    /// ([`contact_scale`]): < 1 means overlap.
    pub fn scale_at(&self, tau: f64) -> f64 {
        let rot = |s: &Spin| UnitQuaternion::from_scaled_axis(s.omega * tau) * s.orientation;
        let d = self.dr + self.dv * tau;
        let axes = self.a.semi_axes(tau);
        contact_scale(
            &m_of(&rot(&self.sa), &axes),
            &m_of(&rot(&self.sb), &axes),
            &[d.x, d.y, d.z],
        )
    }

    /// The first contact time in [0, 2] by `predictor`.
    pub fn predict(&self, predictor: Predictor) -> Option<f64> {
        self.predict_with_tolerance(predictor, CONTACT_TOLERANCE)
    }

    /// [`Pair::predict`] with contact tolerance `tolerance` (relative to the smallest
    /// semi-axis).
    pub fn predict_with_tolerance(&self, predictor: Predictor, tolerance: f64) -> Option<f64> {
        let a = Ellipsoid {
            predictor,
            contact_tolerance: tolerance,
            ..self.a
        };
        predict_ellipsoid_pair(&a, &a, &self.sa, &self.sb, &self.dr, &self.dv, 0.0, 2.0)
    }
}

/// Random non-overlapping pairs of prolate spheroids (largest semi-axis 1) whose bounding
/// spheres meet within the window, the only pairs that reach the ellipsoid predictor.
pub fn pairs(ratio: f64, n: usize) -> Vec<Pair> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
    let a = Ellipsoid::new(Vec3::new(1.0, 1.0 / ratio, 1.0 / ratio));
    let mut out = Vec::new();
    while out.len() < n {
        let dir = normal3(&mut rng).normalize();
        let pair = Pair {
            a,
            sa: Spin {
                orientation: UnitQuaternion::from_scaled_axis(normal3(&mut rng)),
                omega: normal3(&mut rng),
            },
            sb: Spin {
                orientation: UnitQuaternion::from_scaled_axis(normal3(&mut rng)),
                omega: normal3(&mut rng),
            },
            dr: dir * rng.gen_range(0.3..2.0),
            dv: -dir * rng.gen_range(0.0..1.5) + normal3(&mut rng) * 0.5,
        };
        if pair.scale_at(0.0) > 1.001 {
            out.push(pair);
        }
    }
    out
}

/// Time per prediction and accuracy of both predictors on random pairs of prolate spheroids.
pub fn predictor(ctx: &StudyContext) -> StudyOutput {
    let (ratios, count, repeats): (&[f64], usize, usize) = if ctx.quick {
        (&[1.5, 5.0], 300, 3)
    } else {
        (&[1.5, 5.0, 20.0, 50.0], 2000, 5)
    };
    let mut table = Table::new(
        "ellipsoid predictors: time per prediction against accuracy",
        &format!(
            "{count} random non-overlapping pairs of prolate spheroids per aspect ratio (largest \
             semi-axis 1; random orientations, angular velocities and approach; bounding \
             spheres meet within the window of 2 time units; seed 17). µs/prediction: median \
             over {repeats} passes over the pairs, spread = (max − min)/median. Worst overlap = \
             1 − the smallest Perram–Wertheim contact scale the independent check finds at a \
             predicted contact (> 0: overlap; rounding is ~1e-14; verify accepts 1e-9). Agree: \
             same contact (or none) as separating_axis within 1e-6 relative."
        ),
        &[
            "aspect ratio",
            "predictor",
            "µs/prediction",
            "spread",
            "contacts",
            "agree with separating_axis",
            "worst overlap (1 − scale)",
        ],
    );
    let mut series: Vec<Series> = PREDICTORS
        .iter()
        .map(|(_, name)| Series::points(*name, Vec::new()))
        .collect();
    let mut all = Vec::new();
    let (mut faster, mut worst_all) = (0, f64::NEG_INFINITY);
    for &ratio in ratios {
        let set = pairs(ratio, count);
        let reference: Vec<Option<f64>> = set
            .iter()
            .map(|p| p.predict(Predictor::SeparatingAxis))
            .collect();
        let mut timings = [0.0; 2];
        for (k, (mode, name)) in PREDICTORS.into_iter().enumerate() {
            let mut got = Vec::new();
            let micros: Vec<f64> = (0..repeats)
                .map(|_| {
                    let start = Instant::now();
                    got = set.iter().map(|p| p.predict(mode)).collect();
                    start.elapsed().as_secs_f64() * 1e6 / set.len() as f64
                })
                .collect();
            let mut worst = f64::INFINITY;
            let (mut contacts, mut agree) = (0, 0);
            for ((p, g), r) in set.iter().zip(&got).zip(&reference) {
                if let Some(tau) = g {
                    contacts += 1;
                    worst = worst.min(p.scale_at(*tau));
                }
                match (g, r) {
                    (Some(x), Some(y)) if (x - y).abs() <= 1e-6 * (1.0 + y) => agree += 1,
                    (None, None) => agree += 1,
                    _ => {}
                }
            }
            let us = median(micros.clone());
            timings[k] = us;
            worst_all = worst_all.max(1.0 - worst);
            series[k].points.push((us, 1.0 - worst));
            all.push((us, 1.0 - worst));
            table.row(vec![
                format!("{ratio}"),
                name.into(),
                format!("{us:.2}"),
                format!("{:.2}", spread(&micros)),
                contacts.to_string(),
                format!("{agree}/{}", set.len()),
                format!("{:.2e}", 1.0 - worst),
            ]);
        }
        if timings[0] < timings[1] {
            faster += 1;
        }
    }
    let mut figure = Figure::new(
        "Ellipsoid predictors: time against worst overlap (one point per aspect ratio)",
        "µs per prediction",
        "worst overlap 1 − contact scale",
    )
    .log(true, false);
    figure.series = series;
    figure = figure.with(Series::pareto_front("Pareto front", &all));
    let sweep = tolerance_sweep(ctx, ratios, count, repeats);
    StudyOutput {
        markdown: table.markdown()
            + &sweep
            + &format!(
                "`separating_axis` (the default: never late by construction) was the faster at \
                 {faster} of {} aspect ratios; the worst overlap of either predictor was \
                 {worst_all:.1e} of contact (verify's tolerance: 1e-9).\n\n",
                ratios.len()
            ),
        csv: table,
        figure,
    }
}

/// Contact tolerances swept by `tolerance_sweep` (relative to the smallest semi-axis).
pub const TOLERANCES: [f64; 4] = [1e-6, 1e-9, 1e-12, 1e-14];

/// The contact tolerance against time and error: per tolerance, time per prediction and the
/// worst overlap at a predicted contact on the random pairs (separating-axis predictor), and
/// [`tolerance_runs`]. Markdown.
fn tolerance_sweep(ctx: &StudyContext, ratios: &[f64], count: usize, repeats: usize) -> String {
    let mut pairs_table = Table::new(
        "contact tolerance: time per prediction against accuracy (separating_axis)",
        &format!(
            "The pairs above ({count} per aspect ratio); µs/prediction: median over {repeats} \
             passes. Worst overlap as above (1 − smallest contact scale at a predicted contact)."
        ),
        &[
            "aspect ratio",
            "tolerance",
            "µs/prediction",
            "spread",
            "contacts",
            "worst overlap (1 − scale)",
        ],
    );
    for &ratio in ratios {
        let set = pairs(ratio, count);
        for tol in TOLERANCES {
            let mut got = Vec::new();
            let micros: Vec<f64> = (0..repeats)
                .map(|_| {
                    let start = Instant::now();
                    got = set
                        .iter()
                        .map(|p| p.predict_with_tolerance(Predictor::SeparatingAxis, tol))
                        .collect();
                    start.elapsed().as_secs_f64() * 1e6 / set.len() as f64
                })
                .collect();
            let hits: Vec<f64> = set
                .iter()
                .zip(&got)
                .filter_map(|(p, g)| g.map(|tau| p.scale_at(tau)))
                .collect();
            let worst = hits.iter().copied().fold(f64::INFINITY, f64::min);
            pairs_table.row(vec![
                format!("{ratio}"),
                format!("{tol:e}"),
                format!("{:.2}", median(micros.clone())),
                format!("{:.2}", spread(&micros)),
                hits.len().to_string(),
                format!("{:.2e}", 1.0 - worst),
            ]);
        }
    }
    pairs_table.markdown() + &tolerance_runs(ctx).markdown()
}

/// One jamming run per contact tolerance: CPU seconds, the packing fraction reached, the
/// smallest relative gap by the independent check and the prediction failures.
fn tolerance_runs(ctx: &StudyContext) -> Table {
    let (text, what) = if ctx.quick {
        (
            include_str!("../../../examples/scenes/ellipsoids_prolate_r2_n30.toml"),
            "`ellipsoids_prolate_r2_n30.toml` (30 prolate spheroids R = 2 grown to φ 0.60)",
        )
    } else {
        (
            include_str!("../../../examples/scenes/sample_ellipsoids.toml"),
            "`sample_ellipsoids.toml` (200 prolate spheroids R = 1.5 grown to Z = 10⁶)",
        )
    };
    let base = Scene::from_toml(text).expect("the shipped ellipsoid scene is valid");
    let mut table = Table::new(
        "contact tolerance: whole runs",
        &format!(
            "{what}, seed of the scene, separating_axis; CPU s of the run's thread (seeding and \
             the independent check included). Smallest gap: relative surface gap by `verify` \
             (negative: overlap)."
        ),
        &[
            "tolerance",
            "CPU s",
            "final φ",
            "smallest relative gap",
            "prediction failures",
            "stop",
        ],
    );
    for tol in TOLERANCES {
        let mut scene = base.clone();
        if let Some(e) = scene.particles.ellipsoid.as_mut() {
            e.contact_tolerance = tol;
        }
        eprintln!("-- contact tolerance {tol:e}");
        let cpu_start = cpu_time::ThreadTime::now();
        let lead = vec![format!("{tol:e}")];
        match run_scene(&scene, &mut |_, _| {}) {
            Ok(o) => {
                let failures = o
                    .packing
                    .stats
                    .extra
                    .get("ellipsoid_prediction_failures")
                    .map_or_else(String::new, ToString::to_string);
                table.row(vec![
                    lead[0].clone(),
                    format!("{:.2}", cpu_start.elapsed().as_secs_f64()),
                    format!("{:.4}", o.packing.stats.packing_fraction),
                    format!(
                        "{:.2e}",
                        o.verification.min_pair_gap_relative.unwrap_or(f64::NAN)
                    ),
                    failures,
                    o.packing.stats.stop_reason.clone(),
                ]);
            }
            Err(e) => table.failed_row(lead, &e.to_string()),
        }
    }
    table
}

/// Paper 004, Table 2: the MATLAB code's time beside densepack's, both predictors.
pub fn table2(ctx: &StudyContext) -> StudyOutput {
    let cases = [
        (
            "R1 = R2 = 2 (prolate) → φ 0.60",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r2_n30.toml"),
            30,
            54.3,
        ),
        (
            "R1 = 2, R2 = 1 (oblate) → φ 0.60",
            include_str!("../../../examples/scenes/ellipsoids_oblate_r2_n30.toml"),
            30,
            52.7,
        ),
        (
            "R1 = R2 = 5 (prolate) → φ 0.55",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r5_n45.toml"),
            45,
            69.9,
        ),
        (
            "R1 = 5, R2 = 1 (oblate) → φ 0.55",
            include_str!("../../../examples/scenes/ellipsoids_oblate_r5_n45.toml"),
            45,
            65.2,
        ),
        (
            "R1 = R2 = 10 (prolate) → φ 0.30",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r10_n90.toml"),
            90,
            48.6,
        ),
        (
            "R1 = R2 = 20 (prolate) → φ 0.20",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r20_n175.toml"),
            175,
            112.5,
        ),
        (
            "R1 = R2 = 30 (prolate) → φ 0.10",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r30_n175.toml"),
            175,
            104.9,
        ),
        (
            "R1 = R2 = 40 (prolate) → φ 0.10",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r40_n310.toml"),
            310,
            181.3,
        ),
        (
            "R1 = 10, R2 = 1 (oblate) → φ 0.30",
            include_str!("../../../examples/scenes/ellipsoids_oblate_r10_n60.toml"),
            60,
            39.3,
        ),
        (
            "R1 = 20, R2 = 1 (oblate) → φ 0.20",
            include_str!("../../../examples/scenes/ellipsoids_oblate_r20_n75.toml"),
            75,
            47.8,
        ),
        (
            "R1 = 30, R2 = 1 (oblate) → φ 0.10",
            include_str!("../../../examples/scenes/ellipsoids_oblate_r30_n90.toml"),
            90,
            53.7,
        ),
        (
            "R1 = 40, R2 = 1 (oblate) → φ 0.10",
            include_str!("../../../examples/scenes/ellipsoids_oblate_r40_n100.toml"),
            100,
            92.8,
        ),
    ];
    let mut table = Table::new(
        "paper 004, Table 2: periodic ellipsoids grown to φ",
        &format!(
            "At the paper's N: `examples/scenes/ellipsoids_{{prolate,oblate}}_r2_n30.toml`, \
             `ellipsoids_{{prolate,oblate}}_r5_n45.toml` and \
             `ellipsoids_{{prolate,oblate}}_r{{10,20,30,40}}_n*.toml` (particles about as long \
             as the box: the kernel tracks periodic images); the paper's times are its MATLAB \
             code's. Seconds are CPU seconds of the run's thread (the machine is shared). \
             Speed-up = paper s / densepack CPU s. Smallest gap: relative surface gap found \
             by the independent check, every image and self-image included (negative would \
             be an overlap). The characteristic predictor runs on the R ≤ 5 rows only. {}",
            if ctx.quick {
                "Quick: one seed (the scene's); the characteristic predictor on the R = 2 case \
                 only."
            } else {
                "Three seeds (the scene's, +1, +2): median CPU s, spread = (max − min)/median."
            }
        ),
        &[
            "case",
            "paper N",
            "paper s",
            "densepack N",
            "predictor",
            "runs",
            "median CPU s",
            "spread",
            "speed-up",
            "final φ",
            "smallest relative gap",
        ],
    );
    let seeds = if ctx.quick { 1 } else { 3 };
    let mut series: Vec<Series> = PREDICTORS
        .iter()
        .map(|(_, name)| Series::points(*name, Vec::new()))
        .collect();
    for (case, text, paper_n, paper_s) in cases {
        let base = Scene::from_toml(text).expect("the shipped ellipsoid scene is valid");
        for (k, (predictor, name)) in PREDICTORS.into_iter().enumerate() {
            // The slower characteristic predictor on the R ≤ 5 cases (quick: the first only).
            let with_characteristic = if ctx.quick {
                paper_n == 30
            } else {
                paper_n <= 45
            };
            if predictor == Predictor::Characteristic && !with_characteristic {
                continue;
            }
            let mut cpu_seconds = Vec::new();
            let mut phi = f64::NAN;
            let mut gap = f64::INFINITY;
            let mut n = 0;
            let mut errors = Vec::new();
            for s in 0..seeds {
                let mut scene = base.clone();
                scene.seed += s;
                if let Some(e) = scene.particles.ellipsoid.as_mut() {
                    e.predictor = predictor;
                }
                eprintln!("-- table 2 {case}, {name}, seed {}", scene.seed);
                let cpu_start = cpu_time::ThreadTime::now();
                match run_scene(&scene, &mut |_, _| {}) {
                    Ok(o) => {
                        cpu_seconds.push(cpu_start.elapsed().as_secs_f64());
                        phi = o.packing.stats.packing_fraction;
                        n = o.packing.particles.len();
                        gap = gap.min(o.verification.min_pair_gap_relative.unwrap_or(f64::NAN));
                    }
                    Err(e) => errors.push(e.to_string()),
                }
            }
            let lead = vec![case.to_owned(), paper_n.to_string(), format!("{paper_s}")];
            if cpu_seconds.is_empty() {
                table.failed_row(lead, &errors.join("; "));
                continue;
            }
            let cpu = median(cpu_seconds.clone());
            series[k].points.push((paper_s, paper_s / cpu));
            table.row(
                [
                    lead,
                    vec![
                        n.to_string(),
                        name.into(),
                        format!(
                            "{}{}",
                            cpu_seconds.len(),
                            if errors.is_empty() {
                                String::new()
                            } else {
                                format!(" ({} failed: {})", errors.len(), errors.join("; "))
                            }
                        ),
                        format!("{cpu:.3}"),
                        format!("{:.2}", spread(&cpu_seconds)),
                        format!("{:.0}×", paper_s / cpu),
                        format!("{phi:.4}"),
                        format!("{gap:.2e}"),
                    ],
                ]
                .concat(),
            );
        }
    }
    let mut figure = Figure::new(
        "Paper 004 Table 2: speed-up of densepack over the paper",
        "paper's time (s)",
        "speed-up (paper s / densepack CPU s)",
    )
    .log(false, true);
    figure.series = series;
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure,
    }
}

/// Mean `ρ̄` of the eigenvalue ratio of `T = ⟨w wᵀ⟩` over `draws` sets of `n` independent
/// uniformly distributed axes: what a perfectly random packing of `n` bodies gives (`ρ ≥ 1`
/// for any finite set, → 1 as `n` grows), the reference for [`isotropy`].
fn isotropic_reference(n: usize, draws: usize, seed: u64) -> f64 {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let total: f64 = (0..draws)
        .map(|_| {
            densepack::run::ellipsoid::axis_tensor((0..n).map(|_| normal3(&mut rng).normalize())).1
        })
        .sum();
    total / draws as f64
}

/// Paper 004, Fig. 6: isotropy of the packings. For prolate spheroids R₁ = R₂ = 2 grown to
/// φ = 0.30 and R₁ = R₂ = 10 grown to φ = 0.10, and N = 10 … 500 bodies, the mean `ρ̄` of the
/// orientation tensor's eigenvalue ratio `ρ = λ_max/λ_min` (Eq. 1) over 10 seeds, with its
/// 95 % confidence interval (Student t, 9 degrees of freedom), beside `ρ̄` of N independent
/// uniform axes (10⁴ draws). The paper shows `ρ̄ → 1` as N grows; a random packing should
/// match the independent axes within the interval.
pub fn isotropy(ctx: &StudyContext) -> StudyOutput {
    // (label, shipped scene it starts from, target φ)
    let cases = [
        (
            "prolate R = 2, φ 0.30",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r2_n30.toml"),
            0.30,
        ),
        (
            "prolate R = 10, φ 0.10",
            include_str!("../../../examples/scenes/ellipsoids_prolate_r10_n90.toml"),
            0.10,
        ),
    ];
    let (counts, seeds): (&[usize], u64) = if ctx.quick {
        (&[10, 50], 3)
    } else {
        (&[10, 25, 50, 100, 200, 500], 10)
    };
    // Two-sided 95 % Student t quantiles for `seeds − 1` degrees of freedom.
    let t95 = if seeds == 3 { 4.303 } else { 2.262 };
    let mut table = Table::new(
        "paper 004, Fig. 6: orientation isotropy ρ̄ against N",
        &format!(
            "ρ = λ_max/λ_min of the orientation tensor of the `a` axes (Eq. 1), mean ρ̄ over {seeds} \
             seeds (the scene's seed + 0…{}) with its 95 % confidence interval; reference: ρ̄ of \
             N independent uniform axes (10⁴ draws). Scenes: `ellipsoids_prolate_r2_n30.toml` \
             and `ellipsoids_prolate_r10_n90.toml` with N and the target φ replaced. A case \
             whose bodies would outgrow the box edge is refused by the scene check.",
            seeds - 1
        ),
        &[
            "case",
            "N",
            "runs",
            "ρ̄ packings",
            "95 % CI",
            "ρ̄ independent axes",
            "CPU s per run",
        ],
    );
    let mut series = Vec::new();
    for (label, text, phi) in cases {
        let mut points = Vec::new();
        let mut reference = Vec::new();
        for &n in counts {
            let mut base = Scene::from_toml(text).expect("the shipped ellipsoid scene is valid");
            base.particles.count = Some(n);
            base.stages[0].until.packing_fraction = Some(phi);
            let lead = vec![label.to_owned(), n.to_string()];
            if let Err(e) = base.validate() {
                table.failed_row(lead, &e.to_string());
                continue;
            }
            let (mut ratios, mut cpu, mut errors) = (Vec::new(), 0.0, Vec::new());
            for s in 0..seeds {
                let mut scene = base.clone();
                scene.seed += s;
                eprintln!("-- isotropy {label}, N = {n}, seed {}", scene.seed);
                let cpu_start = cpu_time::ThreadTime::now();
                match run_scene(&scene, &mut |_, _| {}) {
                    Ok(o) => {
                        cpu += cpu_start.elapsed().as_secs_f64();
                        ratios
                            .extend(o.packing.stats.extra["orientation_eigenvalue_ratio"].as_f64());
                    }
                    Err(e) => errors.push(e.to_string()),
                }
            }
            if ratios.len() < 2 {
                table.failed_row(lead, &errors.join("; "));
                continue;
            }
            let (mean, sd) = mean_sd(&ratios);
            let half = t95 * sd / (ratios.len() as f64).sqrt();
            let ideal = isotropic_reference(n, 10_000, 6 + n as u64);
            points.push((n as f64, mean));
            reference.push((n as f64, ideal));
            table.row(
                [
                    lead,
                    vec![
                        if errors.is_empty() {
                            ratios.len().to_string()
                        } else {
                            format!(
                                "{} ({} failed: {})",
                                ratios.len(),
                                errors.len(),
                                errors.join("; ")
                            )
                        },
                        format!("{mean:.3}"),
                        format!("[{:.3}, {:.3}]", mean - half, mean + half),
                        format!("{ideal:.3}"),
                        format!("{:.3}", cpu / ratios.len() as f64),
                    ],
                ]
                .concat(),
            );
        }
        series.push(Series::points(format!("{label}: packings"), points));
        series.push(Series::line(
            format!("{label}: independent axes"),
            reference,
        ));
    }
    let mut figure = Figure::new(
        "Paper 004 Fig. 6: orientation isotropy",
        "number of ellipsoids N",
        "ρ̄ = mean λ_max/λ_min",
    )
    .log(true, false);
    figure.series = series;
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure,
    }
}

/// One case of the cost studies (paper 004, Figs. 7–9): `n` prolate spheroids with semi-axes
/// `a : a/r : a/r` in a periodic cube, grown to fraction `phi` at the relative `rate`.
///
/// One protocol for every case, so that cases differ in N, φ and R alone: random sequential
/// addition at the ellipsoid fraction `start` (at most 0.2/R², bounding spheres at fraction
/// 0.2 or less, the rule of the shipped Table 2 scenes), then relative growth at `rate` (per
/// time unit ℓ·√(m/kT)) until `phi`. The cube's edge is set so that the final volume-equivalent diameter is 1 (edge³ =
/// N·(π/6)/φ), which fixes the length unit, hence the thermal speed against the body size.
/// The paper starts from zero volume; a relative rate needs a non-zero start (docs/papers.md).
#[derive(Clone, Copy, Debug)]
struct CostCase {
    r: f64,
    n: usize,
    phi: f64,
    rate: f64,
    start: f64,
}

impl CostCase {
    fn scene(&self, seed: u64) -> Result<Scene, String> {
        let edge = (self.n as f64 * std::f64::consts::PI / 6.0 / self.phi).cbrt();
        let text = format!(
            "seed = {seed}\nqueue = \"calendar\"\n\
             [container]\ntype = \"box\"\nsize = [{edge}, {edge}, {edge}]\n\
             periodic = [true, true, true]\n\
             [particles]\ncount = {}\ndiameter = 1.0\npacking_fraction = {}\n\
             [particles.ellipsoid]\naspect_ratios = [{}, {}]\n\
             [[stage]]\ngrowth = \"relative\"\nrate = {}\nuntil = {{ packing_fraction = {} }}\n",
            self.n, self.start, self.r, self.r, self.rate, self.phi
        );
        Scene::from_toml(&text).map_err(|e| e.to_string())
    }
}

/// `seeds` realisations of a case (seeds 1 … `seeds`): process CPU seconds (every thread, the
/// seeding and the independent check included, as the paper's t_CPU covers the whole run),
/// events, and the smallest relative gap the independent check found over all of them.
struct CostRuns {
    cpu: Vec<f64>,
    events: Vec<f64>,
    min_gap: f64,
    errors: Vec<String>,
}

fn cost_runs(case: &CostCase, seeds: u64, label: &str) -> CostRuns {
    let mut out = CostRuns {
        cpu: Vec::new(),
        events: Vec::new(),
        min_gap: f64::INFINITY,
        errors: Vec::new(),
    };
    for seed in 1..=seeds {
        let scene = match case.scene(seed) {
            Ok(s) => s,
            Err(e) => {
                out.errors.push(e);
                return out;
            }
        };
        eprintln!(
            "-- {label}: R = {}, N = {}, φ = {}, seed {seed}",
            case.r, case.n, case.phi
        );
        let cpu_start = cpu_time::ProcessTime::now();
        match run_scene(&scene, &mut |_, _| {}) {
            Ok(o) => {
                out.cpu.push(cpu_start.elapsed().as_secs_f64());
                out.events.push(o.packing.stats.events as f64);
                let gap = o.verification.min_pair_gap_relative.unwrap_or(f64::NAN);
                out.min_gap = out.min_gap.min(gap);
            }
            Err(e) => out.errors.push(e.to_string()),
        }
    }
    out
}

/// A cost law of paper 004: one series of cases per label, the x value each case is plotted
/// at, and the slope ranges to fit with the paper's exponent for each.
struct CostLaw {
    title: &'static str,
    x_name: &'static str,
    /// The variable in the paper's law (`N`, `φ`, `R₁`).
    x_symbol: &'static str,
    caption: String,
    series: Vec<(String, Vec<(f64, CostCase)>)>,
    /// (label, lowest x, highest x, the paper's exponent) of each fitted range.
    fits: Vec<(&'static str, f64, f64, f64)>,
    seeds: u64,
}

/// Runs a cost law: a table of mean CPU seconds per case (± standard deviation over the
/// seeds), events and µs per event, the fitted log–log slopes of CPU time, events and µs per
/// event over each range beside the paper's exponent (slope of t = slope of events + slope of
/// µs per event, which says whether a law comes from the work or from its unit cost), and the
/// log–log figure with the paper's exponent drawn through each series' first point.
fn cost_law(law: CostLaw) -> StudyOutput {
    let mut table = Table::new(
        law.title,
        &law.caption,
        &[
            "series",
            law.x_name,
            "runs",
            "mean CPU s",
            "sd",
            "mean events",
            "µs per event",
            "smallest relative gap",
        ],
    );
    let mut fit_table = Table::new(
        &format!("{}: fitted exponents", law.title),
        "Least-squares slopes of ln(mean) against ln(x) over each range, beside the paper's \
         exponent of CPU time. The exponent of time is that of the events plus that of the µs \
         per event.",
        &[
            "series",
            "range",
            "points",
            "CPU time",
            "events",
            "µs per event",
            "paper (CPU time)",
        ],
    );
    let mut figure = Figure::new(law.title, law.x_name, "mean CPU s per run").log(true, true);
    for (label, cases) in &law.series {
        let mut points = Vec::new(); // (x, mean cpu, mean events)
        for (x, case) in cases {
            let runs = cost_runs(case, law.seeds, label);
            let lead = vec![label.clone(), format!("{x}")];
            if runs.cpu.is_empty() {
                table.failed_row(lead, &runs.errors.join("; "));
                continue;
            }
            let (cpu, sd) = mean_sd(&runs.cpu);
            let (events, _) = mean_sd(&runs.events);
            points.push((*x, cpu, events));
            let runs_cell = if runs.errors.is_empty() {
                runs.cpu.len().to_string()
            } else {
                format!(
                    "{} ({} failed: {})",
                    runs.cpu.len(),
                    runs.errors.len(),
                    runs.errors.join("; ")
                )
            };
            table.row(
                [
                    lead,
                    vec![
                        runs_cell,
                        format!("{cpu:.4}"),
                        format!("{sd:.4}"),
                        format!("{events:.0}"),
                        format!("{:.3}", cpu / events * 1e6),
                        format!("{:.2e}", runs.min_gap),
                    ],
                ]
                .concat(),
            );
        }
        for &(range, lo, hi, paper) in &law.fits {
            let inside: Vec<_> = points
                .iter()
                .filter(|p| p.0 >= lo && p.0 <= hi)
                .copied()
                .collect();
            let fit = |f: &dyn Fn(&(f64, f64, f64)) -> f64| {
                let xy: Vec<_> = inside.iter().map(|p| (p.0.ln(), f(p).ln())).collect();
                slope(&xy).map_or("n/a".into(), |s| format!("{s:.2}"))
            };
            fit_table.row(vec![
                label.clone(),
                range.into(),
                inside.len().to_string(),
                fit(&|p| p.1),
                fit(&|p| p.2),
                fit(&|p| p.1 / p.2),
                format!("{paper}"),
            ]);
            // The paper's exponent, drawn through the first series' points in the range.
            let first_series = std::ptr::eq(label, &law.series[0].0);
            if let (true, Some(a), Some(b)) = (first_series, inside.first(), inside.last()) {
                if b.0 > a.0 {
                    figure = figure.with(Series::line(
                        format!("paper: ∝ {}^{paper} ({range})", law.x_symbol),
                        vec![(a.0, a.1), (b.0, a.1 * (b.0 / a.0).powf(paper))],
                    ));
                }
            }
        }
        figure = figure.with(Series::points(
            label.clone(),
            points.iter().map(|p| (p.0, p.1)).collect(),
        ));
    }
    StudyOutput {
        markdown: format!("{}\n{}", table.markdown(), fit_table.markdown()),
        csv: table,
        figure,
    }
}

/// Seeds per case: the paper's 10 realisations, 2 in the quick run.
fn cost_seeds(ctx: &StudyContext) -> u64 {
    if ctx.quick {
        2
    } else {
        10
    }
}

const COST_PROTOCOL: &str = "Prolate spheroids (a : a/R : a/R), periodic cube with edge³ = \
     N·(π/6)/φ (final volume-equivalent diameter 1), seeded by RSA of the bounding spheres, \
     relative growth to φ. Mean over the seeds 1 … k of the process CPU seconds of a whole \
     run (seeding, EDMD and the independent overlap check); smallest relative gap: the \
     independent check over all runs (negative would be an overlap).";

/// Paper 004, Fig. 7: CPU time against N for five (R, φ) combinations; the paper fits
/// t ∝ N^1.5 above N = 100.
pub fn cost_against_n(ctx: &StudyContext) -> StudyOutput {
    // (R, φ, relative rate): the rate of the shipped Table 2 scene of that R.
    let combos: &[(f64, f64, f64)] = if ctx.quick {
        &[(2.0, 0.3, 0.05)]
    } else {
        &[
            (2.0, 0.3, 0.05),
            (2.0, 0.5, 0.05),
            (5.0, 0.3, 0.2),
            (10.0, 0.2, 2.0),
            (20.0, 0.1, 2.0),
        ]
    };
    let counts: &[usize] = if ctx.quick {
        &[100, 200]
    } else {
        &[100, 200, 400, 800, 1600, 3200]
    };
    let seeds = cost_seeds(ctx);
    cost_law(CostLaw {
        title: "paper 004, Fig. 7: CPU time against the number of prolate ellipsoids",
        x_name: "N",
        x_symbol: "N",
        caption: format!(
            "{COST_PROTOCOL} {seeds} seeds per point, seeded at fraction 0.2/R² (bounding \
             spheres at 0.2). Relative rate per (R, φ): 0.05 for R = 2, 0.2 for R = 5, 2 for \
             R ≥ 10 (the shipped Table 2 scenes' rates). The paper's five \
             combinations are not given in its text; these span its Table 2."
        ),
        series: combos
            .iter()
            .map(|&(r, phi, rate)| {
                (
                    format!("R = {r}, φ = {phi}"),
                    counts
                        .iter()
                        .map(|&n| {
                            let start = 0.2 / (r * r);
                            (
                                n as f64,
                                CostCase {
                                    r,
                                    n,
                                    phi,
                                    rate,
                                    start,
                                },
                            )
                        })
                        .collect(),
                )
            })
            .collect(),
        fits: vec![("N ≥ 100", 100.0, f64::INFINITY, 1.5)],
        seeds,
    })
}

/// Paper 004, Fig. 8: CPU time against the volume fraction, R₁ = R₂ = 2; the paper fits
/// t ∝ V_f^2.6 whatever N.
pub fn cost_against_fraction(ctx: &StudyContext) -> StudyOutput {
    let fractions: &[f64] = if ctx.quick {
        &[0.2, 0.4]
    } else {
        &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    };
    let counts: &[usize] = if ctx.quick { &[100] } else { &[100, 400] };
    let seeds = cost_seeds(ctx);
    cost_law(CostLaw {
        title: "paper 004, Fig. 8: CPU time against the volume fraction, R₁ = R₂ = 2",
        x_name: "φ",
        x_symbol: "φ",
        caption: format!(
            "{COST_PROTOCOL} {seeds} seeds per point, seeded at fraction 0.05, relative rate \
             0.05 (the shipped R = 2 scene's). A power law can only describe part of the curve: the cost diverges as φ \
             approaches jamming (≈ 0.70 for R = 2, Donev et al. 2004)."
        ),
        series: counts
            .iter()
            .map(|&n| {
                (
                    format!("N = {n}"),
                    fractions
                        .iter()
                        .map(|&phi| {
                            (
                                phi,
                                CostCase {
                                    r: 2.0,
                                    n,
                                    phi,
                                    rate: 0.05,
                                    start: 0.05,
                                },
                            )
                        })
                        .collect(),
                )
            })
            .collect(),
        fits: vec![("all φ", 0.0, 1.0, 2.6)],
        seeds,
    })
}

/// Paper 004, Fig. 9: CPU time against the aspect ratio at V_f = 10 %; the paper fits
/// t ∝ R₁^0.6 for R₁ ≤ 10 and R₁^2.8 above.
pub fn cost_against_aspect(ctx: &StudyContext) -> StudyOutput {
    let ratios: &[f64] = if ctx.quick {
        &[2.0, 10.0]
    } else {
        &[2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0, 40.0]
    };
    // Bodies shorter than the edge need N > 6R²φ/π (305 at R = 40, φ = 0.1).
    let n = if ctx.quick { 100 } else { 400 };
    // Every R starts at the fraction of the longest needles' start, so that all grow by the
    // same factor, as the paper's bodies all grow from zero volume.
    let start = 0.2 / ratios.iter().fold(1.0f64, |m, &r| m.max(r)).powi(2);
    let seeds = cost_seeds(ctx);
    cost_law(CostLaw {
        title: "paper 004, Fig. 9: CPU time against the aspect ratio, V_f = 10 %",
        x_name: "R₁ = R₂",
        x_symbol: "R₁",
        caption: format!(
            "{COST_PROTOCOL} N = {n}, {seeds} seeds per point, every R seeded at fraction \
             {start:.3e} (the longest needles' bounding spheres at 0.2), so all grow by the same \
             factor, relative rate 2 (the shipped R ≥ 10 scenes' rate)."
        ),
        series: vec![(
            format!("N = {n}, φ = 0.1"),
            ratios
                .iter()
                .map(|&r| {
                    (
                        r,
                        CostCase {
                            r,
                            n,
                            phi: 0.1,
                            rate: 2.0,
                            start,
                        },
                    )
                })
                .collect(),
        )],
        fits: vec![
            ("R ≤ 10", 0.0, 10.0, 0.6),
            ("R ≥ 10", 10.0, f64::INFINITY, 2.8),
        ],
        seeds,
    })
}
