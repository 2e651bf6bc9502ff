//! Random sequential adsorption of spheres and cylinders (§III, Algorithm 5).
//!
//! Bodies are placed one after the other in the given order (see
//! [`super::MixtureSpec::sizes`] for the paper's generation orders): a uniformly random
//! centre in the box and, for a cylinder, a uniformly random axis direction; the candidate
//! is rejected if the exact tests ([`overlaps`]) find it intersecting any image of a placed
//! body, or — for a body longer than half the box — one of its own images. After
//! `max_attempts_per_body` consecutive rejections of one body the configuration is declared
//! stuck and, as the paper advises ("relaunch the program in the case of stagnating
//! configuration"), generation starts again from an empty box, up to `max_restarts` times.
//! The random generator is the caller's (Xoshiro256++ in the CLI), so a seed fixes the
//! result unless the optional wall-clock limit strikes.

use super::{random_direction, BodySize, MixtureError, PeriodicPairs, Rve};
use crate::boundary::PeriodicBox;
use crate::geometry::cylinder::{overlaps, Shape};
use crate::shape::Vec3;
use rand::Rng;
use std::time::{Duration, Instant};

/// Limits of random sequential adsorption.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RsaLimits {
    /// Consecutive rejections of one body before the attempt is declared stuck.
    pub max_attempts_per_body: u64,
    /// Fresh starts after a stuck attempt (0: fail at the first stuck body).
    pub max_restarts: u32,
    /// Wall-clock limit over all attempts (`None`: only the attempt limits apply).
    pub time_limit: Option<Duration>,
}

impl Default for RsaLimits {
    fn default() -> Self {
        Self {
            max_attempts_per_body: 100_000,
            max_restarts: 20,
            time_limit: None,
        }
    }
}

/// What a successful adsorption did.
#[derive(Clone, Debug)]
pub struct RsaOutcome {
    /// The intersection-free configuration (bodies in placement order).
    pub rve: Rve,
    /// Candidates drawn over all starts.
    pub candidates: u64,
    /// Fresh starts that were needed.
    pub restarts: u32,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Which limit stopped an adsorption.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RsaStop {
    /// Every start got stuck on one body.
    Attempts,
    /// The wall-clock limit.
    Time,
}

/// Random sequential adsorption could not place every body.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "random sequential adsorption placed {placed} of {total} bodies ({spheres_placed} of \
     {spheres} spheres, {cylinders_placed} of {cylinders} cylinders; fractions reached \
     f_s = {sphere_fraction:.4}, f_c = {cylinder_fraction:.4}) in its best of {starts} starts \
     before {reason}; lower the fractions, use the relaxer (method = \"md\") or raise the limits"
)]
pub struct RsaFailure {
    /// Bodies placed in the best start.
    pub placed: usize,
    /// Bodies requested.
    pub total: usize,
    /// Spheres placed.
    pub spheres_placed: usize,
    /// Spheres requested.
    pub spheres: usize,
    /// Cylinders placed.
    pub cylinders_placed: usize,
    /// Cylinders requested.
    pub cylinders: usize,
    /// Sphere fraction reached.
    pub sphere_fraction: f64,
    /// Cylinder fraction reached.
    pub cylinder_fraction: f64,
    /// Starts made (1 + restarts).
    pub starts: u32,
    /// Which limit struck.
    pub stop: RsaStop,
    /// The per-body rejection limit.
    pub max_attempts_per_body: u64,
    /// Wall-clock seconds spent.
    pub seconds: f64,
    /// The stop in words.
    pub reason: String,
}

/// Either bad sizes or a failed adsorption.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RsaError {
    /// A size does not fit the box.
    #[error(transparent)]
    Invalid(#[from] MixtureError),
    /// The limits struck.
    #[error(transparent)]
    Failed(#[from] RsaFailure),
}

/// Whether `candidate` intersects one of its own periodic images.
pub(crate) fn meets_own_image(pairs: &PeriodicPairs, candidate: &Shape) -> bool {
    let mut hit = false;
    pairs.self_image_offsets(candidate.bounding_radius(), |t| {
        hit = hit || overlaps(candidate, &candidate.translated(t));
    });
    hit
}

/// Places bodies of the given sizes, in this order, in `boundary` (Algorithm 5).
pub fn rsa_mixture<R: Rng>(
    boundary: &PeriodicBox,
    sizes: &[BodySize],
    limits: &RsaLimits,
    rng: &mut R,
) -> Result<RsaOutcome, RsaError> {
    for s in sizes {
        s.check_fits(boundary)?;
    }
    let start = Instant::now();
    let max_radius = sizes
        .iter()
        .map(|s| s.at(Vec3::zeros(), Vec3::z()).bounding_radius())
        .fold(0.0, f64::max);
    let mut candidates = 0u64;
    let mut best: Vec<Shape> = Vec::new();
    let mut starts = 0u32;
    let stop = loop {
        starts += 1;
        let mut pairs = PeriodicPairs::new(boundary, max_radius, sizes.len());
        let mut bodies: Vec<Shape> = Vec::with_capacity(sizes.len());
        let mut stuck = None;
        'bodies: for size in sizes {
            let mut rejections = 0u64;
            loop {
                candidates += 1;
                let center = boundary.min + boundary.len.map(|l| l * rng.gen::<f64>());
                let direction = if size.is_cylinder() {
                    random_direction(rng)
                } else {
                    Vec3::z()
                };
                let candidate = size.at(center, direction);
                let free = !meets_own_image(&pairs, &candidate)
                    && !pairs.any_image(&bodies, &candidate, |j, offset| {
                        overlaps(&candidate, &bodies[j].translated(offset))
                    });
                if free {
                    pairs.insert(bodies.len(), &center);
                    bodies.push(candidate);
                    continue 'bodies;
                }
                rejections += 1;
                if limits
                    .time_limit
                    .is_some_and(|t| rejections % 1024 == 0 && start.elapsed() > t)
                {
                    stuck = Some(RsaStop::Time);
                    break 'bodies;
                }
                if rejections >= limits.max_attempts_per_body {
                    stuck = Some(RsaStop::Attempts);
                    break 'bodies;
                }
            }
        }
        match stuck {
            None => {
                return Ok(RsaOutcome {
                    rve: Rve {
                        boundary: boundary.clone(),
                        bodies,
                    },
                    candidates,
                    restarts: starts - 1,
                    seconds: start.elapsed().as_secs_f64(),
                })
            }
            Some(stop) => {
                if bodies.len() > best.len() {
                    best = bodies;
                }
                if stop == RsaStop::Time || starts > limits.max_restarts {
                    break stop;
                }
            }
        }
    };
    let rve = Rve {
        boundary: boundary.clone(),
        bodies: best,
    };
    let (sphere_fraction, cylinder_fraction) = rve.fractions();
    let cylinders_placed = rve
        .bodies
        .iter()
        .filter(|b| matches!(b, Shape::Cylinder(_)))
        .count();
    let cylinders = sizes.iter().filter(|s| s.is_cylinder()).count();
    Err(RsaFailure {
        placed: rve.bodies.len(),
        total: sizes.len(),
        spheres_placed: rve.bodies.len() - cylinders_placed,
        spheres: sizes.len() - cylinders,
        cylinders_placed,
        cylinders,
        sphere_fraction,
        cylinder_fraction,
        starts,
        stop,
        max_attempts_per_body: limits.max_attempts_per_body,
        seconds: start.elapsed().as_secs_f64(),
        reason: match stop {
            RsaStop::Attempts => format!(
                "{} consecutive rejections of one body",
                limits.max_attempts_per_body
            ),
            RsaStop::Time => format!(
                "the time limit of {:.3} s",
                limits.time_limit.unwrap_or_default().as_secs_f64()
            ),
        },
    }
    .into())
}
