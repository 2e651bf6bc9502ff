//! The characteristic polynomial of two ellipsoids and its root classification
//! (paper 004, Eq. 13, Algorithms 3–4, Table 1; Wang et al. 2001, Jia et al. 2011).
//!
//! With `A`, `B` the 4×4 homogeneous quadric matrices (`xᵀAx = 0` on the surface, negative
//! inside), `f(λ) = det(λA + B) = p1λ⁴ + p2λ³ + p3λ² + p4λ + p5`. Two ellipsoids are separate
//! exactly when `f` has four distinct real roots of which two are positive, externally
//! tangent when the two positive roots merge into a double root, and overlapping otherwise
//! (Wang et al.; the other two roots are always negative).
//!
//! # η coefficients (derived here; the extracted Algorithm 4 is garbled)
//! With the normalised coefficients `p̄1 = −p2/(4p1)`, `p̄2 = p3/(6p1)`, `p̄3 = −p4/(4p1)`,
//! `p̄4 = p5/p1`, i.e. `f/p1 = λ⁴ − 4p̄1λ³ + 6p̄2λ² − 4p̄3λ + p̄4`, the classical invariants of
//! the quartic are `I = p̄4 − 4p̄1p̄3 + 3p̄2²` (β1 of Algorithm 4) and
//! `J = p̄2p̄4 + 2p̄1p̄2p̄3 − p̄2³ − p̄3² − p̄1²p̄4` (β2), and
//! - `η1 = I³ − 27J²` = discriminant/256: `> 0` four distinct real roots or two complex
//!   pairs, `< 0` two real roots, `= 0` a multiple root (tangency);
//! - `η2 = −D/64 = 12p̄1⁴ − 24p̄1²p̄2 + 9p̄2² + 4p̄1p̄3 − p̄4` and `η5 = p̄1² − p̄2 = −P/48`,
//!   with `P = 8p1p3 − 3p2²` and `D = 64p1³p5 − 16p1²p3² + 16p1p2²p3 − 16p1²p2p4 − 3p2⁴`
//!   the standard quartic discriminants: for `η1 > 0` the roots are all real iff `η2 > 0`
//!   and `η5 > 0`. This is the role Table 1 gives its η2 and η5 in the "separate" rows; the
//!   extracted η2 formula is replaced by this one, and η3, η4 (which only split the tangent
//!   cases) are not needed: tangency is the boundary `η1 = 0` reached from "separate".
//!
//! Whether two of the real roots are positive follows from Descartes' rule, exact when all
//! roots are real. Unit tests check the coefficients against a numerical determinant and the
//! classification against numerically computed roots.

use super::Vec3;
use nalgebra::{Matrix3, Matrix4};

/// Coefficients `[p1, …, p5]` of `det(λA + B)` for general 4×4 matrices: the coefficient of
/// `λ^k` is the sum over the `k`-subsets `S` of columns of the determinant of the matrix that
/// takes the columns in `S` from `A` and the others from `B` (multilinearity, Algorithm 3).
pub fn pencil_polynomial(a: &Matrix4<f64>, b: &Matrix4<f64>) -> [f64; 5] {
    let mut p = [0.0; 5];
    for mask in 0u32..16 {
        let mut m = *b;
        for col in 0..4 {
            if mask & (1 << col) != 0 {
                m.set_column(col, &a.column(col));
            }
        }
        p[4 - mask.count_ones() as usize] += m.determinant();
    }
    p
}

/// Homogeneous quadric matrix of an ellipsoid with rotation `rot` (body → world), semi-axes
/// `axes` and centre `c`: `[[Q, −Qc], [−cᵀQ, cᵀQc − 1]]`, `Q = R·diag(axes⁻²)·Rᵀ` (Eq. 7).
pub fn quadric_matrix(rot: &Matrix3<f64>, axes: &Vec3, c: &Vec3) -> Matrix4<f64> {
    let inv2 = axes.map(|a| 1.0 / (a * a));
    let q = rot * Matrix3::from_diagonal(&inv2) * rot.transpose();
    let qc = q * c;
    let mut m = Matrix4::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&q);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&(-qc));
    m.fixed_view_mut::<1, 3>(3, 0).copy_from(&(-qc.transpose()));
    m[(3, 3)] = c.dot(&qc) - 1.0;
    m
}

/// `[p1, …, p5]` of `det(λA + B)` for ellipsoid `a` at the origin and `b` at `r`, computed in
/// the frame where `a` is the unit sphere (`x = R_a D_a y`), which keeps the coefficients of
/// order one whatever the aspect ratios. The polynomial differs from the world-frame one by
/// the positive factor `det(R_a D_a)⁻²`, so its roots and signs are the same.
pub fn pencil_coefficients(
    rot_a: &Matrix3<f64>,
    axes_a: &Vec3,
    rot_b: &Matrix3<f64>,
    axes_b: &Vec3,
    r: &Vec3,
) -> [f64; 5] {
    // In a's unit frame: b has centre D_a⁻¹R_aᵀr and orientation/shape from the map.
    let to_unit = Matrix3::from_diagonal(&axes_a.map(|x| 1.0 / x)) * rot_a.transpose();
    let centre = to_unit * r;
    let inv2 = axes_b.map(|x| 1.0 / (x * x));
    let qb = rot_b * Matrix3::from_diagonal(&inv2) * rot_b.transpose();
    let from_unit = rot_a * Matrix3::from_diagonal(axes_a);
    let s = from_unit.transpose() * qb * from_unit;
    let sc = s * centre;
    let mut bm = Matrix4::zeros();
    bm.fixed_view_mut::<3, 3>(0, 0).copy_from(&s);
    bm.fixed_view_mut::<3, 1>(0, 3).copy_from(&(-sc));
    bm.fixed_view_mut::<1, 3>(3, 0)
        .copy_from(&(-sc.transpose()));
    bm[(3, 3)] = centre.dot(&sc) - 1.0;
    let am = Matrix4::from_diagonal(&nalgebra::Vector4::new(1.0, 1.0, 1.0, -1.0));
    pencil_polynomial(&am, &bm)
}

/// The η coefficients of a quartic (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eta {
    /// Discriminant / 256 of the normalised quartic.
    pub eta1: f64,
    /// `−D/64`.
    pub eta2: f64,
    /// `−P/48`.
    pub eta5: f64,
}

impl Eta {
    /// The η coefficients of `p1λ⁴ + … + p5` (`p1 ≠ 0`).
    pub fn of(p: &[f64; 5]) -> Self {
        let p1 = -p[1] / (4.0 * p[0]);
        let p2 = p[2] / (6.0 * p[0]);
        let p3 = -p[3] / (4.0 * p[0]);
        let p4 = p[4] / p[0];
        let i = (p4 - p1 * p3) + 3.0 * (p2 * p2 - p1 * p3);
        let j = -p3 * (p3 - p1 * p2) - p4 * (p1 * p1 - p2) - p2 * (p2 * p2 - p1 * p3);
        let p1s = p1 * p1;
        Self {
            eta1: i * i * i - 27.0 * j * j,
            eta2: 12.0 * p1s * p1s - 24.0 * p1s * p2 + 9.0 * p2 * p2 + 4.0 * p1 * p3 - p4,
            eta5: p1s - p2,
        }
    }
}

/// Relative position of two ellipsoids from their characteristic polynomial.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Configuration {
    /// Four distinct real roots, two of them positive (Table 1, cases 1–2).
    Separate,
    /// Touching or overlapping (everything else; tangency is the boundary `η1 = 0`).
    NotSeparate,
}

/// Classifies the configuration of the pair whose characteristic polynomial is `p`.
pub fn classify(p: &[f64; 5]) -> Configuration {
    let eta = Eta::of(p);
    if !(eta.eta1 > 0.0 && eta.eta2 > 0.0 && eta.eta5 > 0.0) {
        return Configuration::NotSeparate;
    }
    // All roots real: the number of positive roots is the number of sign changes.
    let mut changes = 0;
    let mut last = 0.0;
    for &c in p {
        if c != 0.0 {
            if last != 0.0 && (c > 0.0) != (last > 0.0) {
                changes += 1;
            }
            last = c;
        }
    }
    if changes == 2 {
        Configuration::Separate
    } else {
        Configuration::NotSeparate
    }
}
