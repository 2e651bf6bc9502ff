//! Jamming by sequential linear programming (SLP): the last step of a jamming protocol for
//! spheres in a box, after event-driven growth has brought the packing close to jamming.
//!
//! Growth by event-driven dynamics reaches a high reduced pressure with a contact network
//! that is not rigid (README, "Is it jammed?"): the collective rearrangements that make it
//! rigid are slow. Each step here asks a linear program for the displacements `Δx_i` of all
//! spheres that allow the largest common growth of the radii, with the non-overlap
//! constraints linearised (Torquato & Jiao, PRE 82, 061302, 2010; the test of Donev,
//! Torquato, Stillinger & Connelly, J. Comput. Phys. 197, 139, 2004, with a compression
//! variable). A packing from which no step grows the spheres is collectively jammed in its
//! fixed box, to first order.
//!
//! **The program.** Spheres at `c_i` with radii `r_i` in a fixed box; a pair's separation
//! `r_ij = c_j − c_i` (nearest image) and contact distance `D_ij = r_i + r_j`. The radii
//! become `r_i·s` with `s² = 1 + q`; the variables are the displacements and `q`:
//!
//! ```text
//! maximise q   subject to   |r_ij|² + 2 r_ij·(Δx_j − Δx_i) − q D_ij² ≥ D_ij²   (near pairs)
//!                           x_ia + Δx_ia − r_i (1 + q/2) ≥ lo_a,  ≤ … hi_a   (walled axes)
//!                           |Δx_ia| ≤ Δ,   q ≤ q_max = 8Δ/d̄.
//! ```
//!
//! The pair rows are *conservative*: `|r + δ|² = |r|² + 2 r·δ + |δ|² ≥ |r|² + 2 r·δ`, so a
//! feasible point never overlaps a constrained pair; the wall rows likewise, as
//! `√(1 + q) ≤ 1 + q/2`. Pairs left out of the program are farther than
//! `√(1 + q_max)·D_ij + 2√3·Δ` and cannot meet. The solver's answer is still not trusted:
//! the spheres are moved, and the common scale `s` of the radii is computed afresh from the
//! exact distances (the closest pair or wall sets it), never above `√(1 + q_max)`. A step
//! whose exact scale does not exceed 1 is halved.
//!
//! **Scaling and the trust region.** The variables are scaled by the trust region `Δ`
//! (`y = Δx/Δ`, `q = (Δ/d̄)·g` with `d̄` the mean diameter), so the program is of order one
//! at every `Δ` and the solver's relative tolerance (10⁻⁸) is 10⁻⁸ of `Δ`. The first region
//! is a tenth of the largest, `settings.trust` (2 % of `d̄`): a smaller region holds fewer
//! pairs, and its program is cheaper (at 10⁴ spheres, 200 s against 400 s at 2 %). The
//! region grows tenfold, up to the largest, only when it *binds*: by LP duality the optimum
//! is `Σ b_k z_k` over the rows, and when the trust-region rows carry more than half of it
//! the region, not the packing, limits the growth. Growth found in a region that does not
//! bind needs no wider one (steps from packings near jamming move the spheres by a
//! thousandth of the region). When the growth per unit of displacement falls below 10⁻⁶
//! (only gaps left to close) the region shrinks a hundredfold, down to 10⁻⁷ of `d̄`, where
//! the contacts close to about 10⁻¹⁵ of a diameter. The packing is *jammed* when a step in
//! the smallest region promises less than [`JAMMED_GROWTH`].
//!
//! **The solver.** Clarabel (interior point, faer's sparse factorisation), already the
//! analysis' LP solver. Its answer lies in the relative interior of the optimal face, so the
//! spheres move along every direction that lets the packing grow. The cost of a program is
//! the factorisation of a matrix with the pattern of the contact network, which fills in
//! three dimensions: about 1.5 s at 1 000 spheres, minutes at 10 000. The one growth
//! variable would be a dense column of that matrix; each sphere has its own copy instead,
//! the copies made equal along a spanning tree of the pairs (3× faster at 1 000 spheres).
//! A simplex code (`microlp`) took 73 s for the first program of 1 000 spheres that Clarabel
//! solves in 2.5 s.

use crate::analysis::jamming::lp_settings;
use crate::analysis::separation;
use crate::cancel::CancelFlag;
use crate::verify::PairLevels;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Spheres in an axis-aligned box `[lo, lo + len]`, periodic along `periodic` axes and
/// walled along the others: the state the steps move and grow. Pairs are taken at their
/// nearest image, so a periodic edge must exceed twice the largest diameter (with room for
/// the growth of a step, 10 %), as scenes require.
#[derive(Clone, Debug)]
pub struct BoxedSpheres {
    /// Lower corner of the box.
    pub lo: [f64; 3],
    /// Edges of the box.
    pub len: [f64; 3],
    /// Periodic axes.
    pub periodic: [bool; 3],
    /// Centres (inside the box along periodic axes).
    pub centers: Vec<[f64; 3]>,
    /// Radii (all grow by the same factor).
    pub radii: Vec<f64>,
}

/// How far the steps go, and who may stop them.
#[derive(Clone, Debug)]
pub struct SlpSettings {
    /// Largest trust region: displacement `Δ` per coordinate, as a fraction of the mean
    /// diameter. The first step takes a tenth of it; later steps widen the region while it
    /// binds and shrink it towards the growth they find.
    pub trust: f64,
    /// Most steps.
    pub max_steps: usize,
    /// Most seconds, a program included: the solver is given what is left and checks it
    /// at each of its iterations.
    pub max_seconds: f64,
    /// Stops the steps when set ([`SlpStop::Cancelled`]): checked between steps and at each
    /// iteration of the solver (one factorisation: under a second at 10³ spheres, about ten
    /// at 10⁴).
    pub cancel: Option<CancelFlag>,
}

impl Default for SlpSettings {
    fn default() -> Self {
        Self {
            trust: 0.02,
            max_steps: 200,
            max_seconds: f64::INFINITY,
            cancel: None,
        }
    }
}

/// Why the steps ended.
#[derive(Clone, Debug, PartialEq)]
pub enum SlpStop {
    /// No step grows the spheres by more than [`JAMMED_GROWTH`] within the smallest trust
    /// region: collectively jammed to first order, within rounding.
    Jammed,
    /// `max_steps` steps were taken first.
    StepLimit,
    /// `max_seconds` ran out first.
    TimeLimit,
    /// The solver failed (its status).
    SolverFailed(String),
    /// The cancel flag of the settings was set.
    Cancelled,
}

/// What the steps did.
#[derive(Clone, Debug)]
pub struct SlpOutcome {
    /// Why they ended.
    pub stop: SlpStop,
    /// Steps taken.
    pub steps: usize,
    /// Product of the steps' scales: every radius is this many times its starting size.
    pub growth: f64,
    /// Solver and bookkeeping time, seconds.
    pub seconds: f64,
}

/// The relative growth of `q = s² − 1` below which a step in the smallest trust region
/// counts as no growth: a few hundred ulps of a radius.
pub const JAMMED_GROWTH: f64 = 1e-13;

/// The smallest trust region, as a fraction of the mean diameter. The program is scaled by
/// the trust region, so the solver's relative tolerance (10⁻⁸) is `10⁻¹⁵` of a diameter
/// here: contacts close to within rounding.
const MIN_TRUST: f64 = 1e-7;

/// A step whose growth per unit of displacement is below this shrinks the trust region.
const SHRINK_BELOW: f64 = 1e-6;

/// The share of a program's optimum owed to the trust region above which the region binds
/// and the next step widens it.
const BINDING_SHARE: f64 = 0.5;

/// What a step did, for progress reports.
#[derive(Clone, Copy, Debug)]
pub struct StepReport {
    /// Steps so far (this one included).
    pub step: usize,
    /// Its trust region `Δ`, as a fraction of the mean diameter.
    pub trust: f64,
    /// The program's optimum `q = s² − 1`: the growth it promised.
    pub q: f64,
    /// The exact scale applied to the radii.
    pub scale: f64,
    /// Seconds since the first step began.
    pub seconds: f64,
}

/// Why a step did not finish.
enum Halt {
    /// The time left ran out inside the program.
    Time,
    /// The cancel flag was set inside the program.
    Cancel,
    /// The solver failed (its status).
    Failed(String),
}

/// One step's result.
struct Step {
    /// The exact scale applied to the radii (1 when the step did not grow them).
    scale: f64,
    /// The program's optimum `q`.
    q: f64,
    /// The share of the optimum owed to the trust region (module docs); 1 when the
    /// optimum is not positive.
    binding: f64,
}

impl BoxedSpheres {
    /// Steps until jammed (module docs), or until a limit or the cancel flag of `settings`
    /// stops them; `on_step` sees each step.
    pub fn jam(
        &mut self,
        settings: &SlpSettings,
        on_step: &mut dyn FnMut(&StepReport),
    ) -> SlpOutcome {
        let start = Instant::now();
        let unit = self.mean_diameter();
        let mut trust = 0.1 * settings.trust * unit;
        let mut outcome = SlpOutcome {
            stop: SlpStop::StepLimit,
            steps: 0,
            growth: 1.0,
            seconds: 0.0,
        };
        while outcome.steps < settings.max_steps {
            let left = settings.max_seconds - start.elapsed().as_secs_f64();
            if left <= 0.0 {
                outcome.stop = SlpStop::TimeLimit;
                break;
            }
            if crate::cancel::is_set(settings.cancel.as_deref()) {
                outcome.stop = SlpStop::Cancelled;
                break;
            }
            let step = match self.step(trust, left, settings.cancel.as_ref()) {
                Ok(step) => step,
                Err(halt) => {
                    outcome.stop = match halt {
                        Halt::Time => SlpStop::TimeLimit,
                        Halt::Cancel => SlpStop::Cancelled,
                        Halt::Failed(status) => SlpStop::SolverFailed(status),
                    };
                    break;
                }
            };
            outcome.steps += 1;
            outcome.growth *= step.scale;
            on_step(&StepReport {
                step: outcome.steps,
                trust: trust / unit,
                q: step.q,
                scale: step.scale,
                seconds: start.elapsed().as_secs_f64(),
            });
            if step.q < JAMMED_GROWTH && trust <= MIN_TRUST * unit * (1.0 + 1e-9) {
                outcome.stop = SlpStop::Jammed;
                break;
            }
            // `q·unit/Δ` is the growth per unit of displacement the step found. When it falls
            // towards zero (jammed but for the gaps left) the region shrinks, so that the
            // scaled program resolves smaller gaps; while the region binds, it widens.
            if step.q * unit < SHRINK_BELOW * trust {
                trust = (0.01 * trust).max(MIN_TRUST * unit);
            } else if step.binding > BINDING_SHARE {
                trust = (10.0 * trust).min(settings.trust * unit);
            }
        }
        outcome.seconds = start.elapsed().as_secs_f64();
        outcome
    }

    fn mean_diameter(&self) -> f64 {
        2.0 * self.radii.iter().sum::<f64>() / self.radii.len().max(1) as f64
    }

    /// The pairs `(i, j)` whose centres are closer than `√(1 + q_max)·D_ij + 2√3·Δ`, with
    /// their separations `r_ij`.
    fn near_pairs(&self, trust: f64, q_max: f64) -> Vec<(u32, u32, [f64; 3])> {
        let stretch = (1.0 + q_max).sqrt();
        let slack = 3f64.sqrt() * trust;
        let reach = |i: usize| 2.0 * (stretch * self.radii[i] + slack);
        let levels = PairLevels::new(
            self.lo,
            self.len,
            self.periodic,
            self.centers.len(),
            |i| self.centers[i],
            reach,
        );
        let mut pairs = Vec::new();
        let mut seen = Vec::with_capacity(27);
        for (i, ci) in self.centers.iter().enumerate() {
            levels.for_each_pair_of(i, ci, &mut seen, |j| {
                let r = separation(&self.len, &self.periodic, ci, &self.centers[j]);
                let dist = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
                if dist < 0.5 * (reach(i) + reach(j)) {
                    pairs.push((i as u32, j as u32, r));
                }
            });
        }
        pairs
    }

    /// The room between the centre `c` and the wall at the low (`high = false`) or
    /// high end of axis `a`.
    fn room(&self, c: &[f64; 3], a: usize, high: bool) -> f64 {
        if high {
            self.lo[a] + self.len[a] - c[a]
        } else {
            c[a] - self.lo[a]
        }
    }

    /// The exact common scale of the radii after moving the centres to `moved`: the closest
    /// pair (of `pairs`) or wall sets it, capped at `√(1 + q_max)`, and rounded down so that
    /// the scaled radii do not overlap after rounding.
    fn exact_scale(&self, moved: &[[f64; 3]], pairs: &[(u32, u32, [f64; 3])], q_max: f64) -> f64 {
        let mut s = (1.0 + q_max).sqrt();
        for &(i, j, _) in pairs {
            let (i, j) = (i as usize, j as usize);
            let r = separation(&self.len, &self.periodic, &moved[i], &moved[j]);
            let dist = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            s = s.min(dist / (self.radii[i] + self.radii[j]));
        }
        for (i, c) in moved.iter().enumerate() {
            for a in (0..3).filter(|&a| !self.periodic[a]) {
                let room = self.room(c, a, false).min(self.room(c, a, true));
                s = s.min(room / self.radii[i]);
            }
        }
        // A few ulps below: `r_i·s + r_j·s` rounds to within 3 ulps of `(r_i + r_j)·s`.
        s * (1.0 - 8.0 * f64::EPSILON)
    }

    /// One step with trust region `trust` (module docs): solve, move, grow by the exact
    /// scale. A step that cannot grow the radii leaves the packing as it was, and so does
    /// one halted after `seconds` or by `cancel`.
    fn step(
        &mut self,
        trust: f64,
        seconds: f64,
        cancel: Option<&CancelFlag>,
    ) -> Result<Step, Halt> {
        use clarabel::algebra::CscMatrix;
        use clarabel::solver::{DefaultSolver, IPSolver, SolverStatus, SupportedConeT};
        let n = self.centers.len();
        let unit = self.mean_diameter();
        // Growth beyond a few trust regions is out of reach for touching pairs.
        let q_max = 8.0 * trust / unit;
        let pairs = self.near_pairs(trust, q_max);
        // Variables, scaled by the trust region so that they are of order one: `y = Δx/Δ`
        // (3n), and `q = (Δ/unit)·g` with one copy `g_i` per sphere (3n + i), the copies
        // made equal along a spanning forest of the pairs and a chain of its roots. One
        // global `q` would be a dense column of the KKT matrix, filling its factor.
        let g = |i: usize| 3 * n + i;
        let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
        let mut b = Vec::new();
        let mut entry = |row: usize, col: usize, value: f64| {
            rows.push(row);
            cols.push(col);
            vals.push(value);
        };
        // Equalities first (Clarabel's zero cone): `g_i − g_j = 0`.
        let mut forest = Forest::new(n);
        for &(i, j, _) in &pairs {
            if let Some((a, c)) = forest.join(i as usize, j as usize) {
                let row = b.len();
                entry(row, g(a), 1.0);
                entry(row, g(c), -1.0);
                b.push(0.0);
            }
        }
        for (a, c) in forest.roots_chain() {
            let row = b.len();
            entry(row, g(a), 1.0);
            entry(row, g(c), -1.0);
            b.push(0.0);
        }
        let equalities = b.len();
        // Pairs, divided by `Δ·D_ij`: `2 u_ij·(y_i − y_j) + (D_ij/unit)·g_i ≤ (|r|² − D²)/(D·Δ)`
        // with `u_ij = r_ij/D_ij`.
        for &(i, j, r) in &pairs {
            let (i, j) = (i as usize, j as usize);
            let d = self.radii[i] + self.radii[j];
            let dist = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            let row = b.len();
            for (a, ra) in r.iter().enumerate() {
                let c = 2.0 * ra / d;
                entry(row, 3 * i + a, c);
                entry(row, 3 * j + a, -c);
            }
            entry(row, g(i), d / unit);
            b.push((dist - d) * (dist + d) / (d * trust));
        }
        // Walls within reach: `∓y_ia + (r_i/(2 unit))·g_i ≤ (room − r_i)/Δ`.
        for (i, c) in self.centers.iter().enumerate() {
            let r = self.radii[i];
            for a in (0..3).filter(|&a| !self.periodic[a]) {
                for high in [false, true] {
                    let room = self.room(c, a, high);
                    if room >= r * (1.0 + 0.5 * q_max) + trust {
                        continue;
                    }
                    let row = b.len();
                    entry(row, 3 * i + a, if high { 1.0 } else { -1.0 });
                    entry(row, g(i), 0.5 * r / unit);
                    b.push((room - r) / trust);
                }
            }
        }
        // Bounds: `±y ≤ 1`, `g ≤ q_max·unit/Δ`.
        let region_rows = b.len()..b.len() + 6 * n;
        for v in 0..3 * n {
            for sign in [1.0, -1.0] {
                let row = b.len();
                entry(row, v, sign);
                b.push(1.0);
            }
        }
        let row = b.len();
        entry(row, g(0), 1.0);
        b.push(q_max * unit / trust);
        let (m, nv) = (b.len(), 4 * n);
        let a = CscMatrix::new_from_triplets(m, nv, rows, cols, vals);
        let p = CscMatrix::zeros((nv, nv));
        let mut c = vec![0.0; nv];
        c[g(0)] = -1.0;
        let cones = [
            SupportedConeT::ZeroConeT(equalities),
            SupportedConeT::NonnegativeConeT(m - equalities),
        ];
        let mut solver = DefaultSolver::new(&p, &c, &a, &b, &cones, lp_settings(seconds))
            .map_err(|e| Halt::Failed(format!("{e:?}")))?;
        if let Some(flag) = cancel {
            let flag = flag.clone();
            solver.set_termination_callback(move |_| flag.load(Ordering::Relaxed));
        }
        solver.solve();
        let solution = &solver.solution;
        match solution.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {}
            SolverStatus::MaxTime => return Err(Halt::Time),
            SolverStatus::CallbackTerminated => return Err(Halt::Cancel),
            status => return Err(Halt::Failed(format!("{status:?}"))),
        }
        let q = solution.x[g(0)] * trust / unit;
        // Duality: the optimum `g_0 = b·z`, and the region's rows have `b = 1`.
        let binding = if solution.x[g(0)] > 0.0 {
            solution.z[region_rows].iter().sum::<f64>() / solution.x[g(0)]
        } else {
            1.0
        };
        // Clamped to the region: the pairs left out are safe only within it.
        let mut step: Vec<f64> = solution.x[..3 * n]
            .iter()
            .map(|y| y.clamp(-1.0, 1.0) * trust)
            .collect();
        // The exact scale decides; a step the rounding of the solver spoiled is halved.
        for _ in 0..40 {
            let moved: Vec<[f64; 3]> = self
                .centers
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    std::array::from_fn(|a| {
                        let x = c[a] + step[3 * i + a];
                        if self.periodic[a] {
                            self.lo[a] + (x - self.lo[a]).rem_euclid(self.len[a])
                        } else {
                            x
                        }
                    })
                })
                .collect();
            let s = self.exact_scale(&moved, &pairs, q_max);
            if s > 1.0 {
                self.centers = moved;
                self.radii.iter_mut().for_each(|r| *r *= s);
                return Ok(Step {
                    scale: s,
                    q,
                    binding,
                });
            }
            step.iter_mut().for_each(|x| *x *= 0.5);
        }
        Ok(Step {
            scale: 1.0,
            q,
            binding,
        })
    }
}

/// Union–find over the spheres, recording the edges that join two trees (a spanning
/// forest of the pair graph). A dozen lines: not worth a graph crate.
struct Forest {
    parent: Vec<u32>,
}

impl Forest {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
        }
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] as usize != i {
            let up = self.parent[self.parent[i] as usize];
            self.parent[i] = up;
            i = up as usize;
        }
        i
    }

    /// Joins the trees of `i` and `j`; `Some((i, j))` when they were apart.
    fn join(&mut self, i: usize, j: usize) -> Option<(usize, usize)> {
        let (ri, rj) = (self.root(i), self.root(j));
        (ri != rj).then(|| {
            self.parent[ri] = rj as u32;
            (i, j)
        })
    }

    /// Consecutive pairs of the roots of the trees, which make the forest one tree.
    fn roots_chain(&mut self) -> Vec<(usize, usize)> {
        let roots: Vec<usize> = (0..self.parent.len())
            .filter(|&i| self.parent[i] as usize == i)
            .collect();
        roots.windows(2).map(|w| (w[0], w[1])).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `centres` perturbed by a fixed pattern of at most `amplitude` per coordinate.
    fn perturbed(centres: &[[f64; 3]], amplitude: f64) -> Vec<[f64; 3]> {
        centres
            .iter()
            .enumerate()
            .map(|(i, c)| {
                std::array::from_fn(|a| {
                    let phase = (7 * i + 3 * a) as f64;
                    c[a] + amplitude * phase.sin()
                })
            })
            .collect()
    }

    /// The centres of the octants of the cube `[0, 4]³`.
    fn octant_centres() -> Vec<[f64; 3]> {
        (0..8)
            .map(|k| std::array::from_fn(|a| if (k >> a) & 1 == 1 { 3.0 } else { 1.0 }))
            .collect()
    }

    /// Spheres of radius `r` at `centres` in the walled cube `[0, 4]³`.
    fn walled_octants(centres: &[[f64; 3]], r: f64) -> BoxedSpheres {
        BoxedSpheres {
            lo: [0.0; 3],
            len: [4.0; 3],
            periodic: [false; 3],
            centers: centres.to_vec(),
            radii: vec![r; centres.len()],
        }
    }

    fn jammed(spheres: &mut BoxedSpheres) -> SlpOutcome {
        let outcome = spheres.jam(&SlpSettings::default(), &mut |_| {});
        assert_eq!(outcome.stop, SlpStop::Jammed, "{outcome:?}");
        outcome
    }

    #[test]
    fn spheres_in_a_periodic_cube_jam_as_fcc() {
        // The densest packing of 32 equal spheres in a periodic cube of edge 2 is FCC
        // (2 × 2 × 2 cells), touching at r = √2/4 (φ = π/√18). From a shaken lattice at
        // r = 0.3 the steps must find it.
        let cell = [
            [0.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.5, 0.0, 0.5],
            [0.0, 0.5, 0.5],
        ];
        let fcc: Vec<[f64; 3]> = (0..8)
            .flat_map(|k| {
                cell.iter()
                    .map(move |c| std::array::from_fn(|a| c[a] + ((k >> a) & 1) as f64 + 0.25))
            })
            .collect();
        let mut spheres = BoxedSpheres {
            lo: [0.0; 3],
            len: [2.0; 3],
            periodic: [true; 3],
            centers: perturbed(&fcc, 0.02),
            radii: vec![0.3; 32],
        };
        jammed(&mut spheres);
        let exact = 2f64.sqrt() / 4.0;
        for r in &spheres.radii {
            assert!((r / exact - 1.0).abs() < 1e-12, "r = {r}, FCC {exact}");
        }
    }

    #[test]
    fn a_cancel_between_steps_keeps_the_steps_taken() {
        let mut spheres = walled_octants(&octant_centres(), 0.5);
        let cancel: CancelFlag = std::sync::Arc::new(false.into());
        let settings = SlpSettings {
            cancel: Some(cancel.clone()),
            ..SlpSettings::default()
        };
        let outcome = spheres.jam(&settings, &mut |r| {
            assert_eq!(r.step, 1);
            cancel.store(true, Ordering::Relaxed);
        });
        assert_eq!((&outcome.stop, outcome.steps), (&SlpStop::Cancelled, 1));
        assert!(outcome.growth > 1.0, "the step taken is kept: {outcome:?}");
    }

    #[test]
    fn a_program_halted_by_time_or_cancel_leaves_the_spheres() {
        let before = walled_octants(&octant_centres(), 0.5);
        let mut spheres = before.clone();
        assert!(matches!(spheres.step(0.02, 0.0, None), Err(Halt::Time)));
        let set: CancelFlag = std::sync::Arc::new(true.into());
        assert!(matches!(
            spheres.step(0.02, f64::INFINITY, Some(&set)),
            Err(Halt::Cancel)
        ));
        assert_eq!(
            (&spheres.centers, &spheres.radii),
            (&before.centers, &before.radii)
        );
        // Through `jam`: a set flag stops it before any step.
        let settings = SlpSettings {
            cancel: Some(set),
            ..SlpSettings::default()
        };
        let outcome = spheres.jam(&settings, &mut |_| {});
        assert_eq!((&outcome.stop, outcome.steps), (&SlpStop::Cancelled, 0));
    }

    #[test]
    fn eight_spheres_in_a_walled_cube_jam_on_the_simple_cubic_lattice() {
        // In a walled cube of edge 4, eight equal spheres jam at r = 1, one per octant,
        // each touching three walls and three neighbours.
        let lattice = octant_centres();
        let mut spheres = walled_octants(&perturbed(&lattice, 0.1), 0.8);
        let outcome = jammed(&mut spheres);
        assert!((outcome.growth * 0.8 - 1.0).abs() < 1e-12, "{outcome:?}");
        for (c, l) in spheres.centers.iter().zip(&lattice) {
            for a in 0..3 {
                assert!((c[a] - l[a]).abs() < 1e-9, "{c:?} against {l:?}");
            }
        }
    }
}
