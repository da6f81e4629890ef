//! `#[simhc_problem]`: declare a polynomial system symbolically, get straight-line residual,
//! Jacobian, parameter-derivative and simulator code. All logic lives in
//! [`solvergen::expand`]; this crate only converts token streams. See the workspace README for
//! the declaration language.

use proc_macro::TokenStream;

/// Compiles an inline module that declares unknowns, parameters and equations.
#[proc_macro_attribute]
pub fn simhc_problem(attr: TokenStream, item: TokenStream) -> TokenStream {
    solvergen::expand(attr.into(), item.into()).into()
}

/// On `impl simhc::solver::DeclaredProblem for YourProblem { type Tracked = ..; type Data = ..; .. }`:
/// fills in the trait's sizes from the two instances, so the impl writes no number; on
/// `impl simhc::solver::Scenes for YourProblem { .. }`, the same sizes.
#[proc_macro_attribute]
pub fn declared_problem(attr: TokenStream, item: TokenStream) -> TokenStream {
    solvergen::registration::expand(attr.into(), item.into()).into()
}
