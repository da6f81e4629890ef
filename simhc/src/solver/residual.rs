//! A row's equations and the default per-correspondence error ([`row_residual`]): what a
//! problem's [`super::DeclaredProblem::row_error`] defaults to and the robust estimator
//! differentiates. Imports none of the solver's modules.

use crate::{CoefficientForm, ParamLanes, ProblemLayout};
use nalgebra::{SMatrix, SVector};

/// The equations of one row (`row`: its numbers, `globals`: the global numbers) at `x` and
/// their Jacobian rows, into the first `equations_per_row` entries of `f` and rows of `j`; that
/// count, or `None` for rows or globals of the wrong length.
///
/// The instance's compiled one-row kernel ([`ParamLanes::row_equations`]) where it has one:
/// the cost of one row. Otherwise the whole system with the row written into every row slot
/// (its first row's equations are the row's).
pub(super) fn row_equations<Q, const NX: usize, const NF: usize, const NP: usize, const NC: usize>(
    x: &SVector<f64, NX>,
    row: &[f64],
    globals: &[f64],
    f: &mut SVector<f64, NF>,
    j: &mut SMatrix<f64, NF, NX>,
) -> Option<usize>
where
    Q: CoefficientForm<NX, NF, NP, NC> + ProblemLayout,
{
    let layout = Q::LAYOUT;
    let (per_row, epr) = (layout.per_row, layout.equations_per_row);
    if row.len() != per_row || globals.len() != layout.globals_len() || layout.rows == 0 {
        return None;
    }
    let mut p = SVector::<f64, NP>::zeros();
    if let Some(kernel) = Q::PARAM_LANES {
        let inputs = per_row + globals.len();
        p.as_mut_slice()[..per_row].copy_from_slice(row);
        p.as_mut_slice()[per_row..inputs].copy_from_slice(globals);
        let (mut fr, mut jr) = ([0.0; NF], [[0.0; NX]; NF]);
        let xa: [f64; NX] = (*x).into();
        if kernel.row_equations(&xa, &p.as_slice()[..inputs], &mut fr[..epr], jr[..epr].as_flattened_mut()) {
            for e in 0..epr {
                f[e] = fr[e];
                j.row_mut(e).copy_from_slice(&jr[e]);
            }
            return Some(epr);
        }
    }
    for r in 0..layout.rows {
        p.as_mut_slice()[r * per_row..(r + 1) * per_row].copy_from_slice(row);
    }
    p.as_mut_slice()[layout.rows * per_row..].copy_from_slice(globals);
    Q::residual_jacobian(x, &p, f, j);
    Some(epr)
}

/// The default per-correspondence error: the largest absolute residual of the row's equations
/// at `x` (the problem's algebraic units); infinite for a row of the wrong length or a
/// non-finite residual.
pub fn row_residual<Q, const NX: usize, const NF: usize, const NP: usize, const NC: usize>(
    x: &SVector<f64, NX>,
    row: &[f64],
    globals: &[f64],
) -> f64
where
    Q: CoefficientForm<NX, NF, NP, NC> + ProblemLayout,
{
    let (mut f, mut j) = (SVector::<f64, NF>::zeros(), SMatrix::<f64, NF, NX>::zeros());
    match row_equations::<Q, NX, NF, NP, NC>(x, row, globals, &mut f, &mut j) {
        Some(epr) => largest(&f, epr),
        None => f64::INFINITY,
    }
}

/// The largest absolute value of the first `epr` entries of `f`; infinite when one is NaN.
fn largest<const NF: usize>(f: &SVector<f64, NF>, epr: usize) -> f64 {
    let e = f.iter().take(epr).fold(0.0f64, |m, v| m.max(v.abs()));
    if e.is_nan() {
        f64::INFINITY
    } else {
        e
    }
}
