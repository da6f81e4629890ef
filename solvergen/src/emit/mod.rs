//! Emission: straight-line Rust for a lowered declaration. Emission does not lower: the
//! instances, their coefficient forms and the one-row lowerings arrive in [`crate::Lowered`],
//! made once; emission builds the DAGs of the functions (derivatives included) and renders them.
//!
//! Each trait method gets its own DAG (so the fused residual+Jacobian shares subexpressions
//! between the two), emitted as one `let` per live node in topological order. The code is
//! generic over `S: simhc::Ring` (residual and Jacobian) or `S: simhc::Scalar`, uses fixed-size nalgebra types, and cannot panic: all
//! indices are constants within the fixed sizes.
//!
//! - `render`: a DAG as `let` statements and output assignments (every body goes through it).
//! - `data_structs`: the `Unknowns` / `Row` / `Globals` structs and their field layouts.
//! - `instance`: the type and trait impls of one instance.
//! - `row_kernels`: the lane kernels of a problem with rows (parameter and coefficient form).
//! - `param_kernel`: the path-lane row kernel from the row's unexpanded parameters.

mod data_structs;
mod instance;
mod param_kernel;
mod render;
mod row_kernels;

use crate::decl::Declaration;
use crate::Lowered;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// `snake_case` to `CamelCase`.
pub fn camel(name: &str) -> String {
    name.split('_')
        .filter(|s| !s.is_empty())
        .map(|s| {
            let mut c = s.chars();
            match c.next() {
                Some(f) => f.to_uppercase().chain(c).collect::<String>(),
                None => String::new(),
            }
        })
        .collect()
}

/// An index or size as an unsuffixed literal (`3`, not `3usize`).
fn n(v: usize) -> Literal {
    Literal::usize_unsuffixed(v)
}

/// The names the expansion defines in the module: the instances, their size aliases and the
/// module's own (a passthrough item of the same name is an error).
pub fn emitted_names(decl: &Declaration) -> Vec<String> {
    let base = camel(&decl.module.ident.to_string());
    let mut names: Vec<String> = ["NX", "UnknownVector", "CanonicalFrame", "Refinement", "Unknowns", "Row", "Globals", "__SimhcRowKernels"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let suffixes: Vec<String> =
        if decl.row_fields.is_empty() { vec![String::new()] } else { decl.rows.iter().map(|(r, _)| r.to_string()).collect() };
    for s in suffixes {
        names.extend([format!("{base}{s}"), format!("Params{s}"), format!("AllRoots{s}"), format!("SquareSubsystem{s}")]);
    }
    names
}

/// The whole generated module: the passthrough items, the plain-data structs, the row kernels
/// shared by the instances and the items of every instance.
pub fn module(decl: &Declaration, lowered: &Lowered) -> TokenStream {
    let m = &decl.module;
    let attrs = &m.attrs;
    let vis = &m.vis;
    let ident = &m.ident;
    let passthrough = &decl.passthrough;
    let unknowns = data_structs::data_struct(&format_ident!("Unknowns"), " The unknowns of the problem.", &decl.unknowns);
    let rows = if decl.row_fields.is_empty() {
        quote!()
    } else {
        data_structs::data_struct(&format_ident!("Row"), " Parameters of one correspondence (row).", &decl.row_fields)
    };
    let globals = if decl.globals.is_empty() {
        quote!()
    } else {
        data_structs::data_struct(&format_ident!("Globals"), " Parameters shared by all rows.", &decl.globals)
    };
    // Row kernels depend on the declaration only: emitted once for all instances.
    let mut kernels: Vec<TokenStream> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let impls: Vec<TokenStream> = lowered
        .instances
        .iter()
        .map(|expanded| {
            let items = instance::instance(decl, lowered, expanded);
            for kernel in items.kernels {
                if seen.insert(kernel.to_string()) {
                    kernels.push(kernel);
                }
            }
            items.items
        })
        .collect();
    let kernels = if kernels.is_empty() {
        quote!()
    } else {
        quote! {
            /// Row kernels shared by the instances (see `simhc::lanes`).
            #[doc(hidden)]
            #[derive(Debug, Clone, Copy)]
            pub struct __SimhcRowKernels;
            #[allow(dead_code)]
            impl __SimhcRowKernels {
                #(#kernels)*
            }
        }
    };
    let nx = n(decl.unknowns.iter().map(|f| f.shape.scalar_count()).sum());
    let sizes = quote! {
        /// Number of unknown scalars (every instance's `NX`).
        pub const NX: usize = #nx;
        /// The unknowns as a vector, in layout order.
        pub type UnknownVector = ::simhc::__private::nalgebra::SVector<f64, NX>;
        /// A canonical frame of this problem's unknowns (`simhc::solver::CanonicalFrame`).
        pub type CanonicalFrame = ::simhc::solver::CanonicalFrame<NX>;
        /// What a refinement on all rows did (`simhc::solver::Refinement`).
        pub type Refinement = ::simhc::solver::Refinement<NX>;
    };
    quote! {
        #(#attrs)*
        #vis mod #ident {
            #(#passthrough)*
            #sizes
            #unknowns
            #rows
            #globals
            #kernels
            #(#impls)*
        }
    }
}
