//! The items of one instance (one row count): the unit type, its constants and parameter
//! packing, and the `simhc` trait impls (`ProblemInfo`, `ProblemLayout`, `Problem`,
//! `ParamDerivative`, the default `OnlineSimulator`, `CoefficientForm`). Instances with two or
//! more rows take their bodies from the row kernels; the others are expanded scalar code.

use super::data_structs::field_layouts;
use super::render::{render_scalar, Outputs};
use super::row_kernels::{LaneImpls, LanedCoefficientForm, RowKernels};
use super::{instance_names, n};
use crate::dag::Dag;
use crate::decl::Declaration;
use crate::lower::Instance;
use crate::poly::{Poly, Var};
use crate::{Expanded, Lowered};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

/// What one instance contributes to the module.
pub(super) struct InstanceItems {
    /// The type and its impls.
    pub items: TokenStream,
    /// Row-kernel items, the same for every instance (emitted once per module).
    pub kernels: Vec<TokenStream>,
}

/// The items of instance `expanded` of the declaration lowered as `lowered`.
pub(super) fn instance(decl: &Declaration, lowered: &Lowered, expanded: &Expanded) -> InstanceItems {
    let inst = &expanded.instance;
    let base = decl.module.ident.to_string();
    let has_rows = !decl.row_fields.is_empty();
    let names = instance_names(decl, inst.rows);
    let type_name = format_ident!("{}", names.instance);
    let problem_name = if has_rows { format!("{base}{}", inst.rows) } else { base.clone() };
    let (nx_v, nf_v, np_v) = (inst.vars.nx(), inst.equations.len(), inst.vars.np());
    let (nx, nf, np) = (n(nx_v), n(nf_v), n(np_v));
    let n_rows = n(inst.rows);
    let unknown_names = &inst.vars.unknown_names;
    let param_names = &inst.vars.param_names;
    let derivs = Derivatives::new(inst);
    let sv = quote!(::simhc::__private::nalgebra::SVector);
    let sm = quote!(::simhc::__private::nalgebra::SMatrix);

    let row_len_v: usize = decl.row_fields.iter().map(|f| f.shape.scalar_count()).sum();
    // `lowered.one_row` is there exactly when some instance has two or more rows.
    let row_kernels = match &lowered.one_row {
        Some(one_row) if has_rows && inst.rows >= 2 => Some(RowKernels::new(one_row, expanded, row_len_v)),
        _ => None,
    };
    let (residual, jacobian, fused, kernel_items) = if let Some(k) = &row_kernels {
        (k.residual.clone(), k.jacobian.clone(), k.fused.clone(), k.items.clone())
    } else {
        let mut dag = Dag::default();
        let f = derivs.residual(&mut dag);
        let residual = render_scalar(&dag, &inst.vars, &[(quote!(f), &f)]);

        let mut dag = Dag::default();
        let j = derivs.jacobian(&mut dag);
        let jacobian = render_scalar(&dag, &inst.vars, &[(quote!(j), &j)]);

        let mut dag = Dag::default();
        let f = derivs.residual(&mut dag);
        let j = derivs.jacobian(&mut dag);
        let fused = render_scalar(&dag, &inst.vars, &[(quote!(f), &f), (quote!(j), &j)]);
        (residual, jacobian, fused, quote!())
    };

    let mut dag = Dag::default();
    let jp = derivs.param_jacobian(&mut dag);
    let param_jacobian = render_scalar(&dag, &inst.vars, &[(quote!(jp), &jp)]);

    let mut dag = Dag::default();
    let dir = derivs.param_directional(&mut dag);
    let param_directional = render_scalar(&dag, &inst.vars, &[(quote!(out), &dir)]);

    let nc = n(expanded.coefficients.table.len());
    let laned_coefficients = row_kernels.as_ref().and_then(|k| k.coefficient_form(expanded));
    let coefficient_form = coefficient_form(expanded, &type_name, laned_coefficients.as_ref());
    let coefficient_items = laned_coefficients.map(|l| l.items).unwrap_or_default();

    // Packing helpers: rows then globals.
    let row_len = n(row_len_v);
    let mut args = Vec::new();
    let mut packs = Vec::new();
    if has_rows {
        args.push(quote!(rows: &[Row; #n_rows]));
        packs.push(quote! {
            for (r, row) in rows.iter().enumerate() {
                let mut buf = [0.0; #row_len];
                row.write_to(&mut buf);
                for (k, v) in buf.iter().enumerate() { p[r * #row_len + k] = *v; }
            }
        });
    }
    if !decl.globals.is_empty() {
        let glen = n(decl.globals.iter().map(|f| f.shape.scalar_count()).sum());
        let off = n(inst.rows * row_len_v);
        args.push(quote!(globals: &Globals));
        packs.push(quote! {
            let mut buf = [0.0; #glen];
            globals.write_to(&mut buf);
            for (k, v) in buf.iter().enumerate() { p[#off + k] = *v; }
        });
    }
    let doc = format!(
        " `{problem_name}`: {nf_v} equations in {nx_v} unknowns with {np_v} parameters{}.",
        if has_rows { format!(" ({} rows)", inst.rows) } else { String::new() }
    );
    let simulator = if decl.options.custom_simulator {
        quote!()
    } else {
        quote! {
            /// The generic minimum-norm online simulator (declare `simulator = custom` to
            /// provide a geometric one instead).
            impl ::simhc::OnlineSimulator<#nx, #nf, #np> for #type_name {
                fn simulate(
                    &self,
                    x0: &#sv<f64, #nx>,
                    p: &#sv<f64, #np>,
                ) -> ::core::result::Result<#sv<f64, #np>, ::simhc::SimulatorError> {
                    ::simhc::MinNormSimulator::<Self>::new().run::<#nx, #nf, #np>(x0, p)
                }
            }
        }
    };
    let layout_unknowns = field_layouts(&decl.unknowns);
    let layout_row = field_layouts(&decl.row_fields);
    let layout_globals = field_layouts(&decl.globals);
    let parameter_free = crate::constraints::parameter_free(inst).into_iter().map(n);
    let norms = crate::constraints::norms(decl, inst).into_iter().map(|crate::constraints::FieldNorm { field, equation, norm }| {
        let (field, equation, norm) = (n(field), n(equation), Literal::f64_unsuffixed(norm));
        quote!(::simhc::FieldNorm { field: #field, equation: #equation, norm: #norm })
    });
    let eqs_per_row = n(inst.eqs_per_row);
    // Names of this instance's sizes, so that user code writes no number (`Params7`,
    // `AllRoots7`, `SquareSubsystem6`; without rows, no suffix).
    let params_alias = format_ident!("{}", names.params);
    let all_roots_alias = format_ident!("{}", names.all_roots);
    let subsystem_alias = format_ident!("{}", names.square_subsystem);
    let params_doc = format!(" The parameter vector of [`{type_name}`] ({np_v} numbers).");
    let all_roots_doc = format!(" An all-roots fallback for data of [`{type_name}`]: `simhc::solver::AllRoots` with its sizes.");
    let subsystem_doc = format!(" All roots of [`{type_name}`] by a start system: `simhc::solver::SquareSubsystem` with its sizes.");
    let square = nf_v == nx_v;
    let square_subsystem = if square {
        quote! {
            /// All roots of this square instance from a start system (`monodromy`'s JSON;
            /// `None`: not made yet), `expected` the solution count from theory if known: a
            /// problem's all-roots fallback (`simhc::solver::SquareSubsystem::new`).
            pub fn square_subsystem(
                start_json: ::core::option::Option<&str>,
                expected: ::core::option::Option<usize>,
            ) -> ::core::result::Result<#subsystem_alias, ::simhc::start_system::StartSystemError> {
                ::simhc::solver::SquareSubsystem::new(start_json, expected)
            }
        }
    } else {
        quote!()
    };
    let subsystem_type = if square {
        quote! {
            #[doc = #subsystem_doc]
            pub type #subsystem_alias = ::simhc::solver::SquareSubsystem<#type_name, #nx, #np, #nc>;
        }
    } else {
        quote!()
    };
    let aliases = quote! {
        #[doc = #params_doc]
        pub type #params_alias = #sv<f64, #np>;
        #[doc = #all_roots_doc]
        pub type #all_roots_alias<'a> = dyn ::simhc::solver::AllRoots<#nx, #np> + 'a;
        #subsystem_type
    };
    let tokens = quote! {
        #[doc = #doc]
        #[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
        pub struct #type_name;

        impl #type_name {
            /// Number of unknowns.
            pub const NX: usize = #nx;
            /// Number of equations.
            pub const NF: usize = #nf;
            /// Number of parameters.
            pub const NP: usize = #np;
            /// Number of rows (correspondences).
            pub const ROWS: usize = #n_rows;
            /// Number of coefficients of the coefficient form.
            pub const NC: usize = #nc;
            /// Packs the parameter vector: rows in order, then globals.
            pub fn params(#(#args),*) -> #sv<f64, #np> {
                let mut p = #sv::<f64, #np>::zeros();
                #(#packs)*
                p
            }
            /// The unknowns as a vector.
            pub fn unknowns_vector(u: &Unknowns) -> #sv<f64, #nx> {
                let mut buf = [0.0; #nx];
                u.write_to(&mut buf);
                #sv::<f64, #nx>::from(buf)
            }
            /// Gauss-Newton on this instance's equations from `x0`
            /// (`simhc::pipeline::path::gauss_newton` with this instance's sizes).
            pub fn gauss_newton(
                x0: &#sv<f64, #nx>,
                p: &#sv<f64, #np>,
                options: &::simhc::tracker::NewtonOptions,
            ) -> ::core::result::Result<(#sv<f64, #nx>, ::simhc::tracker::TrackStats), ::simhc::tracker::TrackError> {
                ::simhc::pipeline::path::gauss_newton::<Self, #nx, #nf, #np>(x0, p, options)
            }
            /// This instance's parameters from data of at least as many rows: its first rows
            /// and the globals (`simhc::Layout::first_rows`); `None` when `p` is too short.
            pub fn first_rows(p: &[f64]) -> ::core::option::Option<#sv<f64, #np>> {
                <Self as ::simhc::ProblemLayout>::LAYOUT.first_rows::<#np>(p)
            }
            #square_subsystem
        }

        #aliases

        impl ::simhc::ProblemInfo for #type_name {
            const NAME: &'static str = #problem_name;
            const UNKNOWN_NAMES: &'static [&'static str] = &[#(#unknown_names),*];
            const PARAM_NAMES: &'static [&'static str] = &[#(#param_names),*];
        }

        impl ::simhc::InstanceSizes<#nx, #np> for #type_name {}

        impl ::simhc::ProblemLayout for #type_name {
            const LAYOUT: ::simhc::Layout = ::simhc::Layout {
                unknowns: &[#(#layout_unknowns),*],
                row: &[#(#layout_row),*],
                globals: &[#(#layout_globals),*],
                rows: #n_rows,
                per_row: #row_len,
                equations_per_row: #eqs_per_row,
                parameter_free: &[#(#parameter_free),*],
                norms: &[#(#norms),*],
            };
        }

        #[allow(clippy::all, unused_variables)]
        impl ::simhc::Problem<#nx, #nf, #np> for #type_name {
            #[inline]
            fn residual<S: ::simhc::Ring>(x: &#sv<S, #nx>, p: &#sv<S, #np>, f: &mut #sv<S, #nf>) {
                #residual
            }
            #[inline]
            fn jacobian<S: ::simhc::Ring>(x: &#sv<S, #nx>, p: &#sv<S, #np>, j: &mut #sm<S, #nf, #nx>) {
                #jacobian
            }
            #[inline]
            fn residual_jacobian<S: ::simhc::Ring>(
                x: &#sv<S, #nx>,
                p: &#sv<S, #np>,
                f: &mut #sv<S, #nf>,
                j: &mut #sm<S, #nf, #nx>,
            ) {
                #fused
            }
        }

        #[allow(clippy::all, unused_variables)]
        impl ::simhc::ParamDerivative<#nx, #nf, #np> for #type_name {
            fn param_jacobian<S: ::simhc::Scalar>(x: &#sv<S, #nx>, p: &#sv<S, #np>, jp: &mut #sm<S, #nf, #np>) {
                #param_jacobian
            }
            #[inline]
            fn param_directional<S: ::simhc::Scalar>(
                x: &#sv<S, #nx>,
                p: &#sv<S, #np>,
                dp: &#sv<S, #np>,
                out: &mut #sv<S, #nf>,
            ) {
                #param_directional
            }
        }

        #simulator

        #coefficient_form
    };
    let mut items = Vec::new();
    if !kernel_items.is_empty() {
        items.push(kernel_items);
    }
    if !coefficient_items.is_empty() {
        items.push(coefficient_items);
    }
    InstanceItems { items: tokens, kernels: items }
}

/// `impl CoefficientForm`: coefficients from parameters, and the system over coefficients.
fn coefficient_form(expanded: &Expanded, type_name: &Ident, laned: Option<&LanedCoefficientForm>) -> TokenStream {
    let (inst, split) = (&expanded.instance, &expanded.coefficients);
    let (nx, nf, np, nc) = (n(inst.vars.nx()), n(inst.equations.len()), n(inst.vars.np()), n(split.table.len()));
    let sv = quote!(::simhc::__private::nalgebra::SVector);
    let sm = quote!(::simhc::__private::nalgebra::SMatrix);
    let vars = &split.vars;

    let mut dag = Dag::default();
    let entries: Outputs = split
        .table
        .iter()
        .enumerate()
        .map(|(k, poly)| {
            let k = n(k);
            (quote!(#k), dag.polynomial(poly, vars))
        })
        .collect();
    let coefficients = render_scalar(&dag, vars, &[(quote!(c), &entries)]);

    let residual_of = |dag: &mut Dag, polys: &[Poly]| -> Outputs {
        polys
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let i = n(i);
                (quote!(#i), dag.polynomial(f, vars))
            })
            .collect()
    };
    let jacobian_of = |dag: &mut Dag| -> Outputs {
        let mut out = Vec::new();
        for (i, f) in split.equations.iter().enumerate() {
            for k in 0..inst.vars.nx() {
                let d = f.diff(k as Var);
                let (i, k) = (n(i), n(k));
                out.push((quote!((#i, #k)), dag.polynomial(&d, vars)));
            }
        }
        out
    };

    let (fused, residual, linear, lanes) = match laned {
        Some(l) => (l.fused.clone(), l.residual.clone(), l.linear.clone(), l.lanes.as_ref()),
        None => {
            let mut dag = Dag::default();
            let f = residual_of(&mut dag, &split.equations);
            let j = jacobian_of(&mut dag);
            let fused = render_scalar(&dag, vars, &[(quote!(f), &f), (quote!(j), &j)]);

            let mut dag = Dag::default();
            let f = residual_of(&mut dag, &split.equations);
            let residual = render_scalar(&dag, vars, &[(quote!(f), &f)]);

            let mut dag = Dag::default();
            let lin = residual_of(&mut dag, &split.linear);
            // The linear part reads its coefficients from `dc` (renamed `c`).
            let linear = render_scalar(&dag, vars, &[(quote!(out), &lin)]);
            (fused, residual, quote!(let c = dc; #linear), None)
        }
    };
    let (lane_types, lane_impls) = lane_kernels(type_name, lanes, (&nx, &nf));

    quote! {
        #[allow(clippy::all, unused_variables)]
        impl ::simhc::CoefficientForm<#nx, #nf, #np, #nc> for #type_name {
            #[inline]
            fn coefficients<S: ::simhc::Scalar>(p: &#sv<S, #np>, c: &mut #sv<S, #nc>) {
                #coefficients
            }
            #[inline]
            fn residual_jacobian_coeffs<S: ::simhc::Scalar>(
                x: &#sv<S, #nx>,
                c: &#sv<S, #nc>,
                f: &mut #sv<S, #nf>,
                j: &mut #sm<S, #nf, #nx>,
            ) {
                #fused
            }
            #[inline]
            fn residual_coeffs<S: ::simhc::Scalar>(x: &#sv<S, #nx>, c: &#sv<S, #nc>, f: &mut #sv<S, #nf>) {
                #residual
            }
            #[inline]
            fn coefficient_part<S: ::simhc::Scalar>(x: &#sv<S, #nx>, dc: &#sv<S, #nc>, out: &mut #sv<S, #nf>) {
                #linear
            }
            #lane_types
        }
        #lane_impls
    }
}

/// `CoefficientForm`'s lane-kernel types and constants, and the impls of the capability traits
/// `simhc::{RowLanes, PathLanes, ParamLanes}` on the instance type where it has them (else
/// `simhc::NoLanes` and `None`).
fn lane_kernels(type_name: &Ident, lanes: Option<&LaneImpls>, (nx, nf): (&Literal, &Literal)) -> (TokenStream, TokenStream) {
    let Some(LaneImpls { row, path, param, param_doc }) = lanes else {
        let none = quote!(::core::option::Option<::simhc::NoLanes> = ::core::option::Option::None);
        let types = quote! {
            type RowLanes = ::simhc::NoLanes;
            const ROW_LANES: #none;
            type PathLanes = ::simhc::NoLanes;
            const PATH_LANES: #none;
            type ParamLanes = ::simhc::NoLanes;
            const PARAM_LANES: #none;
        };
        return (types, quote!());
    };
    let some = quote!(::core::option::Option<Self> = ::core::option::Option::Some(Self));
    let types = quote! {
        type RowLanes = Self;
        const ROW_LANES: #some;
        type PathLanes = Self;
        const PATH_LANES: #some;
        type ParamLanes = Self;
        const PARAM_LANES: #some;
    };
    let impls = quote! {
        #[allow(clippy::all, unused_variables)]
        impl ::simhc::RowLanes<#nx, #nf> for #type_name {
            #row
        }
        #[allow(clippy::all, unused_variables)]
        impl ::simhc::PathLanes<#nx, #nf> for #type_name {
            #path
        }
        #[doc = #param_doc]
        #[allow(clippy::all, unused_variables)]
        impl ::simhc::ParamLanes<#nx, #nf> for #type_name {
            #param
        }
    };
    (types, impls)
}

/// Derivative tables of one instance.
struct Derivatives<'a> {
    inst: &'a Instance,
    /// `dF_i/dx_k`.
    dx: Vec<Vec<Poly>>,
}

impl<'a> Derivatives<'a> {
    fn new(inst: &'a Instance) -> Self {
        let nx = inst.vars.nx();
        let dx = inst.equations.iter().map(|f| (0..nx).map(|k| f.diff(k as Var)).collect()).collect();
        Self { inst, dx }
    }

    fn residual(&self, dag: &mut Dag) -> Outputs {
        self.inst
            .equations
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let i = n(i);
                (quote!(#i), dag.polynomial(f, &self.inst.vars))
            })
            .collect()
    }

    fn jacobian(&self, dag: &mut Dag) -> Outputs {
        let mut out = Vec::new();
        for (i, row) in self.dx.iter().enumerate() {
            for (k, d) in row.iter().enumerate() {
                let (i, k) = (n(i), n(k));
                out.push((quote!((#i, #k)), dag.polynomial(d, &self.inst.vars)));
            }
        }
        out
    }

    fn param_jacobian(&self, dag: &mut Dag) -> Outputs {
        let (nx, np) = (self.inst.vars.nx(), self.inst.vars.np());
        let mut out = Vec::new();
        for (i, f) in self.inst.equations.iter().enumerate() {
            for m in 0..np {
                let d = f.diff((nx + m) as Var);
                let (i, m) = (n(i), n(m));
                out.push((quote!((#i, #m)), dag.polynomial(&d, &self.inst.vars)));
            }
        }
        out
    }

    fn param_directional(&self, dag: &mut Dag) -> Outputs {
        let (nx, np) = (self.inst.vars.nx(), self.inst.vars.np());
        let mut out = Vec::new();
        for (i, f) in self.inst.equations.iter().enumerate() {
            let mut acc = dag.constant(0.0);
            for m in 0..np {
                let d = f.diff((nx + m) as Var);
                if d.is_zero() {
                    continue;
                }
                let dn = dag.polynomial(&d, &self.inst.vars);
                let dir = dag.direction(m as u32);
                let term = dag.mul(dn, dir);
                acc = dag.add(acc, term);
            }
            let i = n(i);
            out.push((quote!(#i), acc));
        }
        out
    }
}
