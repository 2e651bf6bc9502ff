//! Validation of a sphere or ellipsoid scene (the ellipsoids' own checks are in
//! [`super::ellipsoid`]): every field against its allowed range, with a
//! message that names the field, the range and why ([`Scene::validate`]).

use super::{
    fraction, invalid, positive, show, sphere_volume, wall_seconds, within, ContainerSpec,
    GrowthKind, Method, Scene, SceneError, EVENTS_PER_INTERVAL_RANGE, KEPLER_FRACTION,
    MAX_PARTICLES, RATE_RANGE, TEMPERATURE_RANGE,
};
use crate::tuning::MAX_SKIN;

/// Most steps `[jam]` may take.
const MAX_JAM_STEPS: usize = 10_000;

impl Scene {
    /// Checks every field against its allowed range.
    pub fn validate(&self) -> Result<(), SceneError> {
        within(
            "temperature",
            self.temperature,
            TEMPERATURE_RANGE,
            ": kT only sets the thermal speed against the growth rates (time is in units of \
             ℓ·√(m/kT)); a run at kT = 10⁸ needs 10⁴ times the events of kT = 1. Keep kT = 1 \
             and scale the rates instead",
        )?;
        within(
            "events_per_particle_per_interval",
            self.events_per_particle_per_interval,
            EVENTS_PER_INTERVAL_RANGE,
            ": goals are checked at time barriers, and an interval of more events reaches \
             them too late (default 4)",
        )?;
        if !(self.neighbour_skin > 0.0 && self.neighbour_skin <= MAX_SKIN) {
            return Err(invalid(
                "neighbour_skin",
                format!(
                    "= {} is outside the allowed range (0, {MAX_SKIN}]",
                    self.neighbour_skin
                ),
            ));
        }
        let (smallest_extent, periodic_extent) = self.validate_container()?;
        let sizes = self.validate_particles()?;
        if sizes.count > MAX_PARTICLES as f64 {
            return Err(invalid(
                "particles",
                format!(
                    "{:.4e} particles in all: more than {MAX_PARTICLES} (the kernel's index range)",
                    sizes.count
                ),
            ));
        }
        let container = self.container_volume();
        let p = &self.particles;
        if p.packing_fraction.is_some() && p.seed_scale.is_some() {
            return Err(invalid(
                "particles.seed_scale",
                "give either `seed_scale` or `packing_fraction`, not both",
            ));
        }
        if let Some(phi) = p.packing_fraction {
            fraction("particles.packing_fraction", phi)?;
        } else if sizes.volume / container >= 1.0 {
            return Err(invalid(
                "particles",
                format!(
                    "the spheres fill {:.3} of the container; the packing fraction must be < 1",
                    sizes.volume / container
                ),
            ));
        }
        if let Some(x) = p.seed_scale {
            if !(x.is_finite() && x > 0.0 && x <= 1.0) {
                return Err(invalid(
                    "particles.seed_scale",
                    format!("= {x} is outside the allowed range (0, 1]"),
                ));
            }
        }
        let scale = match p.packing_fraction {
            Some(phi) => (phi * container / sizes.volume).cbrt(),
            None => p.seed_scale.unwrap_or(1.0),
        };
        let seeded_phi = sizes.volume * scale.powi(3) / container;
        if !(seeded_phi > 0.0 && seeded_phi.is_finite() && scale.is_finite()) {
            return Err(invalid(
                "particles",
                format!(
                    "the spheres' volume relative to the container ({seeded_phi:e}) is not a \
                     positive finite number: the diameters are too small (or too large) for the \
                     container"
                ),
            ));
        }
        let rsa_gap = p.gap.unwrap_or(0.0);
        if let Some(g) = p.gap {
            if self.method != Method::Rsa {
                return Err(invalid(
                    "particles.gap",
                    "applies to method = \"rsa\"; with EDMD open a gap with a stage \
                     `until = { gap = .. }`",
                ));
            }
            if !(g.is_finite() && g >= 0.0) {
                return Err(invalid("particles.gap", format!("= {g} must be ≥ 0")));
            }
        }
        if let Some(w) = p.wall_gap {
            let Some(g) = p.gap else {
                return Err(invalid(
                    "particles.wall_gap",
                    "applies only with `particles.gap`",
                ));
            };
            if !(w.is_finite() && (0.0..=0.5 * g).contains(&w)) {
                return Err(invalid(
                    "particles.wall_gap",
                    format!(
                        "= {w} is outside the allowed range [0, gap/2 = {}]",
                        0.5 * g
                    ),
                ));
            }
        }
        let d_seed = sizes.d_max * scale;
        if d_seed + rsa_gap >= smallest_extent {
            return Err(invalid(
                "particles",
                format!(
                    "the largest sphere (diameter {d_seed}{}) does not fit the container \
                     (smallest extent {smallest_extent})",
                    if rsa_gap > 0.0 {
                        format!(" plus the gap {rsa_gap}")
                    } else {
                        String::new()
                    }
                ),
            ));
        }
        if rsa_gap > 0.0 {
            let inflated =
                sizes.count * std::f64::consts::PI / 6.0 * (sizes.d_min + rsa_gap).powi(3);
            if inflated >= container {
                return Err(invalid(
                    "particles.gap",
                    format!(
                        "= {rsa_gap}: {:.0} spheres of at least {} plus the gap cannot fit the \
                         container; lower the gap",
                        sizes.count, sizes.d_min
                    ),
                ));
            }
        }
        let final_diameter = self.validate_stages(&sizes, scale, container)?;
        self.validate_jam()?;
        if let Some(e) = &self.particles.ellipsoid {
            let grows = self.stages.iter().any(|s| s.growth != GrowthKind::None);
            self.validate_ellipsoids(
                e,
                d_seed,
                smallest_extent,
                periodic_extent,
                seeded_phi,
                grows,
            )?;
        }
        // Minimum image needs every contact distance below half the periodic box length.
        if periodic_extent.is_finite()
            && 2.0 * final_diameter.max(d_seed + rsa_gap) >= periodic_extent
        {
            let d = final_diameter.max(d_seed + rsa_gap);
            return Err(invalid(
                "container.size",
                format!(
                    "a periodic box edge must exceed twice the largest diameter the run can \
                     reach ({d:.4}); give at least {:.4} or use more, smaller particles",
                    2.0 * d
                ),
            ));
        }
        Ok(())
    }

    /// Checks `[jam]`: spheres in a box after EDMD stages, no gap claimed, limits in range.
    fn validate_jam(&self) -> Result<(), SceneError> {
        let Some(jam) = &self.jam else {
            return Ok(());
        };
        let refuse = |why: &str| Err(invalid("jam", why));
        if self.particles.ellipsoid.is_some() {
            return refuse(
                "applies to spheres: its programs are the spheres' non-overlap constraints \
                 (ellipsoids jam by their curvature, which first order does not see)",
            );
        }
        if matches!(self.container, ContainerSpec::Cylinder { .. }) {
            return refuse("applies to a box container (periodic or walled axes)");
        }
        if self.method == Method::Rsa {
            return refuse("follows the stages of method = \"edmd\"");
        }
        if self.stages.iter().any(|s| s.opens_gap()) {
            return refuse(
                "grows every radius by the same factor, which would break the gap a gap \
                 stage claims; jam without the gap stage",
            );
        }
        if let Some(n) = jam.max_steps {
            if !(1..=MAX_JAM_STEPS).contains(&n) {
                return Err(invalid(
                    "jam.max_steps",
                    format!("= {n} is outside the allowed range [1, {MAX_JAM_STEPS}]"),
                ));
            }
        }
        if let Some(x) = jam.max_wall_seconds {
            wall_seconds("jam.max_wall_seconds", x)?;
        }
        Ok(())
    }

    /// Checks the container; returns its smallest extent and smallest periodic edge.
    fn validate_container(&self) -> Result<(f64, f64), SceneError> {
        let extents = match &self.container {
            ContainerSpec::Box {
                min,
                size,
                periodic,
            } => {
                for k in 0..3 {
                    positive(&format!("container.size[{k}]"), size[k])?;
                    if !min[k].is_finite() {
                        return Err(invalid(
                            format!("container.min[{k}]"),
                            format!("= {} must be a finite number", min[k]),
                        ));
                    }
                    if !(min[k] + size[k]).is_finite() {
                        return Err(invalid(
                            format!("container.size[{k}]"),
                            "the upper corner min + size overflows a finite number",
                        ));
                    }
                }
                let smallest = size.iter().copied().fold(f64::INFINITY, f64::min);
                let periodic_min = (0..3)
                    .filter(|&k| periodic[k])
                    .map(|k| size[k])
                    .fold(f64::INFINITY, f64::min);
                Ok((smallest, periodic_min))
            }
            ContainerSpec::Cylinder {
                base_center,
                radius,
                height,
            } => {
                positive("container.radius", *radius)?;
                positive("container.height", *height)?;
                if base_center.iter().any(|x| !x.is_finite()) {
                    return Err(invalid(
                        "container.base_center",
                        format!("= {base_center:?} must be finite numbers"),
                    ));
                }
                Ok(((2.0 * radius).min(*height), f64::INFINITY))
            }
        }?;
        let volume = self.container_volume();
        if !(volume.is_finite() && volume > 0.0) {
            return Err(invalid(
                "container",
                format!("its volume ({volume}) must be a finite number > 0"),
            ));
        }
        Ok(extents)
    }

    /// Checks the particle description; returns its nominal sizes (expected ones for a
    /// grading curve).
    fn validate_particles(&self) -> Result<NominalSizes, SceneError> {
        let p = &self.particles;
        if p.from.is_some() {
            return self.validate_start();
        }
        if p.rsa_max_failures == 0 {
            return Err(invalid("particles.rsa_max_failures", "= 0 must be ≥ 1"));
        }
        let graded = p.grading.is_some();
        if !graded
            && (p.mixture_fraction.is_some() || p.effective_fraction.is_some() || p.d_min.is_some())
        {
            let field = if p.d_min.is_some() {
                "particles.d_min"
            } else if p.effective_fraction.is_some() {
                "particles.effective_fraction"
            } else {
                "particles.mixture_fraction"
            };
            return Err(invalid(field, "applies only with `grading`"));
        }
        match (&p.components, p.count, p.diameter, graded) {
            (None, None, None, true) => {
                let take = self.take_phase().expect("graded")?;
                let summary = take.summary();
                Ok(NominalSizes {
                    count: summary.expected_count,
                    d_min: summary.smallest_diameter,
                    d_max: summary.largest_diameter,
                    volume: summary.aggregate_volume,
                })
            }
            (Some(cs), None, None, false) => {
                if cs.is_empty() {
                    return Err(invalid(
                        "particles.components",
                        "needs at least one component",
                    ));
                }
                for (k, c) in cs.iter().enumerate() {
                    if c.count == 0 {
                        return Err(invalid(
                            format!("particles.components[{k}].count"),
                            "= 0 must be ≥ 1",
                        ));
                    }
                    positive(&format!("particles.components[{k}].diameter"), c.diameter)?;
                }
                let diameters: Vec<f64> = cs.iter().map(|c| c.diameter).collect();
                Ok(NominalSizes {
                    count: cs.iter().map(|c| c.count as f64).sum(),
                    d_min: diameters.iter().copied().fold(f64::INFINITY, f64::min),
                    d_max: diameters.iter().copied().fold(0.0, f64::max),
                    volume: cs
                        .iter()
                        .map(|c| c.count as f64 * sphere_volume(&[c.diameter]))
                        .sum(),
                })
            }
            (None, Some(count), Some(d), false) => {
                if count == 0 {
                    return Err(invalid("particles.count", "= 0 must be ≥ 1"));
                }
                positive("particles.diameter", d)?;
                Ok(NominalSizes {
                    count: count as f64,
                    d_min: d,
                    d_max: d,
                    volume: count as f64 * sphere_volume(&[d]),
                })
            }
            _ => Err(invalid(
                "particles",
                "give exactly one of: `count` and `diameter`; `components`; or `grading` \
                 with `mixture_fraction` and `d_min`",
            )),
        }
    }

    /// Checks the stages; returns the largest diameter the run can reach (for the
    /// minimum-image bound of periodic boxes).
    fn validate_stages(
        &self,
        sizes: &NominalSizes,
        scale: f64,
        container: f64,
    ) -> Result<f64, SceneError> {
        if self.method == Method::Rsa {
            if !self.stages.is_empty() {
                return Err(invalid(
                    "stage",
                    "method = \"rsa\" takes no stages (the seeding is the packing)",
                ));
            }
            return Ok(sizes.d_max * scale);
        }
        if self.stages.is_empty() {
            return Err(invalid("stage", "at least one [[stage]] is required"));
        }
        // Upper bound on any gap: N spheres of at least d_min + Δd must fit the volume.
        let gap_bound =
            (6.0 * container / (std::f64::consts::PI * sizes.count)).cbrt() - sizes.d_min;
        let seeded_phi = sizes.volume * scale.powi(3) / container;
        let equal_spheres = sizes.d_min == sizes.d_max && self.particles.ellipsoid.is_none();
        let mut final_diameter = sizes.d_max * scale;
        let mut at_true_size = scale == 1.0;
        let last = self.stages.len() - 1;
        for (k, s) in self.stages.iter().enumerate() {
            let f = |name: &str| format!("stage[{k}].{name}");
            match (s.growth, s.rate) {
                (GrowthKind::None, Some(_)) => {
                    return Err(invalid(f("rate"), "is not allowed with growth = \"none\""))
                }
                (GrowthKind::None, None) => {}
                (_, None) => return Err(invalid(f("rate"), "is required when the particles grow")),
                (GrowthKind::Relative, Some(r)) => within(
                    &f("rate"),
                    r,
                    RATE_RANGE,
                    " per unit time (relative growth): faster growth leaves the packing \
                     unchanged and overflows the speeds, slower growth cannot finish",
                )?,
                (GrowthKind::Absolute, Some(r)) => {
                    // In smallest diameters per unit time, so that a scene in other units
                    // (every length ×10^k) has the same range.
                    let [lo, hi] = RATE_RANGE.map(|x| x * sizes.d_min);
                    if !(r.is_finite() && r >= lo && r <= hi) {
                        return Err(invalid(
                            f("rate"),
                            format!(
                                "= {} is outside the allowed range [{lo:e}, {hi:e}] lengths \
                                 per unit time (absolute growth: {:e} to {:e} times the \
                                 smallest diameter {}): faster growth leaves the packing \
                                 unchanged and overflows the speeds, slower growth cannot finish",
                                show(r),
                                RATE_RANGE[0],
                                RATE_RANGE[1],
                                sizes.d_min
                            ),
                        ));
                    }
                }
            }
            if let Some(a) = &s.adaptive {
                let rate = s
                    .rate
                    .filter(|_| s.growth != GrowthKind::None)
                    .ok_or_else(|| {
                        invalid(f("adaptive"), "needs a growing stage (growth and rate)")
                    })?;
                within(
                    &f("adaptive.onset_pressure"),
                    a.onset_pressure,
                    [1.0, 1e12],
                    "",
                )?;
                if !(a.exponent > 0.0 && a.exponent <= 4.0) {
                    return Err(invalid(
                        f("adaptive.exponent"),
                        format!("= {} is outside the allowed range (0, 4]", show(a.exponent)),
                    ));
                }
                if !(a.min_rate > 0.0 && a.min_rate <= rate) {
                    return Err(invalid(
                        f("adaptive.min_rate"),
                        format!(
                            "= {} is outside the allowed range (0, rate = {}]",
                            show(a.min_rate),
                            show(rate)
                        ),
                    ));
                }
                let u = &s.until;
                if u.packing_fraction.is_some()
                    || u.time.is_some()
                    || u.full_size.is_some()
                    || u.gap.is_some()
                {
                    return Err(invalid(
                        f("adaptive"),
                        "applies to goals reduced_pressure, max_gap and \
                         collisions_per_particle: a packing fraction, time or gap goal is \
                         placed with a fixed rate",
                    ));
                }
            }
            let u = &s.until;
            if u.packing_fraction.is_none()
                && u.reduced_pressure.is_none()
                && u.time.is_none()
                && u.collisions_per_particle.is_none()
                && u.full_size.is_none()
                && u.gap.is_none()
                && u.max_gap.is_none()
            {
                return Err(invalid(
                    f("until"),
                    "needs a goal: packing_fraction, reduced_pressure, time, \
                     collisions_per_particle, full_size, gap or max_gap",
                ));
            }
            for (name, flag) in [("full_size", u.full_size), ("max_gap", u.max_gap)] {
                if flag == Some(false) {
                    return Err(invalid(
                        f(&format!("until.{name}")),
                        "= false is not a goal; remove it or set it to true",
                    ));
                }
            }
            if let Some(x) = u.packing_fraction {
                fraction(&f("until.packing_fraction"), x)?;
                if equal_spheres && x >= KEPLER_FRACTION {
                    return Err(invalid(
                        f("until.packing_fraction"),
                        format!(
                            "= {x} cannot be reached: equal spheres pack at most π/√18 ≈ \
                             {KEPLER_FRACTION:.6} (Kepler); allowed range (0, {KEPLER_FRACTION:.6})"
                        ),
                    ));
                }
                if s.growth == GrowthKind::None {
                    return Err(invalid(
                        f("until.packing_fraction"),
                        "cannot be reached without growth",
                    ));
                }
            }
            if let Some(x) = u.reduced_pressure {
                if !(x.is_finite() && x > 1.0) {
                    return Err(invalid(
                        f("until.reduced_pressure"),
                        format!("= {x} must be a finite number > 1"),
                    ));
                }
            }
            if let Some(x) = u.time {
                positive(&f("until.time"), x)?;
            }
            if let Some(x) = u.collisions_per_particle {
                positive(&f("until.collisions_per_particle"), x)?;
            }
            if let Some(x) = s.max_wall_seconds {
                wall_seconds(&f("max_wall_seconds"), x)?;
            }
            if s.max_events == Some(0) {
                return Err(invalid(f("max_events"), "= 0 must be ≥ 1"));
            }
            if let Some(x) = s.stall_epsilon {
                if !(x.is_finite() && x >= 0.0) {
                    return Err(invalid(f("stall_epsilon"), format!("= {x} must be ≥ 0")));
                }
            }
            if !s.opens_gap() {
                for (key, given) in [
                    ("wall_gap", s.wall_gap.is_some()),
                    ("wall_gap_fraction", s.wall_gap_fraction.is_some()),
                ] {
                    if given {
                        return Err(invalid(
                            f(key),
                            "applies only to a gap stage (`until.gap` or `until.max_gap`)",
                        ));
                    }
                }
            }
            if u.full_size.is_some() {
                if s.growth != GrowthKind::Relative {
                    return Err(invalid(
                        f("until.full_size"),
                        "needs growth = \"relative\" (all sizes reach their target together, \
                         Eq. 30)",
                    ));
                }
                if u.packing_fraction.is_some() {
                    return Err(invalid(
                        f("until.full_size"),
                        "give either `full_size` or `packing_fraction`",
                    ));
                }
                at_true_size = true;
                final_diameter = final_diameter.max(sizes.d_max);
            }
            if s.opens_gap() {
                let field = f(if u.gap.is_some() {
                    "until.gap"
                } else {
                    "until.max_gap"
                });
                if u.gap.is_some() && u.max_gap.is_some() {
                    return Err(invalid(field, "give either `gap` or `max_gap`"));
                }
                if s.growth != GrowthKind::Absolute {
                    return Err(invalid(
                        field,
                        "needs growth = \"absolute\" (every radius gains the same, Eq. 31)",
                    ));
                }
                if k != last {
                    return Err(invalid(field, "must be the goal of the last stage"));
                }
                if !at_true_size {
                    return Err(invalid(
                        field,
                        "needs the spheres at their true sizes: put a stage with \
                         `until = { full_size = true }` before it, or seed at true size \
                         (seed_scale = 1, no packing_fraction)",
                    ));
                }
                if u.packing_fraction.is_some() || u.full_size.is_some() {
                    return Err(invalid(
                        field,
                        "cannot be combined with packing_fraction or full_size",
                    ));
                }
                if let Some(x) = s.wall_gap_fraction {
                    if s.wall_gap.is_some() {
                        return Err(invalid(
                            f("wall_gap_fraction"),
                            "give either `wall_gap` or `wall_gap_fraction`",
                        ));
                    }
                    if !(x.is_finite() && (0.0..=0.5).contains(&x)) {
                        return Err(invalid(
                            f("wall_gap_fraction"),
                            format!("= {x} is outside the allowed range [0, 0.5]"),
                        ));
                    }
                }
                if let Some(w) = s.wall_gap {
                    let Some(g) = u.gap else {
                        return Err(invalid(
                            f("wall_gap"),
                            "is a length and applies with `until.gap`; with `max_gap` the \
                             gap is not known in advance: give `wall_gap_fraction` in \
                             [0, 0.5] (wall gap / Δd) instead",
                        ));
                    };
                    if !(w.is_finite() && (0.0..=0.5 * g).contains(&w)) {
                        return Err(invalid(
                            f("wall_gap"),
                            format!(
                                "= {w} is outside the allowed range [0, gap/2 = {}]",
                                0.5 * g
                            ),
                        ));
                    }
                }
                let gap = match u.gap {
                    Some(g) => {
                        positive(&field, g)?;
                        if g >= gap_bound {
                            return Err(invalid(
                                field,
                                format!(
                                    "= {g} cannot be reached: {:.0} spheres of at least {:.4} \
                                     plus the gap would overfill the container (gap < {:.4}); \
                                     lower the gap or the mixture fraction",
                                    sizes.count,
                                    sizes.d_min,
                                    gap_bound.max(0.0)
                                ),
                            ));
                        }
                        g
                    }
                    None => gap_bound.max(0.0),
                };
                final_diameter = final_diameter.max(sizes.d_max + gap);
            } else if s.growth != GrowthKind::None && u.full_size.is_none() {
                // Growth to a fraction, or to jamming (bounded by the Kepler fraction for
                // equal spheres; polydisperse scenes by the same scale, an estimate).
                let phi = u.packing_fraction.unwrap_or(KEPLER_FRACTION);
                at_true_size = false;
                final_diameter = final_diameter
                    .max(sizes.d_max * scale * (phi.max(seeded_phi) / seeded_phi).cbrt());
            }
        }
        Ok(final_diameter)
    }
}

/// Count, extreme diameters and total volume of a scene's spheres at their true sizes
/// (expected values for a grading curve).
struct NominalSizes {
    count: f64,
    d_min: f64,
    d_max: f64,
    volume: f64,
}

impl Scene {
    /// A scene that starts from a packing (`particles.from`): nothing else describes the
    /// particles, the stages are EDMD's, and the file is a sphere packing in the scene's
    /// container ([`Scene::start_packing`]); its sizes are the nominal ones.
    fn validate_start(&self) -> Result<NominalSizes, SceneError> {
        let p = &self.particles;
        for (given, field) in [
            (p.count.is_some(), "particles.count"),
            (p.diameter.is_some(), "particles.diameter"),
            (p.components.is_some(), "particles.components"),
            (p.grading.is_some(), "particles.grading"),
            (p.mixture_fraction.is_some(), "particles.mixture_fraction"),
            (
                p.effective_fraction.is_some(),
                "particles.effective_fraction",
            ),
            (p.d_min.is_some(), "particles.d_min"),
            (p.packing_fraction.is_some(), "particles.packing_fraction"),
            (p.seed_scale.is_some(), "particles.seed_scale"),
            (p.gap.is_some(), "particles.gap"),
            (p.wall_gap.is_some(), "particles.wall_gap"),
            (p.ellipsoid.is_some(), "particles.ellipsoid"),
        ] {
            if given {
                return Err(invalid(
                    field,
                    "does not apply with `particles.from`: the particles are the file's, at \
                     their sizes and places",
                ));
            }
        }
        if self.method != Method::Edmd {
            return Err(invalid(
                "particles.from",
                "needs method = \"edmd\" (a packing to start from is not seeded)",
            ));
        }
        let start = self.start_packing()?.expect("`from` is given");
        let diameters: Vec<f64> = start.radii.iter().map(|r| 2.0 * r).collect();
        for (i, &d) in diameters.iter().enumerate() {
            if !(d.is_finite() && d > 0.0) {
                return Err(invalid(
                    "particles.from",
                    format!(
                        "particle {i} has radius {}: must be finite and > 0",
                        0.5 * d
                    ),
                ));
            }
        }
        Ok(NominalSizes {
            count: diameters.len() as f64,
            d_min: diameters.iter().copied().fold(f64::INFINITY, f64::min),
            d_max: diameters.iter().copied().fold(0.0, f64::max),
            volume: sphere_volume(&diameters),
        })
    }
}
