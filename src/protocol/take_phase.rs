//! Grading curves and the *take phase*: turning a concrete mix design into a list of
//! sphere diameters.
//!
//! The take-and-place scheme for concrete mesostructures first *takes* the aggregate
//! particles (this module) and then *places* them in the specimen (RSA or EDMD). The take
//! phase follows Titscher & Unger, "Application of molecular dynamics simulations for the
//! generation of dense concrete mesoscale geometries", §2–3. Equation numbers below refer
//! to that paper; every formula was re-derived here, and two misprints are noted. All
//! lengths are in millimetres and volumes in mm³. The particle density ρ cancels
//! everywhere, so masses are handled as volumes.
//!
//! One module (about 900 lines): the grading curve, its tables and the take algorithm
//! share their notation and equation numbers, and the curve is read only by the take.
//!
//! # Grading curves
//!
//! A grading curve is the mass CDF `F(d)`: the fraction of the aggregate mass passing a
//! sieve of mesh size `d` ([`GradingCurve::passing`]). Three kinds are supported:
//!
//! * Fuller's curve `P(d) = (d / d_max)^q`, `0 < q < 1` (Eq. 11);
//! * the DIN 1045-2 curves A8, B8, C8, A16, B16, C16 ([`DinCurve`]);
//! * any user sieve table ([`GradingCurve::table`]).
//!
//! A sieve table splits the diameter axis into *mineral size classes* `[d_lo, d_hi)`
//! between consecutive sieves, class `i` holding the mass fraction `F(d_hi) − F(d_lo)`
//! (Eq. 1). Inside a class the mass CDF is linear in `ln d` (Eq. 2), so the mass density is
//! `f_m(d) = 1 / (d ln(d_hi/d_lo))` (Eq. 3).
//!
//! # From mass to number (Eq. 4–10)
//!
//! A particle of diameter `d` has volume `π d³ / 6` (Eq. 4), so the expected *number* of
//! particles per unit diameter is `n(d) = V_i f_m(d) / (π d³/6) ∝ d⁻⁴` (Eq. 5), where `V_i`
//! is the aggregate volume of the class. Integrating gives the number CDF (Eq. 6–8)
//!
//! ```text
//! F_N(d) = (d_lo⁻³ − d⁻³) / (d_lo⁻³ − d_hi⁻³),
//! ```
//!
//! and inverting it gives the sampling formula (Eq. 9–10), `U` uniform in `[0, 1)`:
//!
//! ```text
//! d = d_lo d_hi / ∛(d_hi³ (1 − U) + d_lo³ U).
//! ```
//!
//! The mean particle volume of this number distribution is
//! `v̄ = (π/6) ln(d_hi/d_lo) · 3 / (d_lo⁻³ − d_hi⁻³)`, so the class holds on average
//! `N_i = V_i / v̄ = 2 V_i (d_lo⁻³ − d_hi⁻³) / (π ln(d_hi/d_lo))` particles.
//!
//! For Fuller's curve the mass density is `P'(d) = q d^(q−1) / d_max^q`, the number density
//! is `∝ d^(q−4)`, and the expected count on `[d_min, d_max]` (Eq. 12) is
//!
//! ```text
//! N = 6 φ_M V q / (π d_max^q (3 − q)) · (d_min^(q−3) − d_max^(q−3))
//! ```
//!
//! ([`fuller_expected_count`]). Eq. 13 as printed has `(q − 3)` in the denominator, which
//! makes `N` negative; the correct factor is `(3 − q)`.
//!
//! **Fuller sampling.** The paper splits Fuller's curve into "sufficiently small classes"
//! and samples each with Eq. 10, which only approximates the curve inside each class. Here
//! the curve is split into classes of a quarter octave (edges `d_max · 2^(−k/4)`, the
//! lowest class cut at `d_min`), and inside each class the diameters are drawn *exactly*
//! from the truncated Fuller number density `∝ d^(q−4)` by inverse sampling,
//! `d = (d_lo^(q−3) (1 − U) + d_hi^(q−3) U)^(1/(q−3))`. The classes only stratify the
//! sample (each quarter octave receives its exact volume); the sampled distribution is
//! Fuller's curve without discretisation error, and the class counts sum exactly to the
//! formula above.
//!
//! # Algorithm 1 and the overshoot
//!
//! Classes are processed from the largest to the smallest. Diameters are drawn while the
//! *cumulative* drawn volume is below the *cumulative* class target; the last particle of
//! a class overshoots and the overshoot is thereby taken away from the next (smaller)
//! class. Algorithm 1 as printed both keeps cumulative sums *and* subtracts the overshoot
//! `m_diff` again, which would count every overshoot twice; the cumulative form used here
//! carries it exactly once. Going from large to small means the large overshoots are
//! absorbed by the many small particles and the total aggregate volume exceeds its target
//! by less than one particle of the smallest class.
//!
//! # Cut-off (Eq. 14–17)
//!
//! Particles below `d_min` belong to the mortar and are not generated. With the mixture
//! fraction `φ_M = m_total / (ρ V)` (Eq. 15) the resolved, *effective* fraction is
//!
//! ```text
//! φ_eff = φ_M (1 − F(d_min))          (Eq. 16–17)
//! ```
//!
//! and the aggregate volume actually generated is `φ_eff V`. The paper's examples
//! (`φ_M` = 0.70, `d_min` = 2 mm, 150 mm cube): B16 passes 42 % at 2 mm, so
//! `φ_eff` = 0.406 and `N` ≈ 40 049 from the sieve table; A16 passes 21 %, so
//! `φ_eff` = 0.553 and `N` ≈ 44 202. The paper prints 53.3 % for A16, which no reading of
//! the curve reproduces (its Fuller approximation q = 0.7 gives 0.537); 0.553 is used here.
//!
//! # Example
//!
//! ```
//! use densepack::protocol::take_phase::{DinCurve, GradingCurve, TakeParams, TakePhase};
//! use rand::SeedableRng;
//! use rand_xoshiro::Xoshiro256PlusPlus;
//!
//! let curve = GradingCurve::din(DinCurve::B16);
//! let params = TakeParams { volume: 50.0_f64.powi(3), phi_m: 0.70, d_min: 2.0 };
//! let take = TakePhase::new(&curve, params)?;
//! let summary = take.summary();
//! assert!((summary.phi_eff - 0.406).abs() < 1e-12); // B16 passes 42 % at 2 mm
//!
//! let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
//! let diameters = take.sample(&mut rng);
//! assert!(diameters.windows(2).all(|w| w[0] >= w[1])); // largest first
//! assert!(diameters.iter().all(|&d| (2.0..=16.0).contains(&d)));
//! let drawn: f64 = diameters.iter().map(|d| std::f64::consts::PI / 6.0 * d.powi(3)).sum();
//! assert!((drawn / summary.aggregate_volume - 1.0).abs() < 1e-3);
//! # Ok::<(), densepack::protocol::take_phase::TakeError>(())
//! ```
//!
//! Curves can be read from a scene file, e.g. TOML
//! `grading = { kind = "fuller", q = 0.5, d_max = 16.0 }`,
//! `{ kind = "din", name = "B16" }` or
//! `{ kind = "table", sizes = [2.0, 4.0, 8.0], passing = [0.0, 40.0, 100.0] }`; see
//! [`GradingSpec`].

use std::f64::consts::PI;

use rand::Rng;
use serde::Deserialize;

/// Bytes of memory per particle assumed by [`TakeSummary::estimated_memory_bytes`]: the
/// measured peak of a sphere run ([`crate::memory::SPHERE_BYTES`]), the figure `densepack run`
/// checks a scene against before it allocates.
pub const BYTES_PER_PARTICLE: u64 = crate::memory::SPHERE_BYTES;

/// Effective volume fraction reached by random sequential addition in the paper's packing
/// experiment (Titscher & Unger, §6.2, Fig. 7b): Fuller's curve `q = 0.5`, `d_max = 16` mm,
/// `d_min = 2` mm, cubic specimen of edge 80 mm with rigid walls, stopping criterion
/// `N^F = 10^6` failed attempts. A reported reference value, not computed here.
pub const RSA_REACHABLE_PHI_EFF: f64 = 0.665;

/// Effective volume fraction reached by event-driven molecular dynamics with growing
/// particles in the same experiment as [`RSA_REACHABLE_PHI_EFF`] (Titscher & Unger, §6.2,
/// Fig. 7b). A reported reference value, not computed here.
pub const EDMD_REACHABLE_PHI_EFF: f64 = 0.70;

/// Number of Fuller sampling classes per octave of diameter (see the module docs).
const FULLER_CLASSES_PER_OCTAVE: f64 = 4.0;

/// Upper bound on the capacity reserved up front by [`TakePhase::sample`].
const MAX_INITIAL_CAPACITY: usize = 1 << 24;

/// Invalid grading curve or take-phase parameters. Every message names the offending
/// field and its allowed range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TakeError {
    /// Fuller exponent outside `(0, 1)`.
    #[error("fuller curve: q = {0} is outside the open interval (0, 1)")]
    FullerExponent(f64),
    /// Fuller maximum diameter not finite and positive.
    #[error("fuller curve: d_max = {0} mm must be finite and > 0")]
    FullerMaxDiameter(f64),
    /// `sizes` and `passing` differ in length.
    #[error("sieve table: sizes has {sizes} entries but passing has {passing}; they must match")]
    TableLengths {
        /// Length of `sizes`.
        sizes: usize,
        /// Length of `passing`.
        passing: usize,
    },
    /// Fewer than two sieves.
    #[error("sieve table: {0} sieve(s) given, at least 2 are required")]
    TableTooShort(usize),
    /// A sieve size that is not finite and positive.
    #[error("sieve table: sizes[{index}] = {value} mm must be finite and > 0")]
    SizeNotPositive {
        /// Position in the table.
        index: usize,
        /// Offending size (mm).
        value: f64,
    },
    /// Sieve sizes not strictly increasing.
    #[error(
        "sieve table: sizes[{index}] = {value} mm must be greater than \
         sizes[{prev_index}] = {prev} mm (sizes strictly increasing)",
        prev_index = .index - 1
    )]
    SizesNotIncreasing {
        /// Position in the table.
        index: usize,
        /// Offending size (mm).
        value: f64,
        /// The preceding size (mm).
        prev: f64,
    },
    /// A passing value outside `0..=100` %.
    #[error("sieve table: passing[{index}] = {value} % is outside 0..=100")]
    PassingOutOfRange {
        /// Position in the table.
        index: usize,
        /// Offending value (%).
        value: f64,
    },
    /// Passing values decreasing.
    #[error(
        "sieve table: passing[{index}] = {value} % is below passing[{prev_index}] = {prev} % \
         (passing must be non-decreasing)",
        prev_index = .index - 1
    )]
    PassingDecreasing {
        /// Position in the table.
        index: usize,
        /// Offending value (%).
        value: f64,
        /// The preceding value (%).
        prev: f64,
    },
    /// Last passing value is not 100 %.
    #[error("sieve table: passing[{index}] = {value} % is the last value and must be 100 %")]
    LastNotFull {
        /// Position of the last entry.
        index: usize,
        /// Its value (%).
        value: f64,
    },
    /// Mixture fraction outside `(0, 1)`.
    #[error("take phase: phi_m = {0} is outside the open interval (0, 1)")]
    MixtureFraction(f64),
    /// Effective fraction outside `(0, 1)`.
    #[error("take phase: phi_eff = {0} is outside the open interval (0, 1)")]
    EffectiveFraction(f64),
    /// Container volume not finite and positive.
    #[error("take phase: volume = {0} mm³ must be finite and > 0")]
    Volume(f64),
    /// Cut-off diameter not in `(0, d_max)`.
    #[error("take phase: d_min = {d_min} mm must be > 0 and < d_max = {d_max} mm")]
    CutOff {
        /// The requested cut-off (mm).
        d_min: f64,
        /// The largest diameter of the curve (mm).
        d_max: f64,
    },
    /// Cut-off below the smallest sieve of a table that has material passing that sieve.
    #[error(
        "take phase: d_min = {d_min} mm is below the smallest sieve sizes[0] = {smallest} mm, \
         which {passing} % of the mass passes; the grading below it is unknown, so d_min \
         must be >= {smallest} mm"
    )]
    CutOffBelowTable {
        /// The requested cut-off (mm).
        d_min: f64,
        /// The smallest sieve size of the table (mm).
        smallest: f64,
        /// Percentage passing that sieve.
        passing: f64,
    },
}

/// The DIN 1045-2 standard grading curves ("Sieblinien") for maximum aggregate sizes 8 and
/// 16 mm.
///
/// Passing percentages by mass at the sieves 0.25/0.5/1/2/4/8(/16) mm:
///
/// | curve | 0.25 | 0.5 | 1  | 2  | 4  | 8   | 16  |
/// |-------|------|-----|----|----|----|-----|-----|
/// | A8    | 5    | 14  | 21 | 36 | 61 | 100 |     |
/// | B8    | 11   | 26  | 42 | 57 | 74 | 100 |     |
/// | C8    | 21   | 39  | 57 | 71 | 85 | 100 |     |
/// | A16   | 3    | 8   | 12 | 21 | 36 | 60  | 100 |
/// | B16   | 8    | 20  | 32 | 42 | 56 | 76  | 100 |
/// | C16   | 18   | 34  | 49 | 62 | 74 | 88  | 100 |
///
/// Source: DIN 1045-2 (2008), Anhang L, grading-curve figures for maximum aggregate sizes
/// 8 mm (Bild L.1) and 16 mm (Bild L.2), in the values commonly reproduced in German
/// concrete handbooks. The standard itself was not available to check them against.
/// Plausibility checks: every row is monotone, and the local Fuller exponents
/// `ln P(d) / ln(d / d_max)` lie in 0.71–0.86 (A8), 0.41–0.64 (B8), 0.23–0.45 (C8), next
/// to 0.73–0.84 (A16), 0.40–0.61 (B16), 0.18–0.41 (C16); the paper approximates A16, B16,
/// C16 by Fuller curves with q = 0.7, 0.35, 0.22.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize, serde::Serialize)]
pub enum DinCurve {
    /// Coarse curve, maximum size 8 mm.
    A8,
    /// Medium curve, maximum size 8 mm.
    B8,
    /// Fine curve, maximum size 8 mm.
    C8,
    /// Coarse curve, maximum size 16 mm.
    A16,
    /// Medium curve, maximum size 16 mm.
    B16,
    /// Fine curve, maximum size 16 mm.
    C16,
}

impl DinCurve {
    /// All six curves.
    pub const ALL: [DinCurve; 6] = [
        DinCurve::A8,
        DinCurve::B8,
        DinCurve::C8,
        DinCurve::A16,
        DinCurve::B16,
        DinCurve::C16,
    ];

    /// The sieve table as `(size in mm, passing in %)` pairs, smallest sieve first.
    pub fn sieve_table(self) -> &'static [(f64, f64)] {
        match self {
            DinCurve::A8 => &[
                (0.25, 5.0),
                (0.5, 14.0),
                (1.0, 21.0),
                (2.0, 36.0),
                (4.0, 61.0),
                (8.0, 100.0),
            ],
            DinCurve::B8 => &[
                (0.25, 11.0),
                (0.5, 26.0),
                (1.0, 42.0),
                (2.0, 57.0),
                (4.0, 74.0),
                (8.0, 100.0),
            ],
            DinCurve::C8 => &[
                (0.25, 21.0),
                (0.5, 39.0),
                (1.0, 57.0),
                (2.0, 71.0),
                (4.0, 85.0),
                (8.0, 100.0),
            ],
            DinCurve::A16 => &[
                (0.25, 3.0),
                (0.5, 8.0),
                (1.0, 12.0),
                (2.0, 21.0),
                (4.0, 36.0),
                (8.0, 60.0),
                (16.0, 100.0),
            ],
            DinCurve::B16 => &[
                (0.25, 8.0),
                (0.5, 20.0),
                (1.0, 32.0),
                (2.0, 42.0),
                (4.0, 56.0),
                (8.0, 76.0),
                (16.0, 100.0),
            ],
            DinCurve::C16 => &[
                (0.25, 18.0),
                (0.5, 34.0),
                (1.0, 49.0),
                (2.0, 62.0),
                (4.0, 74.0),
                (8.0, 88.0),
                (16.0, 100.0),
            ],
        }
    }
}

/// Serialised description of a grading curve, as found in a scene file. Convert it with
/// [`GradingSpec::build`] (or `GradingCurve::try_from`), which validates it.
///
/// TOML forms: `{ kind = "fuller", q = 0.5, d_max = 16.0 }`, `{ kind = "din", name = "B16" }`,
/// `{ kind = "table", sizes = [..], passing = [..] }` (sizes in mm, passing in %). Unknown
/// fields are rejected.
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum GradingSpec {
    /// Fuller's curve `(d / d_max)^q`.
    Fuller {
        /// Exponent, `0 < q < 1`.
        q: f64,
        /// Largest diameter (mm).
        d_max: f64,
    },
    /// A DIN 1045-2 curve.
    Din {
        /// Curve name, e.g. `"B16"`.
        name: DinCurve,
    },
    /// A user sieve table.
    Table {
        /// Sieve sizes (mm), strictly increasing.
        sizes: Vec<f64>,
        /// Mass percentage passing each sieve, non-decreasing, last 100.
        passing: Vec<f64>,
    },
}

impl GradingSpec {
    /// The short forms of a curve on the command line and in Python: a DIN 1045-2 name
    /// (`A8`, `B8`, `C8`, `A16`, `B16`, `C16`, any case) or `fuller:Q:D_MAX` (e.g.
    /// `fuller:0.5:16`, validated). `None` when `text` is neither; the error names `text`.
    pub fn parse_short(text: &str) -> Option<Result<Self, String>> {
        if let Some(c) = DinCurve::ALL
            .iter()
            .find(|c| format!("{c:?}").eq_ignore_ascii_case(text))
        {
            return Some(Ok(GradingSpec::Din { name: *c }));
        }
        let rest = text.strip_prefix("fuller:")?;
        Some((|| {
            let parts: Vec<&str> = rest.split(':').collect();
            let [q, d_max] = parts[..] else {
                return Err(format!("{text}: write fuller:Q:D_MAX, e.g. fuller:0.5:16"));
            };
            let q: f64 = q.parse().map_err(|e| format!("{text}: Q: {e}"))?;
            let d_max: f64 = d_max.parse().map_err(|e| format!("{text}: D_MAX: {e}"))?;
            GradingCurve::fuller(q, d_max).map_err(|e| format!("{text}: {e}"))?;
            Ok(GradingSpec::Fuller { q, d_max })
        })())
    }

    /// A short name for people: `DIN 1045-2 B16`, `Fuller q = 0.5, d_max = 16 mm`,
    /// `sieve table 2–16 mm`.
    pub fn describe(&self) -> String {
        match self {
            GradingSpec::Din { name } => format!("DIN 1045-2 {name:?}"),
            GradingSpec::Fuller { q, d_max } => format!("Fuller q = {q}, d_max = {d_max} mm"),
            GradingSpec::Table { sizes, .. } => format!(
                "sieve table {}–{} mm",
                sizes.first().copied().unwrap_or(f64::NAN),
                sizes.last().copied().unwrap_or(f64::NAN)
            ),
        }
    }

    /// Validates the description and builds the curve.
    pub fn build(&self) -> Result<GradingCurve, TakeError> {
        match self {
            GradingSpec::Fuller { q, d_max } => GradingCurve::fuller(*q, *d_max),
            GradingSpec::Din { name } => Ok(GradingCurve::din(*name)),
            GradingSpec::Table { sizes, passing } => {
                if sizes.len() != passing.len() {
                    return Err(TakeError::TableLengths {
                        sizes: sizes.len(),
                        passing: passing.len(),
                    });
                }
                let pairs: Vec<(f64, f64)> =
                    sizes.iter().copied().zip(passing.iter().copied()).collect();
                GradingCurve::table(&pairs)
            }
        }
    }
}

impl TryFrom<GradingSpec> for GradingCurve {
    type Error = TakeError;

    fn try_from(spec: GradingSpec) -> Result<Self, Self::Error> {
        spec.build()
    }
}

/// A validated grading curve: the aggregate mass fraction passing each sieve size.
///
/// Deserialising a `GradingCurve` directly reads a [`GradingSpec`] and validates it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(try_from = "GradingSpec")]
pub struct GradingCurve {
    kind: CurveKind,
}

#[derive(Debug, Clone, PartialEq)]
enum CurveKind {
    Fuller {
        q: f64,
        d_max: f64,
    },
    /// `passing` as fractions in `0..=1`.
    Table {
        sizes: Vec<f64>,
        passing: Vec<f64>,
    },
}

impl GradingCurve {
    /// Fuller's curve `P(d) = (d / d_max)^q` (Eq. 11), `0 < q < 1`, `d_max > 0` in mm.
    pub fn fuller(q: f64, d_max: f64) -> Result<Self, TakeError> {
        if !(q > 0.0 && q < 1.0) {
            return Err(TakeError::FullerExponent(q));
        }
        if !(d_max.is_finite() && d_max > 0.0) {
            return Err(TakeError::FullerMaxDiameter(d_max));
        }
        Ok(GradingCurve {
            kind: CurveKind::Fuller { q, d_max },
        })
    }

    /// A DIN 1045-2 curve (see [`DinCurve`] for the values and their source).
    pub fn din(curve: DinCurve) -> Self {
        let table = curve.sieve_table();
        GradingCurve {
            kind: CurveKind::Table {
                sizes: table.iter().map(|&(s, _)| s).collect(),
                passing: table.iter().map(|&(_, p)| p / 100.0).collect(),
            },
        }
    }

    /// A user sieve table of `(size in mm, passing in %)` pairs, smallest sieve first.
    ///
    /// Requirements: at least two sieves; sizes finite, positive and strictly increasing;
    /// passing within `0..=100`, non-decreasing, and exactly 100 at the last sieve. Between
    /// sieves the curve is linear in `ln d` (Eq. 2).
    pub fn table(pairs: &[(f64, f64)]) -> Result<Self, TakeError> {
        if pairs.len() < 2 {
            return Err(TakeError::TableTooShort(pairs.len()));
        }
        for (index, &(size, _)) in pairs.iter().enumerate() {
            if !(size.is_finite() && size > 0.0) {
                return Err(TakeError::SizeNotPositive { index, value: size });
            }
            if index > 0 {
                let prev = pairs[index - 1].0;
                if size <= prev {
                    return Err(TakeError::SizesNotIncreasing {
                        index,
                        value: size,
                        prev,
                    });
                }
            }
        }
        for (index, &(_, passing)) in pairs.iter().enumerate() {
            if !(0.0..=100.0).contains(&passing) {
                return Err(TakeError::PassingOutOfRange {
                    index,
                    value: passing,
                });
            }
            if index > 0 {
                let prev = pairs[index - 1].1;
                if passing < prev {
                    return Err(TakeError::PassingDecreasing {
                        index,
                        value: passing,
                        prev,
                    });
                }
            }
        }
        let index = pairs.len() - 1;
        let last = pairs[index].1;
        if last != 100.0 {
            return Err(TakeError::LastNotFull { index, value: last });
        }
        Ok(GradingCurve {
            kind: CurveKind::Table {
                sizes: pairs.iter().map(|&(s, _)| s).collect(),
                passing: pairs.iter().map(|&(_, p)| p / 100.0).collect(),
            },
        })
    }

    /// Mass fraction (0..1) of the aggregate passing a sieve of size `d` mm.
    ///
    /// Fuller: `(d / d_max)^q`, 1 above `d_max`. Tables: linear in `ln d` between sieves
    /// (Eq. 2), 1 from the first sieve with 100 % on. Below the smallest sieve a table gives
    /// no information; there the value is extrapolated linearly in `d` to 0 at `d = 0`
    /// (a monotone, continuous convention for reporting only: the take phase refuses a
    /// cut-off in that range when material passes the smallest sieve). 0 for `d <= 0`.
    pub fn passing(&self, d: f64) -> f64 {
        if d <= 0.0 {
            return 0.0;
        }
        match &self.kind {
            CurveKind::Fuller { q, d_max } => {
                if d >= *d_max {
                    1.0
                } else {
                    (d / d_max).powf(*q)
                }
            }
            CurveKind::Table { sizes, passing } => {
                let upper = sizes.partition_point(|&s| s <= d);
                if upper == 0 {
                    passing[0] * d / sizes[0]
                } else if upper == sizes.len() {
                    1.0
                } else {
                    let (lo, hi) = (sizes[upper - 1], sizes[upper]);
                    let (p_lo, p_hi) = (passing[upper - 1], passing[upper]);
                    p_lo + (p_hi - p_lo) * (d / lo).ln() / (hi / lo).ln()
                }
            }
        }
    }

    /// Largest particle diameter (mm): `d_max` for Fuller, the first sieve that 100 % of the
    /// mass passes for a table.
    pub fn d_max(&self) -> f64 {
        match &self.kind {
            CurveKind::Fuller { d_max, .. } => *d_max,
            CurveKind::Table { sizes, passing } => {
                let full = passing
                    .iter()
                    .position(|&p| p >= 1.0)
                    .unwrap_or(sizes.len() - 1);
                sizes[full]
            }
        }
    }

    /// The sieve sizes (mm) of a table curve; empty for Fuller's curve.
    pub fn sieve_sizes(&self) -> &[f64] {
        match &self.kind {
            CurveKind::Fuller { .. } => &[],
            CurveKind::Table { sizes, .. } => sizes,
        }
    }

    /// The sampling classes above `d_min`, largest first, with their volume fractions
    /// of the total mixture mass (before `φ_M V` scaling). Assumes `d_min` was checked.
    fn classes(&self, d_min: f64) -> Vec<Class> {
        let mut classes = Vec::new();
        match &self.kind {
            CurveKind::Fuller { q, d_max } => {
                let octaves = (d_max / d_min).log2();
                let count = (octaves * FULLER_CLASSES_PER_OCTAVE).ceil().max(1.0) as i32;
                for k in 0..count {
                    let hi = d_max * (-f64::from(k) / FULLER_CLASSES_PER_OCTAVE).exp2();
                    let lo =
                        (d_max * (-f64::from(k + 1) / FULLER_CLASSES_PER_OCTAVE).exp2()).max(d_min);
                    if hi <= lo {
                        continue;
                    }
                    classes.push(Class {
                        lo,
                        hi,
                        fraction: self.passing(hi) - self.passing(lo),
                        shape: *q,
                    });
                }
            }
            CurveKind::Table { sizes, .. } => {
                for i in (1..sizes.len()).rev() {
                    let hi = sizes[i];
                    let lo = sizes[i - 1].max(d_min);
                    if hi <= lo {
                        continue;
                    }
                    let fraction = self.passing(hi) - self.passing(lo);
                    if fraction > 0.0 {
                        classes.push(Class {
                            lo,
                            hi,
                            fraction,
                            shape: 0.0,
                        });
                    }
                }
            }
        }
        classes
    }
}

/// One sampling class `[lo, hi]`: mass density `∝ d^(shape − 1)` (shape 0: linear in
/// `ln d`, Eq. 2; shape q: Fuller), hence number density `∝ d^(shape − 4)`.
#[derive(Debug, Clone, PartialEq)]
struct Class {
    lo: f64,
    hi: f64,
    /// Mass fraction of the whole mixture in this class.
    fraction: f64,
    shape: f64,
}

impl Class {
    /// Inverse number CDF: Eq. 10 for shape 0, its Fuller analogue otherwise.
    fn diameter(&self, u: f64) -> f64 {
        let (lo, hi) = (self.lo, self.hi);
        let d = if self.shape == 0.0 {
            lo * hi / (hi * hi * hi * (1.0 - u) + lo * lo * lo * u).cbrt()
        } else {
            let e = self.shape - 3.0;
            (lo.powf(e) * (1.0 - u) + hi.powf(e) * u).powf(1.0 / e)
        };
        d.clamp(lo, hi)
    }

    /// `E[d^k]` under the number distribution of the class.
    fn moment(&self, k: f64) -> f64 {
        let p = self.shape - 4.0;
        power_integral(self.lo, self.hi, p + k) / power_integral(self.lo, self.hi, p)
    }
}

/// `∫_lo^hi x^p dx`, stable for exponents `p + 1` near zero.
fn power_integral(lo: f64, hi: f64, p: f64) -> f64 {
    let e = p + 1.0;
    let log_ratio = (hi / lo).ln();
    if e == 0.0 {
        log_ratio
    } else {
        lo.powf(e) * (e * log_ratio).exp_m1() / e
    }
}

/// Expected number of particles in `[d_min, d_max]` for Fuller's curve, the corrected
/// Eq. 13: `6 φ_M V q / (π d_max^q (3 − q)) · (d_min^(q−3) − d_max^(q−3))`.
///
/// `phi_m` is the mixture volume fraction and `volume` the container volume (mm³).
/// No validation: see [`TakePhase::new`] for the checked path.
pub fn fuller_expected_count(q: f64, d_max: f64, d_min: f64, phi_m: f64, volume: f64) -> f64 {
    6.0 * phi_m * volume * q / (PI * d_max.powf(q) * (3.0 - q))
        * (d_min.powf(q - 3.0) - d_max.powf(q - 3.0))
}

/// Parameters of the take phase.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TakeParams {
    /// Container (specimen) volume `V` in mm³.
    pub volume: f64,
    /// Aggregate volume fraction of the mix design `φ_M` (Eq. 15), in `(0, 1)`.
    pub phi_m: f64,
    /// Cut-off diameter `d_min` in mm; smaller particles belong to the mortar.
    pub d_min: f64,
}

/// Dry-run summary of a take phase, available before sampling.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TakeSummary {
    /// Expected number of particles (Wald: class volume / mean particle volume, summed).
    pub expected_count: f64,
    /// Approximate standard deviation of the particle count (renewal-process estimate
    /// `sqrt(Σ V_i Var(v) / E[v]³)` over the classes, ignoring the overshoot carry).
    pub count_std_dev: f64,
    /// Mixture fraction `φ_M`.
    pub phi_m: f64,
    /// Mass fraction of the curve below the cut-off, `F(d_min)`.
    pub cutoff_fraction: f64,
    /// Effective fraction `φ_eff = φ_M (1 − F(d_min))` (Eq. 17).
    pub phi_eff: f64,
    /// Container volume `V` (mm³).
    pub container_volume: f64,
    /// Target aggregate volume `φ_eff V` (mm³); the sample exceeds it by less than one
    /// particle of the smallest class.
    pub aggregate_volume: f64,
    /// Smallest diameter that can be drawn (mm): `d_min` or the lower edge of the lowest
    /// class holding material.
    pub smallest_diameter: f64,
    /// Largest diameter that can be drawn (mm).
    pub largest_diameter: f64,
    /// Memory estimate for the place phase: `ceil(expected_count) ×` [`BYTES_PER_PARTICLE`]
    /// plus the process's base ([`crate::memory::estimate`]).
    pub estimated_memory_bytes: u64,
    /// Reference only: [`RSA_REACHABLE_PHI_EFF`].
    pub rsa_reachable_phi_eff: f64,
    /// Reference only: [`EDMD_REACHABLE_PHI_EFF`].
    pub edmd_reachable_phi_eff: f64,
}

/// A validated take phase: grading curve, container volume, mixture fraction and cut-off,
/// split into sampling classes. Build it with [`TakePhase::new`].
#[derive(Debug, Clone, PartialEq)]
pub struct TakePhase {
    params: TakeParams,
    cutoff_fraction: f64,
    /// Sampling classes, largest first; class volume = `fraction · φ_M V`.
    classes: Vec<Class>,
}

impl TakePhase {
    /// Validates the parameters against the curve and prepares the sampling classes.
    ///
    /// Errors: `volume` not finite and positive, `phi_m` outside `(0, 1)`, `d_min` not in
    /// `(0, d_max)`, or `d_min` below the smallest sieve of a table when material passes
    /// that sieve.
    pub fn new(curve: &GradingCurve, params: TakeParams) -> Result<Self, TakeError> {
        if !(params.phi_m > 0.0 && params.phi_m < 1.0) {
            return Err(TakeError::MixtureFraction(params.phi_m));
        }
        Self::build(curve, params)
    }

    /// A take phase that fills the fraction `phi_eff` of `volume` with the grains of the
    /// curve between `d_min` and `d_max` (the paper's first experiment, §6.2, prescribes
    /// `φ_eff` directly). The implied mixture fraction `φ_M = φ_eff / (1 − F(d_min))` may
    /// exceed 1: the curve then only describes the size distribution above the cut-off.
    ///
    /// Errors as [`TakePhase::new`], with `phi_eff` outside `(0, 1)` reported as
    /// [`TakeError::EffectiveFraction`].
    pub fn for_effective_fraction(
        curve: &GradingCurve,
        volume: f64,
        phi_eff: f64,
        d_min: f64,
    ) -> Result<Self, TakeError> {
        if !(phi_eff > 0.0 && phi_eff < 1.0) {
            return Err(TakeError::EffectiveFraction(phi_eff));
        }
        let above = 1.0 - curve.passing(d_min.clamp(0.0, curve.d_max()));
        let phi_m = if above > 0.0 {
            phi_eff / above
        } else {
            f64::INFINITY
        };
        Self::build(
            curve,
            TakeParams {
                volume,
                phi_m,
                d_min,
            },
        )
    }

    fn build(curve: &GradingCurve, params: TakeParams) -> Result<Self, TakeError> {
        if !(params.volume.is_finite() && params.volume > 0.0) {
            return Err(TakeError::Volume(params.volume));
        }
        let d_max = curve.d_max();
        if !(params.d_min > 0.0 && params.d_min < d_max) {
            return Err(TakeError::CutOff {
                d_min: params.d_min,
                d_max,
            });
        }
        if let CurveKind::Table { sizes, passing } = &curve.kind {
            if params.d_min < sizes[0] && passing[0] > 0.0 {
                return Err(TakeError::CutOffBelowTable {
                    d_min: params.d_min,
                    smallest: sizes[0],
                    passing: passing[0] * 100.0,
                });
            }
        }
        Ok(TakePhase {
            params,
            cutoff_fraction: curve.passing(params.d_min),
            classes: curve.classes(params.d_min),
        })
    }

    /// The parameters this take phase was built with.
    pub fn params(&self) -> TakeParams {
        self.params
    }

    /// Effective volume fraction `φ_eff = φ_M (1 − F(d_min))` (Eq. 17).
    pub fn phi_eff(&self) -> f64 {
        self.params.phi_m * (1.0 - self.cutoff_fraction)
    }

    /// Expected number of particles: per class, the class volume `φ_M V ΔF_i` divided by the
    /// mean particle volume of its number distribution, summed. For tables this is
    /// `Σ 2 V_i (d_lo⁻³ − d_hi⁻³) / (π ln(d_hi/d_lo))`; for Fuller the sum telescopes to
    /// [`fuller_expected_count`].
    ///
    /// This is the paper's estimate (Wald's identity per class, Eq. 6). The overshoot carried
    /// from class to class shifts the true mean by O(1) particles per class, downwards: a
    /// large particle's overshoot displaces several smaller ones (about −10 particles for
    /// B16 with `d_min` = 2 mm), irrelevant against [`TakeSummary::count_std_dev`] for
    /// large samples.
    pub fn expected_count(&self) -> f64 {
        self.classes
            .iter()
            .map(|c| self.class_volume(c) / (PI / 6.0 * c.moment(3.0)))
            .sum()
    }

    /// Dry-run summary: counts, fractions, diameters and memory, without sampling.
    pub fn summary(&self) -> TakeSummary {
        let expected_count = self.expected_count();
        let variance: f64 = self
            .classes
            .iter()
            .map(|c| {
                let m3 = c.moment(3.0);
                self.class_volume(c) * (c.moment(6.0) - m3 * m3) / (PI / 6.0 * m3 * m3 * m3)
            })
            .sum();
        let phi_eff = self.phi_eff();
        TakeSummary {
            expected_count,
            count_std_dev: variance.max(0.0).sqrt(),
            phi_m: self.params.phi_m,
            cutoff_fraction: self.cutoff_fraction,
            phi_eff,
            container_volume: self.params.volume,
            aggregate_volume: phi_eff * self.params.volume,
            smallest_diameter: self.classes.last().map_or(self.params.d_min, |c| c.lo),
            largest_diameter: self.classes.first().map_or(self.params.d_min, |c| c.hi),
            estimated_memory_bytes: crate::memory::estimate(expected_count, BYTES_PER_PARTICLE),
            rsa_reachable_phi_eff: RSA_REACHABLE_PHI_EFF,
            edmd_reachable_phi_eff: EDMD_REACHABLE_PHI_EFF,
        }
    }

    /// Draws the particle diameters (mm) by Algorithm 1, sorted largest first.
    ///
    /// Classes are filled from the largest to the smallest; within a class diameters come
    /// from the inverse number CDF (Eq. 10, or its Fuller analogue) with one uniform number
    /// `rng.gen::<f64>()` each, until the cumulative drawn volume reaches the cumulative
    /// target, so each overshoot is carried into the next class. Deterministic for a given
    /// generator state. Memory is about 8 bytes per particle; check
    /// [`TakePhase::summary`] first for very small cut-offs.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Vec<f64> {
        let summary = self.summary();
        let estimate = summary.expected_count + 4.0 * summary.count_std_dev + 16.0;
        let mut diameters = Vec::with_capacity((estimate as usize).min(MAX_INITIAL_CAPACITY));
        let mut target = 0.0;
        let mut drawn = 0.0;
        for class in &self.classes {
            target += self.class_volume(class);
            while drawn < target {
                let d = class.diameter(rng.gen::<f64>());
                drawn += PI / 6.0 * d * d * d;
                diameters.push(d);
            }
        }
        diameters.sort_unstable_by(|a, b| b.total_cmp(a));
        diameters
    }

    fn class_volume(&self, class: &Class) -> f64 {
        class.fraction * self.params.phi_m * self.params.volume
    }
}
