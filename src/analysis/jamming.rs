//! Is a sphere or ellipsoid packing jammed? Contacts, rattlers, the backbone's contact
//! number, the bond-orientational order and (spheres) a linear-programming certificate, all
//! computed from the written packing alone (no kernel counters, no prediction code).
//!
//! - **Contacts.** A pair is in contact when its relative surface gap
//!   `|c_i − c_j| / (r_i + r_j) − 1` is below the cut-off `h`; a sphere touches a wall when
//!   `(distance to the wall − r) / r < h`. Radii are first inflated by half the packing's
//!   `min_gap` (and wall distances reduced by its `wall_gap`), so that the network of a gap
//!   packing (paper 001, Eq. 31) is that of the grown grains. A jammed packing at reduced
//!   pressure `Z` has its contacts within about `1/Z` and its next neighbours orders of
//!   magnitude further: the count is flat over a wide range of `h` (the *plateau*, reported
//!   for `h = 10⁻¹⁴ … 10⁻⁴`).
//! - **Rattlers** are the spheres that are not *locally jammed* (Torquato & Stillinger,
//!   J. Phys. Chem. B 105, 11849, 2001): with the others held fixed, a sphere can move when
//!   the directions `d_k` to its contacts (walls included) lie in a closed hemisphere,
//!   `w·d_k ≤ 0` for some `w ≠ 0` and every `k` (it moves along `w`, opening or sliding
//!   along each contact). That is always so with fewer than `d + 1 = 4` contacts; with more
//!   it is tested directly: if such a `w` exists, one exists on the intersection of two
//!   contact planes, `w ∥ d_a × d_b`, so the pairs' cross products are the only candidates.
//!   Rattlers are removed iteratively (removing one may free a neighbour); the rest is the
//!   *backbone*.
//! - **Isostaticity.** The backbone of `n` spheres has `3n − t` non-trivial degrees of freedom
//!   (`t` = 3 rigid translations along periodic axes, fewer with walls). A collectively jammed
//!   network needs at least `3n − t + 1` contacts (one self-stress to carry the pressure);
//!   a random jammed packing has exactly that many (Donev, Torquato & Stillinger,
//!   PRE 71, 011105, 2005; O'Hern et al., PRE 68, 011306, 2003): mean contact number
//!   `Z = 2·pairs/n → 6` for a periodic packing.
//! - **Q6.** The global bond-orientational order of Steinhardt, Nelson & Ronchetti (PRB 28,
//!   784, 1983) over the bonds shorter than 1.2·(r_i + r_j), from the addition theorem:
//!   `Q6² = Σ_{a,b} P6(u_a·u_b) / N_b²`, evaluated through the moment tensors
//!   `M_k = Σ_a u_a^{⊗k}` as `(231‖M6‖² − 315‖M4‖² + 105‖M2‖² − 5N_b²) / (16 N_b²)`
//!   (`P6(x) = (231x⁶ − 315x⁴ + 105x² − 5)/16`). A perfect FCC crystal has 0.5745; bonds in
//!   random directions give `1/√N_b`.
//! - **Collective jamming** (Donev, Torquato, Stillinger & Connelly, J. Comput. Phys. 197,
//!   139, 2004): the backbone is collectively jammed (in a fixed container) when no
//!   displacement `Δx` of its spheres opens a contact without closing another, to first
//!   order: the openings `(Aᵀ Δx)_c = u_ij·(Δx_j − Δx_i)` of the contacts (and `n_w·Δx_i` of
//!   the wall contacts; `u_ij` the unit vector from `i` to `j`, `n_w` the wall's inward normal)
//!   are nowhere negative only for the rigid translations along periodic axes. The test solves
//!   the dual of that program: by Farkas' lemma, exactly one of *(a)* some contact forces
//!   `f ≥ 0` balance a load, `A f = b`, and *(b)* some motion `y` with `Aᵀ y ≥ 0` does negative
//!   work `bᵀ y < 0`. Draw a random load `b` with zero mean along each periodic axis (rigid
//!   translations do no work) and ask whether `b` and `−b` are both carried by compressive
//!   forces. A jammed backbone carries every such load; an unjamming motion `y` has `bᵀ y ≠ 0`
//!   with probability 1, so one of `±b` is not carried. Each question is the program
//!   `min Σ f  s.t.  A f = b, f ≥ 0`, solved by the Clarabel interior-point solver: a jammed
//!   backbone has strictly positive solutions (a self-stress plus a particular one), so the
//!   solver works in the interior and converges in a few dozen iterations; a not-jammed one
//!   ends with a certificate of infeasibility (the motion `y`). This is why the test does not
//!   maximise the openings directly: that program's feasible set is the translations alone
//!   when the packing is jammed (no interior), where interior-point methods crawl.
//!
//! **Ellipsoids** (and spheres beside them) get the same report with these changes:
//!
//! - A pair's gap is `s − 1`, `s = √max_λ F(λ)` the Perram–Wertheim scale factor by which
//!   both must be scaled about their centres to touch, computed by the independent check's
//!   [`contact_scale`] (for two spheres `s = |c_i − c_j| / (r_i + r_j)`: the sphere gap).
//!   Candidates are the pairs whose bounding spheres (radius: the largest semi-axis) are
//!   within the widest cut-off: scaled by `s`, the bodies stay inside their scaled bounding
//!   spheres, so `s − 1` is at least the bounding spheres' relative gap. A wall gap is
//!   `(distance to the wall − w)/w`, `w = √(nᵀMn)` the half-width along the wall normal `n`
//!   (`M = R·diag(a², b², c²)·Rᵀ`): the same scale factor against the plane. Ellipsoids come
//!   in boxes without gap claims (the scenes allow nothing else); other files are refused.
//! - The rattler rule for an ellipsoid is *fewer than `d + 1 = 4` contacts* only: a
//!   frictionless particle whose contacts all push on it needs four for force balance
//!   whatever its shape; the hemisphere test needs the contact normals, which for an
//!   ellipsoid are not along the line of centres. The stricter
//!   first-order count `d_f + 1` (force and torque) is not used: Donev, Connelly, Stillinger &
//!   Torquato (PRE 75, 051304, 2007) show that curved particles are jammed with fewer
//!   contacts through second-order (curvature) terms, so it would discard jammed particles.
//! - Degrees of freedom: `d_f = 3` for a sphere, 5 for a spheroid (two equal semi-axes: the
//!   spin about its axis moves nothing), 6 for a general ellipsoid. The isostatic contact
//!   number is `Z_iso = 2·d_f` (10 for spheroids, 12 for general ellipsoids), the counting
//!   `(pairs + walls)/(Σ d_f − t)` over the backbone. Jammed ellipsoid packings are
//!   *hypostatic*, `Z < Z_iso` (Donev et al., Science 303, 990, 2004; PRE 2007): near the
//!   sphere point `Z` rises from 6 with the aspect ratio and stays below 2·d_f.
//! - The LP test is first-order and for spheres only (its constraints ignore rotations and
//!   curvature, which decide jamming of hypostatic ellipsoid packings): it is skipped.
//! - Q6 uses the centre–centre bonds shorter than 1.2 times the sum of the bounding radii.

use super::separation;
use crate::io::export::{container_bounds, periodic_axes};
use crate::io::packing::{ContainerRecord, Packing};
use crate::io::record::Body as Checked;
use crate::verify::{contact_scale, PairLevels};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::sync::LazyLock;

/// The cut-offs of the plateau table: `10⁻¹⁴ … 10⁻⁴`.
pub const PLATEAU_CUTOFFS: [f64; 11] = [
    1e-14, 1e-13, 1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4,
];

/// Default contact cut-off: well inside the plateau of a packing jammed to `Z = 10¹²`.
pub const DEFAULT_CUTOFF: f64 = 1e-9;

/// Bonds of the Q6 order: centre distance below this multiple of `r_i + r_j`.
const BOND_REACH: f64 = 1.2;

/// Q6 of a perfect face-centred cubic crystal (12 nearest neighbours).
pub const Q6_FCC: f64 = 0.574_52;

/// Particles per task of the contact search on the thread pool (a fixed size, so that the
/// report does not depend on the number of threads).
const PARTICLES_PER_TASK: usize = 4096;

/// Rattlers have fewer contacts than this (see the module docs).
const RATTLER_BELOW: u32 = 4;

/// Contact directions closer than this (in sine or cosine) to a hemisphere's boundary count
/// as on it: far below any angle a contact network resolves, far above rounding.
const HEMISPHERE_TOLERANCE: f64 = 1e-12;

/// A particle as the report sees it.
#[derive(Clone, Copy, Debug)]
struct Body {
    center: [f64; 3],
    /// A sphere's radius (inflated by half the claimed gap), an ellipsoid's bounding radius.
    radius: f64,
    /// `M = R·diag(a², b², c²)·Rᵀ` of an ellipsoid, `None` for a sphere.
    shape: Option<[[f64; 3]; 3]>,
    /// Degrees of freedom: 3, 5 or 6.
    freedoms: u8,
}

/// One contact: a pair of particles, or a particle and a wall.
#[derive(Clone, Copy, Debug)]
struct Contact {
    i: u32,
    /// The partner, or `None` for a wall.
    j: Option<u32>,
    /// Unit vector from `i` to `j`, or from the wall into the container for a wall contact.
    normal: [f64; 3],
    /// Relative gap (see the module docs).
    gap: f64,
}

/// The contacts and rattlers at one cut-off.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CutoffRow {
    /// The relative gap cut-off `h`.
    pub cutoff: f64,
    /// Mean contacts per sphere before rattlers are removed (`(2·pairs + walls)/N`).
    pub mean_contacts: f64,
    /// Fraction of the spheres that are rattlers.
    pub rattler_fraction: f64,
    /// Mean contact number of the backbone (`(2·pairs + walls)/n`), `None` if it is empty.
    pub backbone_mean_contacts: Option<f64>,
    /// Contacts of the backbone per non-trivial degree of freedom, `(pairs + walls)/(F − t)`
    /// with `F = Σ d_f` over the backbone (`3n` for spheres): 1 (plus `1/(F − t)`) for an
    /// isostatic network, below 1 for a floppy or hypostatic one.
    pub constraints_per_freedom: Option<f64>,
}

/// The verdict of the linear-programming test for collective jamming.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LpCertificate {
    /// Both loads `b` and `−b` are carried: collectively jammed.
    pub jammed: bool,
    /// Whether compressive contact forces balance the random load `b` and `−b` (`None`:
    /// not decided, see [`LpCertificate::status`]).
    pub loads_carried: [Option<bool>; 2],
    /// Largest contact force of the solutions found, relative to the mean load `Σ|b|/(3n)`
    /// (`NaN` when no load is carried).
    pub max_force: f64,
    /// The solver's status for the two programs (`Solved`, `PrimalInfeasible`, or why not).
    pub status: [String; 2],
    /// Solver seconds for both programs.
    pub seconds: f64,
}

/// Everything the report says about a packing.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct JammingReport {
    /// Number of particles.
    pub particles: usize,
    /// How many of them are ellipsoids (the rest are spheres).
    pub ellipsoids: usize,
    /// Mean degrees of freedom per particle (3 spheres, 5 spheroids, 6 ellipsoids).
    pub freedoms_per_particle: f64,
    /// The isostatic mean contact number `2·d_f` (6 spheres, 10 spheroids, 12 ellipsoids).
    pub isostatic_contacts: f64,
    /// The cut-off of the verdict.
    pub cutoff: f64,
    /// Contacts, rattlers and backbone at [`JammingReport::cutoff`].
    pub at_cutoff: CutoffRow,
    /// The same at every cut-off of [`PLATEAU_CUTOFFS`].
    pub plateau: Vec<CutoffRow>,
    /// Rigid translations of the container (periodic axes): `t` of the isostatic count.
    pub trivial_motions: usize,
    /// Global Q6 over the bonds (see the module docs).
    pub q6: f64,
    /// `1/√N_b`: Q6 of as many bonds in random directions.
    pub q6_random: f64,
    /// Number of bonds behind Q6.
    pub bonds: usize,
    /// The LP test on the backbone, when asked for and the particles are spheres.
    pub lp: Option<LpCertificate>,
    /// Asked for but skipped: the packing has ellipsoids (see the module docs).
    pub lp_skipped: bool,
    /// Contacts of each particle at [`JammingReport::cutoff`] (partners and walls, before
    /// rattlers are removed), in the packing's order; not serialised (one number per
    /// particle), for [`crate::analysis::structure`].
    #[serde(skip)]
    pub contact_numbers: Vec<u32>,
    /// Whether each particle is a rattler at [`JammingReport::cutoff`]; not serialised.
    #[serde(skip)]
    pub rattlers: Vec<bool>,
}

/// Why a packing has no jamming report.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum JammingError {
    /// The report is for spheres and ellipsoids (particle index and kind).
    #[error("the jamming report is for spheres and ellipsoids (particle {0} is a {1})")]
    Unsupported(usize, &'static str),
    /// Ellipsoids outside a box, or with a claimed gap (no scene makes either).
    #[error("ellipsoid packings are analysed in box containers without gap claims: {0}")]
    EllipsoidFile(String),
    /// The cut-off is outside `(0, 0.1]`.
    #[error("cut-off = {0}: must be > 0 and ≤ 0.1 (a relative surface gap)")]
    Cutoff(f64),
}

/// The jamming report of `packing` at contact cut-off `cutoff`, with the LP test when `lp`
/// and the particles are spheres (seeded by `seed` for its random load, each program given
/// at most `time_limit` seconds; a program out of time gives no verdict: `jammed` is false
/// and its status says why).
pub fn jamming_report(
    packing: &Packing,
    cutoff: f64,
    lp: bool,
    seed: u64,
    time_limit: f64,
) -> Result<JammingReport, JammingError> {
    if !(cutoff > 0.0 && cutoff <= 0.1) {
        return Err(JammingError::Cutoff(cutoff));
    }
    let bodies = bodies_of(packing)?;
    let n = bodies.len();
    let ellipsoids = bodies.iter().filter(|b| b.shape.is_some()).count();
    let sphere: Vec<bool> = bodies.iter().map(|b| b.shape.is_none()).collect();
    let periodic = periodic_axes(&packing.container);
    let trivial = periodic.iter().filter(|&&p| p).count();
    let widest = PLATEAU_CUTOFFS[PLATEAU_CUTOFFS.len() - 1].max(cutoff);
    let (contacts, bond_moments) = near_pairs(packing, &bodies, widest);
    // Non-trivial degrees of freedom of the particles kept.
    let freedoms_of = |alive: &[bool]| -> i64 {
        let kept: i64 = bodies
            .iter()
            .zip(alive)
            .filter(|(_, &a)| a)
            .map(|(b, _)| i64::from(b.freedoms))
            .sum();
        kept - trivial as i64
    };
    // The row at cut-off `h` of the backbone `alive` with contacts `backbone`.
    let row_of = |h: f64, alive: &[bool], backbone: &[Contact]| -> CutoffRow {
        let nb = alive.iter().filter(|&&a| a).count();
        let count = contacts.iter().filter(|c| c.gap < h).count() as f64;
        let pairs = contacts
            .iter()
            .filter(|c| c.gap < h && c.j.is_some())
            .count() as f64;
        let walls = count - pairs;
        let b_pairs = backbone.iter().filter(|c| c.j.is_some()).count() as f64;
        let b_walls = backbone.len() as f64 - b_pairs;
        let freedoms = freedoms_of(alive);
        CutoffRow {
            cutoff: h,
            mean_contacts: (2.0 * pairs + walls) / n.max(1) as f64,
            rattler_fraction: (n - nb) as f64 / n.max(1) as f64,
            backbone_mean_contacts: (nb > 0).then(|| (2.0 * b_pairs + b_walls) / nb as f64),
            constraints_per_freedom: (freedoms > 0).then(|| (b_pairs + b_walls) / freedoms as f64),
        }
    };
    // The backbone at the report's cut-off serves its row, the plateau's row at the same
    // cut-off (the default is one of them), the LP test and the rattler flags.
    let (alive_at_cutoff, backbone_at_cutoff) = backbone(n, &contacts, cutoff, &sphere);
    let at_cutoff = row_of(cutoff, &alive_at_cutoff, &backbone_at_cutoff);
    // The rows are independent: one per task on the thread pool, collected in order.
    let plateau = PLATEAU_CUTOFFS
        .par_iter()
        .map(|&h| {
            if h == cutoff {
                at_cutoff.clone()
            } else {
                let (alive, kept) = backbone(n, &contacts, h, &sphere);
                row_of(h, &alive, &kept)
            }
        })
        .collect();
    let mut contact_numbers = vec![0u32; n];
    for c in contacts.iter().filter(|c| c.gap < cutoff) {
        contact_numbers[c.i as usize] += 1;
        if let Some(j) = c.j {
            contact_numbers[j as usize] += 1;
        }
    }
    let lp_skipped = lp && ellipsoids > 0;
    let lp = (lp && !lp_skipped).then(|| {
        let freedoms = freedoms_of(&alive_at_cutoff);
        if (backbone_at_cutoff.len() as i64) < freedoms + 1 {
            // Fewer contacts than non-trivial freedoms plus the self-stress: floppy motions
            // exist by counting alone (Maxwell), no program needs to find one.
            LpCertificate::hypostatic(backbone_at_cutoff.len(), freedoms)
        } else {
            lp_certificate(
                &alive_at_cutoff,
                &backbone_at_cutoff,
                periodic,
                seed,
                time_limit,
            )
        }
    });
    let bonds = bond_moments.bonds;
    let freedoms_per_particle =
        bodies.iter().map(|b| f64::from(b.freedoms)).sum::<f64>() / n.max(1) as f64;
    Ok(JammingReport {
        particles: n,
        ellipsoids,
        freedoms_per_particle,
        isostatic_contacts: 2.0 * freedoms_per_particle,
        cutoff,
        at_cutoff,
        plateau,
        trivial_motions: trivial,
        q6: bond_moments.q6(),
        q6_random: 1.0 / (bonds.max(1) as f64).sqrt(),
        bonds,
        lp,
        lp_skipped,
        contact_numbers,
        rattlers: alive_at_cutoff.iter().map(|&a| !a).collect(),
    })
}

/// The particles as the report sees them: spheres with radii inflated by half the claimed
/// gap, ellipsoids with their shape matrices (from the independent check) and degrees of
/// freedom.
fn bodies_of(packing: &Packing) -> Result<Vec<Body>, JammingError> {
    let bodies = packing
        .particles
        .iter()
        .enumerate()
        .map(|(i, p)| match p.body() {
            Checked::Ball { center, radius } => Ok(Body {
                center,
                radius: radius + 0.5 * packing.min_gap,
                shape: None,
                freedoms: 3,
            }),
            Checked::Ellipsoid {
                center,
                bound,
                oriented,
            } => Ok(Body {
                center,
                radius: bound,
                shape: Some(oriented.m),
                freedoms: 3 + p.rotations(),
            }),
            Checked::Convex(_) => Err(JammingError::Unsupported(i, p.kind())),
        })
        .collect::<Result<Vec<Body>, JammingError>>()?;
    if bodies.iter().any(|b| b.shape.is_some()) {
        // The scale factor of the gap is that of the bodies as written: a claimed gap would
        // turn them into parallel bodies, which are no ellipsoids.
        if packing.min_gap > 0.0 || packing.wall_gap() > 0.0 {
            return Err(JammingError::EllipsoidFile(format!(
                "min_gap = {}, wall_gap = {} (must be 0)",
                packing.min_gap,
                packing.wall_gap()
            )));
        }
        if !matches!(packing.container, ContainerRecord::Box { .. }) {
            return Err(JammingError::EllipsoidFile(
                "the container is a cylinder (must be a box)".into(),
            ));
        }
    }
    Ok(bodies)
}

/// The contacts with relative gap below `reach` (pairs and walls), and the moments of the
/// bonds of Q6. Pairs come from levels of cells ([`PairLevels`], the independent check's
/// search, not the kernel's grid and lists) with reach diameters `2·f·r` (bounding radii,
/// `f = max(1.2, 1 + reach)`): every pair closer than `f·(r_i + r_j)` is visited once, at a
/// cost per particle that does not grow with the size ratio. Chunks of particles run on all
/// threads and are joined in order.
fn near_pairs(packing: &Packing, bodies: &[Body], reach: f64) -> (Vec<Contact>, BondMoments) {
    let factor = BOND_REACH.max(1.0 + reach);
    let (lo, hi) = container_bounds(&packing.container);
    let len: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
    let periodic = periodic_axes(&packing.container);
    let pairs = PairLevels::new(
        lo,
        len,
        periodic,
        bodies.len(),
        |i| bodies[i].center,
        |i| 2.0 * factor * bodies[i].radius,
    );
    // Chunks of a fixed size, joined in order: the contacts, and the moments' sums (added
    // chunk by chunk), are the same on any number of threads.
    let chunk = PARTICLES_PER_TASK;
    let starts: Vec<usize> = (0..bodies.len()).step_by(chunk).collect();
    let parts: Vec<(Vec<Contact>, BondMoments)> = starts
        .into_par_iter()
        .map(|start| {
            let mut contacts = Vec::new();
            let mut bonds = BondMoments::new();
            let mut seen = Vec::with_capacity(27);
            for (i, bi) in bodies.iter().enumerate().skip(start).take(chunk) {
                let (ci, ri) = (bi.center, bi.radius);
                pairs.for_each_pair_of(i, &ci, &mut seen, |j| {
                    let bj = &bodies[j];
                    let (cj, rj) = (bj.center, bj.radius);
                    let d = separation(&len, &periodic, &ci, &cj);
                    let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    let sum = ri + rj;
                    let u = d.map(|x| x / dist);
                    if dist < BOND_REACH * sum {
                        bonds.add(&u);
                    }
                    // Spheres: the exact relative gap. With an ellipsoid it is a lower bound
                    // of the scale factor's gap (bounding spheres), refined below.
                    let mut gap = dist / sum - 1.0;
                    if gap < reach && (bi.shape.is_some() || bj.shape.is_some()) {
                        let sphere =
                            |r: f64| [[r * r, 0.0, 0.0], [0.0, r * r, 0.0], [0.0, 0.0, r * r]];
                        let mi = bi.shape.unwrap_or_else(|| sphere(ri));
                        let mj = bj.shape.unwrap_or_else(|| sphere(rj));
                        gap = contact_scale(&mi, &mj, &d) - 1.0;
                    }
                    if gap < reach {
                        contacts.push(Contact {
                            i: i as u32,
                            j: Some(j as u32),
                            normal: u,
                            gap,
                        });
                    }
                });
                walls_of(packing, i, bi, reach, &mut contacts);
            }
            (contacts, bonds)
        })
        .collect();
    let mut contacts = Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum());
    let mut bonds = BondMoments::new();
    for (c, b) in parts {
        contacts.extend(c);
        bonds.merge(&b);
    }
    (contacts, bonds)
}

/// The wall contacts of particle `i` with relative gap below `reach`: a sphere's
/// `(distance − wall_gap − r)/r`, an ellipsoid's `(distance − w)/w` with `w = √(nᵀMn)` its
/// half-width along the wall normal `n` (ellipsoids come in boxes without gap claims).
fn walls_of(packing: &Packing, i: usize, body: &Body, reach: f64, out: &mut Vec<Contact>) {
    let wall_gap = packing.wall_gap() - 0.5 * packing.min_gap;
    let c = body.center;
    let mut push = |distance: f64, normal: [f64; 3]| {
        let gap = match &body.shape {
            None => (distance - wall_gap - body.radius) / body.radius,
            Some(m) => {
                let mut q = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        q += normal[a] * m[a][b] * normal[b];
                    }
                }
                let w = q.sqrt();
                (distance - w) / w
            }
        };
        if gap < reach {
            out.push(Contact {
                i: i as u32,
                j: None,
                normal,
                gap,
            });
        }
    };
    match &packing.container {
        ContainerRecord::Box { min, max, periodic } => {
            for k in (0..3).filter(|&k| !periodic[k]) {
                let mut n = [0.0; 3];
                n[k] = 1.0;
                push(c[k] - min[k], n);
                n[k] = -1.0;
                push(max[k] - c[k], n);
            }
        }
        ContainerRecord::Cylinder {
            base_center: b,
            radius,
            height,
        } => {
            push(c[2] - b[2], [0.0, 0.0, 1.0]);
            push(b[2] + height - c[2], [0.0, 0.0, -1.0]);
            let (dx, dy) = (c[0] - b[0], c[1] - b[1]);
            let rho = dx.hypot(dy);
            if rho > 0.0 {
                push(radius - rho, [-dx / rho, -dy / rho, 0.0]);
            }
        }
    }
}

/// The particles left after removing rattlers iteratively at cut-off `h`, and their
/// contacts: fewer than [`RATTLER_BELOW`] contacts, or (spheres, `sphere[i]`) contact
/// directions in a closed hemisphere (see the module docs).
fn backbone(n: usize, contacts: &[Contact], h: f64, sphere: &[bool]) -> (Vec<bool>, Vec<Contact>) {
    let kept: Vec<Contact> = contacts.iter().copied().filter(|c| c.gap < h).collect();
    // Each particle's contacts (indices into `kept`), in compressed rows.
    let mut start = vec![0usize; n + 1];
    for c in &kept {
        start[c.i as usize + 1] += 1;
        if let Some(j) = c.j {
            start[j as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut rows = vec![0u32; start[n]];
    for (k, c) in kept.iter().enumerate() {
        for end in [Some(c.i), c.j].into_iter().flatten() {
            rows[fill[end as usize]] = k as u32;
            fill[end as usize] += 1;
        }
    }
    // Removal is monotone (fewer contacts never make a particle less free), so the
    // particles left do not depend on the order of removal: a work list re-tests only the
    // partners of a removed particle, not every particle each round.
    let mut alive = vec![true; n];
    let mut contact_alive = vec![true; kept.len()];
    let mut queued = vec![true; n];
    let mut work: std::collections::VecDeque<usize> = (0..n).collect();
    let mut directions: Vec<[f64; 3]> = Vec::new();
    while let Some(i) = work.pop_front() {
        queued[i] = false;
        directions.clear();
        for &k in &rows[start[i]..start[i + 1]] {
            if !contact_alive[k as usize] {
                continue;
            }
            let c = &kept[k as usize];
            let u = c.normal;
            // From the particle towards the partner (or the wall).
            let towards = if c.j.is_some() && c.i as usize == i {
                u
            } else {
                [-u[0], -u[1], -u[2]]
            };
            directions.push(towards);
        }
        let free = directions.len() < RATTLER_BELOW as usize
            || (sphere[i] && in_closed_hemisphere(&directions));
        if !free {
            continue;
        }
        alive[i] = false;
        for &k in &rows[start[i]..start[i + 1]] {
            let k = k as usize;
            if !contact_alive[k] {
                continue;
            }
            contact_alive[k] = false;
            let c = &kept[k];
            let partner = if c.i as usize == i { c.j } else { Some(c.i) };
            if let Some(o) = partner.map(|o| o as usize) {
                if alive[o] && !queued[o] {
                    queued[o] = true;
                    work.push_back(o);
                }
            }
        }
    }
    let kept = kept
        .into_iter()
        .zip(contact_alive)
        .filter_map(|(c, a)| a.then_some(c))
        .collect();
    (alive, kept)
}

/// Whether the unit vectors `d` lie in a closed hemisphere: some `w ≠ 0` has `w·d_k ≤ 0`
/// for every `k`. Candidates are `±(d_a × d_b)` (see the module docs); vectors all parallel
/// (no independent pair) always lie in one. Dot products within [`HEMISPHERE_TOLERANCE`] of
/// zero count as on the boundary.
fn in_closed_hemisphere(d: &[[f64; 3]]) -> bool {
    let mut independent = false;
    for (a, u) in d.iter().enumerate() {
        for v in &d[a + 1..] {
            let w = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let norm = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            if norm < HEMISPHERE_TOLERANCE {
                continue;
            }
            independent = true;
            // The candidate fails once directions on both sides of its plane are seen: for a
            // locally jammed particle after a few, so a test costs about k² rather than k³
            // dot products (k contacts; a large grain among small ones has hundreds).
            let (mut above, mut below) = (false, false);
            for x in d {
                let t = (w[0] * x[0] + w[1] * x[1] + w[2] * x[2]) / norm;
                above |= t > HEMISPHERE_TOLERANCE;
                below |= t < -HEMISPHERE_TOLERANCE;
                if above && below {
                    break;
                }
            }
            if !(above && below) {
                return true;
            }
        }
    }
    !independent
}

/// Exponents `(p, q, r)` of `x^p y^q z^r` and the multiplicity of its tensor entry.
type Monomial = (usize, usize, usize, f64);

/// The exponents `(p, q, r)`, `p + q + r = k`, of the distinct entries of a symmetric
/// tensor of order `k = 2, 4, 6` (6, 15 and 28 of them), with their multiplicities
/// `k!/(p! q! r!)`: one table for every report.
static MONOMIALS: LazyLock<[Vec<Monomial>; 3]> = LazyLock::new(|| {
    let factorial = |n: usize| (1..=n).product::<usize>() as f64;
    [2, 4, 6].map(|k| {
        let mut out = Vec::new();
        for p in 0..=k {
            for q in 0..=k - p {
                let r = k - p - q;
                out.push((
                    p,
                    q,
                    r,
                    factorial(k) / (factorial(p) * factorial(q) * factorial(r)),
                ));
            }
        }
        out
    })
});

/// The moment tensors `M_k = Σ_a u_a^{⊗k}` (k = 2, 4, 6) of Q6's bonds `u_a`, kept as their
/// distinct entries ([`MONOMIALS`]): the entry for an index tuple with `p` x's, `q` y's and
/// `r` z's is `S_pqr = Σ_a x_a^p y_a^q z_a^r`, shared by `k!/(p! q! r!)` tuples, so
/// `‖M_k‖² = Σ_{p+q+r=k} k!/(p! q! r!)·S_pqr²`: 49 sums per bond instead of the
/// 9 + 81 + 729 entries of the full tensors, and no list of bonds.
struct BondMoments {
    sums: [Vec<f64>; 3],
    bonds: usize,
}

impl BondMoments {
    fn new() -> Self {
        Self {
            sums: std::array::from_fn(|o| vec![0.0; MONOMIALS[o].len()]),
            bonds: 0,
        }
    }

    /// Adds the bond of unit vector `u`.
    fn add(&mut self, u: &[f64; 3]) {
        let mut powers = [[1.0; 7]; 3];
        for (axis, row) in powers.iter_mut().enumerate() {
            for e in 1..7 {
                row[e] = row[e - 1] * u[axis];
            }
        }
        for (terms, sum) in MONOMIALS.iter().zip(self.sums.iter_mut()) {
            for (&(p, q, r, _), s) in terms.iter().zip(sum.iter_mut()) {
                *s += powers[0][p] * powers[1][q] * powers[2][r];
            }
        }
        self.bonds += 1;
    }

    /// Adds the bonds of `other`.
    fn merge(&mut self, other: &Self) {
        for (mine, theirs) in self.sums.iter_mut().zip(&other.sums) {
            mine.iter_mut().zip(theirs).for_each(|(x, y)| *x += y);
        }
        self.bonds += other.bonds;
    }

    /// Global Q6 through the addition theorem (module docs); NaN without bonds.
    fn q6(&self) -> f64 {
        if self.bonds == 0 {
            return f64::NAN;
        }
        let norm = |o: usize| -> f64 {
            MONOMIALS[o]
                .iter()
                .zip(&self.sums[o])
                .map(|(&(_, _, _, w), s)| w * s * s)
                .sum()
        };
        let nb = self.bonds as f64;
        let sum_p6 = (231.0 * norm(2) - 315.0 * norm(1) + 105.0 * norm(0) - 5.0 * nb * nb) / 16.0;
        (sum_p6.max(0.0)).sqrt() / nb
    }
}

impl LpCertificate {
    /// The verdict without a program for a backbone of `contacts` contacts and `freedoms`
    /// non-trivial degrees of freedom, `contacts ≤ freedoms`.
    fn hypostatic(contacts: usize, freedoms: i64) -> Self {
        let why = format!("not solved: {contacts} contacts for {freedoms} freedoms");
        Self {
            jammed: false,
            loads_carried: [Some(false); 2],
            max_force: f64::NAN,
            status: [why.clone(), why],
            seconds: 0.0,
        }
    }
}

/// Clarabel's settings for the contact-network programs (this LP test and the `[jam]` step,
/// [`crate::protocol::slp`]), each given at most `time_limit` seconds: quiet, and faer's
/// supernodal factorisation, about 6× faster than the default QDLDL on the contact networks
/// of 2 000 spheres (7.8 s against 49.6 s for one program).
pub(crate) fn lp_settings(time_limit: f64) -> clarabel::solver::DefaultSettings<f64> {
    clarabel::solver::DefaultSettingsBuilder::default()
        .verbose(false)
        .direct_solve_method("faer".to_string())
        .time_limit(time_limit)
        .build()
        .expect("valid solver settings")
}

/// The LP test of the module docs on the backbone `alive` with contacts `contacts`, each
/// program given at most `time_limit` seconds; `periodic` marks the axes along which rigid
/// translations are free.
fn lp_certificate(
    alive: &[bool],
    contacts: &[Contact],
    periodic: [bool; 3],
    seed: u64,
    time_limit: f64,
) -> LpCertificate {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{DefaultSolver, IPSolver, SolverStatus, SupportedConeT};
    let mut index = vec![usize::MAX; alive.len()];
    let mut n = 0;
    for (i, &a) in alive.iter().enumerate() {
        if a {
            index[i] = n;
            n += 1;
        }
    }
    if n == 0 {
        // Every sphere is a rattler: nothing holds the packing.
        return LpCertificate {
            jammed: false,
            loads_carried: [Some(false); 2],
            max_force: f64::NAN,
            status: ["no backbone".into(), "no backbone".into()],
            seconds: 0.0,
        };
    }
    // Force balance rows `3k + a` of sphere `k` along axis `a`. Along a periodic axis the
    // rows of all spheres sum to zero (each pair force acts twice with opposite signs, walls
    // have no normal along it), so the last sphere's row is implied and left out: the
    // equality system keeps full row rank.
    let dropped = |row: usize| row / 3 == n - 1 && periodic[row % 3];
    let mut row_of = vec![usize::MAX; 3 * n];
    let mut rows_kept = 0;
    for (row, slot) in row_of.iter_mut().enumerate() {
        if !dropped(row) {
            *slot = rows_kept;
            rows_kept += 1;
        }
    }
    let m = contacts.len();
    // Column `c` of `A`: the force of contact `c` on its spheres per unit magnitude, −u on
    // `i` and +u on `j` (so that `(Aᵀ y)_c` is the contact's opening), +n_w on a wall's sphere.
    // Then `−I` for `f ≥ 0` in Clarabel's form `A x + s = b, s ∈ K`.
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    for (col, c) in contacts.iter().enumerate() {
        let i = index[c.i as usize];
        let sign_i = if c.j.is_some() { -1.0 } else { 1.0 };
        for a in 0..3 {
            let mut push = |sphere: usize, value: f64| {
                let row = row_of[3 * sphere + a];
                if row != usize::MAX && value != 0.0 {
                    rows.push(row);
                    cols.push(col);
                    vals.push(value);
                }
            };
            push(i, sign_i * c.normal[a]);
            if let Some(j) = c.j {
                push(index[j as usize], c.normal[a]);
            }
        }
        rows.push(rows_kept + col);
        cols.push(col);
        vals.push(-1.0);
    }
    let a = CscMatrix::new_from_triplets(rows_kept + m, m, rows, cols, vals);
    let cones = [
        SupportedConeT::ZeroConeT(rows_kept),
        SupportedConeT::NonnegativeConeT(m),
    ];
    let p = CscMatrix::zeros((m, m));
    let q = vec![1.0; m];
    // A random load with zero mean along each periodic axis, scaled to mean magnitude 1.
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut load: Vec<f64> = (0..3 * n).map(|_| rng.gen_range(-1.0..1.0)).collect();
    for axis in (0..3).filter(|&axis| periodic[axis]) {
        let mean = load.iter().skip(axis).step_by(3).sum::<f64>() / n as f64;
        load.iter_mut()
            .skip(axis)
            .step_by(3)
            .for_each(|x| *x -= mean);
    }
    let mean_load = load.iter().map(|x| x.abs()).sum::<f64>() / (3 * n) as f64;
    load.iter_mut()
        .for_each(|x| *x /= mean_load.max(f64::MIN_POSITIVE));
    let carried = |sign: f64| -> (Option<bool>, f64, String, f64) {
        let mut b = vec![0.0; rows_kept + m];
        for (row, &value) in load.iter().enumerate() {
            if row_of[row] != usize::MAX {
                b[row_of[row]] = sign * value;
            }
        }
        match DefaultSolver::new(&p, &q, &a, &b, &cones, lp_settings(time_limit)) {
            Ok(mut solver) => {
                solver.solve();
                let s = &solver.solution;
                let verdict = match s.status {
                    SolverStatus::Solved | SolverStatus::AlmostSolved => Some(true),
                    SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                        Some(false)
                    }
                    _ => None,
                };
                let largest = if verdict == Some(true) {
                    s.x.iter().fold(0.0_f64, |acc, &f| acc.max(f))
                } else {
                    f64::NAN
                };
                (verdict, largest, format!("{:?}", s.status), s.solve_time)
            }
            Err(e) => (None, f64::NAN, format!("{e:?}"), 0.0),
        }
    };
    let (plus, force_plus, status_plus, t_plus) = carried(1.0);
    let (minus, force_minus, status_minus, t_minus) = carried(-1.0);
    LpCertificate {
        jammed: plus == Some(true) && minus == Some(true),
        loads_carried: [plus, minus],
        max_force: force_plus.max(force_minus),
        status: [status_plus, status_minus],
        seconds: t_plus + t_minus,
    }
}
