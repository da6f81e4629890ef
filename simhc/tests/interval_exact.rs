//! Every interval operation contains the exact result: the endpoints' exact hull computed in
//! rational arithmetic (`BigRational` holds every finite `f64` exactly) lies inside the
//! computed interval, and the computed interval is at most two ulps wider on each side (so an
//! implementation that returned the whole line would fail too).
//!
//! Inputs mix signs, zeros, subnormals, values near `f64::MAX` and ordinary magnitudes; proptest
//! reports the failing case and its seed (`PROPTEST_RNG_SEED` / the persisted regressions).

use num_bigint::BigInt;
use num_rational::BigRational;
use proptest::prelude::*;
use simhc::interval::{next_down, next_up, Interval};
use simhc::Ring;

/// A finite `f64` of every kind: any bit pattern, small integers, subnormals, huge, zeros.
fn finite_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<u64>().prop_map(f64::from_bits).prop_filter("finite", |v| v.is_finite()),
        (-1000i32..1000).prop_map(f64::from),
        (1u64..(1u64 << 52), any::<bool>()).prop_map(|(m, neg)| if neg { -f64::from_bits(m) } else { f64::from_bits(m) }),
        (0.5f64..1.0, any::<bool>()).prop_map(|(m, neg)| if neg { -m * f64::MAX } else { m * f64::MAX }),
        Just(0.0),
        Just(-0.0),
        (-1.0e3f64..1.0e3),
    ]
}

/// An interval with finite endpoints, sometimes a point.
fn interval() -> impl Strategy<Value = Interval> {
    prop_oneof![
        (finite_f64(), finite_f64()).prop_map(|(a, b)| Interval::new(a.min(b), a.max(b)).expect("ordered finite endpoints")),
        finite_f64().prop_map(Interval::point),
    ]
}

fn exact(v: f64) -> BigRational {
    BigRational::from_float(v).expect("finite")
}

/// `r` contains `[lo, hi]` (exact), and each finite endpoint of `r` is within two ulps of it.
fn check(r: Interval, lo: &BigRational, hi: &BigRational) -> Result<(), TestCaseError> {
    prop_assert!(!r.lo().is_nan() && !r.hi().is_nan());
    if r.lo().is_finite() {
        prop_assert!(exact(r.lo()) <= *lo, "lower end {} above the exact {}", r.lo(), lo);
        let tight = next_up(next_up(r.lo()));
        prop_assert!(!tight.is_finite() || exact(tight) > *lo, "lower end {} more than 2 ulps below {}", r.lo(), lo);
    } else {
        // Only an overflowing exact value may lose its finite bound.
        prop_assert!(r.lo() == f64::NEG_INFINITY && *lo <= -exact(f64::MAX), "lower end {} for exact {}", r.lo(), lo);
    }
    if r.hi().is_finite() {
        prop_assert!(exact(r.hi()) >= *hi, "upper end {} below the exact {}", r.hi(), hi);
        let tight = next_down(next_down(r.hi()));
        prop_assert!(!tight.is_finite() || exact(tight) < *hi, "upper end {} more than 2 ulps above {}", r.hi(), hi);
    } else {
        prop_assert!(r.hi() == f64::INFINITY && *hi >= exact(f64::MAX), "upper end {} for exact {}", r.hi(), hi);
    }
    Ok(())
}

fn hull(values: [BigRational; 4]) -> (BigRational, BigRational) {
    let lo = values.iter().min().cloned().expect("four values");
    let hi = values.iter().max().cloned().expect("four values");
    (lo, hi)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4096))]

    #[test]
    fn sum_contains_the_exact_sum(a in interval(), b in interval()) {
        let r = a + b;
        check(r, &(exact(a.lo()) + exact(b.lo())), &(exact(a.hi()) + exact(b.hi())))?;
    }

    #[test]
    fn difference_contains_the_exact_difference(a in interval(), b in interval()) {
        let r = a - b;
        check(r, &(exact(a.lo()) - exact(b.hi())), &(exact(a.hi()) - exact(b.lo())))?;
    }

    #[test]
    fn product_contains_the_exact_product(a in interval(), b in interval()) {
        let r = a * b;
        let (al, ah, bl, bh) = (exact(a.lo()), exact(a.hi()), exact(b.lo()), exact(b.hi()));
        let (lo, hi) = hull([&al * &bl, &al * &bh, &ah * &bl, &ah * &bh]);
        check(r, &lo, &hi)?;
    }

    #[test]
    fn negation_is_exact(a in interval()) {
        let r = -a;
        prop_assert_eq!((r.lo(), r.hi()), (-a.hi(), -a.lo()));
    }

    #[test]
    fn scaling_and_constants_contain_the_exact_value(a in interval(), c in finite_f64()) {
        let r = a.scale_by(c);
        let (al, ah, c) = (exact(a.lo()), exact(a.hi()), exact(c));
        let (lo, hi) = hull([&al * &c, &ah * &c, &al * &c, &ah * &c]);
        check(r, &lo, &hi)?;
        let k = <Interval as Ring>::constant(a.lo());
        prop_assert_eq!((k.lo(), k.hi()), (a.lo(), a.lo()));
    }

    #[test]
    fn a_box_around_a_point_contains_it(c in finite_f64(), r in 0.0f64..1.0e300) {
        let x = Interval::around(c, r);
        let (c, r) = (exact(c), exact(r));
        check(x, &(&c - &r), &(&c + &r))?;
    }

    #[test]
    fn one_ulp_steps_are_adjacent(v in finite_f64()) {
        let (up, down) = (next_up(v), next_down(v));
        prop_assert!(up > v && down < v);
        // No f64 strictly between: stepping back lands on `v` (or on the other zero).
        prop_assert!(next_down(up) == v && next_up(down) == v);
        if up.is_finite() {
            // The gap is at least the smallest subnormal, never more than 2^-52 relative.
            let gap = exact(up) - exact(v);
            prop_assert!(gap >= exact(f64::from_bits(1)));
            prop_assert!(gap <= exact(v.abs().max(f64::MIN_POSITIVE)) * BigRational::new(BigInt::from(1), BigInt::from(1u64 << 52)));
        }
    }
}
