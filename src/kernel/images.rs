//! Periodic images for particles comparable to the box (shapes with
//! [`crate::shape::Collidable::Images`]).
//!
//! Minimum image is exact while every pair of neighbour-list spheres reaches less than half the
//! shortest periodic edge: then two particles can meet through one image only. A needle about
//! as long as the box meets several images of a partner, and its own images. The kernel then
//! tracks *which* image a neighbour is: a neighbour-list entry (and the partner of a collision
//! event) carries a lattice shift `n ∈ {−2, …, 2}³` in the high bits of its `u32`,
//! [`INDEX_BITS`] bits holding the particle index. Entry `(j, n)` in `i`'s list means that
//! `i`'s list sphere overlaps that of `j` translated by `n·L` (`L` the periodic edges; `n_k = 0`
//! on walled axes); `j`'s list holds `(i, −n)`. A particle's own images are entries `(i, n)`
//! with `n ≠ 0`, stored once for the pair `±n` (the contacts of `i` with `i + nL` and with
//! `i − nL` are one event, translated by the period).
//!
//! Shift 0 is code 0, so a list without images holds plain indices: the mode can be switched
//! on at a barrier without rewriting the lists (they are rebuilt with images then).
//!
//! Two shifts per axis suffice while `R_i + R_j ≤ 2L` (list-sphere centres are wrapped into
//! the box, so their offset is below `L` per axis): the scene keeps the bounding diameter
//! below the shortest periodic edge and the list skin is at most half the radius.

use crate::shape::Vec3;

/// Bits of the particle index in an entry that carries an image code.
pub(super) const INDEX_BITS: u32 = 25;
const INDEX_MASK: u32 = (1 << INDEX_BITS) - 1;
/// Largest shift per axis.
pub(super) const MAX_SHIFT: i32 = 2;
const SIDE: i32 = 2 * MAX_SHIFT + 1;
const CODES: i32 = SIDE * SIDE * SIDE;
/// Offset that maps shift 0 to code 0.
const ZERO: i32 = (CODES - 1) / 2;

/// Most particles a kernel with images can hold.
pub(super) const MAX_PARTICLES: usize = 1 << INDEX_BITS;

/// The packed entry for particle `j` translated by `shift` lattice vectors.
#[inline]
pub(super) fn encode(j: usize, shift: [i32; 3]) -> u32 {
    let c =
        (shift[0] + MAX_SHIFT) + SIDE * ((shift[1] + MAX_SHIFT) + SIDE * (shift[2] + MAX_SHIFT));
    let code = (c + CODES - ZERO) % CODES;
    (code as u32) << INDEX_BITS | j as u32
}

/// Particle index of a packed entry.
#[inline]
pub(super) fn index(entry: u32) -> usize {
    (entry & INDEX_MASK) as usize
}

/// Lattice shift of a packed entry.
#[inline]
pub(super) fn shift(entry: u32) -> [i32; 3] {
    let c = ((entry >> INDEX_BITS) as i32 + ZERO) % CODES;
    [
        c % SIDE - MAX_SHIFT,
        (c / SIDE) % SIDE - MAX_SHIFT,
        c / (SIDE * SIDE) - MAX_SHIFT,
    ]
}

/// The same image seen from the other particle: `(j, n)` in `i`'s list ↔ `(i, −n)` in `j`'s.
#[inline]
pub(super) fn mirrored(i: usize, entry: u32) -> u32 {
    let n = shift(entry);
    encode(i, [-n[0], -n[1], -n[2]])
}

/// The translation `n·L` of a shift, `period` holding the periodic edges (0 on walled axes).
#[inline]
pub(super) fn translation(shift: [i32; 3], period: &Vec3) -> Vec3 {
    Vec3::new(
        f64::from(shift[0]) * period.x,
        f64::from(shift[1]) * period.y,
        f64::from(shift[2]) * period.z,
    )
}

/// Calls `f` with every shift `n` for which spheres of radii summing to `reach`, centred `d`
/// apart (`d = c_i − c_j`, both wrapped into the box), overlap when the second is translated by
/// `n·L`. With `own` (a sphere against its own images) the zero shift is left out and only one
/// of `±n` is given (the one whose first non-zero component is positive). Shifts come in the
/// order of increasing `(n_z, n_y, n_x)`.
///
/// Called for every candidate of every list update with images (all particles when the list
/// spheres span the box), so it avoids divisions and rounding calls: per axis, the squared
/// offsets `(d_k − n_k L_k)²` of the at most `2·MAX_SHIFT + 1` shifts are tabulated once and
/// those already beyond `reach` dropped; a pair of axes whose partial sum is beyond it skips
/// its inner loop (the sum only grows).
pub(super) fn overlapping_shifts(
    d: &Vec3,
    reach: f64,
    period: &Vec3,
    own: bool,
    mut f: impl FnMut([i32; 3]),
) {
    let reach2 = reach * reach;
    // Shifts per axis with their squared offsets, in increasing order of the shift.
    let mut shifts = [[(0i32, 0.0f64); SIDE as usize]; 3];
    let mut counts = [0usize; 3];
    for k in 0..3 {
        if period[k] > 0.0 {
            for n in -MAX_SHIFT..=MAX_SHIFT {
                let offset = d[k] - f64::from(n) * period[k];
                let sq = offset * offset;
                if sq < reach2 {
                    shifts[k][counts[k]] = (n, sq);
                    counts[k] += 1;
                }
            }
        } else {
            shifts[k][0] = (0, d[k] * d[k]);
            counts[k] = 1;
        }
    }
    for &(nz, z2) in &shifts[2][..counts[2]] {
        for &(ny, y2) in &shifts[1][..counts[1]] {
            if y2 + z2 >= reach2 {
                continue;
            }
            for &(nx, x2) in &shifts[0][..counts[0]] {
                let n = [nx, ny, nz];
                if own && n.iter().copied().find(|&x| x != 0).is_none_or(|x| x < 0) {
                    continue;
                }
                // The squared norm of `d − n·L`, summed in the order `Vector3::norm_squared`
                // uses.
                if x2 + y2 + z2 < reach2 {
                    f(n);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary::{Boundary, PeriodicBox};
    use crate::kernel::{Edmd, EventKind, KernelConfig};
    use crate::queue::CalendarQueue;
    use crate::shape::ellipsoid::Spin;
    use crate::shape::{Collidable, Ellipsoid, Growth};
    use nalgebra::UnitQuaternion;
    use rand::SeedableRng;

    /// Needles of semi-axes `a0 : 0.05 : 0.05` along `axis` (angle about z), growing at
    /// `g` (largest semi-axis per time), at rest (temperature 10⁻²⁴), in a periodic box.
    fn needles(
        centres: Vec<Vec3>,
        angle: f64,
        a0: f64,
        g: f64,
        len: Vec3,
    ) -> Edmd<Ellipsoid, PeriodicBox, CalendarQueue> {
        let n = centres.len();
        let shape = Ellipsoid::new(Vec3::new(a0, 0.05, 0.05));
        let spin = Spin {
            orientation: UnitQuaternion::from_scaled_axis(Vec3::z() * angle),
            omega: Vec3::zeros(),
        };
        let config = KernelConfig {
            temperature: 1e-24,
            // List spheres and envelopes that already hold the contacts of the whole
            // window (pair predictions stop at the partners' list exits, here the growth
            // through the skin width).
            neighbour_skin: 5.0,
            ..KernelConfig::default()
        };
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
        let boundary = PeriodicBox {
            min: Vec3::zeros(),
            len,
        };
        let mut kernel = Edmd::with_spins(
            centres,
            vec![shape; n],
            vec![spin; n],
            boundary,
            config,
            &mut rng,
        );
        for p in &mut kernel.particles {
            p.shape.set_growth(0.0, Growth::Absolute(g));
        }
        kernel
    }

    /// The earliest collision the kernel predicts over an interval of `window`: time and
    /// the two indices (the same for a contact with the particle's own image).
    fn first_collision(
        kernel: &mut Edmd<Ellipsoid, PeriodicBox, CalendarQueue>,
        window: f64,
    ) -> Option<(f64, usize, usize)> {
        kernel.begin_interval(window);
        let mut best: Option<(f64, usize, usize)> = None;
        for i in 0..kernel.particles.len() {
            while let Some((k, e)) = kernel.local.earliest(i) {
                if let EventKind::Collision { partner, .. } = e.kind() {
                    if best.is_none_or(|b| e.time < b.0) {
                        best = Some((e.time, i, index(partner)));
                    }
                }
                kernel.local.remove(i, k);
            }
        }
        best
    }

    #[test]
    fn needles_meet_through_an_image_that_is_not_the_minimum_one() {
        // Both needles along u at 10° to x in a cube of edge 4: `B + 4x` lies on `A`'s axis
        // 2.2 away, so the tips touch when the semi-axis reaches 1.1 (t = 1 at g = 0.1); the
        // minimum image of `B` is a parallel needle 0.69 off the axis, never touched.
        let u = Vec3::new(10f64.to_radians().cos(), 10f64.to_radians().sin(), 0.0);
        let a = Vec3::new(0.5, 1.5, 2.0);
        let b = a + u * 2.2 - Vec3::new(4.0, 0.0, 0.0);
        let mut kernel = needles(vec![a, b], 10f64.to_radians(), 1.0, 0.1, Vec3::repeat(4.0));
        assert!(
            kernel.lists.tracks_images(),
            "list spheres reach half the box: images are tracked"
        );
        let (t, i, j) = first_collision(&mut kernel, 2.0).expect("the tips meet");
        assert_ne!(i, j);
        assert!((t - 1.0).abs() < 1e-9, "{t}");
        // Minimum image alone sees no contact in the window.
        let (pa, pb) = (&kernel.particles[0], &kernel.particles[1]);
        let mut dr = pa.pos - pb.pos;
        kernel.boundary.minimum_image(&mut dr);
        let dv = pa.vel - pb.vel;
        let seen =
            Ellipsoid::collision_time(&pa.shape, &pb.shape, &pa.spin, &pb.spin, &dr, &dv, 0.0, 2.0);
        assert_eq!(seen, f64::INFINITY);
    }

    #[test]
    fn a_needle_growing_along_a_short_edge_meets_its_own_image_on_time() {
        // Semi-axis 0.9 + 0.1 t along x in a box 2 long in x: tip meets the image's tip when
        // 2a = 2, at t = 1; the other edges (3) are never reached.
        let mut kernel = needles(
            vec![Vec3::new(1.0, 1.5, 1.5)],
            0.0,
            0.9,
            0.1,
            Vec3::new(2.0, 3.0, 3.0),
        );
        assert!(kernel.lists.tracks_images());
        let (t, i, j) = first_collision(&mut kernel, 2.0).expect("the needle meets itself");
        assert_eq!(i, j);
        assert!((t - 1.0).abs() < 1e-9, "{t}");
    }

    #[test]
    fn a_tilted_needle_meets_its_own_image_on_time_and_keeps_its_momentum() {
        // Tilted by θ in the x-y plane: the needle and its translate by L = 2 along x touch
        // when L²·x̂ᵀM⁻¹x̂ = 4, i.e. a = (L/2)·√(cos²θ + (a/b)² sin²θ) (b = a/18 throughout).
        let theta: f64 = 0.01;
        let contact_a = (theta.cos().powi(2) + (18.0 * theta.sin()).powi(2)).sqrt();
        let expected = (contact_a - 0.9) / 0.1;
        let centre = vec![Vec3::new(1.0, 1.5, 1.5)];
        let len = Vec3::new(2.0, 3.0, 3.0);
        let mut kernel = needles(centre.clone(), theta, 0.9, 0.1, len);
        let (t, i, j) = first_collision(&mut kernel, 2.0).expect("the needle meets itself");
        assert_eq!(i, j);
        assert!((t - expected).abs() < 1e-9, "{t} vs {expected}");
        // Through the contact: only the rotation changes, the velocity stays bit for bit.
        let mut kernel = needles(centre, theta, 0.9, 0.1, len);
        let (vel, omega) = (kernel.particles[0].vel, kernel.particles[0].spin.omega);
        let stage = crate::kernel::Stage {
            growth: Growth::Absolute(0.1),
            schedule: crate::kernel::RateSchedule::Fixed,
            until: crate::kernel::Until {
                time: Some(expected + 0.02),
                ..Default::default()
            },
            limits: crate::kernel::Limits::default(),
            thermostat: false,
            wall_growth: 1.0,
        };
        kernel.run_stage(&stage);
        assert!(kernel.counters().collisions >= 1);
        assert_eq!(kernel.particles[0].vel, vel);
        assert!((kernel.particles[0].spin.omega - omega).norm() > 1e-6);
    }

    #[test]
    fn entries_round_trip_and_plain_indices_are_the_zero_shift() {
        assert_eq!(encode(12345, [0, 0, 0]), 12345);
        for n in [[1, 0, 0], [-2, 2, -1], [2, 2, 2], [-2, -2, -2], [0, -1, 1]] {
            let e = encode(MAX_PARTICLES - 1, n);
            assert_eq!((index(e), shift(e)), (MAX_PARTICLES - 1, n));
            assert_eq!(shift(mirrored(7, e)), n.map(|x| -x));
            // Never the tag of a particle's own events (`u32::MAX`).
            assert_ne!(e, u32::MAX);
        }
    }

    #[test]
    fn own_images_are_listed_once_per_pair_of_opposite_shifts() {
        let period = Vec3::new(1.0, 1.0, 0.0);
        let mut found = Vec::new();
        // A sphere of radius 0.75 (reach 1.5) against its own images in a box periodic on x, y:
        // the edge neighbours at 1 and the diagonal ones at √2, not those at 2.
        overlapping_shifts(&Vec3::zeros(), 1.5, &period, true, |n| found.push(n));
        found.sort();
        assert_eq!(found, vec![[0, 1, 0], [1, -1, 0], [1, 0, 0], [1, 1, 0]][..]);
    }
}
