//! Equations without parameters, found on the expanded polynomials.
//!
//! The online simulator moves parameters only, so an equation such as `q.q - 1` or
//! `t.t - 1` cannot be made to hold by simulation: the start must satisfy it itself. The
//! runtime learns which equations these are from the layout ([`parameter_free`]), and which of
//! them fix the norm of one unknown field ([`norms`]), so that the learned start's decoder,
//! random starts and the pipeline can put a start on them exactly (normalization) before the
//! simulator runs.

use crate::decl::Declaration;
use crate::lower::Instance;
use crate::poly::{Monomial, Poly};

/// Indices of the equations of `inst` (rows first, then globals) in which no parameter occurs.
pub fn parameter_free(inst: &Instance) -> Vec<usize> {
    inst.equations.iter().enumerate().filter(|(_, f)| !f.involves(|v| inst.vars.is_param(v))).map(|(i, _)| i).collect()
}

/// An equation `a (v . v) - b = 0` over all scalars of one unknown field `v`, with `b / a > 0`:
/// it fixes `|v| = sqrt(b / a)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldNorm {
    /// Index of the field among the declared unknowns.
    pub field: usize,
    /// The equation's index in `F`.
    pub equation: usize,
    /// The norm it fixes.
    pub norm: f64,
}

/// The parameter-free equations of `inst` that fix the norm of one whole unknown field (the
/// first such equation per field).
pub fn norms(decl: &Declaration, inst: &Instance) -> Vec<FieldNorm> {
    let mut first = 0u32;
    let mut out = Vec::new();
    for (field, f) in decl.unknowns.iter().enumerate() {
        let len = f.shape.scalar_count() as u32;
        let range = first..first + len;
        first += len;
        if let Some((equation, norm)) =
            parameter_free(inst).into_iter().find_map(|e| norm_of(&inst.equations[e], range.clone()).map(|n| (e, n)))
        {
            out.push(FieldNorm { field, equation, norm });
        }
    }
    out
}

/// `sqrt(b / a)` when `f` is `a (sum of v^2 over range) - b` with `b / a > 0`.
fn norm_of(f: &Poly, range: std::ops::Range<u32>) -> Option<f64> {
    let mut square = None;
    let mut constant = 0.0;
    let mut seen = 0usize;
    for (m, &c) in &f.terms {
        match m.0.as_slice() {
            [] => constant = c,
            &[(v, 2)] if range.contains(&v) => {
                // Every square must have the same coefficient.
                if *square.get_or_insert(c) != c {
                    return None;
                }
                seen += 1;
            }
            _ => return None,
        }
    }
    let a = square?;
    let ratio = -constant / a;
    (seen == range.len() && ratio > 0.0 && ratio.is_finite() && f.terms.contains_key(&Monomial::one())).then(|| ratio.sqrt())
}

#[cfg(test)]
mod tests {
    use super::norm_of;
    use crate::poly::Poly;

    fn sum_of_squares(vars: std::ops::Range<u32>, a: f64) -> Poly {
        let mut p = Poly::zero();
        for v in vars {
            p = &p + &(&Poly::var(v) * &(&Poly::var(v) * &Poly::constant(a)));
        }
        p
    }

    #[test]
    fn a_sum_of_squares_minus_a_constant_fixes_a_norm() {
        let unit = &sum_of_squares(4..7, 1.0) - &Poly::constant(1.0);
        assert_eq!(norm_of(&unit, 4..7), Some(1.0));
        let scaled = &sum_of_squares(0..4, 2.0) - &Poly::constant(8.0);
        assert_eq!(norm_of(&scaled, 0..4), Some(2.0));
        // Not the whole field, another field, a positive constant, a cross term.
        assert_eq!(norm_of(&unit, 4..8), None);
        assert_eq!(norm_of(&unit, 0..3), None);
        assert_eq!(norm_of(&(&sum_of_squares(4..7, 1.0) + &Poly::constant(1.0)), 4..7), None);
        let cross = &unit + &(&Poly::var(4) * &Poly::var(5));
        assert_eq!(norm_of(&cross, 4..7), None);
        assert_eq!(norm_of(&sum_of_squares(4..7, 1.0), 4..7), None);
    }
}
