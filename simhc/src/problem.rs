//! Traits of a compiled polynomial system `F(x; p) = 0`.
//!
//! `#[simhc_problem]` implements [`Problem`] and [`ParamDerivative`] for each instantiated row
//! count with straight-line code; hand-written systems (tests, experiments) implement them too.
//! Sizes are const generics so every buffer is a fixed-size nalgebra type on the stack:
//! `NX` unknowns, `NF` equations (`NF >= NX`), `NP` parameters.

use crate::{Ring, Scalar};
use nalgebra::{SMatrix, SVector};

/// The sizes of a compiled instance: `NX` unknowns and `NP` parameters. `#[simhc_problem]`
/// implements it for every instance, so a bound such as `Data: InstanceSizes<NX, ND>` checks
/// the sizes a user writes at compile time, on the user's tokens.
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not an instance with {NX} unknowns and {NP} parameters",
    label = "this instance has other sizes",
    note = "`#[simhc_problem]` gives every instance its sizes as constants: write `Foo7::NX` and `Foo7::NP` instead of numbers"
)]
pub trait InstanceSizes<const NX: usize, const NP: usize> {}

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
    ///
    /// Generic over a [`Ring`], not a field: the straight-line code only adds, subtracts,
    /// multiplies and embeds real constants, so it runs over intervals too
    /// ([`crate::certify`]).
    fn residual<S: Ring>(x: &SVector<S, NX>, p: &SVector<S, NP>, f: &mut SVector<S, NF>);
    /// `dF/dx (x; p)`, over a [`Ring`] as [`Problem::residual`].
    fn jacobian<S: Ring>(x: &SVector<S, NX>, p: &SVector<S, NP>, j: &mut SMatrix<S, NF, NX>);
    /// Both at once, sharing common subexpressions.
    fn residual_jacobian<S: Ring>(x: &SVector<S, NX>, p: &SVector<S, NP>, f: &mut SVector<S, NF>, j: &mut SMatrix<S, NF, NX>);
}

/// Derivatives of `F(x; p)` with respect to the parameters `p`, for parameter homotopies
/// (`dH/dt = dF/dp * (p1 - p0)`) and for the generic minimum-norm simulator.
pub trait ParamDerivative<const NX: usize, const NF: usize, const NP: usize>: Problem<NX, NF, NP> {
    /// `dF/dp (x; p)`, dense.
    fn param_jacobian<S: Scalar>(x: &SVector<S, NX>, p: &SVector<S, NP>, jp: &mut SMatrix<S, NF, NP>);
    /// `dF/dp (x; p) * dp` without forming the matrix.
    fn param_directional<S: Scalar>(x: &SVector<S, NX>, p: &SVector<S, NP>, dp: &SVector<S, NP>, out: &mut SVector<S, NF>);
}

/// The system written as linear in a vector of `NC` coefficients that depend on the parameters
/// only: `F(x; p) = Fc(x; c(p))` with `Fc` affine in `c`.
///
/// The paper's straight-line homotopy `(1-t) F(x; p0) + t F(x; p1)` is then
/// `Fc(x; c0 + t (c1 - c0))`: one evaluation per step instead of two, and the coefficients are
/// computed once per path ([`crate::homotopy::CoefficientLine`]).
///
/// Where the declaration has rows, `#[simhc_problem]` also generates vectorized kernels, one
/// capability trait each: [`RowLanes`], [`PathLanes`] and [`ParamLanes`]. An instance names
/// them in the associated types and gives a value of each in the associated constants, `Some`
/// exactly where the kernel was generated; otherwise the type is [`NoLanes`], which has no
/// value, so an absent kernel cannot be called.
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

    /// The row-lane kernel ([`RowLanes`]), or [`NoLanes`].
    type RowLanes: RowLanes<NX, NF>;
    /// `Some` when the coefficients are row blocks evaluated by a row kernel.
    const ROW_LANES: Option<Self::RowLanes>;
    /// The path-lane kernels ([`PathLanes`]), or [`NoLanes`].
    type PathLanes: PathLanes<NX, NF>;
    /// `Some` when the path-lane kernels are generated.
    const PATH_LANES: Option<Self::PathLanes>;
    /// The parameter row kernels ([`ParamLanes`]), or [`NoLanes`].
    type ParamLanes: ParamLanes<NX, NF>;
    /// `Some` when the parameter row kernels are generated.
    const PARAM_LANES: Option<Self::ParamLanes>;
}

/// How the coefficients of a [`RowLanes`] instance are laid out: `rows` blocks of `per_row`
/// (row `r`'s at `r * per_row ..`); the global equations have no coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowLayout {
    /// Rows of the instance.
    pub rows: usize,
    /// Coefficients per row.
    pub per_row: usize,
}

/// The coefficient part evaluated by a row kernel, `LANES` rows at a time ([`crate::lanes`]).
///
/// A value of the implementing type is the proof that the instance has the kernel; see
/// [`CoefficientForm::ROW_LANES`].
pub trait RowLanes<const NX: usize, const NF: usize>: Copy {
    /// The coefficients' row blocks.
    fn layout(self) -> RowLayout;

    /// [`CoefficientForm::coefficient_part`] at `dc(t) = sum_k t^k dc_k`, with the polynomial
    /// given in row-lane layout: with `chunks = ceil(rows / LANES)`, entry
    /// `(k * chunks + chunk) * per_row + m` holds coefficient `m` of rows
    /// `chunk * LANES ..` (one per lane) at degree `k`; `poly.len()` is a multiple of
    /// `chunks * per_row`. The row kernels then take `dc(t)` straight from the lanes (no
    /// gathering, Horner in `t` vectorized). A `poly` of another length writes NaN.
    fn coefficient_part_poly<S: Scalar>(self, x: &SVector<S, NX>, t: f64, poly: &[S::Lanes], out: &mut SVector<S, NF>);
}

/// Path lanes put one *path* (its own unknowns and coefficients) in each lane, so that
/// [`crate::tracker::batch`] tracks as many paths at once as the lane type `L` has lanes. The
/// equations are `rows` blocks of [`PathLanes::equations_per_row`] row equations followed by
/// `NF - rows * epr` global equations without coefficients.
///
/// The slices have the lengths given below; a kernel given other lengths leaves its outputs
/// untouched (and is a bug of the caller, caught by a debug assertion).
pub trait PathLanes<const NX: usize, const NF: usize>: RowLanes<NX, NF> {
    /// Equations per row, `epr`.
    fn equations_per_row(self) -> usize;

    /// Row equations of one row, one path per lane of `L`: from the unknowns `x`, the row's
    /// coefficients `c` and coefficient derivatives `dc` (`per_row` each), the residuals `f`
    /// (`epr`), Jacobian rows `j` (`epr * NX`, row-major) and the coefficient part at `dc`,
    /// `d` (`epr`: `dH/dt` for `dc = dc/dt`).
    fn row<L: crate::lanes::Lanes>(self, x: &[L; NX], c: &[L], dc: &[L], f: &mut [L], j: &mut [L], d: &mut [L]);

    /// The global equations' residuals `f` (`NF - rows * epr`) and Jacobian rows `j`
    /// (row-major), one path per lane of `L`.
    fn globals<L: crate::lanes::Lanes>(self, x: &[L; NX], f: &mut [L], j: &mut [L]);
}

/// Where [`ParamLanes::row_params`] finds its inputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamRowLayout {
    /// Parameters of one row: row `r`'s are `p[r * row_len ..][..row_len]`.
    pub row_len: usize,
    /// Inputs of the row kernel: the row's `row_len` parameters, then the
    /// `inputs - row_len` global parameters (stored after all rows).
    pub inputs: usize,
    /// Entries of the shared part ([`ParamLanes::shared`]).
    pub shared: usize,
    /// Whether solvergen estimates this kernel cheaper than the coefficient form's
    /// ([`PathLanes::row`] plus the Horner pass for the coefficients): operation counts of the
    /// two, written in the generated docs of the `ParamLanes` impl. A declaration that keeps
    /// structure (GRPS: `rotation(q)` times vectors) favours the parameters; one written out as
    /// a long polynomial may favour the coefficients.
    pub preferred: bool,
}

/// [`PathLanes::row`] from each row's *parameters* instead of its coefficients. Generated from
/// the declaration without expanding it (reverse mode for `j`, forward mode for `d`), so it
/// keeps the structure the coefficient form multiplies out.
pub trait ParamLanes<const NX: usize, const NF: usize>: PathLanes<NX, NF> {
    /// Where the row kernel finds its inputs.
    fn param_layout(self) -> ParamRowLayout;

    /// The part of [`ParamLanes::row_params`] that depends on the unknowns alone, the same for
    /// every row (GRPS: `rotation(q)`), into `out` (`shared` entries of [`ParamRowLayout`]):
    /// computed once per evaluation instead of once per row.
    fn shared<L: crate::lanes::Lanes>(self, x: &[L; NX], out: &mut [L]);

    /// From the unknowns `x`, their shared part ([`ParamLanes::shared`]), the row's `inputs`
    /// parameters `p` (its own, then the globals) and a direction `dp` of them, the residuals
    /// `f`, Jacobian rows `j` and `dF/dp * dp` in `d` (`dH/dt` for `dp = dp/dt`).
    fn row_params<L: crate::lanes::Lanes>(self, x: &[L; NX], shared: &[L], p: &[L], dp: &[L], f: &mut [L], j: &mut [L], d: &mut [L]);

    /// One row's equations `f` (`epr`) and their Jacobian rows `j` (`epr * NX`, row-major) at
    /// `x`, in `f64`, from the row's `inputs` parameters `p` (its own, then the globals): the
    /// shared part and the row kernel in one call, with buffers sized by the generator. The
    /// robust estimator's per-correspondence kernel (one row, not the whole system with the row
    /// in every slot). Slices of other lengths: `false`, outputs untouched.
    fn row_equations(self, x: &[f64; NX], p: &[f64], f: &mut [f64], j: &mut [f64]) -> bool;
}

/// The lane kernels of an instance that has none: a type without values, so that
/// [`CoefficientForm::ROW_LANES`] (and the others) can only be `None` and its methods are
/// never called.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoLanes {}

impl<const NX: usize, const NF: usize> RowLanes<NX, NF> for NoLanes {
    fn layout(self) -> RowLayout {
        match self {}
    }
    fn coefficient_part_poly<S: Scalar>(self, _: &SVector<S, NX>, _: f64, _: &[S::Lanes], _: &mut SVector<S, NF>) {
        match self {}
    }
}

impl<const NX: usize, const NF: usize> PathLanes<NX, NF> for NoLanes {
    fn equations_per_row(self) -> usize {
        match self {}
    }
    fn row<L: crate::lanes::Lanes>(self, _: &[L; NX], _: &[L], _: &[L], _: &mut [L], _: &mut [L], _: &mut [L]) {
        match self {}
    }
    fn globals<L: crate::lanes::Lanes>(self, _: &[L; NX], _: &mut [L], _: &mut [L]) {
        match self {}
    }
}

impl<const NX: usize, const NF: usize> ParamLanes<NX, NF> for NoLanes {
    fn param_layout(self) -> ParamRowLayout {
        match self {}
    }
    fn shared<L: crate::lanes::Lanes>(self, _: &[L; NX], _: &mut [L]) {
        match self {}
    }
    fn row_params<L: crate::lanes::Lanes>(self, _: &[L; NX], _: &[L], _: &[L], _: &[L], _: &mut [L], _: &mut [L], _: &mut [L]) {
        match self {}
    }
    fn row_equations(self, _: &[f64; NX], _: &[f64], _: &mut [f64], _: &mut [f64]) -> bool {
        match self {}
    }
}
