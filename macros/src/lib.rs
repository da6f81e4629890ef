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
