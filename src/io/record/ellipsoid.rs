//! A written ellipsoid: `{"type": "ellipsoid", "center": [..], "semi_axes": [a, b, c],
//! "orientation": [w, x, y, z]}`.

use super::{placed, rotation_of, Body, Oriented, RecordShape, SectionCut};
use crate::io::export::vtk::VtkAttributes;
use nalgebra::{Matrix2, Matrix3, SymmetricEigen, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// An ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EllipsoidRecord {
    /// Centre.
    pub center: [f64; 3],
    /// Semi-axes along the body x, y, z axes.
    pub semi_axes: [f64; 3],
    /// Unit quaternion `[w, x, y, z]` rotating the body frame (whose axes carry the
    /// semi-axes) into the world frame.
    pub orientation: [f64; 4],
}

/// Semi-axes this close (relative) make a spheroid (two rotations move its contacts) or a
/// sphere (none).
const SPHEROID_TOLERANCE: f64 = 1e-9;

impl EllipsoidRecord {
    /// `R·diag(a², b², c²)·Rᵀ` with `R` the rotation matrix of the normalised quaternion
    /// (paper 004, Eq. 5a), written here from the quaternion's components (the check does
    /// not reuse nalgebra's rotation, nor the kernel's).
    fn shape_matrix(&self) -> [[f64; 3]; 3] {
        let n = self.orientation.iter().map(|x| x * x).sum::<f64>().sqrt();
        let [w, x, y, z] = self.orientation.map(|q| q / n);
        let r = [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ];
        let a = self.semi_axes;
        let mut m = [[0.0; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| r[i][k] * r[j][k] * a[k] * a[k]).sum();
            }
        }
        m
    }
}

impl RecordShape for EllipsoidRecord {
    const NAME: &'static str = "ellipsoid";
    const PHASE: u8 = 2;

    fn center(&self) -> [f64; 3] {
        self.center
    }

    fn bounding_radius(&self) -> f64 {
        self.semi_axes.iter().copied().fold(0.0, f64::max)
    }

    fn volume(&self) -> f64 {
        let a = self.semi_axes;
        4.0 / 3.0 * PI * a[0] * a[1] * a[2]
    }

    /// Knud Thomsen's formula (relative error below 1.1 %; the voxel export's resolution
    /// bound is all that uses it).
    fn surface_area(&self) -> f64 {
        let a = self.semi_axes;
        let p = 1.6075;
        let mean = ((a[0] * a[1]).powf(p) + (a[0] * a[2]).powf(p) + (a[1] * a[2]).powf(p)) / 3.0;
        4.0 * PI * mean.powf(1.0 / p)
    }

    /// In the body frame: `Σ (x_k / a_k)² ≤ 1`.
    fn contains(&self, x: [f64; 3]) -> bool {
        let c = self.center;
        let d = Vector3::new(x[0] - c[0], x[1] - c[1], x[2] - c[2]);
        let body = rotation_of(&self.orientation).inverse_transform_vector(&d);
        (0..3)
            .map(|k| (body[k] / self.semi_axes[k]).powi(2))
            .sum::<f64>()
            <= 1.0
    }

    fn in_frame(self, origin: [f64; 3], scale: &dyn Fn(f64) -> f64) -> Self {
        Self {
            center: placed(self.center, origin, scale),
            semi_axes: self.semi_axes.map(scale),
            orientation: self.orientation,
        }
    }

    fn scaled(&self, factor: f64) -> Self {
        Self {
            semi_axes: self.semi_axes.map(|x| x * factor),
            ..*self
        }
    }

    /// Twice its middle semi-axis.
    fn sieve_diameter(&self) -> f64 {
        let mut a = self.semi_axes;
        a.sort_by(f64::total_cmp);
        2.0 * a[1]
    }

    /// 0 for a sphere, 2 for a spheroid, 3 otherwise (semi-axes equal to a relative 10⁻⁹).
    fn rotations(&self) -> u8 {
        let mut a = self.semi_axes;
        a.sort_by(f64::total_cmp);
        let close = |x: f64, y: f64| (y - x).abs() <= SPHEROID_TOLERANCE * y.abs();
        match (close(a[0], a[1]), close(a[1], a[2])) {
            (true, true) => 0,
            (true, false) | (false, true) => 2,
            (false, false) => 3,
        }
    }

    /// The ellipsoid `(x − c)ᵀ A (x − c) ≤ 1`, `A = R diag(a⁻²) Rᵀ`, cut as the ellipse
    /// `(p − p*)ᵀ M (p − p*) ≤ ρ`, where `M` is the in-plane block of `A`, `b` its in-plane
    /// column on the normal axis, `p* = −t M⁻¹ b` and `ρ = 1 − t² (A_nn − bᵀ M⁻¹ b)`
    /// (completing the square in the in-plane coordinates); its semi-axes are `√(ρ/λ)` for
    /// the eigenvalues `λ` of `M`.
    fn plane_cut(
        &self,
        particle: usize,
        center: [f64; 2],
        axes: [usize; 3],
        t: f64,
    ) -> Option<SectionCut> {
        let r = rotation_of(&self.orientation).to_rotation_matrix();
        let s = self.semi_axes;
        let inverse_squares =
            Matrix3::from_diagonal(&Vector3::new(s[0].powi(-2), s[1].powi(-2), s[2].powi(-2)));
        let a = r.matrix() * inverse_squares * r.matrix().transpose();
        let [h, v, n] = axes;
        let m = Matrix2::new(a[(h, h)], a[(h, v)], a[(v, h)], a[(v, v)]);
        let b = Vector2::new(a[(h, n)], a[(v, n)]);
        // M is positive definite (a block of a positive definite matrix).
        let m_inv_b = m.cholesky()?.solve(&b);
        let rho = 1.0 - t * t * (a[(n, n)] - b.dot(&m_inv_b));
        if rho <= 0.0 {
            return None;
        }
        let offset = -t * m_inv_b;
        let eigen = SymmetricEigen::new(m);
        let first = eigen.eigenvectors.column(0);
        Some(SectionCut::Ellipse {
            center: [center[0] + offset[0], center[1] + offset[1]],
            semi_axes: [
                (rho / eigen.eigenvalues[0]).sqrt(),
                (rho / eigen.eigenvalues[1]).sqrt(),
            ],
            angle: first[1].atan2(first[0]),
            particle,
        })
    }

    fn csv_row(&self) -> String {
        let (c, a, q) = (self.center, self.semi_axes, self.orientation);
        format!(
            "ellipsoid,{},{},{},,,,,{},{},{},{},{},{},{}",
            c[0], c[1], c[2], a[0], a[1], a[2], q[0], q[1], q[2], q[3]
        )
    }

    /// A unit sphere at the origin dilated to the semi-axes (a shell adds `inflate` to each:
    /// an ellipsoid, not the exact offset surface), rotated about the origin and then
    /// translated to its centre: every periodic image is then the same solid moved, so
    /// OpenCASCADE cuts matching curves on opposite faces. (Built at its own centre, an
    /// image's spline surface differs in the last bits from the original's and Gmsh 4.8
    /// failed to pair the cut curves of a periodic box: "Cannot find periodic counterpart",
    /// then a crash.)
    fn gmsh_solid(&self, tag: usize, scale: f64, shift: [f64; 3], inflate: f64) -> String {
        let c: [f64; 3] = std::array::from_fn(|k| self.center[k] + shift[k]);
        let a = self.semi_axes.map(|x| x * scale + inflate);
        let mut text = format!(
            "Sphere({tag}) = {{0, 0, 0, 1}};\nDilate {{{{0, 0, 0}}, {{{}, {}, {}}}}} {{ Volume{{{tag}}}; }}",
            a[0], a[1], a[2]
        );
        if let Some((axis, angle)) = rotation_of(&self.orientation).axis_angle() {
            text.push_str(&format!(
                "\nRotate {{{{{}, {}, {}}}, {{0, 0, 0}}, {}}} {{ Volume{{{tag}}}; }}",
                axis[0], axis[1], axis[2], angle
            ));
        }
        text.push_str(&format!(
            "\nTranslate {{{}, {}, {}}} {{ Volume{{{tag}}}; }}",
            c[0], c[1], c[2]
        ));
        text
    }

    fn vtk_attributes(&self) -> VtkAttributes {
        let a = self.semi_axes;
        let r = rotation_of(&self.orientation).to_rotation_matrix();
        let tensor = r.matrix()
            * Matrix3::from_diagonal(&Vector3::new(a[0], a[1], a[2]))
            * r.matrix().transpose();
        VtkAttributes {
            center: self.center,
            radius: self.bounding_radius(),
            semi_axes: a,
            orientation: self.orientation,
            shape_tensor: std::array::from_fn(|k| tensor[(k / 3, k % 3)]),
            half_axis: [0.0; 3],
            shape: Self::PHASE,
        }
    }

    fn size_error(&self) -> Option<String> {
        let norm = self.orientation.iter().map(|x| x * x).sum::<f64>().sqrt();
        let valid = self.semi_axes.iter().all(|a| a.is_finite() && *a > 0.0);
        (!(valid && (norm - 1.0).abs() < 1e-9))
            .then(|| "semi-axes ≤ 0 or orientation not a unit quaternion".to_string())
    }

    fn body(&self) -> Body {
        let a = self.semi_axes;
        Body::Ellipsoid {
            center: self.center,
            bound: self.bounding_radius(),
            oriented: Oriented {
                m: self.shape_matrix(),
                volume: self.volume(),
                a_min: a.iter().copied().fold(f64::INFINITY, f64::min),
            },
        }
    }
}
