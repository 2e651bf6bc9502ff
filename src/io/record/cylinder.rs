//! A written finite cylinder: `{"type": "cylinder", "center": [..], "radius": r,
//! "half_axis": [lx, ly, lz]}`.

use super::{convex_hull, norm2, placed, Body, RecordShape, SectionCut, SupportMap};
use crate::io::export::vtk::VtkAttributes;
use nalgebra::{Matrix3, UnitQuaternion, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A finite flat-ended cylinder (sphere + cylinder mixtures): the body within `radius` of
/// the segment from `center − half_axis` to `center + half_axis`, cut by the planes of its
/// two end disks.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderRecord {
    /// Centre.
    pub center: [f64; 3],
    /// Radius.
    pub radius: f64,
    /// Half axis: from the centre to the centre of one end disk.
    pub half_axis: [f64; 3],
}

/// Angles at which a cylinder's side is sampled for its section polygon
/// ([`SectionCut::Polygon`]).
pub const SECTION_SAMPLES: usize = 96;

impl CylinderRecord {
    /// Half the length along the axis, `|half_axis|`.
    fn half_length(&self) -> f64 {
        norm2(&self.half_axis).sqrt()
    }
}

impl RecordShape for CylinderRecord {
    const NAME: &'static str = "cylinder";
    const PHASE: u8 = 3;

    fn center(&self) -> [f64; 3] {
        self.center
    }

    fn bounding_radius(&self) -> f64 {
        (self.radius * self.radius + norm2(&self.half_axis)).sqrt()
    }

    fn volume(&self) -> f64 {
        PI * self.radius * self.radius * 2.0 * self.half_length()
    }

    fn surface_area(&self) -> f64 {
        let length = 2.0 * self.half_length();
        2.0 * PI * self.radius * (self.radius + length)
    }

    fn contains(&self, x: [f64; 3]) -> bool {
        // Axial coordinate t along the unit axis, radial distance² = |x − c|² − t².
        let length = self.half_length();
        let d: [f64; 3] = std::array::from_fn(|k| x[k] - self.center[k]);
        let t = (0..3).map(|k| d[k] * self.half_axis[k]).sum::<f64>() / length;
        let radial2 = norm2(&d) - t * t;
        t.abs() <= length && radial2 <= self.radius * self.radius
    }

    fn in_frame(self, origin: [f64; 3], scale: &dyn Fn(f64) -> f64) -> Self {
        Self {
            center: placed(self.center, origin, scale),
            radius: scale(self.radius),
            half_axis: self.half_axis.map(scale),
        }
    }

    fn scaled(&self, factor: f64) -> Self {
        Self {
            center: self.center,
            radius: self.radius * factor,
            half_axis: self.half_axis.map(|x| x * factor),
        }
    }

    /// Its diameter: it passes a mesh axis first.
    fn sieve_diameter(&self) -> f64 {
        2.0 * self.radius
    }

    fn rotations(&self) -> u8 {
        2
    }

    /// The section by the plane at signed distance `t` from the centre along `axes[2]`. Its
    /// points are `s·â + u·e₁ + v·e₂` from the centre, `|s| ≤ |l|`, `u² + v² ≤ r²`
    /// (`â = l/|l|`, `e₁, e₂ ⊥ â`). The boundary is where the plane meets the side (for each
    /// angle φ, `s = (t − r (cos φ e₁ₙ + sin φ e₂ₙ))/âₙ` if `|s| ≤ |l|`) and the end disks
    /// (the chord `(u, v)·w = t ∓ |l| âₙ`, `w = (e₁ₙ, e₂ₙ)`, inside the circle); the section
    /// is their convex hull. Along the axis (`âₙ = 0`) the side gives straight lines whose
    /// ends are the chords' ends: the hull of the chords alone is the exact rectangle.
    fn plane_cut(
        &self,
        particle: usize,
        center: [f64; 2],
        axes: [usize; 3],
        t: f64,
    ) -> Option<SectionCut> {
        let r = self.radius;
        let axis = Vector3::from(self.half_axis);
        let length = axis.norm();
        let a = axis / length;
        let helper = if a.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e1 = a.cross(&helper).normalize();
        let e2 = a.cross(&e1);
        let [h, v, n] = axes;
        let in_plane = |p: Vector3<f64>| [center[0] + p[h], center[1] + p[v]];
        let mut points = Vec::new();
        if a[n].abs() > 1e-12 {
            for k in 0..SECTION_SAMPLES {
                let phi = std::f64::consts::TAU * k as f64 / SECTION_SAMPLES as f64;
                let radial = r * (phi.cos() * e1 + phi.sin() * e2);
                let s = (t - radial[n]) / a[n];
                if s.abs() <= length {
                    points.push(in_plane(s * a + radial));
                }
            }
        }
        let w = Vector2::new(e1[n], e2[n]);
        let q = w.norm();
        if q > 1e-12 {
            for end in [-length, length] {
                // The chord of this end disk: (u, v)·w = t − end·âₙ.
                let offset = (t - end * a[n]) / q;
                if offset.abs() <= r {
                    let foot = offset * w / q;
                    let half = (r * r - offset * offset).sqrt();
                    let along = Vector2::new(-w[1], w[0]) / q;
                    for sign in [-1.0, 1.0] {
                        let uv = foot + sign * half * along;
                        points.push(in_plane(end * a + uv[0] * e1 + uv[1] * e2));
                    }
                }
            }
        }
        let vertices = convex_hull(points);
        (vertices.len() >= 3).then_some(SectionCut::Polygon { vertices, particle })
    }

    fn csv_row(&self) -> String {
        let (c, l) = (self.center, self.half_axis);
        format!(
            "cylinder,{},{},{},{},{},{},{},,,,,,,",
            c[0], c[1], c[2], self.radius, l[0], l[1], l[2]
        )
    }

    /// OpenCASCADE's cylinder: base point, axis vector (full length), radius; a shell also
    /// grows by `inflate` at both caps.
    fn gmsh_solid(&self, tag: usize, scale: f64, shift: [f64; 3], inflate: f64) -> String {
        let l = self.half_axis;
        let length = self.half_length() * scale;
        let stretch = scale * (1.0 + inflate / length);
        let base: [f64; 3] = std::array::from_fn(|k| self.center[k] + shift[k] - l[k] * stretch);
        format!(
            "Cylinder({tag}) = {{{}, {}, {}, {}, {}, {}, {}}};",
            base[0],
            base[1],
            base[2],
            2.0 * l[0] * stretch,
            2.0 * l[1] * stretch,
            2.0 * l[2] * stretch,
            self.radius * scale + inflate
        )
    }

    /// Body frame: z along the axis. The rotation taking z to the axis, as a unit quaternion
    /// `[w, x, y, z]`, and the tensor `R·diag(r, r, |l|)·Rᵀ`.
    fn vtk_attributes(&self) -> VtkAttributes {
        let l = Vector3::from(self.half_axis);
        let length = l.norm();
        let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &l)
            .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI));
        let r = rotation.to_rotation_matrix();
        let tensor = r.matrix()
            * Matrix3::from_diagonal(&Vector3::new(self.radius, self.radius, length))
            * r.matrix().transpose();
        let q = rotation.quaternion();
        VtkAttributes {
            center: self.center,
            radius: self.radius,
            semi_axes: [self.radius, self.radius, length],
            orientation: [q.w, q.i, q.j, q.k],
            shape_tensor: std::array::from_fn(|k| tensor[(k / 3, k % 3)]),
            half_axis: self.half_axis,
            shape: Self::PHASE,
        }
    }

    fn size_error(&self) -> Option<String> {
        let (r, h) = (self.radius, self.half_length());
        (!(r.is_finite() && r > 0.0 && h.is_finite() && h > 0.0))
            .then(|| format!("radius {r} or half axis length {h} is not finite and > 0"))
    }

    fn body(&self) -> Body {
        let l = Vector3::from(self.half_axis);
        let h = l.norm();
        Body::Convex(Box::new(Rod {
            c: Vector3::from(self.center),
            u: l / h,
            h,
            r: self.radius,
        }))
    }
}

/// A cylinder as the independent check sees it: centre, unit axis, half-length, radius,
/// with closed-form support functions.
#[derive(Clone, Copy, Debug)]
struct Rod {
    c: Vector3<f64>,
    u: Vector3<f64>,
    h: f64,
    r: f64,
}

impl SupportMap for Rod {
    fn center(&self) -> Vector3<f64> {
        self.c
    }

    fn radius(&self) -> f64 {
        self.r
    }

    fn bound(&self) -> f64 {
        self.h.hypot(self.r)
    }

    fn volume(&self) -> f64 {
        2.0 * PI * self.r * self.r * self.h
    }

    fn shifted(&self, t: Vector3<f64>) -> Box<dyn SupportMap> {
        Box::new(Rod {
            c: self.c + t,
            ..*self
        })
    }

    /// A cylinder eroded by a ball of radius δ is the cylinder of half-length `h − δ` and
    /// radius `r − δ`.
    fn eroded(&self, delta: f64) -> Box<dyn SupportMap> {
        Box::new(Rod {
            h: self.h - delta,
            r: self.r - delta,
            ..*self
        })
    }

    fn support(&self, d: &Vector3<f64>) -> f64 {
        let along = self.u.dot(d);
        self.c.dot(d) + self.h * along.abs() + self.r * (d - self.u * along).norm()
    }

    /// A base-disk rim point (the base centre when `d` is along the axis).
    fn support_point(&self, d: &Vector3<f64>) -> Vector3<f64> {
        let along = self.u.dot(d);
        let across = d - self.u * along;
        let n = across.norm();
        let end = if along >= 0.0 {
            self.u * self.h
        } else {
            -self.u * self.h
        };
        if n > 0.0 {
            self.c + end + across * (self.r / n)
        } else {
            self.c + end
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn polygon(cut: Option<SectionCut>) -> Vec<[f64; 2]> {
        match cut {
            Some(SectionCut::Polygon { vertices, .. }) => vertices,
            other => panic!("a polygon, got {other:?}"),
        }
    }

    /// Shoelace area of a counter-clockwise polygon.
    fn area(v: &[[f64; 2]]) -> f64 {
        (0..v.len())
            .map(|k| {
                let (p, q) = (v[k], v[(k + 1) % v.len()]);
                p[0] * q[1] - q[0] * p[1]
            })
            .sum::<f64>()
            / 2.0
    }

    #[test]
    fn cylinder_sections_are_the_exact_disc_rectangle_and_ellipse() {
        let cylinder = |half_axis: [f64; 3]| CylinderRecord {
            center: [0.0; 3],
            radius: 0.5,
            half_axis,
        };
        let k = SECTION_SAMPLES as f64;
        let inscribed = k / (2.0 * std::f64::consts::PI) * (2.0 * std::f64::consts::PI / k).sin();
        // Across the axis (z = 0.3 of a cylinder along z): the disc of radius 0.5, as the
        // regular inscribed polygon, every vertex on the circle.
        let v = polygon(cylinder([0.0, 0.0, 1.0]).plane_cut(0, [2.0, 3.0], [0, 1, 2], 0.3));
        let exact = std::f64::consts::PI * 0.25 * inscribed;
        assert!((area(&v) / exact - 1.0).abs() < 1e-12, "{}", area(&v));
        for p in &v {
            assert!(((p[0] - 2.0).hypot(p[1] - 3.0) - 0.5).abs() < 1e-12);
        }
        // Along the axis (x = 0.3): the rectangle 2·√(0.25 − 0.09) wide, 2 high.
        let v = polygon(cylinder([0.0, 0.0, 1.0]).plane_cut(0, [0.0, 0.0], [1, 2, 0], 0.3));
        assert_eq!(v.len(), 4, "{v:?}");
        assert!((area(&v) - 2.0 * 0.4 * 2.0).abs() < 1e-12, "{}", area(&v));
        // Tilted by 30° from the plane normal and cut across its side only: an ellipse of
        // area π r² / cos 30°, semi-axes r and r / cos 30° (inscribed polygon: within 0.1 %).
        let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
        let v = polygon(cylinder([3.0 * s, 0.0, 3.0 * c]).plane_cut(0, [0.0, 0.0], [0, 1, 2], 0.2));
        let ellipse = std::f64::consts::PI * 0.25 / c;
        assert!(
            (area(&v) / ellipse - 1.0).abs() < 1e-3,
            "{} {ellipse}",
            area(&v)
        );
        // A plane past the end disks misses it.
        assert!(cylinder([0.0, 0.0, 1.0])
            .plane_cut(0, [0.0, 0.0], [0, 1, 2], 1.2)
            .is_none());
    }
}
