//! Lane kernels of a problem with rows: every row runs the same straight-line code, so the
//! equations of *one* row become a kernel generic over `simhc::lanes::Lanes` that evaluates
//! `LANES` rows at once (in the parameter form and in the coefficient form), and the path-lane
//! items of `CoefficientForm` put one *path* in each lane. The global equations stay scalar
//! code. The kernels depend on the declaration only, so the module emits them once
//! (`__SimhcRowKernels`) for all instances.

use super::n;
use super::param_kernel::{param_lanes, ParamLanes};
use super::render::{render_lanes, render_scalar, LeafArrays, Outputs};
use crate::coefficients::repeats_per_row;
use crate::dag::{Dag, NodeId};
use crate::lower::VarTable;
use crate::poly::{Poly, Var};
use crate::{Expanded, OneRow};
use proc_macro2::TokenStream;
use quote::{format_ident, quote, ToTokens};

/// Sizes shared by the row kernels of one instance.
#[derive(Clone, Copy)]
pub(super) struct RowShape {
    pub nx: usize,
    pub nf: usize,
    pub rows: usize,
    /// Equations per row.
    pub epr: usize,
}

/// The loop of a row-laned function: for each chunk of `LANES` rows, gather the kernel input
/// from `src` (`row_len` entries per row, then broadcast globals up to `k` entries), run the
/// kernel and scatter its residuals into `f_out` / Jacobian rows into `j_out` (either may be
/// absent; the kernel computes a Jacobian when `kernel_j`).
#[allow(clippy::too_many_arguments)]
fn row_loop(
    shape: RowShape,
    kernel: &str,
    src: TokenStream,
    row_len: usize,
    k: usize,
    kernel_j: bool,
    f_out: Option<TokenStream>,
    j_out: Option<TokenStream>,
) -> TokenStream {
    let (rows, row_len, k_t, epr, ej) = (n(shape.rows), n(row_len), n(k), n(shape.epr), n(shape.epr * shape.nx));
    let lanes = quote!(<S as ::simhc::Ring>::Lanes);
    let zero = quote!(<#lanes as ::simhc::lanes::Lanes>::from_real(0.0));
    let kernel = format_ident!("{}_run", kernel);
    let (decl_j, call) = if kernel_j {
        (quote!(let mut jl = [#zero; #ej];), quote!(__SimhcRowKernels::#kernel(&xl, &rl, &mut fl, &mut jl);))
    } else {
        (quote!(), quote!(__SimhcRowKernels::#kernel(&xl, &rl, &mut fl);))
    };
    let store_f = f_out.map(|f| quote!(::simhc::lanes::scatter_residual(&fl, first, #rows, #f);));
    let store_j = j_out.map(|j| quote!(::simhc::lanes::scatter_jacobian(&jl, first, #rows, #j);));
    quote! {
        let xl = ::simhc::lanes::splat_all(x);
        let mut first = 0;
        while first < #rows {
            let rl: [#lanes; #k_t] = ::simhc::lanes::gather_rows(#src, first, #rows, #row_len);
            let mut fl = [#zero; #epr];
            #decl_j
            #call
            #store_f
            #store_j
            first += ::simhc::lanes::LANES;
        }
    }
}

/// A row kernel: `f` (and `j`, row-major) of one row per lane from the broadcast unknowns `x`
/// and the row's inputs `r` (`k` entries). Emitted as the body (`name`, always inlined) and
/// `name_run`, which runs it through `simhc::lanes::dispatch` (AVX2 where available) via a
/// small job struct: each kernel is compiled once per instruction set and scalar type, however
/// many wrappers call it.
fn kernel_item(name: &str, doc: &str, shape: RowShape, k: usize, with_j: bool, body: TokenStream) -> TokenStream {
    let run = format_ident!("{}_run", name);
    let name = format_ident!("{}", name);
    let (nx, k, epr, ej) = (n(shape.nx), n(k), n(shape.epr), n(shape.epr * shape.nx));
    let (j_arg, j_field, j_name) =
        if with_j { (quote!(, j: &mut [S; #ej]), quote!(j: &'a mut [S; #ej],), quote!(j)) } else { (quote!(), quote!(), quote!()) };
    let j_pass = if with_j { quote!(, #j_name) } else { quote!() };
    let j_self = if with_j { quote!(, self.j) } else { quote!() };
    let run_doc = format!(" [`Self::{name}`] with the best instruction set of this CPU.");
    quote! {
        #[doc = #doc]
        #[inline(always)]
        #[allow(clippy::all, unused_variables)]
        fn #name<S: ::simhc::lanes::Lanes>(x: &[S; #nx], r: &[S; #k], f: &mut [S; #epr] #j_arg) {
            #body
        }
        #[doc = #run_doc]
        #[inline]
        fn #run<S: ::simhc::lanes::Lanes>(x: &[S; #nx], r: &[S; #k], f: &mut [S; #epr] #j_arg) {
            struct Job<'a, S: ::simhc::lanes::Lanes> {
                x: &'a [S; #nx],
                r: &'a [S; #k],
                f: &'a mut [S; #epr],
                #j_field
            }
            impl<'a, S: ::simhc::lanes::Lanes> ::simhc::lanes::Kernel for Job<'a, S> {
                #[inline(always)]
                fn run(self) {
                    __SimhcRowKernels::#name(self.x, self.r, self.f #j_self);
                }
            }
            ::simhc::lanes::dispatch(Job { x, r, f #j_pass });
        }
    }
}

/// The outputs of a row kernel: residuals `f[i]` and, when asked for, Jacobian rows
/// `j[i * nx + k]` (row-major).
struct RowOutputs {
    f: Outputs,
    j: Outputs,
}

/// Outputs of the first `epr` equations `eqs` of a one-row lowering, into `dag`.
fn row_outputs(dag: &mut Dag, eqs: &[Poly], vars: &VarTable, shape: RowShape, with_j: bool) -> RowOutputs {
    let node = |dag: &mut Dag, poly: &Poly| dag.polynomial(poly, vars);
    let f = (0..shape.epr).map(|i| (n(i).into_token_stream(), node(dag, &eqs[i]))).collect();
    let mut j = Vec::new();
    if with_j {
        for i in 0..shape.epr {
            for k in 0..shape.nx {
                j.push((n(i * shape.nx + k).into_token_stream(), node(dag, &eqs[i].diff(k as Var))));
            }
        }
    }
    RowOutputs { f, j }
}

/// Scalar code of the global equations (`eqs[rows * epr ..]`) into `f` / `j`, in a block; empty
/// without global equations. Emitted *before* the row loop: it may zero-fill the whole output.
fn global_part(eqs: &[Poly], vars: &VarTable, shape: RowShape, with_f: bool, with_j: bool) -> TokenStream {
    let first = shape.rows * shape.epr;
    if first == shape.nf {
        return quote!();
    }
    let mut dag = Dag::default();
    let node = |dag: &mut Dag, poly: &Poly| dag.polynomial(poly, vars);
    let mut f = Vec::new();
    let mut j = Vec::new();
    for g in first..shape.nf {
        if with_f {
            f.push((n(g).into_token_stream(), node(&mut dag, &eqs[g])));
        }
        if with_j {
            for k in 0..shape.nx {
                let (gi, ki) = (n(g), n(k));
                j.push((quote!((#gi, #ki)), node(&mut dag, &eqs[g].diff(k as Var))));
            }
        }
    }
    let body = render_scalar(&dag, vars, &[(quote!(f), &f), (quote!(j), &j)]);
    quote!({ #body })
}

/// Row kernels of a problem with rows: the equations of *one* row (lowered from the declaration
/// with a single row), generic over `simhc::lanes::Lanes` so that generated code evaluates
/// `LANES` rows at once, plus scalar code for the global equations. Every row runs the same
/// straight-line code, so this replaces `rows` expanded copies by one kernel run
/// `ceil(rows / LANES)` times (GRPS7 in `Complex<f64>`: residual + Jacobian 1.79 us expanded,
/// 0.45 us in lanes with AVX2).
pub(super) struct RowKernels<'a> {
    /// Kernel items of the parameter form.
    pub items: TokenStream,
    /// Bodies of `residual`, `jacobian`, `residual_jacobian`.
    pub residual: TokenStream,
    pub jacobian: TokenStream,
    pub fused: TokenStream,
    /// The one-row lowering, expanded.
    one: &'a Expanded,
    shape: RowShape,
    row_len: usize,
    /// The row kernel from the row's parameters, unexpanded (see [`param_lanes`]).
    param_lanes: ParamLanes,
}

/// The bodies of `CoefficientForm` in lanes, and the kernel items they call.
pub(super) struct LanedCoefficientForm {
    /// Kernel items (emitted once per module).
    pub items: TokenStream,
    /// Body of `residual_jacobian_coeffs`.
    pub fused: TokenStream,
    /// Body of `residual_coeffs`.
    pub residual: TokenStream,
    /// Body of `coefficient_part`.
    pub linear: TokenStream,
    /// The lane-kernel impls, or `None` when the global equations have coefficients.
    pub lanes: Option<LaneImpls>,
}

/// The bodies of the capability traits `simhc::{RowLanes, PathLanes, ParamLanes}` of one
/// instance (the impl blocks are written by the instance).
pub(super) struct LaneImpls {
    /// `RowLanes`: `layout` and `coefficient_part_poly`.
    pub row: TokenStream,
    /// `PathLanes`: `equations_per_row`, `row` and `globals`.
    pub path: TokenStream,
    /// `ParamLanes`: `param_layout`, `shared` and `row_params`.
    pub param: TokenStream,
    /// Doc of the `ParamLanes` impl: the estimated operation counts.
    pub param_doc: String,
}

impl<'a> RowKernels<'a> {
    /// The row kernels of instance `inst` (two or more rows), from the one-row lowering `one_row`;
    /// `row_len` parameters per row.
    pub fn new(one_row: &'a OneRow, inst: &Expanded, row_len: usize) -> Self {
        let (one, inst) = (&one_row.expanded, &inst.instance);
        let shape = RowShape { nx: inst.vars.nx(), nf: inst.equations.len(), rows: inst.rows, epr: inst.eqs_per_row };
        let one_vars = &one.instance.vars;
        let npk = one_vars.np();

        let mut dag = Dag::default();
        let RowOutputs { f, .. } = row_outputs(&mut dag, &one.instance.equations, one_vars, shape, false);
        let kernel_residual = render_lanes(&dag, one_vars, LeafArrays::ROW_PARAMS, &[(quote!(f), &f)]);
        let mut dag = Dag::default();
        let RowOutputs { f, j } = row_outputs(&mut dag, &one.instance.equations, one_vars, shape, true);
        let kernel_fused = render_lanes(&dag, one_vars, LeafArrays::ROW_PARAMS, &[(quote!(f), &f), (quote!(j), &j)]);

        let lp = |kernel: &str, with_j: bool, f_out: Option<TokenStream>, j_out: Option<TokenStream>| {
            row_loop(shape, kernel, quote!(p), row_len, npk, with_j, f_out, j_out)
        };
        let g = |f: bool, j: bool| global_part(&inst.equations, &inst.vars, shape, f, j);
        let (g_r, g_j, g_f) = (g(true, false), g(false, true), g(true, true));
        let residual_loop = lp("__row_residual", false, Some(quote!(f)), None);
        let jacobian_loop = lp("__row_residual_jacobian", true, None, Some(quote!(j)));
        let fused_loop = lp("__row_residual_jacobian", true, Some(quote!(f)), Some(quote!(j)));
        let residual = quote!(#g_r #residual_loop);
        let jacobian = quote!(#g_j #jacobian_loop);
        let fused = quote!(#g_f #fused_loop);
        let items = [
            kernel_item("__row_residual", " Row kernel: residuals of `LANES` rows, one per lane.", shape, npk, false, kernel_residual),
            kernel_item(
                "__row_residual_jacobian",
                " Row kernel: residuals and Jacobian rows (row-major) of `LANES` rows.",
                shape,
                npk,
                true,
                kernel_fused,
            ),
        ];
        let param_lanes = param_lanes(&one_row.unexpanded, shape, row_len);
        Self { items: quote!(#(#items)*), residual, jacobian, fused, one, shape, row_len, param_lanes }
    }

    /// The coefficient form in lanes, when the coefficients of the instance are `rows` blocks
    /// of the one-row coefficients (checked), else `None`.
    pub fn coefficient_form(&self, inst: &Expanded) -> Option<LanedCoefficientForm> {
        let (one_split, split) = (&self.one.coefficients, &inst.coefficients);
        if !repeats_per_row(split, one_split, &inst.instance, &self.one.instance, self.row_len) {
            return None;
        }
        let shape = self.shape;
        let nc1 = one_split.table.len();
        let vars = &one_split.vars;
        let ids = |entries: &[&Outputs]| -> Vec<NodeId> { entries.iter().flat_map(|e| e.iter().map(|(_, id)| *id)).collect() };
        let mut dag = Dag::default();
        let RowOutputs { f, j } = row_outputs(&mut dag, &one_split.equations, vars, shape, true);
        let k_fused = render_lanes(&dag, vars, LeafArrays::ROW_COEFFICIENTS, &[(quote!(f), &f), (quote!(j), &j)]);
        let mut coefficient_ops = dag.op_count(&ids(&[&f, &j]));
        let mut dag = Dag::default();
        let RowOutputs { f, .. } = row_outputs(&mut dag, &one_split.equations, vars, shape, false);
        let k_residual = render_lanes(&dag, vars, LeafArrays::ROW_COEFFICIENTS, &[(quote!(f), &f)]);
        let mut dag = Dag::default();
        let RowOutputs { f, .. } = row_outputs(&mut dag, &one_split.linear, vars, shape, false);
        let k_linear = render_lanes(&dag, vars, LeafArrays::ROW_COEFFICIENTS, &[(quote!(f), &f)]);
        // The path-lane operation evaluates the fused and the linear kernel, after a Horner pass
        // for `c(t)` and `c'(t)` of each coefficient (about two operations per degree in `t`; on
        // a straight parameter segment the degree of `c` in `p`).
        let degree = one_split.table.iter().map(|c| c.degree() as usize).max().unwrap_or(0);
        coefficient_ops += dag.op_count(&ids(&[&f])) + nc1 * 2 * degree;

        let lp = |kernel: &str, src: TokenStream, with_j: bool, f_out: TokenStream, j_out: Option<TokenStream>| {
            row_loop(shape, kernel, src, nc1, nc1, with_j, Some(f_out), j_out)
        };
        let g = |eqs: &[Poly], f: bool, j: bool| global_part(eqs, &split.vars, shape, f, j);
        let fused = {
            let gp = g(&split.equations, true, true);
            let lp = lp("__row_coeff_residual_jacobian", quote!(c), true, quote!(f), Some(quote!(j)));
            quote!(#gp #lp)
        };
        let residual = {
            let gp = g(&split.equations, true, false);
            let lp = lp("__row_coeff_residual", quote!(c), false, quote!(f), None);
            quote!(#gp #lp)
        };
        let linear = {
            // Global rows of the linear part write `out`.
            let gp = if shape.nf > shape.rows * shape.epr { global_linear(&split.linear, &split.vars, shape) } else { quote!() };
            let lp = lp("__row_coeff_linear", quote!(dc), false, quote!(out), None);
            quote!(#gp #lp)
        };
        let items = [
            kernel_item(
                "__row_coeff_residual_jacobian",
                " Row kernel of the coefficient form: residuals and Jacobian rows of `LANES` rows.",
                shape,
                nc1,
                true,
                k_fused,
            ),
            kernel_item("__row_coeff_residual", " Row kernel of the coefficient form: residuals.", shape, nc1, false, k_residual),
            kernel_item(
                "__row_coeff_linear",
                " Row kernel of the coefficient form: the part linear in the coefficients.",
                shape,
                nc1,
                false,
                k_linear,
            ),
        ];
        // The lane kernels: only when the global equations' linear part vanishes (no
        // coefficients outside the row blocks).
        let first_global = shape.rows * shape.epr;
        let mut lane_kernel = quote!();
        let lanes = if split.linear[first_global..].iter().all(|p| p.is_zero()) {
            let (rows, nc1_t, epr, nx_t, nf_t) = (n(shape.rows), n(nc1), n(shape.epr), n(shape.nx), n(shape.nf));
            let lanes = quote!(<S as ::simhc::Ring>::Lanes);
            let zero = quote!(<#lanes as ::simhc::lanes::Lanes>::from_real(0.0));
            let zero_globals = (first_global..shape.nf).map(|g| {
                let g = n(g);
                quote!(out[#g] = S::from_real(0.0);)
            });
            let body = quote! {
                let chunks = (#rows + ::simhc::lanes::LANES - 1) / ::simhc::lanes::LANES;
                let block = chunks * #nc1_t;
                if poly.is_empty() || poly.len() % block != 0 {
                    out.fill(S::from_real(f64::NAN));
                    return;
                }
                let degrees = poly.len() / block;
                #(#zero_globals)*
                let xl = ::simhc::lanes::splat_all(x);
                for chunk in 0..chunks {
                    let mut rl = [#zero; #nc1_t];
                    for k in (0..degrees).rev() {
                        let base = (k * chunks + chunk) * #nc1_t;
                        for (m, r) in rl.iter_mut().enumerate() {
                            *r = ::simhc::lanes::Lanes::scale(*r, t) + poly[base + m];
                        }
                    }
                    let mut fl = [#zero; #epr];
                    // Already inside `dispatch`: the kernel body, not its dispatching `_run`.
                    __SimhcRowKernels::__row_coeff_linear(&xl, &rl, &mut fl);
                    ::simhc::lanes::scatter_residual(&fl, chunk * ::simhc::lanes::LANES, #rows, out);
                }
            };
            let args = [
                (quote!(x), quote!(&'a ::simhc::__private::nalgebra::SVector<S, #nx_t>)),
                (quote!(t), quote!(f64)),
                (quote!(poly), quote!(&'a [<S as ::simhc::Ring>::Lanes])),
                (quote!(out), quote!(&'a mut ::simhc::__private::nalgebra::SVector<S, #nf_t>)),
            ];
            let wrapped = dispatched(&args, body);
            let (kernel, path) = self.path_lanes(&split.equations, &split.vars, nc1);
            let param_lanes = &self.param_lanes;
            let param_kernel = &param_lanes.kernel;
            let (param, param_doc) = param_lanes.items(param_lanes.ops < coefficient_ops, coefficient_ops);
            lane_kernel = quote!(#kernel #param_kernel);
            let row = quote! {
                #[inline]
                fn layout(self) -> ::simhc::RowLayout {
                    ::simhc::RowLayout { rows: #rows, per_row: #nc1_t }
                }
                #[inline]
                fn coefficient_part_poly<S: ::simhc::Scalar>(
                    self,
                    x: &::simhc::__private::nalgebra::SVector<S, #nx_t>,
                    t: f64,
                    poly: &[<S as ::simhc::Ring>::Lanes],
                    out: &mut ::simhc::__private::nalgebra::SVector<S, #nf_t>,
                ) {
                    #wrapped
                }
            };
            Some(LaneImpls { row, path, param, param_doc })
        } else {
            None
        };
        Some(LanedCoefficientForm { items: quote!(#(#items)* #lane_kernel), fused, residual, linear, lanes })
    }
}

impl RowKernels<'_> {
    /// The body of `simhc::PathLanes` (`equations_per_row`, `row`, `globals`): the
    /// coefficient-form row kernels and the (coefficient-free) global equations, generic over
    /// `simhc::lanes::Lanes`, for callers that put one *path* in each lane. Returns the kernel
    /// item of the global equations (shared by the instances, like the row kernels; empty
    /// without global equations) and the trait body.
    fn path_lanes(&self, eqs: &[Poly], vars: &VarTable, nc1: usize) -> (TokenStream, TokenStream) {
        let shape = self.shape;
        let first = shape.rows * shape.epr;
        let ng = shape.nf - first;
        let (nx, k, epr, ej, ng_t, ngj) = (n(shape.nx), n(nc1), n(shape.epr), n(shape.epr * shape.nx), n(ng), n(ng * shape.nx));
        let mut dag = Dag::default();
        let mut f = Vec::new();
        let mut j = Vec::new();
        for g in first..shape.nf {
            f.push((n(g - first).into_token_stream(), dag.polynomial(&eqs[g], vars)));
            for x in 0..shape.nx {
                j.push((n((g - first) * shape.nx + x).into_token_stream(), dag.polynomial(&eqs[g].diff(x as Var), vars)));
            }
        }
        let (kernel, globals) = if ng == 0 {
            (quote!(), quote!())
        } else {
            let body = render_lanes(&dag, vars, LeafArrays::ARGUMENTS, &[(quote!(f), &f), (quote!(j), &j)]);
            let kernel = quote! {
                #[doc = " The global equations (without coefficients) and their Jacobian rows, one path per lane."]
                #[inline(always)]
                #[allow(clippy::all, unused_variables)]
                fn __global_lanes<S: ::simhc::lanes::Lanes>(x: &[S; #nx], f: &mut [S; #ng_t], j: &mut [S; #ngj]) {
                    #body
                }
            };
            let call = quote! {
                let (Ok(f), Ok(j)) = (<&mut [S; #ng_t]>::try_from(f), <&mut [S; #ngj]>::try_from(j)) else {
                    debug_assert!(false, "PathLanes::globals: slice lengths differ from the layout");
                    return;
                };
                __SimhcRowKernels::__global_lanes(x, f, j);
            };
            (kernel, call)
        };
        let items = quote! {
            #[inline]
            fn equations_per_row(self) -> usize {
                #epr
            }
            #[inline(always)]
            fn row<S: ::simhc::lanes::Lanes>(
                self,
                x: &[S; #nx],
                c: &[S],
                dc: &[S],
                f: &mut [S],
                j: &mut [S],
                d: &mut [S],
            ) {
                let (Ok(c), Ok(dc), Ok(f), Ok(j), Ok(d)) = (
                    <&[S; #k]>::try_from(c),
                    <&[S; #k]>::try_from(dc),
                    <&mut [S; #epr]>::try_from(f),
                    <&mut [S; #ej]>::try_from(j),
                    <&mut [S; #epr]>::try_from(d),
                ) else {
                    debug_assert!(false, "PathLanes::row: slice lengths differ from the layout");
                    return;
                };
                __SimhcRowKernels::__row_coeff_residual_jacobian(x, c, f, j);
                __SimhcRowKernels::__row_coeff_linear(x, dc, d);
            }
            #[inline(always)]
            #[allow(unused_variables)]
            fn globals<S: ::simhc::lanes::Lanes>(self, x: &[S; #nx], f: &mut [S], j: &mut [S]) {
                #globals
            }
        };
        (kernel, items)
    }
}

/// The global rows of the linear part `sum_k dc_k m_k(x)` into `out`, as scalar code.
fn global_linear(eqs: &[Poly], vars: &VarTable, shape: RowShape) -> TokenStream {
    let first = shape.rows * shape.epr;
    let mut dag = Dag::default();
    let f: Vec<_> = (first..shape.nf).map(|g| (n(g).into_token_stream(), dag.polynomial(&eqs[g], vars))).collect();
    let body = render_scalar(&dag, vars, &[(quote!(out), &f)]);
    quote!({ let c = dc; #body })
}

/// `body` (over the arguments `args`, name and type) run through `simhc::lanes::dispatch`: the
/// arguments go into a local job struct whose `run` holds the body, so the kernels inlined
/// there are compiled once per instruction set.
fn dispatched(args: &[(TokenStream, TokenStream)], body: TokenStream) -> TokenStream {
    let names: Vec<_> = args.iter().map(|(n, _)| n).collect();
    let types: Vec<_> = args.iter().map(|(_, t)| t).collect();
    quote! {
        struct Job<'a, S: ::simhc::Scalar> { #(#names: #types),* }
        impl<'a, S: ::simhc::Scalar> ::simhc::lanes::Kernel for Job<'a, S> {
            #[inline(always)]
            fn run(self) {
                let Job { #(#names),* } = self;
                #body
            }
        }
        ::simhc::lanes::dispatch(Job { #(#names),* });
    }
}
