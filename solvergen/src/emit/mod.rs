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

/// The names of the module's own items, whatever the declaration. [`module`] defines its items
/// by these names and [`emitted_names`] reserves them, so that the check cannot miss one.
pub(crate) struct ModuleNames {
    /// The unknown count.
    pub nx: &'static str,
    /// The unknowns as a vector.
    pub unknown_vector: &'static str,
    /// `simhc::solver::CanonicalFrame` with the problem's sizes.
    pub canonical_frame: &'static str,
    /// `simhc::solver::Refinement` with the problem's sizes.
    pub refinement: &'static str,
    /// The unknowns' struct.
    pub unknowns: &'static str,
    /// One row's struct (a declaration with rows).
    pub row: &'static str,
    /// The globals' struct (a declaration with globals).
    pub globals: &'static str,
    /// The row kernels shared by the instances (two or more rows).
    pub row_kernels: &'static str,
}

pub(crate) const MODULE_NAMES: ModuleNames = ModuleNames {
    nx: "NX",
    unknown_vector: "UnknownVector",
    canonical_frame: "CanonicalFrame",
    refinement: "Refinement",
    unknowns: "Unknowns",
    row: "Row",
    globals: "Globals",
    row_kernels: "__SimhcRowKernels",
};

impl ModuleNames {
    /// Every name, the ones a declaration does not use included.
    fn all(&self) -> [&'static str; 8] {
        // Destructured without `..`: a new name is a compile error here until it is listed.
        let ModuleNames { nx, unknown_vector, canonical_frame, refinement, unknowns, row, globals, row_kernels } = *self;
        [nx, unknown_vector, canonical_frame, refinement, unknowns, row, globals, row_kernels]
    }
}

/// The names of one instance's items (its unit type and its size aliases): what
/// `instance::instance` defines and [`emitted_names`] reserves.
pub(crate) struct InstanceNames {
    /// The unit type (`Grp7`; without rows, the module's name in `CamelCase`).
    pub instance: String,
    /// The parameter vector (`Params7`).
    pub params: String,
    /// The all-roots fallback's trait object (`AllRoots7`).
    pub all_roots: String,
    /// The start-system subsystem, emitted for a square instance only (`SquareSubsystem7`).
    pub square_subsystem: String,
}

impl InstanceNames {
    /// Every name, the ones an instance does not define included.
    fn all(self) -> [String; 4] {
        // Destructured without `..`: a new name is a compile error here until it is listed.
        let InstanceNames { instance, params, all_roots, square_subsystem } = self;
        [instance, params, all_roots, square_subsystem]
    }
}

/// The names of the instance of `rows` rows: suffixed by the row count (`Grp7`, `Params7`),
/// without a suffix for a declaration without rows (`rows` then is 0 and not written).
pub(crate) fn instance_names(decl: &Declaration, rows: usize) -> InstanceNames {
    let suffix = if decl.row_fields.is_empty() { String::new() } else { rows.to_string() };
    InstanceNames {
        instance: format!("{}{suffix}", camel(&decl.module.ident.to_string())),
        params: format!("Params{suffix}"),
        all_roots: format!("AllRoots{suffix}"),
        square_subsystem: format!("SquareSubsystem{suffix}"),
    }
}

/// The names the expansion defines in the module: the instances, their size aliases and the
/// module's own (a passthrough item of the same name is an error).
pub fn emitted_names(decl: &Declaration) -> Vec<String> {
    let mut names: Vec<String> = MODULE_NAMES.all().iter().map(|s| s.to_string()).collect();
    // The row counts of the instances, as `crate::Lowered::new` makes them.
    let counts: Vec<usize> = if decl.row_fields.is_empty() { vec![0] } else { decl.rows.iter().map(|&(r, _)| r).collect() };
    for rows in counts {
        names.extend(instance_names(decl, rows).all());
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
    let names = &MODULE_NAMES;
    let unknowns = data_structs::data_struct(&format_ident!("{}", names.unknowns), " The unknowns of the problem.", &decl.unknowns);
    let rows = if decl.row_fields.is_empty() {
        quote!()
    } else {
        data_structs::data_struct(&format_ident!("{}", names.row), " Parameters of one correspondence (row).", &decl.row_fields)
    };
    let globals = if decl.globals.is_empty() {
        quote!()
    } else {
        data_structs::data_struct(&format_ident!("{}", names.globals), " Parameters shared by all rows.", &decl.globals)
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
    // The definitions below take their names from `MODULE_NAMES`; the code that only refers to
    // them (`&Unknowns`, `__SimhcRowKernels::__row_residual`) writes them out, and a mismatch
    // does not compile (every snapshot and `generated/` file is compiled).
    let kernels = if kernels.is_empty() {
        quote!()
    } else {
        let row_kernels = format_ident!("{}", names.row_kernels);
        quote! {
            /// Row kernels shared by the instances (see `simhc::lanes`).
            #[doc(hidden)]
            #[derive(Debug, Clone, Copy)]
            pub struct #row_kernels;
            #[allow(dead_code)]
            impl #row_kernels {
                #(#kernels)*
            }
        }
    };
    let nx = n(decl.unknowns.iter().map(|f| f.shape.scalar_count()).sum());
    let (nx_name, unknown_vector, canonical_frame, refinement) = (
        format_ident!("{}", names.nx),
        format_ident!("{}", names.unknown_vector),
        format_ident!("{}", names.canonical_frame),
        format_ident!("{}", names.refinement),
    );
    let sizes = quote! {
        /// Number of unknown scalars (every instance's `NX`).
        pub const #nx_name: usize = #nx;
        /// The unknowns as a vector, in layout order.
        pub type #unknown_vector = ::simhc::__private::nalgebra::SVector<f64, #nx_name>;
        /// A canonical frame of this problem's unknowns (`simhc::solver::CanonicalFrame`).
        pub type #canonical_frame = ::simhc::solver::CanonicalFrame<#nx_name>;
        /// What a refinement on all rows did (`simhc::solver::Refinement`).
        pub type #refinement = ::simhc::solver::Refinement<#nx_name>;
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
