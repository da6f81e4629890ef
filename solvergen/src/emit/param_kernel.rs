//! The path-lane row kernel from the row's *parameters*, with the part that depends on the
//! unknowns alone hoisted out of the rows.

use super::n;
use super::render::{render_lanes, LeafArrays, Outputs};
use super::row_kernels::RowShape;
use crate::dag::{Node, NodeId, Unexpanded};
use crate::poly::Var;
use proc_macro2::TokenStream;
use quote::{quote, ToTokens};

/// The path-lane row kernel from the row's *parameters*: the row equations lowered without
/// expansion (the declared expression as a DAG, [`crate::dag::DagAlgebra`]: `rotation(q)`
/// formed once, `R * (v x f)` not multiplied out), their `x`-gradient by reverse mode and
/// `dF/dp * dp` by forward mode on that DAG. The batch tracker feeds it `p(t)` and `dp/dt`
/// (`k` entries per row: the row's `row_len` parameters, then the globals) instead of the
/// coefficients of the expansion, which need a Horner pass over many more entries per row
/// (GRPS: 12 parameters against 38 coefficients).
pub(super) fn param_lanes(one_row: &Unexpanded, shape: RowShape, row_len: usize) -> ParamLanes {
    // The derivatives add nodes: each instance differentiates its own copy of the lowering.
    let mut dag = one_row.dag.clone();
    let (eqs, vars, epr) = (&one_row.equations, &one_row.vars, one_row.eqs_per_row);
    let k = vars.np();
    let xs: Vec<NodeId> = (0..shape.nx).map(|i| dag.leaf(i as Var, vars)).collect();
    let (mut f, mut j, mut d) = (Vec::new(), Vec::new(), Vec::new());
    for (i, &eq) in eqs.iter().take(epr).enumerate() {
        f.push((n(i).into_token_stream(), eq));
        for (x, g) in dag.gradient(eq, &xs).into_iter().enumerate() {
            j.push((n(i * shape.nx + x).into_token_stream(), g));
        }
        let moved = dag.derivative(eq, |dag, leaf| match *leaf {
            Node::P(m) => Some(dag.direction(m)),
            _ => None,
        });
        d.push((n(i).into_token_stream(), moved));
    }
    // The part that depends on `x` alone (GRPS: `rotation(q)`) is the same for every row: it is
    // computed once per operation (`lanes_params_shared`) and read by the row kernel.
    let outputs: Vec<NodeId> = f.iter().chain(&j).chain(&d).map(|(_, id)| *id).collect();
    let hoisted = dag.hoist_x_only(&outputs);
    let (row_dag, shared) = (&hoisted.row, &hoisted.shared);
    let remap =
        |entries: &Outputs| -> Outputs { entries.iter().map(|(t, id)| (t.clone(), hoisted.map[id.0 as usize].unwrap_or(*id))).collect() };
    let (fr, jr, dr) = (remap(&f), remap(&j), remap(&d));
    let body = render_lanes(row_dag, vars, LeafArrays::SHARED_SLOTS, &[(quote!(f), &fr), (quote!(j), &jr), (quote!(d), &dr)]);
    // The same kernel without `dF/dp * dp`, for one row in `f64` (`row_equations`): the forward
    // pass for `d` is not dead code there, a zero `dp` does not fold away in floating point.
    let body_fj = render_lanes(row_dag, vars, LeafArrays::SHARED_SLOTS, &[(quote!(f), &fr), (quote!(j), &jr)]);
    let shared_entries: Outputs = shared.iter().enumerate().map(|(slot, id)| (n(slot).into_token_stream(), *id)).collect();
    let shared_body = render_lanes(&dag, vars, LeafArrays::ARGUMENTS, &[(quote!(out), &shared_entries)]);
    let ns = shared.len();
    // Per row: the kernel, its share of the shared part, and one operation per input for `p(t)`.
    let row_ids: Vec<NodeId> = fr.iter().chain(&jr).chain(&dr).map(|(_, id)| *id).collect();
    let ops = row_dag.op_count(&row_ids) + dag.op_count(shared).div_ceil(shape.rows.max(1)) + k;
    let (nx, k_t, epr_t, ej, ns_t) = (n(shape.nx), n(k), n(epr), n(epr * shape.nx), n(ns));
    let kernel = quote! {
        #[doc = " The part of the parameter row kernel that depends on the unknowns only (the same for every row), one path per lane."]
        #[inline(always)]
        #[allow(clippy::all, unused_variables)]
        fn __row_param_shared<S: ::simhc::lanes::Lanes>(x: &[S; #nx], out: &mut [S; #ns_t]) {
            #shared_body
        }
        #[doc = " Row kernel from the row's parameters `p` (the declaration unexpanded) and the shared part `shared`, one path per lane: residuals `f`, Jacobian rows `j` and `dF/dp * dp` in `d`."]
        #[inline(always)]
        #[allow(clippy::all, unused_variables)]
        fn __row_param_lanes<S: ::simhc::lanes::Lanes>(
            x: &[S; #nx],
            shared: &[S; #ns_t],
            p: &[S; #k_t],
            dp: &[S; #k_t],
            f: &mut [S; #epr_t],
            j: &mut [S; #ej],
            d: &mut [S; #epr_t],
        ) {
            #body
        }
        #[doc = " Row kernel from the row's parameters `p` and the shared part `shared`, one path per lane: residuals `f` and Jacobian rows `j` only."]
        #[inline(always)]
        #[allow(clippy::all, unused_variables)]
        fn __row_param_fj<S: ::simhc::lanes::Lanes>(
            x: &[S; #nx],
            shared: &[S; #ns_t],
            p: &[S; #k_t],
            f: &mut [S; #epr_t],
            j: &mut [S; #ej],
        ) {
            #body_fj
        }
    };
    ParamLanes { kernel, ops, nx: shape.nx, k, epr, ej: epr * shape.nx, row_len, shared: ns }
}

/// The parameter row kernel of [`param_lanes`] and what its trait items need.
pub(super) struct ParamLanes {
    /// The kernel items (`__row_param_shared`, `__row_param_lanes`, `__row_param_fj`).
    pub kernel: TokenStream,
    /// Estimated operations per row (see [`param_lanes`]).
    pub ops: usize,
    nx: usize,
    k: usize,
    epr: usize,
    ej: usize,
    row_len: usize,
    shared: usize,
}

impl ParamLanes {
    /// The body of `simhc::ParamLanes` (`param_layout`, `shared`, `row_params`) and the doc of
    /// its impl; `preferred` when the estimate is below the coefficient kernel's
    /// (`coefficient_ops`).
    pub fn items(&self, preferred: bool, coefficient_ops: usize) -> (TokenStream, String) {
        let (nx, k_t, epr_t, ej, row_len_t, ns_t) = (n(self.nx), n(self.k), n(self.epr), n(self.ej), n(self.row_len), n(self.shared));
        let doc = format!(" Estimated operations per row: {} from the parameters, {} from the coefficients.", self.ops, coefficient_ops);
        let body = quote! {
            #[inline]
            fn param_layout(self) -> ::simhc::ParamRowLayout {
                ::simhc::ParamRowLayout { row_len: #row_len_t, inputs: #k_t, shared: #ns_t, preferred: #preferred }
            }
            #[inline(always)]
            fn shared<S: ::simhc::lanes::Lanes>(self, x: &[S; #nx], out: &mut [S]) {
                let Ok(out) = <&mut [S; #ns_t]>::try_from(out) else {
                    debug_assert!(false, "ParamLanes::shared: slice length differs from the layout");
                    return;
                };
                __SimhcRowKernels::__row_param_shared(x, out);
            }
            #[inline(always)]
            fn row_params<S: ::simhc::lanes::Lanes>(
                self,
                x: &[S; #nx],
                shared: &[S],
                p: &[S],
                dp: &[S],
                f: &mut [S],
                j: &mut [S],
                d: &mut [S],
            ) {
                let (Ok(shared), Ok(p), Ok(dp), Ok(f), Ok(j), Ok(d)) = (
                    <&[S; #ns_t]>::try_from(shared),
                    <&[S; #k_t]>::try_from(p),
                    <&[S; #k_t]>::try_from(dp),
                    <&mut [S; #epr_t]>::try_from(f),
                    <&mut [S; #ej]>::try_from(j),
                    <&mut [S; #epr_t]>::try_from(d),
                ) else {
                    debug_assert!(false, "ParamLanes::row_params: slice lengths differ from the layout");
                    return;
                };
                __SimhcRowKernels::__row_param_lanes(x, shared, p, dp, f, j, d);
            }
            #[inline]
            fn row_equations(self, x: &[f64; #nx], p: &[f64], f: &mut [f64], j: &mut [f64]) -> bool {
                let (Ok(p), Ok(f), Ok(j)) = (
                    <&[f64; #k_t]>::try_from(p),
                    <&mut [f64; #epr_t]>::try_from(f),
                    <&mut [f64; #ej]>::try_from(j),
                ) else {
                    return false;
                };
                let mut shared = [0.0f64; #ns_t];
                __SimhcRowKernels::__row_param_shared(x, &mut shared);
                __SimhcRowKernels::__row_param_fj(x, &shared, p, f, j);
                true
            }
        };
        (body, doc)
    }
}
