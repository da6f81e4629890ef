//! Sparse multivariate polynomials with `f64` coefficients: the IR that declarations lower to.
//!
//! Variables are small integers (unknowns first, then parameters; see [`crate::lower::VarTable`]).
//! Terms live in a `BTreeMap`, so iteration order, and therefore the generated code, is
//! deterministic. Coefficients that become exactly zero are dropped, which is what makes
//! identities such as `2 q0 q1 - 2 q0 q1` vanish.

use std::collections::BTreeMap;
use std::ops::{Add, Mul, Neg, Sub};

/// Index of a scalar variable.
pub type Var = u32;

/// A monomial: `(variable, exponent)` pairs sorted by variable, exponents > 0.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Monomial(pub Vec<(Var, u32)>);

impl Monomial {
    /// The monomial `1`.
    pub fn one() -> Self {
        Monomial(Vec::new())
    }

    /// The monomial `v`.
    pub fn var(v: Var) -> Self {
        Monomial(vec![(v, 1)])
    }

    /// Total degree.
    pub fn degree(&self) -> u32 {
        self.0.iter().map(|&(_, e)| e).sum()
    }

    /// Product of two monomials (merge of sorted exponent lists).
    pub fn mul(&self, other: &Monomial) -> Monomial {
        let (a, b) = (&self.0, &other.0);
        let mut out = Vec::with_capacity(a.len() + b.len());
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            match a[i].0.cmp(&b[j].0) {
                std::cmp::Ordering::Less => {
                    out.push(a[i]);
                    i += 1;
                }
                std::cmp::Ordering::Greater => {
                    out.push(b[j]);
                    j += 1;
                }
                std::cmp::Ordering::Equal => {
                    out.push((a[i].0, a[i].1 + b[j].1));
                    i += 1;
                    j += 1;
                }
            }
        }
        out.extend_from_slice(&a[i..]);
        out.extend_from_slice(&b[j..]);
        Monomial(out)
    }

    /// Exponent of `v`.
    pub fn exponent(&self, v: Var) -> u32 {
        self.0.iter().find(|&&(w, _)| w == v).map_or(0, |&(_, e)| e)
    }

    /// `d/dv`: the exponent of `v` (0 when absent) and the monomial with it lowered by one.
    pub fn diff(&self, v: Var) -> Option<(u32, Monomial)> {
        let pos = self.0.iter().position(|&(w, _)| w == v)?;
        let e = self.0[pos].1;
        let mut m = self.0.clone();
        if e == 1 {
            m.remove(pos);
        } else {
            m[pos].1 = e - 1;
        }
        Some((e, Monomial(m)))
    }

    /// Splits into the part whose variables satisfy `pred` and the rest.
    pub fn split(&self, pred: impl Fn(Var) -> bool) -> (Monomial, Monomial) {
        let (a, b): (Vec<_>, Vec<_>) = self.0.iter().partition(|&&(v, _)| pred(v));
        (Monomial(a), Monomial(b))
    }
}

/// A sparse polynomial.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Poly {
    /// Nonzero terms.
    pub terms: BTreeMap<Monomial, f64>,
}

impl Poly {
    /// The zero polynomial.
    pub fn zero() -> Self {
        Poly::default()
    }

    /// A constant.
    pub fn constant(c: f64) -> Self {
        let mut p = Poly::zero();
        p.add_term(Monomial::one(), c);
        p
    }

    /// The variable `v`.
    pub fn var(v: Var) -> Self {
        let mut p = Poly::zero();
        p.add_term(Monomial::var(v), 1.0);
        p
    }

    /// Whether this is the zero polynomial.
    pub fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }

    /// The constant value if the polynomial has no variables.
    pub fn as_constant(&self) -> Option<f64> {
        match self.terms.len() {
            0 => Some(0.0),
            1 => self.terms.get(&Monomial::one()).copied(),
            _ => None,
        }
    }

    /// Adds `c * m`, dropping the term if it cancels exactly.
    pub fn add_term(&mut self, m: Monomial, c: f64) {
        if c == 0.0 {
            return;
        }
        let entry = self.terms.entry(m);
        match entry {
            std::collections::btree_map::Entry::Vacant(v) => {
                v.insert(c);
            }
            std::collections::btree_map::Entry::Occupied(mut o) => {
                let s = *o.get() + c;
                if s == 0.0 {
                    o.remove();
                } else {
                    *o.get_mut() = s;
                }
            }
        }
    }

    /// `c * self`.
    pub fn scale(&self, c: f64) -> Poly {
        if c == 0.0 {
            return Poly::zero();
        }
        Poly { terms: self.terms.iter().map(|(m, &a)| (m.clone(), a * c)).collect() }
    }

    /// `self^n` by repeated squaring.
    pub fn pow(&self, mut n: u32) -> Poly {
        let mut base = self.clone();
        let mut acc = Poly::constant(1.0);
        while n > 0 {
            if n & 1 == 1 {
                acc = &acc * &base;
            }
            n >>= 1;
            if n > 0 {
                base = &base * &base;
            }
        }
        acc
    }

    /// Exact partial derivative `d/dv`.
    pub fn diff(&self, v: Var) -> Poly {
        let mut out = Poly::zero();
        for (m, &c) in &self.terms {
            if let Some((e, dm)) = m.diff(v) {
                out.add_term(dm, c * f64::from(e));
            }
        }
        out
    }

    /// Total degree (0 for the zero polynomial).
    pub fn degree(&self) -> u32 {
        self.terms.keys().map(Monomial::degree).max().unwrap_or(0)
    }

    /// Evaluates at a point given as a function of the variable index.
    pub fn eval(&self, value: impl Fn(Var) -> f64) -> f64 {
        self.terms.iter().map(|(m, &c)| c * m.0.iter().map(|&(v, e)| value(v).powi(e as i32)).product::<f64>()).sum()
    }

    /// Whether any term involves a variable satisfying `pred`.
    pub fn involves(&self, pred: impl Fn(Var) -> bool) -> bool {
        self.terms.keys().any(|m| m.0.iter().any(|&(v, _)| pred(v)))
    }
}

impl Add for &Poly {
    type Output = Poly;
    fn add(self, rhs: &Poly) -> Poly {
        let mut out = self.clone();
        for (m, &c) in &rhs.terms {
            out.add_term(m.clone(), c);
        }
        out
    }
}

impl Sub for &Poly {
    type Output = Poly;
    fn sub(self, rhs: &Poly) -> Poly {
        let mut out = self.clone();
        for (m, &c) in &rhs.terms {
            out.add_term(m.clone(), -c);
        }
        out
    }
}

impl Mul for &Poly {
    type Output = Poly;
    fn mul(self, rhs: &Poly) -> Poly {
        let mut out = Poly::zero();
        for (ma, &ca) in &self.terms {
            for (mb, &cb) in &rhs.terms {
                out.add_term(ma.mul(mb), ca * cb);
            }
        }
        out
    }
}

impl Neg for &Poly {
    type Output = Poly;
    fn neg(self) -> Poly {
        self.scale(-1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cancellation_and_derivative() {
        let (x, y) = (Poly::var(0), Poly::var(1));
        let p = &(&x * &y).scale(2.0) - &(&y * &x).scale(2.0);
        assert!(p.is_zero());
        let q = (&x + &y).pow(3); // x^3 + 3x^2y + 3xy^2 + y^3
        assert_eq!(q.terms.len(), 4);
        let dq = q.diff(0); // 3x^2 + 6xy + 3y^2
        assert_eq!(dq.eval(|v| [2.0, 1.0][v as usize]), 3.0 * 4.0 + 12.0 + 3.0);
        assert_eq!(q.degree(), 3);
    }
}
