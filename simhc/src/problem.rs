//! Traits of a compiled polynomial system `F(x; p) = 0`.
//!
//! `#[simhc_problem]` implements [`Problem`] and [`ParamDerivative`] for each instantiated row
//! count with straight-line code; hand-written systems (tests, experiments) implement them too.
//! Sizes are const generics so every buffer is a fixed-size nalgebra type on the stack:
//! `NX` unknowns, `NF` equations (`NF >= NX`), `NP` parameters.

use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// Static description of a problem instance.
pub trait ProblemInfo {
    /// Human-readable name, e.g. `"grps8"`.
    const NAME: &'static str;
    /// Names of the unknown scalars in vector order, e.g. `["q[0]", ..., "s"]`.
    const UNKNOWN_NAMES: &'static [&'static str];
    /// Names of the parameters in vector order, e.g. `["row0.f[0]", ...]`.
    const PARAM_NAMES: &'static [&'static str];
}

/// Residual and Jacobian of `F(x; p)` with respect to the unknowns `x`.
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a compiled instance with NX = {NX} unknowns, NF = {NF} equations and NP = {NP} parameters",
    label = "sizes differ from this instance's",
    note = "the sizes of a `#[simhc_problem]` instance are in its docs and in `Foo::NX`, `Foo::NF`, `Foo::NP`"
)]
pub trait Problem<const NX: usize, const NF: usize, const NP: usize>: ProblemInfo {
    /// `F(x; p)`.
    fn residual<S: Scalar>(x: &SVector<S, NX>, p: &SVector<S, NP>, f: &mut SVector<S, NF>);
    /// `dF/dx (x; p)`.
    fn jacobian<S: Scalar>(x: &SVector<S, NX>, p: &SVector<S, NP>, j: &mut SMatrix<S, NF, NX>);
    /// Both at once, sharing common subexpressions.
    fn residual_jacobian<S: Scalar>(x: &SVector<S, NX>, p: &SVector<S, NP>, f: &mut SVector<S, NF>, j: &mut SMatrix<S, NF, NX>);
}

/// Derivatives of `F(x; p)` with respect to the parameters `p`, for parameter homotopies
/// (`dH/dt = dF/dp * (p1 - p0)`) and for the generic minimum-norm simulator.
pub trait ParamDerivative<const NX: usize, const NF: usize, const NP: usize>: Problem<NX, NF, NP> {
    /// `dF/dp (x; p)`, dense.
    fn param_jacobian<S: Scalar>(x: &SVector<S, NX>, p: &SVector<S, NP>, jp: &mut SMatrix<S, NF, NP>);
    /// `dF/dp (x; p) * dp` without forming the matrix.
    fn param_directional<S: Scalar>(x: &SVector<S, NX>, p: &SVector<S, NP>, dp: &SVector<S, NP>, out: &mut SVector<S, NF>);
}

/// Where [`CoefficientForm::lanes_row_params`] finds its inputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamRowLayout {
    /// Parameters of one row: row `r`'s are `p[r * row_len ..][..row_len]`.
    pub row_len: usize,
    /// Inputs of the row kernel: the row's `row_len` parameters, then the
    /// `inputs - row_len` global parameters (stored after all rows).
    pub inputs: usize,
    /// Entries of the shared part ([`CoefficientForm::lanes_params_shared`]).
    pub shared: usize,
    /// Whether solvergen estimates this kernel cheaper than the coefficient form's
    /// ([`CoefficientForm::lanes_row`] plus the Horner pass for the coefficients): operation
    /// counts of the two, written in the generated docs of `PARAM_LANES`. A declaration that
    /// keeps structure (GRPS: `rotation(q)` times vectors) favours the parameters; one written
    /// out as a long polynomial may favour the coefficients.
    pub preferred: bool,
}

/// The system written as linear in a vector of `NC` coefficients that depend on the parameters
/// only: `F(x; p) = Fc(x; c(p))` with `Fc` affine in `c`.
///
/// The paper's straight-line homotopy `(1-t) F(x; p0) + t F(x; p1)` is then
/// `Fc(x; c0 + t (c1 - c0))`: one evaluation per step instead of two, and the coefficients are
/// computed once per path ([`crate::homotopy::CoefficientLine`]).
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a compiled instance with NX = {NX} unknowns, NF = {NF} equations, NP = {NP} parameters and NC = {NC} coefficients",
    label = "sizes differ from this instance's",
    note = "the sizes of a `#[simhc_problem]` instance are in its docs and in `Foo::NX`, `Foo::NF`, `Foo::NP`, `Foo::NC`"
)]
pub trait CoefficientForm<const NX: usize, const NF: usize, const NP: usize, const NC: usize>: Problem<NX, NF, NP> {
    /// `c(p)`.
    fn coefficients<S: Scalar>(p: &SVector<S, NP>, c: &mut SVector<S, NC>);
    /// `Fc(x; c)` and `dFc/dx (x; c)`.
    fn residual_jacobian_coeffs<S: Scalar>(x: &SVector<S, NX>, c: &SVector<S, NC>, f: &mut SVector<S, NF>, j: &mut SMatrix<S, NF, NX>);
    /// `Fc(x; c)`.
    fn residual_coeffs<S: Scalar>(x: &SVector<S, NX>, c: &SVector<S, NC>, f: &mut SVector<S, NF>);
    /// The part of `Fc` linear in the coefficients, evaluated at `dc`: `dFc/dc (x) * dc`, which
    /// is `dH/dt` of the coefficient line with `dc = c1 - c0`.
    fn coefficient_part<S: Scalar>(x: &SVector<S, NX>, dc: &SVector<S, NC>, out: &mut SVector<S, NF>);

    /// `Some((rows, per_row))` when [`CoefficientForm::coefficient_part_poly`] is available:
    /// the coefficients are `rows` blocks of `per_row` (row `r`'s at `r * per_row ..`) evaluated
    /// by a row kernel ([`crate::lanes`]), and the global equations have no coefficients.
    const ROW_LAYOUT: Option<(usize, usize)> = None;

    /// [`CoefficientForm::coefficient_part`] at `dc(t) = sum_k t^k dc_k`, with the polynomial
    /// given in row-lane layout: with `chunks = ceil(rows / LANES)`, entry
    /// `(k * chunks + chunk) * per_row + m` holds coefficient `m` of rows
    /// `chunk * LANES ..` (one per lane) at degree `k`; `poly.len()` is a multiple of
    /// `chunks * per_row`. The row kernels then take `dc(t)` straight from the lanes (no
    /// gathering, Horner in `t` vectorized). Only for `ROW_LAYOUT = Some(..)`; the default (and
    /// a `poly` of the wrong length) writes NaN.
    fn coefficient_part_poly<S: Scalar>(x: &SVector<S, NX>, t: f64, poly: &[S::Lanes], out: &mut SVector<S, NF>) {
        let _ = (x, t, poly);
        out.fill(S::from_real(f64::NAN));
    }

    /// `Some(equations per row)` when the path-lane functions [`CoefficientForm::lanes_row`]
    /// and [`CoefficientForm::lanes_globals`] are generated (with [`CoefficientForm::ROW_LAYOUT`]
    /// `Some((rows, per_row))`): then the equations are `rows` blocks of `epr` row equations
    /// followed by `NF - rows * epr` global equations without coefficients.
    ///
    /// Path lanes put one *path* (its own unknowns and coefficients) in each lane, so that
    /// [`crate::tracker::batch`] tracks as many paths at once as the lane type `L` has lanes.
    const PATH_LANES: Option<usize> = None;

    /// Row equations of one row, one path per lane of `L`: from the unknowns `x`, the row's
    /// coefficients `c` and coefficient derivatives `dc` (`per_row` each), the residuals `f`
    /// (`epr`), Jacobian rows `j` (`epr * NX`, row-major) and the coefficient part at `dc`,
    /// `d` (`epr`: `dH/dt` for `dc = dc/dt`). Wrong lengths leave the outputs untouched. The
    /// default does nothing.
    #[inline(always)]
    fn lanes_row<L: crate::lanes::Lanes>(x: &[L; NX], c: &[L], dc: &[L], f: &mut [L], j: &mut [L], d: &mut [L]) {
        let _ = (x, c, dc, f, j, d);
    }

    /// `Some(layout)` when [`CoefficientForm::lanes_row_params`] is generated (with
    /// [`CoefficientForm::PATH_LANES`]).
    const PARAM_LANES: Option<ParamRowLayout> = None;

    /// The part of [`CoefficientForm::lanes_row_params`] that depends on the unknowns alone, the
    /// same for every row (GRPS: `rotation(q)`), into `out` (`shared` entries of
    /// [`ParamRowLayout`]): computed once per evaluation instead of once per row. Wrong lengths
    /// leave `out` untouched. The default does nothing.
    #[inline(always)]
    fn lanes_params_shared<L: crate::lanes::Lanes>(x: &[L; NX], out: &mut [L]) {
        let _ = (x, out);
    }

    /// [`CoefficientForm::lanes_row`] from the row's *parameters* instead of its coefficients:
    /// from the unknowns `x`, their shared part ([`CoefficientForm::lanes_params_shared`]), the
    /// row's `inputs` parameters `p` (its own, then the globals) and a direction `dp` of them,
    /// the residuals `f`, Jacobian rows `j` and `dF/dp * dp` in `d` (`dH/dt` for
    /// `dp = dp/dt`). Generated from the declaration without expanding it (reverse mode for `j`,
    /// forward mode for `d`), so it keeps the structure the coefficient form multiplies out.
    /// Wrong lengths leave the outputs untouched. The default does nothing.
    #[inline(always)]
    fn lanes_row_params<L: crate::lanes::Lanes>(x: &[L; NX], shared: &[L], p: &[L], dp: &[L], f: &mut [L], j: &mut [L], d: &mut [L]) {
        let _ = (x, shared, p, dp, f, j, d);
    }

    /// The global equations' residuals `f` (`NF - rows * epr`) and Jacobian rows `j`
    /// (row-major), one path per lane of `L`. The default does nothing.
    #[inline(always)]
    fn lanes_globals<L: crate::lanes::Lanes>(x: &[L; NX], f: &mut [L], j: &mut [L]) {
        let _ = (x, f, j);
    }
}
