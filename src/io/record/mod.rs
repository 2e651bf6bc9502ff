//! The particles of a packing file, one type per shape kind.
//!
//! Every tool outside the kernel works on written particles: the exporters, the analyses
//! and the independent overlap check. What they need of a kind is the contract
//! [`RecordShape`]: its geometry (volume, surface, bounding sphere, containment, plane
//! sections, sieve size), its form in each export (a CSV row, a Gmsh solid, VTK point data)
//! and its body for [`crate::verify`]. Each kind implements it in its own file
//! ([`sphere`], [`cylinder`], [`ellipsoid`]), and [`ParticleRecord`] is the one list of
//! kinds: a new kind is a new file here and, in this one, a variant, its arms in the
//! dispatch macros `each_kind!` and `map_kind!` and its entry in [`PHASE_NAMES`].
//! Exporters and analyses call the methods of [`ParticleRecord`] and never match on its
//! variants, except where a format is defined for one kind (xyzd and LAMMPS take spheres).

pub mod cylinder;
pub mod ellipsoid;
pub mod sphere;

pub use cylinder::CylinderRecord;
pub use ellipsoid::EllipsoidRecord;
pub use sphere::SphereRecord;

use crate::io::export::vtk::VtkAttributes;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// What every tool outside the kernel needs of a written particle kind. Lengths are in the
/// packing's unit; a record is at its written pose (periodic images are the caller's).
pub trait RecordShape: Sized {
    /// The kind's name: the `"type"` tag of the packing file, the CSV's `type` column, the
    /// voxel phase name (and, plural, the Gmsh physical volume of the kind).
    const NAME: &'static str;
    /// Voxel phase id (0 is the matrix); the Gmsh physical volume of the kind is tagged
    /// `3 + PHASE`.
    const PHASE: u8;

    /// Centre.
    fn center(&self) -> [f64; 3];
    /// Radius of the smallest sphere about [`RecordShape::center`] holding the particle.
    fn bounding_radius(&self) -> f64;
    /// Volume.
    fn volume(&self) -> f64;
    /// Surface area.
    fn surface_area(&self) -> f64;
    /// Whether the point `x` lies inside (or on) the particle.
    fn contains(&self, x: [f64; 3]) -> bool;
    /// The particle in another frame: every point `p` becomes `origin + scale(p)` and every
    /// length `x` becomes `scale(x)`; orientations are unchanged.
    fn in_frame(self, origin: [f64; 3], scale: &dyn Fn(f64) -> f64) -> Self;
    /// The particle with every length scaled by `factor` about its centre.
    fn scaled(&self, factor: f64) -> Self;
    /// Diameter used for sieving: the smallest square mesh the particle passes.
    fn sieve_diameter(&self) -> f64;
    /// Rotational degrees of freedom that move its contacts (0 for a sphere, 2 for a body of
    /// revolution, 3 otherwise): the jamming report counts constraints against them.
    fn rotations(&self) -> u8;
    /// The cut of the particle by the plane at signed distance `t` from its centre along
    /// axis `axes[2]`, in the plane coordinates `axes[0], axes[1]` where its centre is at
    /// `center`; `None` when the plane misses it. `particle` is its index in the packing.
    fn plane_cut(
        &self,
        particle: usize,
        center: [f64; 2],
        axes: [usize; 3],
        t: f64,
    ) -> Option<SectionCut>;
    /// The row of the CSV table of mixed kinds (`type,x,y,z,r,lx,ly,lz,a,b,c,qw,qx,qy,qz`,
    /// unused columns empty; see [`crate::io::export::csv`]).
    fn csv_row(&self) -> String;
    /// The `.geo` statements creating OpenCASCADE volume `tag` for the particle with its
    /// lengths scaled by `scale`, moved by `shift` (a periodic image) and inflated by
    /// `inflate` (an interface shell); see [`crate::io::export::gmsh`].
    fn gmsh_solid(&self, tag: usize, scale: f64, shift: [f64; 3], inflate: f64) -> String;
    /// The point data of the particle in the `.vtu` export.
    fn vtk_attributes(&self) -> VtkAttributes;
    /// What is wrong with the record's sizes (not finite, not positive, an orientation that
    /// is not a unit quaternion), for the independent check; `None` when they are valid.
    fn size_error(&self) -> Option<String>;
    /// The body the independent overlap check tests (meaningful when
    /// [`RecordShape::size_error`] is `None`).
    fn body(&self) -> Body;
}

/// One particle of a packing: `{"type": "<kind>", ...}` with the kind's fields.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ParticleRecord {
    /// A sphere.
    Sphere(SphereRecord),
    /// A finite flat-ended cylinder (sphere + cylinder mixtures).
    Cylinder(CylinderRecord),
    /// An ellipsoid.
    Ellipsoid(EllipsoidRecord),
}

/// Calls `$body` with `$p` bound to the record inside `$record`, whatever its kind (static
/// dispatch: one arm per kind).
macro_rules! each_kind {
    ($record:expr, $p:ident => $body:expr) => {
        match $record {
            ParticleRecord::Sphere($p) => $body,
            ParticleRecord::Cylinder($p) => $body,
            ParticleRecord::Ellipsoid($p) => $body,
        }
    };
}

/// Like `each_kind!`, for a `$body` that makes a record of the same kind again.
macro_rules! map_kind {
    ($record:expr, $p:ident => $body:expr) => {
        match $record {
            ParticleRecord::Sphere($p) => ParticleRecord::Sphere($body),
            ParticleRecord::Cylinder($p) => ParticleRecord::Cylinder($body),
            ParticleRecord::Ellipsoid($p) => ParticleRecord::Ellipsoid($body),
        }
    };
}

/// The voxel phases: the matrix and every kind, by id ([`RecordShape::PHASE`]).
pub const PHASE_NAMES: [(u8, &str); 4] = [
    (0, "matrix"),
    (SphereRecord::PHASE, SphereRecord::NAME),
    (EllipsoidRecord::PHASE, EllipsoidRecord::NAME),
    (CylinderRecord::PHASE, CylinderRecord::NAME),
];

impl ParticleRecord {
    /// A sphere of `radius` at `center`.
    pub fn sphere(center: [f64; 3], radius: f64) -> Self {
        Self::Sphere(SphereRecord { center, radius })
    }

    /// The kind's name ([`RecordShape::NAME`]).
    pub fn kind(&self) -> &'static str {
        fn name<S: RecordShape>(_: &S) -> &'static str {
            S::NAME
        }
        each_kind!(self, p => name(p))
    }

    /// The voxel phase id of the kind ([`RecordShape::PHASE`]).
    pub fn phase(&self) -> u8 {
        fn phase<S: RecordShape>(_: &S) -> u8 {
            S::PHASE
        }
        each_kind!(self, p => phase(p))
    }

    /// Centre ([`RecordShape::center`]).
    pub fn center(&self) -> [f64; 3] {
        each_kind!(self, p => p.center())
    }

    /// Centre and radius of the smallest sphere about the centre holding the particle, which
    /// every exporter uses for bounds (periodic images, voxel ranges).
    pub fn bounding_sphere(&self) -> ([f64; 3], f64) {
        each_kind!(self, p => (p.center(), p.bounding_radius()))
    }

    /// Volume.
    pub fn volume(&self) -> f64 {
        each_kind!(self, p => p.volume())
    }

    /// Surface area.
    pub fn surface_area(&self) -> f64 {
        each_kind!(self, p => p.surface_area())
    }

    /// Whether point `x` lies inside (or on) the particle at its written pose (no periodic
    /// wrap: the caller passes the unwrapped point).
    pub fn contains(&self, x: [f64; 3]) -> bool {
        each_kind!(self, p => p.contains(x))
    }

    /// The particle in another frame (see [`crate::io::packing::ContainerRecord::in_frame`]);
    /// orientations are unchanged.
    pub fn in_frame(self, origin: [f64; 3], scale: impl Fn(f64) -> f64) -> Self {
        map_kind!(self, p => p.in_frame(origin, &scale))
    }

    /// The particle with its size scaled by `factor` about its centre.
    pub fn scaled(&self, factor: f64) -> Self {
        map_kind!(self, p => p.scaled(factor))
    }

    /// Diameter used for sieving ([`RecordShape::sieve_diameter`]).
    pub fn sieve_diameter(&self) -> f64 {
        each_kind!(self, p => p.sieve_diameter())
    }

    /// Rotational degrees of freedom ([`RecordShape::rotations`]).
    pub fn rotations(&self) -> u8 {
        each_kind!(self, p => p.rotations())
    }

    /// The cut by a plane ([`RecordShape::plane_cut`]).
    pub fn plane_cut(
        &self,
        particle: usize,
        center: [f64; 2],
        axes: [usize; 3],
        t: f64,
    ) -> Option<SectionCut> {
        each_kind!(self, p => p.plane_cut(particle, center, axes, t))
    }

    /// The row of the mixed CSV table ([`RecordShape::csv_row`]).
    pub fn csv_row(&self) -> String {
        each_kind!(self, p => p.csv_row())
    }

    /// The Gmsh solid ([`RecordShape::gmsh_solid`]).
    pub fn gmsh_solid(&self, tag: usize, scale: f64, shift: [f64; 3], inflate: f64) -> String {
        each_kind!(self, p => p.gmsh_solid(tag, scale, shift, inflate))
    }

    /// The `.vtu` point data ([`RecordShape::vtk_attributes`]).
    pub fn vtk_attributes(&self) -> VtkAttributes {
        each_kind!(self, p => p.vtk_attributes())
    }

    /// What is wrong with the sizes ([`RecordShape::size_error`]).
    pub fn size_error(&self) -> Option<String> {
        each_kind!(self, p => p.size_error())
    }

    /// The body of the independent check ([`RecordShape::body`]).
    pub fn body(&self) -> Body {
        each_kind!(self, p => p.body())
    }
}

/// A particle as the independent overlap check ([`crate::verify`]) sees it
/// ([`RecordShape::body`]): the kind chooses the pair test.
pub enum Body {
    /// A sphere: every pair and wall distance exact.
    Ball {
        /// Centre.
        center: [f64; 3],
        /// Radius.
        radius: f64,
    },
    /// An ellipsoid: pairs by the Perram–Wertheim function (with spheres, in any
    /// container).
    Ellipsoid {
        /// Centre.
        center: [f64; 3],
        /// Largest semi-axis (radius of its bounding sphere).
        bound: f64,
        /// Its shape matrix, volume and smallest semi-axis.
        oriented: Oriented,
    },
    /// Any other convex body: pairs by separating-plane certificates found by GJK on its
    /// support map (with spheres, in a fully periodic box).
    Convex(Box<dyn SupportMap>),
}

/// An ellipsoid as the check sees it: `M = R·diag(a², b², c²)·Rᵀ`, its volume and its
/// smallest semi-axis.
pub struct Oriented {
    /// `M`.
    pub m: [[f64; 3]; 3],
    /// Volume.
    pub volume: f64,
    /// Smallest semi-axis.
    pub a_min: f64,
}

/// A convex body by its closed-form support functions, for the GJK pair test.
pub trait SupportMap {
    /// Centre (a point inside).
    fn center(&self) -> Vector3<f64>;
    /// The length the relative tolerance is taken of (a radius).
    fn radius(&self) -> f64;
    /// Radius of a sphere about the centre holding the body.
    fn bound(&self) -> f64;
    /// Volume.
    fn volume(&self) -> f64;
    /// The body moved by `t`.
    fn shifted(&self, t: Vector3<f64>) -> Box<dyn SupportMap>;
    /// The body minus a shell of thickness `delta` (Minkowski erosion by a ball).
    fn eroded(&self, delta: f64) -> Box<dyn SupportMap>;
    /// Support function `max_{x ∈ body} x·d`.
    fn support(&self, d: &Vector3<f64>) -> f64;
    /// A point of the body maximising `x·d`.
    fn support_point(&self, d: &Vector3<f64>) -> Vector3<f64>;
    /// Centre and radius when the body is a ball (pairs of balls are measured exactly).
    fn as_ball(&self) -> Option<(Vector3<f64>, f64)> {
        None
    }
}

/// What a section plane cuts out of one particle (or of one of its periodic images), in the
/// plane's coordinates ([`crate::analysis::section_axes`]).
#[derive(Clone, Debug, PartialEq)]
pub enum SectionCut {
    /// A sphere cut as a disc.
    Disc {
        /// Centre.
        center: [f64; 2],
        /// Radius `√(r² − t²)` at distance `t` of the plane from the sphere's centre.
        radius: f64,
        /// Index of the particle in the packing.
        particle: usize,
    },
    /// An ellipsoid cut as an ellipse.
    Ellipse {
        /// Centre.
        center: [f64; 2],
        /// Semi-axes.
        semi_axes: [f64; 2],
        /// Angle of the first semi-axis from the horizontal axis (radians).
        angle: f64,
        /// Index of the particle in the packing.
        particle: usize,
    },
    /// A finite cylinder cut as a convex polygon: the plane's section of its side sampled at
    /// [`cylinder::SECTION_SAMPLES`] angles (an ellipse's arc, inscribed) and the chords of its
    /// end disks, in counter-clockwise order.
    Polygon {
        /// Vertices.
        vertices: Vec<[f64; 2]>,
        /// Index of the particle in the packing.
        particle: usize,
    },
}

impl SectionCut {
    /// Index of the particle cut.
    pub fn particle(&self) -> usize {
        match self {
            Self::Disc { particle, .. }
            | Self::Ellipse { particle, .. }
            | Self::Polygon { particle, .. } => *particle,
        }
    }

    /// Centre of the cut (of its bounding box, for a polygon).
    pub fn center(&self) -> [f64; 2] {
        match self {
            Self::Disc { center, .. } | Self::Ellipse { center, .. } => *center,
            Self::Polygon { vertices, .. } => {
                let (lo, hi) = polygon_box(vertices);
                [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])]
            }
        }
    }

    /// Half-widths of the cut's axis-aligned bounding box.
    pub fn half_extent(&self) -> [f64; 2] {
        match self {
            Self::Disc { radius, .. } => [*radius; 2],
            Self::Ellipse {
                semi_axes: [a, b],
                angle,
                ..
            } => {
                let (s, c) = angle.sin_cos();
                [
                    ((a * c).powi(2) + (b * s).powi(2)).sqrt(),
                    ((a * s).powi(2) + (b * c).powi(2)).sqrt(),
                ]
            }
            Self::Polygon { vertices, .. } => {
                let (lo, hi) = polygon_box(vertices);
                [0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1])]
            }
        }
    }

    /// The same cut moved by `offset`.
    pub fn shifted(&self, offset: [f64; 2]) -> Self {
        let mut cut = self.clone();
        match &mut cut {
            Self::Disc { center, .. } | Self::Ellipse { center, .. } => {
                center[0] += offset[0];
                center[1] += offset[1];
            }
            Self::Polygon { vertices, .. } => {
                for p in vertices {
                    p[0] += offset[0];
                    p[1] += offset[1];
                }
            }
        }
        cut
    }
}

/// The axis-aligned bounding box `(lower, upper)` of a polygon's vertices.
fn polygon_box(vertices: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    vertices.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    )
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain); collinear
/// points are dropped. Written here: the only 2-D geometry the project needs, where a
/// crate (parry2d, geo) would add a dependency tree for twenty lines.
fn convex_hull(mut points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * points.len());
    for pass in [points.clone(), points.into_iter().rev().collect()] {
        let floor = hull.len();
        for p in pass {
            while hull.len() >= floor + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// `origin + scale(p)`, coordinate by coordinate.
pub(crate) fn placed(p: [f64; 3], origin: [f64; 3], scale: &dyn Fn(f64) -> f64) -> [f64; 3] {
    std::array::from_fn(|k| origin[k] + scale(p[k]))
}

/// `|v|²`.
fn norm2(v: &[f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum()
}

/// The rotation of a unit quaternion `[w, x, y, z]` (body frame to world frame).
fn rotation_of(orientation: &[f64; 4]) -> nalgebra::UnitQuaternion<f64> {
    let [w, x, y, z] = *orientation;
    nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
}
