//! Scene units: the reduced lengths a run works in, exact under decimal changes of unit.
//!
//! A run divides every length of its scene by one reference length `ℓ = 10^E` before
//! anything random happens, runs in these reduced units and multiplies the lengths it writes
//! by `ℓ`. `E` is the decimal exponent of the scene's smallest diameter ([`Units::of`]):
//! `particles.diameter`, the smallest `components[].diameter`, or `particles.d_min` of a
//! grading curve, so `ℓ` is 1 for a smallest diameter in `[1, 10)` and the reduction is then
//! the identity.
//!
//! **Why a power of ten.** A user who rewrites a scene from millimetres to metres writes every
//! length literal with its decimal exponent shifted by −3. The reduced value of a literal is
//! its decimal digits with the exponent shifted by `−E`; both scenes shift to the *same*
//! decimal number, and [`shift_decimal`] rounds that number correctly to an `f64`, so the
//! two runs start from the same bits and are identical (the same events, the same packing
//! fraction at every barrier). Dividing the parsed `f64`s instead cannot do this: the
//! literals round differently in binary (`fl(9e-3) / fl(d·1e-3) ≠ fl(9) / fl(d)` in general),
//! and hard-sphere dynamics amplifies a last-bit difference until the trajectories part.
//!
//! **What "the decimal digits" are.** The parser rounds a literal `D` to `x = fl(D)`; the
//! reduction sees only `x` and recovers its shortest round-trip decimal `dec(x)` (Rust's
//! `{:e}`). For a literal of at most 15 significant digits `dec(fl(D)) = D`: two distinct
//! decimals of at most 15 digits lie at least 10⁻¹⁵ apart relative to their size, wider than
//! the rounding interval of an `f64` (2⁻⁵² relative), so `D` is the only one of them that
//! rounds to `x`, and a shorter decimal rounding to `x` would be one of them. The guarantee
//! therefore holds for literals of up to 15 significant digits (16- and 17-digit literals
//! usually recover too, but not always).
//!
//! **Time.** Hard spheres have no energy scale: their natural time unit is
//! `ℓ·√(m/kT)`. The run keeps `kT = temperature` and the mass rule in reduced units, so scene
//! time is measured in units of `ℓ·√(m/kT)`: times (`until.time`, `stall_epsilon`) and
//! relative growth rates (1/time) are not converted, absolute growth rates (length/time) are
//! lengths. Wall-clock limits, event counts, packing fractions and pressures are dimensionless.

use crate::io::scene::{Component, ContainerSpec, Scene};
use crate::protocol::take_phase::GradingSpec;

/// `dec(x)·10^k` rounded to the nearest `f64` (ties to even), where `dec(x)` is the shortest
/// decimal that parses back to `x`. Exact in the sense that it depends only on the decimal
/// number `dec(x)·10^k`: `shift_decimal(fl(D), k)` is the same for every decimal rewrite
/// `D·10^j` of a literal `D` (up to 15 significant digits) shifted by `k − j`. Overflow gives
/// ±∞, underflow a subnormal or ±0 (both correctly rounded); NaN and ±∞ are returned as they
/// are.
pub fn shift_decimal(x: f64, k: i32) -> f64 {
    if !x.is_finite() || k == 0 {
        // k = 0: dec(x) rounds to x by definition of the shortest round-trip decimal.
        return x;
    }
    let text = format!("{x:e}");
    let (digits, exponent) = text.split_once('e').expect("`{:e}` writes an exponent");
    let exponent: i64 = exponent.parse().expect("`{:e}` writes an integer exponent");
    // `str::parse::<f64>` rounds correctly (to nearest, ties to even) for any exponent.
    format!("{digits}e{}", exponent + i64::from(k))
        .parse()
        .expect("a decimal in scientific notation parses")
}

/// The decimal exponent of `dec(x)`: `⌊log₁₀ dec(x)⌋` for finite `x ≠ 0` (so `x` lies in
/// `[10^E, 10^(E+1))` as a decimal), 0 for 0 and non-finite values.
pub fn decimal_exponent(x: f64) -> i32 {
    if !x.is_finite() || x == 0.0 {
        return 0;
    }
    let text = format!("{x:e}");
    let (_, exponent) = text.split_once('e').expect("`{:e}` writes an exponent");
    exponent.parse().expect("`{:e}` writes an integer exponent")
}

/// The reference length `ℓ = 10^exponent` of a scene (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Units {
    /// `E` of `ℓ = 10^E`.
    pub exponent: i32,
}

impl Units {
    /// The units of a validated scene: `ℓ` is the power of ten at or below its smallest
    /// diameter (`particles.diameter`, the smallest component diameter, or `d_min` of a
    /// grading curve). Decimal rewrites of the scene's literals shift `E` with them.
    pub fn of(scene: &Scene) -> Self {
        let p = &scene.particles;
        let smallest = match (&p.components, p.diameter, p.d_min) {
            (Some(cs), _, _) => cs.iter().map(|c| c.diameter).fold(f64::INFINITY, f64::min),
            (None, Some(d), _) => d,
            (None, None, Some(d_min)) => d_min,
            (None, None, None) => 1.0,
        };
        Self {
            exponent: decimal_exponent(smallest),
        }
    }

    /// A length of the scene in reduced units: `x / ℓ`, exactly rounded from `dec(x)`.
    pub fn reduce(self, x: f64) -> f64 {
        shift_decimal(x, -self.exponent)
    }

    /// A reduced length in the scene's units: `y·ℓ`, rounded once.
    pub fn to_scene(self, y: f64) -> f64 {
        shift_decimal(y, self.exponent)
    }

    /// The scene with every length in reduced units (see the module documentation for which
    /// fields are lengths). A DIN curve becomes its sieve table (the same curve) with reduced
    /// sizes. The container's origin is kept: runs work relative to it.
    pub fn reduced(self, scene: &Scene) -> Scene {
        let length = |x: f64| self.reduce(x);
        let lengths = |v: &[f64]| -> Vec<f64> { v.iter().map(|&x| length(x)).collect() };
        let mut s = scene.clone();
        s.container = match &scene.container {
            ContainerSpec::Box {
                min,
                size,
                periodic,
            } => ContainerSpec::Box {
                min: *min,
                size: size.map(length),
                periodic: *periodic,
            },
            ContainerSpec::Cylinder {
                base_center,
                radius,
                height,
            } => ContainerSpec::Cylinder {
                base_center: *base_center,
                radius: length(*radius),
                height: length(*height),
            },
        };
        let p = &mut s.particles;
        p.diameter = p.diameter.map(length);
        p.components = p.components.as_ref().map(|cs| {
            cs.iter()
                .map(|c| Component {
                    count: c.count,
                    diameter: length(c.diameter),
                })
                .collect()
        });
        p.grading = p.grading.as_ref().map(|g| match g {
            GradingSpec::Fuller { q, d_max } => GradingSpec::Fuller {
                q: *q,
                d_max: length(*d_max),
            },
            GradingSpec::Din { name } => {
                let (sizes, passing): (Vec<f64>, Vec<f64>) =
                    name.sieve_table().iter().copied().unzip();
                GradingSpec::Table {
                    sizes: lengths(&sizes),
                    passing,
                }
            }
            GradingSpec::Table { sizes, passing } => GradingSpec::Table {
                sizes: lengths(sizes),
                passing: passing.clone(),
            },
        });
        p.d_min = p.d_min.map(length);
        p.gap = p.gap.map(length);
        p.wall_gap = p.wall_gap.map(length);
        for stage in &mut s.stages {
            if stage.growth == crate::io::scene::GrowthKind::Absolute {
                stage.rate = stage.rate.map(length);
            }
            stage.until.gap = stage.until.gap.map(length);
            stage.wall_gap = stage.wall_gap.map(length);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_bigint::BigInt;
    use num_rational::BigRational;
    use num_traits::Signed;
    use proptest::prelude::*;

    /// `m·10^e` as an exact rational.
    fn exact(m: i64, e: i32) -> BigRational {
        let ten = BigRational::from_integer(BigInt::from(10));
        let mut q = BigRational::from_integer(BigInt::from(m));
        let p = num_traits::pow(ten, e.unsigned_abs() as usize);
        if e >= 0 {
            q *= p;
        } else {
            q /= p;
        }
        q
    }

    /// Whether `r` is the nearest `f64` to `q` (no neighbour strictly nearer; ties allowed).
    fn is_nearest(r: f64, q: &BigRational) -> bool {
        let at = |x: f64| BigRational::from_float(x).expect("finite");
        let d = (at(r) - q).abs();
        let up = f64::from_bits(r.to_bits() + 1);
        let down = f64::from_bits(r.to_bits() - 1);
        (at(up) - q).abs() >= d && (at(down) - q).abs() >= d
    }

    #[test]
    fn shortest_digits_are_recovered() {
        assert_eq!(format!("{:e}", 0.0005), "5e-4");
        assert_eq!(decimal_exponent(0.0005), -4);
        assert_eq!(decimal_exponent(9.999), 0);
        assert_eq!(decimal_exponent(10.0), 1);
        assert_eq!(decimal_exponent(-0.25), -1);
    }

    #[test]
    fn decimal_rewrites_reduce_to_the_same_bits() {
        // The parsed literals of a rewrite are not the products of the originals, and their
        // quotients differ: fl(0.9e-3) ≠ fl(0.9)·fl(1e-3), fl(1.1e-3)/fl(20e-3) ≠ fl(1.1)/fl(20).
        assert_ne!(0.9e-3, 0.9 * 1e-3);
        assert_ne!(1.1e-3 / 20e-3, 1.1 / 20.0);
        // Reduced by the power of ten of each scene, they agree.
        assert_eq!(shift_decimal(0.9e-3, 3), 0.9);
        assert_eq!(shift_decimal(1.1e-3, 3), 1.1);
        assert_eq!(shift_decimal(1.1e3, -3), 1.1);
        assert_eq!(shift_decimal(0.0005, 3), 0.5);
        assert_eq!(shift_decimal(4.35, -3), 0.00435);
        let mm = Units { exponent: 0 };
        let m = Units { exponent: -3 };
        assert_eq!(m.reduce(1.1e-3).to_bits(), mm.reduce(1.1).to_bits());
        assert_eq!(m.reduce(20e-3).to_bits(), mm.reduce(20.0).to_bits());
    }

    #[test]
    fn extremes() {
        assert_eq!(shift_decimal(1.5, 400), f64::INFINITY);
        assert_eq!(shift_decimal(-1.5, 400), f64::NEG_INFINITY);
        assert_eq!(shift_decimal(1.5, -400), 0.0);
        assert_eq!(shift_decimal(1e-300, -20), 1e-320);
        assert_eq!(shift_decimal(1e-320, 20), 1e-300);
        assert_eq!(
            shift_decimal(1.7976931348623157e308, -308),
            1.7976931348623157
        );
        assert_eq!(shift_decimal(0.0, 5), 0.0);
        assert!(shift_decimal(f64::NAN, 3).is_nan());
        // 15 significant digits: the literal's own digits are shifted.
        assert_eq!(shift_decimal(0.123456789012345, 5), 12345.6789012345);
        // 17 digits: the shortest round-trip digits of the parsed value are shifted, and the
        // result is their correctly rounded shift.
        let x = 0.12345678901234567;
        let text = format!("{x:e}");
        let (digits, exponent) = text.split_once('e').unwrap();
        let m: i64 = digits.replace('.', "").parse().unwrap();
        let places = digits.split_once('.').map_or(0, |(_, f)| f.len() as i32);
        let e: i32 = exponent.parse::<i32>().unwrap() - places;
        assert_eq!(m.to_string().len(), 17);
        assert!(is_nearest(shift_decimal(x, 5), &exact(m, e + 5)));
    }

    #[test]
    fn reduction_is_the_identity_at_unit_scale() {
        for x in [1.0, 0.1, 1.0 / 3.0, 2.0f64.sqrt(), 1e-300, 123456.789] {
            assert_eq!(Units { exponent: 0 }.reduce(x).to_bits(), x.to_bits());
        }
    }

    proptest! {
        /// For a literal `m·10^a` of up to 15 digits, every decimal rewrite `m·10^(a+j)`
        /// reduced by `10^(E+j)` gives the same bits, and those bits are the correctly
        /// rounded value of the exact quotient `m·10^(a−E)`.
        #[test]
        fn rewrites_agree_and_round_correctly(
            m in 1i64..1_000_000_000_000_000,
            a in -250i32..250,
            e in -30i32..30,
            j in -6i32..=6,
        ) {
            let literal = |shift: i32| -> f64 { format!("{m}e{}", a + shift).parse().unwrap() };
            let reference = shift_decimal(literal(0), -e);
            let rewritten = shift_decimal(literal(j), -(e + j));
            prop_assert_eq!(reference.to_bits(), rewritten.to_bits());
            prop_assert!(is_nearest(reference, &exact(m, a - e)));
        }
    }
}
