//! Emission: straight-line Rust for one instantiated system.
//!
//! Each trait method gets its own DAG (so the fused residual+Jacobian shares subexpressions
//! between the two), emitted as one `let` per live node in topological order. The code is
//! generic over `S: simhc::Scalar`, uses fixed-size nalgebra types, and cannot panic: all
//! indices are constants within the fixed sizes.

use crate::dag::{Dag, Node, NodeId};
use crate::decl::{Declaration, Field, Shape};
use crate::lower::{Instance, VarTable};
use crate::poly::Var;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote, ToTokens};

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

/// A variable name such as `row3.f[2]` made into an identifier fragment `row3_f_2`.
fn sanitize(name: &str) -> String {
    let mut out = String::with_capacity(name.len());
    for ch in name.chars() {
        if ch.is_ascii_alphanumeric() || ch == '_' {
            out.push(ch);
        } else if !out.ends_with('_') {
            out.push('_');
        }
    }
    out.trim_end_matches('_').to_string()
}

/// An index or size as an unsuffixed literal (`3`, not `3usize`).
fn n(v: usize) -> Literal {
    Literal::usize_unsuffixed(v)
}

fn f64_lit(c: f64) -> TokenStream {
    let lit = Literal::f64_unsuffixed(c.abs());
    if c < 0.0 {
        quote!(-#lit)
    } else {
        quote!(#lit)
    }
}

/// Renders the live part of a DAG as `let` statements and returns the tokens naming each node.
struct Renderer<'a> {
    dag: &'a Dag,
    vars: &'a VarTable,
    /// Lane kernels (`S: simhc::lanes::Lanes`): a product or real scaling used once, by a sum
    /// or difference, is emitted fused with it (`Lanes::mul_add`, `mul_sub`, `neg_mul_add`,
    /// `scale_add`), so lane types with fused multiply-adds use them (path lanes); the trait's
    /// defaults are the two operations in the unfused order.
    fused: bool,
}

/// How a sum or difference absorbs one of its operands, a product used only there.
#[derive(Clone, Copy)]
enum Fusion {
    /// `a * b + c` (either operand order of the sum).
    MulAdd { a: NodeId, b: NodeId, c: NodeId },
    /// `a * b - c`.
    MulSub { a: NodeId, b: NodeId, c: NodeId },
    /// `c - a * b`.
    NegMulAdd { a: NodeId, b: NodeId, c: NodeId },
    /// `k x + c` with a real constant `k`.
    ScaleAdd { x: NodeId, k: f64, c: NodeId },
}

impl Renderer<'_> {
    fn leaf_ident(&self, node: &Node) -> Option<Ident> {
        match node {
            Node::X(i) => Some(format_ident!("x_{}", sanitize(&self.vars.unknown_names[*i as usize]))),
            Node::P(i) => Some(format_ident!("p_{}", sanitize(&self.vars.param_names[*i as usize]))),
            Node::Dp(i) => Some(format_ident!("dp_{}", sanitize(&self.vars.param_names[*i as usize]))),
            Node::C(i) => Some(format_ident!("cf_{}", i)),
            _ => None,
        }
    }

    fn name(&self, id: NodeId) -> TokenStream {
        let node = &self.dag.nodes[id.0 as usize];
        if let Some(ident) = self.leaf_ident(node) {
            return quote!(#ident);
        }
        let ident = match node {
            Node::Const(_) => format_ident!("k{}", id.0),
            _ => format_ident!("t{}", id.0),
        };
        quote!(#ident)
    }

    /// For lane kernels: which sums and differences absorb a product (or real scaling) used
    /// only by them, and which products are absorbed (not emitted). A product that is an
    /// output, or used twice, stays.
    fn fusions(&self, outputs: &[NodeId], live: &[bool]) -> (Vec<Option<Fusion>>, Vec<bool>) {
        let nodes = &self.dag.nodes;
        let mut uses = vec![0usize; nodes.len()];
        for &o in outputs {
            uses[o.0 as usize] += 2;
        }
        for (i, node) in nodes.iter().enumerate() {
            if !live[i] {
                continue;
            }
            match node {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) => {
                    uses[a.0 as usize] += 1;
                    uses[b.0 as usize] += 1;
                }
                Node::Neg(a) => uses[a.0 as usize] += 1,
                _ => {}
            }
        }
        let mut fusions = vec![None; nodes.len()];
        let mut absorbed = vec![false; nodes.len()];
        // A product used once: its factors, or (real constant, other factor) for a scaling.
        let product = |id: NodeId, absorbed: &[bool]| -> Option<(NodeId, NodeId, Option<f64>)> {
            let i = id.0 as usize;
            if uses[i] != 1 || absorbed[i] {
                return None;
            }
            match nodes[i] {
                Node::Mul(a, b) => match (self.dag.const_value(a), self.dag.const_value(b)) {
                    (Some(k), None) => Some((b, a, Some(k))),
                    (None, Some(k)) => Some((a, b, Some(k))),
                    (None, None) => Some((a, b, None)),
                    (Some(_), Some(_)) => None,
                },
                _ => None,
            }
        };
        for (i, node) in nodes.iter().enumerate() {
            if !live[i] {
                continue;
            }
            let fusion = match *node {
                Node::Add(a, b) => match (product(a, &absorbed), product(b, &absorbed)) {
                    (Some(p), _) => Some((a, p, b, false)),
                    (None, Some(p)) => Some((b, p, a, false)),
                    _ => None,
                },
                // `p - c` with a full product `p`, or `c - p` (a product or a scaling).
                Node::Sub(a, b) => match (product(a, &absorbed), product(b, &absorbed)) {
                    (Some(p @ (_, _, None)), _) => Some((a, p, b, true)),
                    (_, Some(p)) => Some((b, p, a, false)),
                    _ => None,
                },
                _ => None,
            };
            let Some((pid, (x, y, k), c, product_first)) = fusion else {
                continue;
            };
            let negate = matches!(node, Node::Sub(..)) && !product_first;
            absorbed[pid.0 as usize] = true;
            fusions[i] = Some(match (k, product_first, negate) {
                (Some(k), _, true) => Fusion::ScaleAdd { x, k: -k, c },
                (Some(k), _, false) => Fusion::ScaleAdd { x, k, c },
                (None, true, _) => Fusion::MulSub { a: x, b: y, c },
                (None, false, true) => Fusion::NegMulAdd { a: x, b: y, c },
                (None, false, false) => Fusion::MulAdd { a: x, b: y, c },
            });
        }
        (fusions, absorbed)
    }

    /// Loads of used leaves followed by one `let` per live interior node. A product with a
    /// constant is emitted as `x.scale(c)` (real scaling: 2 multiplications in complex
    /// arithmetic instead of a full complex product); constants are loaded only where they
    /// are used otherwise.
    fn body(&self, outputs: &[NodeId]) -> TokenStream {
        let live = self.dag.reachable(outputs);
        let (fusions, absorbed) = if self.fused { self.fusions(outputs, &live) } else { (Vec::new(), Vec::new()) };
        let mut const_loaded = vec![false; self.dag.nodes.len()];
        for &o in outputs {
            const_loaded[o.0 as usize] = true;
        }
        for (i, node) in self.dag.nodes.iter().enumerate() {
            match node {
                _ if !live[i] => {}
                Node::Mul(a, b) if self.dag.const_value(*a).is_some() || self.dag.const_value(*b).is_some() => {}
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) => {
                    const_loaded[a.0 as usize] = true;
                    const_loaded[b.0 as usize] = true;
                }
                Node::Neg(a) => const_loaded[a.0 as usize] = true,
                _ => {}
            }
        }
        let mut loads = Vec::new();
        let mut lets = Vec::new();
        for (i, node) in self.dag.nodes.iter().enumerate() {
            if !live[i] || absorbed.get(i).copied().unwrap_or(false) {
                continue;
            }
            let id = NodeId(i as u32);
            if let Some(Some(fusion)) = fusions.get(i) {
                let t = format_ident!("t{}", id.0);
                let l = quote!(::simhc::lanes::Lanes);
                lets.push(match *fusion {
                    Fusion::MulAdd { a, b, c } => {
                        let (a, b, c) = (self.name(a), self.name(b), self.name(c));
                        quote!(let #t = #l::mul_add(#a, #b, #c);)
                    }
                    Fusion::MulSub { a, b, c } => {
                        let (a, b, c) = (self.name(a), self.name(b), self.name(c));
                        quote!(let #t = #l::mul_sub(#a, #b, #c);)
                    }
                    Fusion::NegMulAdd { a, b, c } => {
                        let (a, b, c) = (self.name(a), self.name(b), self.name(c));
                        quote!(let #t = #l::neg_mul_add(#a, #b, #c);)
                    }
                    Fusion::ScaleAdd { x, k, c } => {
                        let (x, k, c) = (self.name(x), f64_lit(k), self.name(c));
                        quote!(let #t = #l::scale_add(#x, #k, #c);)
                    }
                });
                continue;
            }
            match node {
                Node::X(k) | Node::P(k) | Node::Dp(k) | Node::C(k) => {
                    let ident = self.leaf_ident(node);
                    let k = n(*k as usize);
                    let src = match node {
                        Node::X(_) => quote!(x[#k]),
                        Node::P(_) => quote!(p[#k]),
                        Node::C(_) => quote!(c[#k]),
                        _ => quote!(dp[#k]),
                    };
                    loads.push(quote!(let #ident = #src;));
                }
                Node::Const(_) if !const_loaded[i] => {}
                Node::Const(bits) => {
                    // Hoisted once per function.
                    let lit = f64_lit(f64::from_bits(*bits));
                    let c = format_ident!("k{}", id.0);
                    loads.push(quote!(let #c: S = S::from_real(#lit);));
                }
                Node::Mul(a, b) if self.dag.const_value(*a).or(self.dag.const_value(*b)).is_some() => {
                    let (c, x) = match self.dag.const_value(*a) {
                        Some(c) => (c, *b),
                        None => (self.dag.const_value(*b).unwrap_or(1.0), *a),
                    };
                    let (lit, x) = (f64_lit(c), self.name(x));
                    let t = format_ident!("t{}", id.0);
                    lets.push(quote!(let #t = #x.scale(#lit);));
                }
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) => {
                    let (a, b) = (self.name(*a), self.name(*b));
                    let t = format_ident!("t{}", id.0);
                    let op = match node {
                        Node::Add(..) => quote!(+),
                        Node::Sub(..) => quote!(-),
                        _ => quote!(*),
                    };
                    lets.push(quote!(let #t = #a #op #b;));
                }
                Node::Neg(a) => {
                    let a = self.name(*a);
                    let t = format_ident!("t{}", id.0);
                    lets.push(quote!(let #t = -#a;));
                }
            }
        }
        quote!(#(#loads)* #(#lets)*)
    }
}

/// Emits assignments `target[idx] = node` for a dense output, with one `fill` for zeros.
fn assign_dense(r: &Renderer<'_>, target: TokenStream, entries: &[(TokenStream, NodeId)]) -> TokenStream {
    let mut zero = false;
    let mut stmts = Vec::new();
    for (idx, id) in entries {
        if r.dag.const_value(*id) == Some(0.0) {
            zero = true;
            continue;
        }
        let v = r.name(*id);
        stmts.push(quote!(#target[#idx] = #v;));
    }
    let fill = if zero { quote!(#target.fill(S::from_real(0.0));) } else { quote!() };
    quote!(#fill #(#stmts)*)
}

/// Derivative tables of one instance.
struct Derivatives<'a> {
    inst: &'a Instance,
    /// `dF_i/dx_k`.
    dx: Vec<Vec<crate::poly::Poly>>,
}

impl<'a> Derivatives<'a> {
    fn new(inst: &'a Instance) -> Self {
        let nx = inst.vars.nx();
        let dx = inst.equations.iter().map(|f| (0..nx).map(|k| f.diff(k as Var)).collect()).collect();
        Self { inst, dx }
    }

    fn residual(&self, dag: &mut Dag) -> Vec<(TokenStream, NodeId)> {
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

    fn jacobian(&self, dag: &mut Dag) -> Vec<(TokenStream, NodeId)> {
        let mut out = Vec::new();
        for (i, row) in self.dx.iter().enumerate() {
            for (k, d) in row.iter().enumerate() {
                let (i, k) = (n(i), n(k));
                out.push((quote!((#i, #k)), dag.polynomial(d, &self.inst.vars)));
            }
        }
        out
    }

    fn param_jacobian(&self, dag: &mut Dag) -> Vec<(TokenStream, NodeId)> {
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

    fn param_directional(&self, dag: &mut Dag) -> Vec<(TokenStream, NodeId)> {
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

/// Plain-data struct of a declaration section, with packing into a flat slice.
fn data_struct(name: &Ident, doc: &str, fields: &[Field]) -> TokenStream {
    let decls = fields.iter().map(|f| {
        let ident = &f.ident;
        let ty = f.shape.rust_type();
        let attrs = &f.attrs;
        quote!(#(#attrs)* pub #ident: #ty,)
    });
    let len_value: usize = fields.iter().map(|f| f.shape.scalar_count()).sum();
    let len = n(len_value);
    let mut writes = Vec::new();
    let mut reads = Vec::new();
    let mut next = 0usize;
    let mut k = || {
        next += 1;
        n(next - 1)
    };
    for f in fields {
        let ident = &f.ident;
        match f.shape {
            Shape::Scalar => {
                let k = k();
                writes.push(quote!(out[#k] = self.#ident;));
                reads.push(quote!(v.#ident = src[#k];));
            }
            Shape::Vector(_) | Shape::Quat => {
                for i in (0..f.shape.scalar_count()).map(n) {
                    let k = k();
                    writes.push(quote!(out[#k] = self.#ident[#i];));
                    reads.push(quote!(v.#ident[#i] = src[#k];));
                }
            }
            Shape::Matrix(r, c) => {
                for i in (0..r).map(n) {
                    for j in (0..c).map(n) {
                        let k = k();
                        writes.push(quote!(out[#k] = self.#ident[#i][#j];));
                        reads.push(quote!(v.#ident[#i][#j] = src[#k];));
                    }
                }
            }
            Shape::Sym(size) => {
                for i in 0..size {
                    for j in i..size {
                        let k = k();
                        let diagonal = i == j;
                        let (i, j) = (n(i), n(j));
                        writes.push(quote!(out[#k] = self.#ident[#i][#j];));
                        if diagonal {
                            reads.push(quote!(v.#ident[#i][#j] = src[#k];));
                        } else {
                            reads.push(quote!(v.#ident[#i][#j] = src[#k]; v.#ident[#j][#i] = src[#k];));
                        }
                    }
                }
            }
        }
    }
    let sym_note = if fields.iter().any(|f| matches!(f.shape, Shape::Sym(_))) {
        " Symmetric matrices contribute their upper triangle, row by row."
    } else {
        ""
    };
    let write_doc = format!(" Writes the {len_value} scalars in parameter order (declaration order, vectors by component).{sym_note}");
    quote! {
        #[doc = #doc]
        #[derive(Debug, Clone, Copy, PartialEq, Default)]
        pub struct #name { #(#decls)* }
        impl #name {
            /// Number of scalars.
            pub const LEN: usize = #len;
            #[doc = #write_doc]
            pub fn write_to(&self, out: &mut [f64; #len]) { #(#writes)* }
            /// Reads the scalars written by `write_to`.
            pub fn read_from(src: &[f64; #len]) -> Self {
                let mut v = Self::default();
                #(#reads)*
                v
            }
        }
    }
}

/// The whole generated module.
/// Output entries of a rendered function: index tokens and the node they are assigned.
type Outputs = Vec<(TokenStream, NodeId)>;

/// Sizes shared by the row kernels of one instance.
#[derive(Clone, Copy)]
struct RowShape {
    nx: usize,
    nf: usize,
    rows: usize,
    /// Equations per row.
    epr: usize,
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
    let lanes = quote!(<S as ::simhc::Scalar>::Lanes);
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
    let (j_arg, j_field, j_name) = if with_j {
        (quote!(, j: &mut [S; #ej]), quote!(j: &'a mut [S; #ej],), quote!(j))
    } else {
        (quote!(), quote!(), quote!())
    };
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

/// Outputs `f[i]` (and `j[i * nx + k]`) of the first `epr` equations `eqs` of a one-row
/// lowering, into `dag`.
fn row_outputs(
    dag: &mut Dag,
    eqs: &[crate::poly::Poly],
    vars: &VarTable,
    shape: RowShape,
    with_j: bool,
) -> (Outputs, Outputs) {
    let node = |dag: &mut Dag, poly: &crate::poly::Poly| dag.polynomial(poly, vars);
    let f = (0..shape.epr).map(|i| (n(i).into_token_stream(), node(dag, &eqs[i]))).collect();
    let mut j = Vec::new();
    if with_j {
        for i in 0..shape.epr {
            for k in 0..shape.nx {
                j.push((n(i * shape.nx + k).into_token_stream(), node(dag, &eqs[i].diff(k as Var))));
            }
        }
    }
    (f, j)
}

/// Scalar code of the global equations (`eqs[rows * epr ..]`) into `f` / `j`, in a block; empty
/// without global equations. Emitted *before* the row loop: it may zero-fill the whole output.
fn global_part(eqs: &[crate::poly::Poly], vars: &VarTable, shape: RowShape, with_f: bool, with_j: bool) -> TokenStream {
    let first = shape.rows * shape.epr;
    if first == shape.nf {
        return quote!();
    }
    let mut dag = Dag::default();
    let node = |dag: &mut Dag, poly: &crate::poly::Poly| dag.polynomial(poly, vars);
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
    let body = render_with(&dag, vars, &[(quote!(f), &f), (quote!(j), &j)]);
    quote!({ #body })
}

/// Row kernels of a problem with rows: the equations of *one* row (lowered from the declaration
/// with a single row), generic over `simhc::lanes::Lanes` so that generated code evaluates
/// `LANES` rows at once, plus scalar code for the global equations. Every row runs the same
/// straight-line code, so this replaces `rows` expanded copies by one kernel run
/// `ceil(rows / LANES)` times (GRPS7 in `Complex<f64>`: residual + Jacobian 1.79 us expanded,
/// 0.45 us in lanes with AVX2).
struct RowKernels {
    /// Kernel items of the parameter form.
    items: TokenStream,
    /// Bodies of `residual`, `jacobian`, `residual_jacobian`.
    residual: TokenStream,
    jacobian: TokenStream,
    fused: TokenStream,
    /// The one-row lowering.
    one: Instance,
    shape: RowShape,
    row_len: usize,
    /// The row kernel from the row's parameters, unexpanded (see [`param_lanes`]).
    param_lanes: ParamLanes,
}

impl RowKernels {
    fn new(decl: &Declaration, inst: &Instance, row_len: usize) -> Self {
        let one = crate::lower::lower(decl, 1);
        let shape = RowShape { nx: inst.vars.nx(), nf: inst.equations.len(), rows: inst.rows, epr: inst.eqs_per_row };
        let npk = one.vars.np();

        let mut dag = Dag::default();
        let (f, _) = row_outputs(&mut dag, &one.equations, &one.vars, shape, false);
        let kernel_residual = render_lanes(&dag, &one.vars, &[(quote!(f), &f)]);
        let mut dag = Dag::default();
        let (f, j) = row_outputs(&mut dag, &one.equations, &one.vars, shape, true);
        let kernel_fused = render_lanes(&dag, &one.vars, &[(quote!(f), &f), (quote!(j), &j)]);
        let kernel_residual = rename_row_input(kernel_residual, "p");
        let kernel_fused = rename_row_input(kernel_fused, "p");

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
        let param_lanes = param_lanes(decl, &one, shape, row_len);
        Self { items: quote!(#(#items)*), residual, jacobian, fused, one, shape, row_len, param_lanes }
    }

    /// The coefficient form in lanes, when the coefficients of the instance are `rows` blocks
    /// of the one-row coefficients (checked), else `None`: kernel items and the bodies of
    /// `residual_jacobian_coeffs`, `residual_coeffs`, `coefficient_part`.
    fn coefficient_form(
        &self,
        inst: &Instance,
        split: &crate::lower::CoefficientSplit,
    ) -> Option<(TokenStream, TokenStream, TokenStream, TokenStream, TokenStream)> {
        let one_split = crate::lower::split_coefficients(&self.one);
        if !row_blocks(split, &one_split, inst, &self.one, self.row_len) {
            return None;
        }
        let shape = self.shape;
        let nc1 = one_split.table.len();
        let vars = &one_split.vars;
        let ids = |entries: &[&Outputs]| -> Vec<NodeId> { entries.iter().flat_map(|e| e.iter().map(|(_, id)| *id)).collect() };
        let mut dag = Dag::default();
        let (f, j) = row_outputs(&mut dag, &one_split.equations, vars, shape, true);
        let k_fused = rename_row_input(render_lanes(&dag, vars, &[(quote!(f), &f), (quote!(j), &j)]), "c");
        let mut coefficient_ops = dag.op_count(&ids(&[&f, &j]));
        let mut dag = Dag::default();
        let (f, _) = row_outputs(&mut dag, &one_split.equations, vars, shape, false);
        let k_residual = rename_row_input(render_lanes(&dag, vars, &[(quote!(f), &f)]), "c");
        let mut dag = Dag::default();
        let (f, _) = row_outputs(&mut dag, &one_split.linear, vars, shape, false);
        let k_linear = rename_row_input(render_lanes(&dag, vars, &[(quote!(f), &f)]), "c");
        // The path-lane operation evaluates the fused and the linear kernel, after a Horner pass
        // for `c(t)` and `c'(t)` of each coefficient (about two operations per degree in `t`; on
        // a straight parameter segment the degree of `c` in `p`).
        let degree = one_split.table.iter().map(|c| c.degree() as usize).max().unwrap_or(0);
        coefficient_ops += dag.op_count(&ids(&[&f])) + nc1 * 2 * degree;

        let lp = |kernel: &str, src: TokenStream, with_j: bool, f_out: TokenStream, j_out: Option<TokenStream>| {
            row_loop(shape, kernel, src, nc1, nc1, with_j, Some(f_out), j_out)
        };
        let g = |eqs: &[crate::poly::Poly], f: bool, j: bool| global_part(eqs, &split.vars, shape, f, j);
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
        // `coefficient_part_poly`: only when the global equations' linear part vanishes (no
        // coefficients outside the row blocks).
        let first_global = shape.rows * shape.epr;
        let mut lane_kernel = quote!();
        let poly_fn = if split.linear[first_global..].iter().all(|p| p.is_zero()) {
            let (rows, nc1_t, epr, nx_t, nf_t) = (n(shape.rows), n(nc1), n(shape.epr), n(shape.nx), n(shape.nf));
            let lanes = quote!(<S as ::simhc::Scalar>::Lanes);
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
                (quote!(poly), quote!(&'a [<S as ::simhc::Scalar>::Lanes])),
                (quote!(out), quote!(&'a mut ::simhc::__private::nalgebra::SVector<S, #nf_t>)),
            ];
            let wrapped = dispatched(&args, body);
            let (kernel, lanes_items) = self.path_lanes(&split.equations, &split.vars, nc1);
            let param = &self.param_lanes;
            let param_kernel = &param.kernel;
            let param_items = param.items(param.ops < coefficient_ops, coefficient_ops);
            lane_kernel = quote!(#kernel #param_kernel);
            let lanes_items = quote!(#lanes_items #param_items);
            quote! {
                #lanes_items
                const ROW_LAYOUT: ::core::option::Option<(usize, usize)> = ::core::option::Option::Some((#rows, #nc1_t));
                #[inline]
                fn coefficient_part_poly<S: ::simhc::Scalar>(
                    x: &::simhc::__private::nalgebra::SVector<S, #nx_t>,
                    t: f64,
                    poly: &[<S as ::simhc::Scalar>::Lanes],
                    out: &mut ::simhc::__private::nalgebra::SVector<S, #nf_t>,
                ) {
                    #wrapped
                }
            }
        } else {
            quote!()
        };
        Some((quote!(#(#items)* #lane_kernel), fused, residual, linear, poly_fn))
    }
}

impl RowKernels {
    /// `CoefficientForm`'s path-lane items (`PATH_LANES`, `lanes_row`, `lanes_globals`): the
    /// coefficient-form row kernels and the (coefficient-free) global equations, generic over
    /// `simhc::lanes::Lanes`, for callers that put one *path* in each lane. Returns the kernel
    /// item of the global equations (shared by the instances, like the row kernels; empty
    /// without global equations) and the trait items.
    fn path_lanes(&self, eqs: &[crate::poly::Poly], vars: &VarTable, nc1: usize) -> (TokenStream, TokenStream) {
        let shape = self.shape;
        let first = shape.rows * shape.epr;
        let ng = shape.nf - first;
        let (nx, k, epr, ej, ng_t, ngj) =
            (n(shape.nx), n(nc1), n(shape.epr), n(shape.epr * shape.nx), n(ng), n(ng * shape.nx));
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
            let body = render_lanes(&dag, vars, &[(quote!(f), &f), (quote!(j), &j)]);
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
                    return;
                };
                __SimhcRowKernels::__global_lanes(x, f, j);
            };
            (kernel, call)
        };
        let items = quote! {
            const PATH_LANES: ::core::option::Option<usize> = ::core::option::Option::Some(#epr);
            #[inline(always)]
            fn lanes_row<S: ::simhc::lanes::Lanes>(
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
                    return;
                };
                __SimhcRowKernels::__row_coeff_residual_jacobian(x, c, f, j);
                __SimhcRowKernels::__row_coeff_linear(x, dc, d);
            }
            #[inline(always)]
            #[allow(unused_variables)]
            fn lanes_globals<S: ::simhc::lanes::Lanes>(x: &[S; #nx], f: &mut [S], j: &mut [S]) {
                #globals
            }
        };
        (kernel, items)
    }
}

/// The path-lane row kernel from the row's *parameters*: the row equations lowered without
/// expansion (the declared expression as a DAG, [`crate::dag::DagAlgebra`]: `rotation(q)`
/// formed once, `R * (v x f)` not multiplied out), their `x`-gradient by reverse mode and
/// `dF/dp * dp` by forward mode on that DAG. The batch tracker feeds it `p(t)` and `dp/dt`
/// (`k` entries per row: the row's `row_len` parameters, then the globals) instead of the
/// coefficients of the expansion, which need a Horner pass over many more entries per row
/// (GRPS: 12 parameters against 38 coefficients).
fn param_lanes(decl: &Declaration, one: &Instance, shape: RowShape, row_len: usize) -> ParamLanes {
    let mut dag = Dag::default();
    let (eqs, vars, epr, _) =
        crate::lower::evaluate(&mut crate::dag::DagAlgebra { dag: &mut dag, nx: one.vars.nx() }, None, decl, 1);
    let k = vars.np();
    let xs: Vec<NodeId> = (0..shape.nx).map(|i| dag.leaf(i as Var, &vars)).collect();
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
    let (row_dag, map, shared) = hoist_x_only(&dag, &outputs);
    let remap = |entries: &[(TokenStream, NodeId)]| -> Vec<(TokenStream, NodeId)> {
        entries.iter().map(|(t, id)| (t.clone(), map[id.0 as usize].unwrap_or(*id))).collect()
    };
    let (fr, jr, dr) = (remap(&f), remap(&j), remap(&d));
    let body = rename_array(
        render_lanes(&row_dag, &vars, &[(quote!(f), &fr), (quote!(j), &jr), (quote!(d), &dr)]),
        "c",
        "shared",
    );
    let shared_entries: Vec<(TokenStream, NodeId)> =
        shared.iter().enumerate().map(|(slot, id)| (n(slot).into_token_stream(), *id)).collect();
    let shared_body = render_lanes(&dag, &vars, &[(quote!(out), &shared_entries)]);
    let ns = shared.len();
    // Per row: the kernel, its share of the shared part, and one operation per input for `p(t)`.
    let row_ids: Vec<NodeId> = fr.iter().chain(&jr).chain(&dr).map(|(_, id)| *id).collect();
    let ops = row_dag.op_count(&row_ids) + dag.op_count(&shared).div_ceil(shape.rows.max(1)) + k;
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
    };
    ParamLanes { kernel, ops, nx: shape.nx, k, epr, ej: epr * shape.nx, row_len, shared: ns }
}

/// Splits the DAG of `outputs` at the nodes that depend on the unknowns alone. Returns a copy
/// (the row DAG) in which each such node that a node depending on the parameters (or an
/// output) reads becomes a leaf `Node::C(slot)`; `map[i]`, the copy of node `i`; and the
/// original nodes of the slots, in slot order. Interior nodes only: leaves and constants are as
/// cheap to load as a slot.
fn hoist_x_only(dag: &Dag, outputs: &[NodeId]) -> (Dag, Vec<Option<NodeId>>, Vec<NodeId>) {
    let live = dag.reachable(outputs);
    let len = dag.nodes.len();
    let x_only: Vec<bool> =
        dag.depends_on(|n| matches!(n, Node::P(_) | Node::Dp(_) | Node::C(_))).into_iter().map(|d| !d).collect();
    let interior = |i: usize| !matches!(dag.nodes[i], Node::X(_) | Node::Const(_));
    // Slots: x-only interior nodes read by a parameter-dependent node, or outputs.
    let mut slot_of = vec![None; len];
    let mut shared = Vec::new();
    let mut take = |i: usize, slot_of: &mut Vec<Option<usize>>| {
        if x_only[i] && interior(i) && slot_of[i].is_none() {
            slot_of[i] = Some(shared.len());
            shared.push(NodeId(i as u32));
        }
    };
    for (i, node) in dag.nodes.iter().enumerate() {
        if !live[i] || x_only[i] {
            continue;
        }
        match *node {
            Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) => {
                take(a.0 as usize, &mut slot_of);
                take(b.0 as usize, &mut slot_of);
            }
            Node::Neg(a) => take(a.0 as usize, &mut slot_of),
            _ => {}
        }
    }
    for o in outputs {
        take(o.0 as usize, &mut slot_of);
    }
    let mut row = Dag::default();
    let mut map: Vec<Option<NodeId>> = vec![None; len];
    for (i, node) in dag.nodes.iter().enumerate() {
        if !live[i] {
            continue;
        }
        let m = |id: NodeId| map[id.0 as usize].unwrap_or(id);
        map[i] = Some(match (slot_of[i], node) {
            (Some(slot), _) => row.intern(Node::C(slot as u32)),
            (None, _) if x_only[i] && interior(i) => continue,
            (None, Node::Add(a, b)) => row.intern(Node::Add(m(*a), m(*b))),
            (None, Node::Sub(a, b)) => row.intern(Node::Sub(m(*a), m(*b))),
            (None, Node::Mul(a, b)) => row.intern(Node::Mul(m(*a), m(*b))),
            (None, Node::Neg(a)) => row.intern(Node::Neg(m(*a))),
            (None, leaf) => row.intern(leaf.clone()),
        });
    }
    (row, map, shared)
}

/// The parameter row kernel of [`param_lanes`] and what its trait items need.
struct ParamLanes {
    /// The kernel items (`__row_param_shared`, `__row_param_lanes`).
    kernel: TokenStream,
    /// Estimated operations per row (see [`param_lanes`]).
    ops: usize,
    nx: usize,
    k: usize,
    epr: usize,
    ej: usize,
    row_len: usize,
    shared: usize,
}

impl ParamLanes {
    /// The trait items `PARAM_LANES`, `lanes_params_shared`, `lanes_row_params`; `preferred`
    /// when the estimate is below the coefficient kernel's (`coefficient_ops`).
    fn items(&self, preferred: bool, coefficient_ops: usize) -> TokenStream {
        let (nx, k_t, epr_t, ej, row_len_t, ns_t) = (n(self.nx), n(self.k), n(self.epr), n(self.ej), n(self.row_len), n(self.shared));
        let doc = format!(
            " Estimated operations per row: {} from the parameters, {} from the coefficients.",
            self.ops, coefficient_ops
        );
        quote! {
            #[doc = #doc]
            const PARAM_LANES: ::core::option::Option<::simhc::ParamRowLayout> =
                ::core::option::Option::Some(::simhc::ParamRowLayout { row_len: #row_len_t, inputs: #k_t, shared: #ns_t, preferred: #preferred });
            #[inline(always)]
            fn lanes_params_shared<S: ::simhc::lanes::Lanes>(x: &[S; #nx], out: &mut [S]) {
                if let Ok(out) = <&mut [S; #ns_t]>::try_from(out) {
                    __SimhcRowKernels::__row_param_shared(x, out);
                }
            }
            #[inline(always)]
            fn lanes_row_params<S: ::simhc::lanes::Lanes>(
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
                    return;
                };
                __SimhcRowKernels::__row_param_lanes(x, shared, p, dp, f, j, d);
            }
        }
    }
}

/// The global rows of the linear part `sum_k dc_k m_k(x)` into `out`, as scalar code.
fn global_linear(eqs: &[crate::poly::Poly], vars: &VarTable, shape: RowShape) -> TokenStream {
    let first = shape.rows * shape.epr;
    let mut dag = Dag::default();
    let f: Vec<_> = (first..shape.nf).map(|g| (n(g).into_token_stream(), dag.polynomial(&eqs[g], vars))).collect();
    let body = render_with(&dag, vars, &[(quote!(out), &f)]);
    quote!({ let c = dc; #body })
}

/// Kernel bodies read their row inputs from `r`: the renderer loads parameters from `p[..]` and
/// coefficients from `c[..]`; rename the array of the kernel's row input (`from`) to `r`.
fn rename_row_input(body: TokenStream, from: &str) -> TokenStream {
    rename_array(body, from, "r")
}

/// Renames the indexed array `from[..]` of a rendered body to `to[..]`.
fn rename_array(body: TokenStream, from: &str, to: &str) -> TokenStream {
    use proc_macro2::{Group, TokenTree};
    fn walk(ts: TokenStream, from: &str, to: &str) -> TokenStream {
        let mut out = Vec::new();
        let mut iter = ts.into_iter().peekable();
        while let Some(tt) = iter.next() {
            match tt {
                TokenTree::Ident(ref id) if id == from => {
                    // Only an indexing `from[..]`.
                    if matches!(iter.peek(), Some(TokenTree::Group(g)) if g.delimiter() == proc_macro2::Delimiter::Bracket) {
                        out.push(TokenTree::Ident(Ident::new(to, id.span())));
                    } else {
                        out.push(tt);
                    }
                }
                TokenTree::Group(g) => {
                    let mut ng = Group::new(g.delimiter(), walk(g.stream(), from, to));
                    ng.set_span(g.span());
                    out.push(TokenTree::Group(ng));
                }
                other => out.push(other),
            }
        }
        out.into_iter().collect()
    }
    walk(body, from, to)
}

/// Whether the coefficient table of the full instance is `rows` consecutive copies of the
/// one-row table, row `r`'s with the row-0 parameters renamed to row `r`'s (and globals moved
/// after all rows): then row `r`'s coefficients are `c[r * nc1 .. (r + 1) * nc1]` in the same
/// order as the one-row kernel's.
fn row_blocks(
    full: &crate::lower::CoefficientSplit,
    one: &crate::lower::CoefficientSplit,
    inst: &Instance,
    one_inst: &Instance,
    row_len: usize,
) -> bool {
    use crate::poly::{Monomial, Poly};
    let (nx, nc1) = (inst.vars.nx() as Var, one.table.len());
    if full.table.len() != inst.rows * nc1 || one_inst.vars.nx() != inst.vars.nx() {
        return false;
    }
    let rename = |v: Var, r: usize| -> Var {
        if v < nx {
            v
        } else {
            let j = (v - nx) as usize;
            let k = if j < row_len { r * row_len + j } else { inst.rows * row_len + (j - row_len) };
            nx + k as Var
        }
    };
    (0..inst.rows).all(|r| {
        (0..nc1).all(|m| {
            let mut renamed = Poly::zero();
            for (mono, &c) in &one.table[m].terms {
                renamed.add_term(Monomial(mono.0.iter().map(|&(v, e)| (rename(v, r), e)).collect()), c);
            }
            renamed == full.table[r * nc1 + m]
        })
    })
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

pub fn module(decl: &Declaration, instances: &[Instance]) -> TokenStream {
    let m = &decl.module;
    let attrs = &m.attrs;
    let vis = &m.vis;
    let ident = &m.ident;
    let passthrough = &decl.passthrough;
    let unknowns = data_struct(&format_ident!("Unknowns"), " The unknowns of the problem.", &decl.unknowns);
    let rows = if decl.row_fields.is_empty() {
        quote!()
    } else {
        data_struct(&format_ident!("Row"), " Parameters of one correspondence (row).", &decl.row_fields)
    };
    let globals = if decl.globals.is_empty() {
        quote!()
    } else {
        data_struct(&format_ident!("Globals"), " Parameters shared by all rows.", &decl.globals)
    };
    // Row kernels depend on the declaration only: emitted once for all instances.
    let mut kernels: Vec<TokenStream> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let impls: Vec<TokenStream> = instances
        .iter()
        .map(|inst| {
            let (tokens, items) = instance(decl, inst);
            for item in items {
                if seen.insert(item.to_string()) {
                    kernels.push(item);
                }
            }
            tokens
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
    quote! {
        #(#attrs)*
        #vis mod #ident {
            #(#passthrough)*
            #unknowns
            #rows
            #globals
            #kernels
            #(#impls)*
        }
    }
}

/// The items of one instance, and its row-kernel items (to be emitted once per module).
fn instance(decl: &Declaration, inst: &Instance) -> (TokenStream, Vec<TokenStream>) {
    let base = decl.module.ident.to_string();
    let has_rows = !decl.row_fields.is_empty();
    let (type_name, problem_name) = if has_rows {
        (format_ident!("{}{}", camel(&base), inst.rows), format!("{base}{}", inst.rows))
    } else {
        (format_ident!("{}", camel(&base)), base.clone())
    };
    let (nx_v, nf_v, np_v) = (inst.vars.nx(), inst.equations.len(), inst.vars.np());
    let (nx, nf, np) = (n(nx_v), n(nf_v), n(np_v));
    let n_rows = n(inst.rows);
    let unknown_names = &inst.vars.unknown_names;
    let param_names = &inst.vars.param_names;
    let derivs = Derivatives::new(inst);
    let sv = quote!(::simhc::__private::nalgebra::SVector);
    let sm = quote!(::simhc::__private::nalgebra::SMatrix);

    let row_len_v: usize = decl.row_fields.iter().map(|f| f.shape.scalar_count()).sum();
    let row_kernels = (has_rows && inst.rows >= 2).then(|| RowKernels::new(decl, inst, row_len_v));
    let (residual, jacobian, fused, kernel_items) = if let Some(k) = &row_kernels {
        (k.residual.clone(), k.jacobian.clone(), k.fused.clone(), k.items.clone())
    } else {
        let mut dag = Dag::default();
        let f = derivs.residual(&mut dag);
        let residual = render(&dag, inst, &[(quote!(f), &f)]);

        let mut dag = Dag::default();
        let j = derivs.jacobian(&mut dag);
        let jacobian = render(&dag, inst, &[(quote!(j), &j)]);

        let mut dag = Dag::default();
        let f = derivs.residual(&mut dag);
        let j = derivs.jacobian(&mut dag);
        let fused = render(&dag, inst, &[(quote!(f), &f), (quote!(j), &j)]);
        (residual, jacobian, fused, quote!())
    };

    let mut dag = Dag::default();
    let jp = derivs.param_jacobian(&mut dag);
    let param_jacobian = render(&dag, inst, &[(quote!(jp), &jp)]);

    let mut dag = Dag::default();
    let dir = derivs.param_directional(&mut dag);
    let param_directional = render(&dag, inst, &[(quote!(out), &dir)]);

    let split = crate::lower::split_coefficients(inst);
    let nc = n(split.table.len());
    let laned_coefficients = row_kernels.as_ref().and_then(|k| k.coefficient_form(inst, &split));
    let coefficient_form = coefficient_form(inst, &split, &type_name, laned_coefficients.as_ref().map(|l| (&l.1, &l.2, (&l.3, &l.4))));
    let coefficient_items = laned_coefficients.as_ref().map(|l| l.0.clone()).unwrap_or_default();

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
        }

        impl ::simhc::ProblemInfo for #type_name {
            const NAME: &'static str = #problem_name;
            const UNKNOWN_NAMES: &'static [&'static str] = &[#(#unknown_names),*];
            const PARAM_NAMES: &'static [&'static str] = &[#(#param_names),*];
        }

        impl ::simhc::ProblemLayout for #type_name {
            const LAYOUT: ::simhc::Layout = ::simhc::Layout {
                unknowns: &[#(#layout_unknowns),*],
                row: &[#(#layout_row),*],
                globals: &[#(#layout_globals),*],
                rows: #n_rows,
                per_row: #row_len,
            };
        }

        #[allow(clippy::all, unused_variables)]
        impl ::simhc::Problem<#nx, #nf, #np> for #type_name {
            #[inline]
            fn residual<S: ::simhc::Scalar>(x: &#sv<S, #nx>, p: &#sv<S, #np>, f: &mut #sv<S, #nf>) {
                #residual
            }
            #[inline]
            fn jacobian<S: ::simhc::Scalar>(x: &#sv<S, #nx>, p: &#sv<S, #np>, j: &mut #sm<S, #nf, #nx>) {
                #jacobian
            }
            #[inline]
            fn residual_jacobian<S: ::simhc::Scalar>(
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
    (tokens, items)
}

/// `impl CoefficientForm`: coefficients from parameters, and the system over coefficients.
fn coefficient_form(
    inst: &Instance,
    split: &crate::lower::CoefficientSplit,
    type_name: &Ident,
    laned: Option<(&TokenStream, &TokenStream, (&TokenStream, &TokenStream))>,
) -> TokenStream {
    let (nx, nf, np, nc) = (n(inst.vars.nx()), n(inst.equations.len()), n(inst.vars.np()), n(split.table.len()));
    let sv = quote!(::simhc::__private::nalgebra::SVector);
    let sm = quote!(::simhc::__private::nalgebra::SMatrix);
    let vars = &split.vars;

    let mut dag = Dag::default();
    let entries: Vec<(TokenStream, NodeId)> = split
        .table
        .iter()
        .enumerate()
        .map(|(k, poly)| {
            let k = n(k);
            (quote!(#k), dag.polynomial(poly, vars))
        })
        .collect();
    let coefficients = render_with(&dag, vars, &[(quote!(c), &entries)]);

    let residual_of = |dag: &mut Dag, polys: &[crate::poly::Poly]| -> Vec<(TokenStream, NodeId)> {
        polys
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let i = n(i);
                (quote!(#i), dag.polynomial(f, vars))
            })
            .collect()
    };
    let jacobian_of = |dag: &mut Dag| -> Vec<(TokenStream, NodeId)> {
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

    let (fused, residual, linear, linear_poly) = match laned {
        Some((fused, residual, (linear, linear_poly))) => (fused.clone(), residual.clone(), linear.clone(), linear_poly.clone()),
        None => {
            let mut dag = Dag::default();
            let f = residual_of(&mut dag, &split.equations);
            let j = jacobian_of(&mut dag);
            let fused = render_with(&dag, vars, &[(quote!(f), &f), (quote!(j), &j)]);

            let mut dag = Dag::default();
            let f = residual_of(&mut dag, &split.equations);
            let residual = render_with(&dag, vars, &[(quote!(f), &f)]);

            let mut dag = Dag::default();
            let lin = residual_of(&mut dag, &split.linear);
            // The linear part reads its coefficients from `dc` (renamed `c`).
            let linear = render_with(&dag, vars, &[(quote!(out), &lin)]);
            (fused, residual, quote!(let c = dc; #linear), quote!())
        }
    };

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
            #linear_poly
        }
    }
}

fn render(dag: &Dag, inst: &Instance, outputs: &[(TokenStream, &Vec<(TokenStream, NodeId)>)]) -> TokenStream {
    render_with(dag, &inst.vars, outputs)
}

fn render_with(dag: &Dag, vars: &VarTable, outputs: &[(TokenStream, &Vec<(TokenStream, NodeId)>)]) -> TokenStream {
    render_body(Renderer { dag, vars, fused: false }, outputs)
}

/// [`render_with`] for a lane kernel (`S: simhc::lanes::Lanes`), with fused products.
fn render_lanes(dag: &Dag, vars: &VarTable, outputs: &[(TokenStream, &Vec<(TokenStream, NodeId)>)]) -> TokenStream {
    render_body(Renderer { dag, vars, fused: true }, outputs)
}

fn render_body(r: Renderer<'_>, outputs: &[(TokenStream, &Vec<(TokenStream, NodeId)>)]) -> TokenStream {
    let ids: Vec<NodeId> = outputs.iter().flat_map(|(_, v)| v.iter().map(|(_, id)| *id)).collect();
    let body = r.body(&ids);
    let assigns = outputs.iter().map(|(target, entries)| assign_dense(&r, target.clone(), entries));
    quote!(#body #(#assigns)*)
}

/// `::simhc::FieldLayout` literals of `fields`, offsets counted from the first.
fn field_layouts(fields: &[Field]) -> Vec<TokenStream> {
    let mut offset = 0usize;
    fields
        .iter()
        .map(|f| {
            let name = f.ident.to_string();
            let kind = match f.shape {
                Shape::Scalar => quote!(::simhc::FieldKind::Scalar),
                Shape::Vector(k) => {
                    let k = n(k);
                    quote!(::simhc::FieldKind::Vector(#k))
                }
                Shape::Quat => quote!(::simhc::FieldKind::Quat),
                Shape::Matrix(r, c) => {
                    let (r, c) = (n(r), n(c));
                    quote!(::simhc::FieldKind::Matrix(#r, #c))
                }
                Shape::Sym(k) => {
                    let k = n(k);
                    quote!(::simhc::FieldKind::Sym(#k))
                }
            };
            let at = n(offset);
            offset += f.shape.scalar_count();
            quote!(::simhc::FieldLayout { name: #name, kind: #kind, offset: #at })
        })
        .collect()
}
