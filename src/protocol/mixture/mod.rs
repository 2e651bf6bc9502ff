//! RVEs of spheres and finite cylinders in a periodic box (Salnikov, Choï &
//! Karamian-Surville 2014): random sequential adsorption ([`rsa`], §III, Algorithm 5) and the
//! time-driven molecular-dynamics relaxer ([`relax`], §IV).
//!
//! # What
//!
//! A mixture is a list of bodies ([`Shape`]: spheres `S(p, r)` and cylinders `C(p, r, l)`)
//! in a [`PeriodicBox`]. Every intersection question goes to the exact typed tests of
//! [`crate::geometry::cylinder`]; the relaxer's candidate pairs come from a [`CellGrid`]
//! over the wrapped centres with cells as wide as the largest bounding diameter, RSA's from
//! a scan of the placed bodies ([`rsa::ImageScan`]) or a capsule-aware index
//! ([`rsa::CapsuleGrid`]); every periodic image of a partner that can
//! reach the body is tested — across faces, edges and corners, and a long cylinder against
//! its own images.
//!
//! # Sizes (Algorithm 5, steps 1–2)
//!
//! In a box of volume `V`, `n_c` cylinders of aspect ratio `a = ‖l‖/r` filling the fraction
//! `f_c` have `r_c = (f_c V / (2π a n_c))^{1/3}` (a cylinder has volume `2π a r³`), and `n_s`
//! spheres filling `f_s` have `r_s = (3 f_s V / (4π n_s))^{1/3}`. A cylinder must be shorter
//! than the box edge `L` (§V): `2 a r_c < L`, i.e. `n_c > 4 f_c a² V / (π L³)` — the bound
//! `N_cyl ≥ 4 f_c a²/π` of the paper for the unit cube, checked by [`MixtureSpec::validate`].
//! Any other size distribution can be given to [`rsa::rsa_mixture`] and
//! [`relax::relax`] directly as a list of [`BodySize`]s.

pub mod relax;
pub mod rsa;

use crate::boundary::{Boundary, PeriodicBox};
use crate::geometry::cylinder::{overlaps, Cylinder, Shape, Sphere};
use crate::shape::Vec3;
use crate::spatial::CellGrid;
use rand::Rng;
use std::f64::consts::PI;

/// Order in which random sequential adsorption places the bodies (§III, Fig. 4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GenerationOrder {
    /// All cylinders, then all spheres (the paper's choice for its tables).
    #[default]
    CylindersFirst,
    /// All spheres, then all cylinders.
    SpheresFirst,
    /// Alternating, keeping the placed share of both kinds equal.
    Interleaved,
}

/// Size (not position) of one body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BodySize {
    /// A sphere of this radius.
    Sphere {
        /// Radius.
        radius: f64,
    },
    /// A cylinder of this radius and half-length `‖l‖`.
    Cylinder {
        /// Radius `r_c`.
        radius: f64,
        /// Half-length `‖l_c‖`.
        half_length: f64,
    },
}

impl BodySize {
    /// The body with this size at `center`; `direction` (unit) orients a cylinder.
    pub fn at(&self, center: Vec3, direction: Vec3) -> Shape {
        match *self {
            BodySize::Sphere { radius } => Shape::Sphere(Sphere::new(center, radius)),
            BodySize::Cylinder {
                radius,
                half_length,
            } => Shape::Cylinder(Cylinder::new(center, direction * half_length, radius)),
        }
    }

    /// Whether it is a cylinder.
    pub fn is_cylinder(&self) -> bool {
        matches!(self, BodySize::Cylinder { .. })
    }

    /// Volume.
    pub fn volume(&self) -> f64 {
        match *self {
            BodySize::Sphere { radius } => 4.0 / 3.0 * PI * radius.powi(3),
            BodySize::Cylinder {
                radius,
                half_length,
            } => 2.0 * PI * radius * radius * half_length,
        }
    }

    /// Checks that the size is positive and the body fits the box: a sphere diameter and a
    /// cylinder length below the smallest box edge (a body must not meet its own image
    /// along its length, §V).
    pub fn check_fits(&self, boundary: &PeriodicBox) -> Result<(), MixtureError> {
        let edge = boundary.len.min();
        let (what, extent, ok_size) = match *self {
            BodySize::Sphere { radius } => ("sphere diameter", 2.0 * radius, radius > 0.0),
            BodySize::Cylinder {
                radius,
                half_length,
            } => (
                "cylinder length",
                2.0 * half_length,
                radius > 0.0 && half_length > 0.0,
            ),
        };
        if !(ok_size && extent.is_finite()) {
            return Err(MixtureError::Invalid {
                field: "sizes".into(),
                message: format!("{self:?} must have finite positive dimensions"),
            });
        }
        if extent >= edge {
            return Err(MixtureError::Invalid {
                field: "sizes".into(),
                message: format!("{what} {extent} must be below the box edge {edge}"),
            });
        }
        Ok(())
    }
}

/// Why a mixture cannot be set up.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MixtureError {
    /// A field is out of range.
    #[error("{field}: {message}")]
    Invalid {
        /// The field (scene key).
        field: String,
        /// What is wrong and the allowed range.
        message: String,
    },
    /// Too few cylinders for their fraction and aspect ratio: each would be longer than
    /// the box (§V, `N_cyl ≥ 4 f_c a²/π` in the unit cube).
    #[error(
        "mixture.cylinders = {cylinders} is below the bound N_cyl > 4 f_c a²/π = {bound:.3} \
         (f_c = {fraction}, a = {aspect_ratio}, unit box): each cylinder would be {length:.4} \
         box edges long; use more than {bound:.3} cylinders, a lower cylinder_fraction or a \
         lower aspect_ratio"
    )]
    CylinderCountBound {
        /// Requested cylinders.
        cylinders: usize,
        /// The bound (for a cube of any size: `4 f_c a² V / (π L³)`).
        bound: f64,
        /// Cylinder fraction.
        fraction: f64,
        /// Aspect ratio.
        aspect_ratio: f64,
        /// Cylinder length in box edges.
        length: f64,
    },
}

/// The inputs of Algorithm 5: volume fractions, counts and aspect ratio, in a periodic
/// cube of edge `box_size`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixtureSpec {
    /// `f_s`, volume fraction of the spheres, in `[0, 1)`.
    pub sphere_fraction: f64,
    /// `f_c`, volume fraction of the cylinders, in `[0, 1)`.
    pub cylinder_fraction: f64,
    /// `n_s`, number of spheres.
    pub spheres: usize,
    /// `n_c`, number of cylinders.
    pub cylinders: usize,
    /// `a = ‖l_c‖ / r_c` (length over diameter), positive.
    pub aspect_ratio: f64,
    /// Edge of the periodic cube.
    pub box_size: f64,
}

impl MixtureSpec {
    /// The periodic cube `[0, L)³`.
    pub fn boundary(&self) -> PeriodicBox {
        PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::repeat(self.box_size),
        }
    }

    fn volume(&self) -> f64 {
        self.box_size.powi(3)
    }

    /// Algorithm 5, step 2: `r_s = (3 f_s V / (4π n_s))^{1/3}`.
    pub fn sphere_radius(&self) -> f64 {
        (3.0 * self.sphere_fraction * self.volume() / (4.0 * PI * self.spheres as f64)).cbrt()
    }

    /// Algorithm 5, step 1: `r_c = (f_c V / (2π a n_c))^{1/3}`.
    pub fn cylinder_radius(&self) -> f64 {
        (self.cylinder_fraction * self.volume()
            / (2.0 * PI * self.aspect_ratio * self.cylinders as f64))
            .cbrt()
    }

    /// Checks every field (names are the scene keys under `[mixture]`) and the cylinder
    /// count bound.
    pub fn validate(&self) -> Result<(), MixtureError> {
        let invalid = |field: &str, message: String| MixtureError::Invalid {
            field: format!("mixture.{field}"),
            message,
        };
        for (field, f) in [
            ("sphere_fraction", self.sphere_fraction),
            ("cylinder_fraction", self.cylinder_fraction),
        ] {
            if !(f.is_finite() && (0.0..1.0).contains(&f)) {
                return Err(invalid(field, format!("{f} must be in [0, 1)")));
            }
        }
        let total = self.sphere_fraction + self.cylinder_fraction;
        if !(total > 0.0 && total < 1.0) {
            return Err(invalid(
                "cylinder_fraction",
                format!("sphere_fraction + cylinder_fraction = {total} must be in (0, 1)"),
            ));
        }
        if !(self.box_size.is_finite() && self.box_size > 0.0) {
            return Err(invalid(
                "box_size",
                format!("{} must be finite and positive", self.box_size),
            ));
        }
        if (self.sphere_fraction > 0.0) != (self.spheres > 0) {
            return Err(invalid(
                "spheres",
                format!(
                    "{} spheres with sphere_fraction {}: both must be zero or both positive",
                    self.spheres, self.sphere_fraction
                ),
            ));
        }
        if (self.cylinder_fraction > 0.0) != (self.cylinders > 0) {
            return Err(invalid(
                "cylinders",
                format!(
                    "{} cylinders with cylinder_fraction {}: both must be zero or both positive",
                    self.cylinders, self.cylinder_fraction
                ),
            ));
        }
        if self.cylinders > 0 {
            if !(self.aspect_ratio.is_finite() && self.aspect_ratio > 0.0) {
                return Err(invalid(
                    "aspect_ratio",
                    format!("{} must be finite and positive", self.aspect_ratio),
                ));
            }
            let length = 2.0 * self.aspect_ratio * self.cylinder_radius() / self.box_size;
            if length >= 1.0 {
                let a = self.aspect_ratio;
                return Err(MixtureError::CylinderCountBound {
                    cylinders: self.cylinders,
                    bound: 4.0 * self.cylinder_fraction * a * a / PI,
                    fraction: self.cylinder_fraction,
                    aspect_ratio: a,
                    length,
                });
            }
        }
        if self.spheres > 0 && self.sphere_radius() * 2.0 >= self.box_size {
            return Err(invalid(
                "spheres",
                format!(
                    "{} spheres at fraction {} have diameter {} ≥ the box edge {}: use more \
                     spheres",
                    self.spheres,
                    self.sphere_fraction,
                    2.0 * self.sphere_radius(),
                    self.box_size
                ),
            ));
        }
        Ok(())
    }

    /// The body sizes in the generation `order`.
    pub fn sizes(&self, order: GenerationOrder) -> Vec<BodySize> {
        let sphere = BodySize::Sphere {
            radius: self.sphere_radius(),
        };
        let rc = self.cylinder_radius();
        let cylinder = BodySize::Cylinder {
            radius: rc,
            half_length: self.aspect_ratio * rc,
        };
        let (ns, nc) = (self.spheres, self.cylinders);
        match order {
            GenerationOrder::CylindersFirst => [vec![cylinder; nc], vec![sphere; ns]].concat(),
            GenerationOrder::SpheresFirst => [vec![sphere; ns], vec![cylinder; nc]].concat(),
            GenerationOrder::Interleaved => {
                let (mut s, mut c) = (0usize, 0usize);
                let mut out = Vec::with_capacity(ns + nc);
                while s + c < ns + nc {
                    // Place the kind whose placed share lags (cross-multiplied shares).
                    if c < nc && (s >= ns || c * ns <= s * nc) {
                        out.push(cylinder);
                        c += 1;
                    } else {
                        out.push(sphere);
                        s += 1;
                    }
                }
                out
            }
        }
    }
}

/// A configuration: bodies with wrapped centres in a periodic box.
#[derive(Clone, Debug, PartialEq)]
pub struct Rve {
    /// The box.
    pub boundary: PeriodicBox,
    /// The bodies; centres lie in the box.
    pub bodies: Vec<Shape>,
}

impl Rve {
    /// Volume fractions of the spheres and of the cylinders.
    pub fn fractions(&self) -> (f64, f64) {
        let v = self.boundary.volume();
        let (mut s, mut c) = (0.0, 0.0);
        for b in &self.bodies {
            match b {
                Shape::Sphere(_) => s += b.volume(),
                Shape::Cylinder(_) => c += b.volume(),
            }
        }
        (s / v, c / v)
    }
}

/// A uniformly random unit vector (the direction of a random cylinder axis).
pub fn random_direction<R: Rng>(rng: &mut R) -> Vec3 {
    let v: [f64; 3] = rand_distr::Distribution::sample(&rand_distr::UnitSphere, rng);
    Vec3::from(v)
}

/// Periodic neighbour search for bodies with bounding spheres: a [`CellGrid`] over the
/// wrapped centres with cells as wide as the largest bounding diameter, and the images of
/// each partner that its bounding sphere can reach.
#[derive(Clone, Debug)]
pub struct PeriodicPairs {
    boundary: PeriodicBox,
    grid: CellGrid,
    max_bounding_radius: f64,
}

impl PeriodicPairs {
    /// An empty search for up to `capacity` bodies no larger (bounding radius) than
    /// `max_bounding_radius`.
    pub fn new(boundary: &PeriodicBox, max_bounding_radius: f64, capacity: usize) -> Self {
        let grid = CellGrid::new(
            boundary.min(),
            boundary.max(),
            [true; 3],
            2.0 * max_bounding_radius,
            capacity,
        );
        Self {
            boundary: boundary.clone(),
            grid,
            max_bounding_radius,
        }
    }

    /// Registers body `i` at its (wrapped) centre.
    pub fn insert(&mut self, i: usize, center: &Vec3) {
        self.grid.insert(i, self.grid.cell_at(0, center));
    }

    /// Moves body `i` to its new (wrapped) centre.
    pub fn update(&mut self, i: usize, center: &Vec3) {
        let cell = self.grid.cell_at(0, center);
        if self.grid.cell_of(i) != cell {
            self.grid.remove(i);
            self.grid.insert(i, cell);
        }
    }

    /// Calls `f(j, offset)` for every registered body `j` and lattice vector `offset` such
    /// that the image `bodies[j]` moved by `offset` has a bounding sphere within `skin` of
    /// that of `probe` (every face, edge and corner image; several images of one body when
    /// it is long enough).
    pub fn for_each_image(
        &self,
        bodies: &[Shape],
        probe: &Shape,
        skin: f64,
        mut f: impl FnMut(usize, Vec3),
    ) {
        let p = probe.center();
        let rp = probe.bounding_radius() + skin;
        self.grid
            .for_each_within(0, &p, rp + self.max_bounding_radius, |j| {
                let reach = rp + bodies[j].bounding_radius();
                let dr = bodies[j].center() - p;
                let mut near = dr;
                self.boundary.minimum_image(&mut near);
                for_each_lattice_vector(&self.boundary.len, &near, reach, |shift| {
                    f(j, near - dr + shift);
                });
            });
    }

    /// Lattice vectors `t ≠ 0`, one of each pair `±t`, by which a body of bounding radius
    /// `radius` could meet its own image.
    pub fn self_image_offsets(&self, radius: f64, f: impl FnMut(Vec3)) {
        self_image_offsets(&self.boundary, radius, f);
    }
}

/// Lattice vectors `t ≠ 0` of `boundary`, one of each pair `±t`, by which a body of
/// bounding radius `radius` could meet its own image (`‖t‖ < 2 radius`).
pub fn self_image_offsets(boundary: &PeriodicBox, radius: f64, mut f: impl FnMut(Vec3)) {
    if 2.0 * radius <= boundary.len.min() {
        // Every lattice vector t ≠ 0 has ‖t‖ ≥ the shortest edge.
        return;
    }
    for_each_lattice_vector(&boundary.len, &Vec3::zeros(), 2.0 * radius, |t| {
        let first_nonzero = t.iter().find(|x| **x != 0.0);
        if first_nonzero.is_some_and(|x| *x > 0.0) {
            f(t);
        }
    });
}

/// Calls `f(t)` for each lattice vector `t = (n_x L_x, n_y L_y, n_z L_z)` with
/// `|d + t| < reach`, where `d` is a minimum-image separation (`|d_k| ≤ L_k/2`, so
/// `|n_k| ≤ ⌊reach/L_k + 1/2⌋`); per axis only the `n_k` with `|d_k + n_k L_k| < reach`
/// are tried.
fn for_each_lattice_vector(len: &Vec3, d: &Vec3, reach: f64, mut f: impl FnMut(Vec3)) {
    // Only `t = 0` can qualify when `|d_k| + reach ≤ L_k` on every axis: a vector with
    // `n_k ≠ 0` has `|d_k + n_k L_k| ≥ L_k − |d_k| ≥ reach` (the common case for bodies
    // shorter than half the box, at no cost in the per-axis lists below).
    if (0..3).all(|k| d[k].abs() + reach <= len[k]) {
        if d.norm_squared() < reach * reach {
            f(Vec3::zeros());
        }
        return;
    }
    let mut axes = [[0.0f64; 8]; 3];
    let mut counts = [0usize; 3];
    for k in 0..3 {
        // |d_k| ≤ L_k/2: for reach < 3L_k/2 only n_k ∈ {−1, 0, 1} can qualify.
        let m = if reach < 1.5 * len[k] {
            1
        } else {
            (reach / len[k] + 0.5).floor() as i64
        };
        for n in -m..=m {
            let t = n as f64 * len[k];
            if (d[k] + t).abs() < reach && counts[k] < axes[k].len() {
                axes[k][counts[k]] = t;
                counts[k] += 1;
            }
        }
    }
    for &tx in &axes[0][..counts[0]] {
        for &ty in &axes[1][..counts[1]] {
            for &tz in &axes[2][..counts[2]] {
                let t = Vec3::new(tx, ty, tz);
                if (d + t).norm_squared() < reach * reach {
                    f(t);
                }
            }
        }
    }
}

/// The first pair (by index; `i == j` for a body meeting its own image) whose images the
/// exact tests find intersecting, with the lattice offset of the second body's image.
pub fn first_intersection(rve: &Rve) -> Option<(usize, usize, Vec3)> {
    let max_radius = rve
        .bodies
        .iter()
        .map(Shape::bounding_radius)
        .fold(0.0, f64::max);
    let mut pairs = PeriodicPairs::new(&rve.boundary, max_radius, rve.bodies.len());
    for (i, b) in rve.bodies.iter().enumerate() {
        pairs.insert(i, &b.center());
    }
    for (i, b) in rve.bodies.iter().enumerate() {
        let mut found = None;
        pairs.self_image_offsets(b.bounding_radius(), |t| {
            if found.is_none() && overlaps(b, &b.translated(t)) {
                found = Some((i, i, t));
            }
        });
        pairs.for_each_image(&rve.bodies, b, 0.0, |j, t| {
            if j > i && found.is_none() && overlaps(b, &rve.bodies[j].translated(t)) {
                found = Some((i, j, t));
            }
        });
        if found.is_some() {
            return found;
        }
    }
    None
}
