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

    /// Loads of used leaves followed by one `let` per live interior node. A product with a
    /// constant is emitted as `x.scale(c)` (real scaling: 2 multiplications in complex
    /// arithmetic instead of a full complex product); constants are loaded only where they
    /// are used otherwise.
    fn body(&self, outputs: &[NodeId]) -> TokenStream {
        let live = self.dag.reachable(outputs);
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
            if !live[i] {
                continue;
            }
            let id = NodeId(i as u32);
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
    let impls = instances.iter().map(|inst| instance(decl, inst));
    quote! {
        #(#attrs)*
        #vis mod #ident {
            #(#passthrough)*
            #unknowns
            #rows
            #globals
            #(#impls)*
        }
    }
}

fn instance(decl: &Declaration, inst: &Instance) -> TokenStream {
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

    let mut dag = Dag::default();
    let jp = derivs.param_jacobian(&mut dag);
    let param_jacobian = render(&dag, inst, &[(quote!(jp), &jp)]);

    let mut dag = Dag::default();
    let dir = derivs.param_directional(&mut dag);
    let param_directional = render(&dag, inst, &[(quote!(out), &dir)]);

    let split = crate::lower::split_coefficients(inst);
    let nc = n(split.table.len());
    let coefficient_form = coefficient_form(inst, &split, &type_name);

    // Packing helpers: rows then globals.
    let row_len_v: usize = decl.row_fields.iter().map(|f| f.shape.scalar_count()).sum();
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
    quote! {
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
    }
}

/// `impl CoefficientForm`: coefficients from parameters, and the system over coefficients.
fn coefficient_form(inst: &Instance, split: &crate::lower::CoefficientSplit, type_name: &Ident) -> TokenStream {
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
                (quote!(#i), dag.polynomial_grouped(f, vars))
            })
            .collect()
    };
    let jacobian_of = |dag: &mut Dag| -> Vec<(TokenStream, NodeId)> {
        let mut out = Vec::new();
        for (i, f) in split.equations.iter().enumerate() {
            for k in 0..inst.vars.nx() {
                let d = f.diff(k as Var);
                let (i, k) = (n(i), n(k));
                out.push((quote!((#i, #k)), dag.polynomial_grouped(&d, vars)));
            }
        }
        out
    };

    let mut dag = Dag::default();
    let f = residual_of(&mut dag, &split.equations);
    let j = jacobian_of(&mut dag);
    let fused = render_with(&dag, vars, &[(quote!(f), &f), (quote!(j), &j)]);

    let mut dag = Dag::default();
    let f = residual_of(&mut dag, &split.equations);
    let residual = render_with(&dag, vars, &[(quote!(f), &f)]);

    let mut dag = Dag::default();
    let lin = residual_of(&mut dag, &split.linear);
    // The linear part reads its coefficients from `dc`.
    let linear = render_with(&dag, vars, &[(quote!(out), &lin)]);

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
                let c = dc;
                #linear
            }
        }
    }
}

fn render(dag: &Dag, inst: &Instance, outputs: &[(TokenStream, &Vec<(TokenStream, NodeId)>)]) -> TokenStream {
    render_with(dag, &inst.vars, outputs)
}

fn render_with(dag: &Dag, vars: &VarTable, outputs: &[(TokenStream, &Vec<(TokenStream, NodeId)>)]) -> TokenStream {
    let r = Renderer { dag, vars };
    let ids: Vec<NodeId> = outputs.iter().flat_map(|(_, v)| v.iter().map(|(_, id)| *id)).collect();
    let body = r.body(&ids);
    let assigns = outputs.iter().map(|(target, entries)| assign_dense(&r, target.clone(), entries));
    quote!(#body #(#assigns)*)
}
