//! Rendering: a DAG as straight-line Rust. Loads of the used leaves, one `let` per live
//! interior node in topological order, then the assignments of the outputs. Every emitted
//! function body comes from here; the callers only choose the outputs, the arrays the leaves
//! are read from and whether products are fused (lane kernels).

use crate::dag::{Dag, Node, NodeId};
use crate::lower::VarTable;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use super::n;

/// Output entries of a rendered function: index tokens and the node they are assigned.
pub(super) type Outputs = Vec<(TokenStream, NodeId)>;

/// The array each kind of leaf is loaded from (`let p_row0_f_0 = p[3];`). The local names stay
/// the same; a kernel whose inputs arrive in another argument names that argument here instead
/// of renaming tokens after rendering.
#[derive(Clone, Copy, Debug)]
pub(super) struct LeafArrays {
    /// Unknowns ([`Node::X`]).
    pub x: &'static str,
    /// Parameters ([`Node::P`]).
    pub p: &'static str,
    /// Parameter directions ([`Node::Dp`]).
    pub dp: &'static str,
    /// Coefficients, or slots of a hoisted part ([`Node::C`]).
    pub c: &'static str,
}

impl LeafArrays {
    /// The arguments of the trait methods.
    pub const ARGUMENTS: Self = Self { x: "x", p: "p", dp: "dp", c: "c" };
    /// A row kernel from the parameters: the row's inputs arrive in `r`.
    pub const ROW_PARAMS: Self = Self { p: "r", ..Self::ARGUMENTS };
    /// A row kernel of the coefficient form: the row's coefficients arrive in `r`.
    pub const ROW_COEFFICIENTS: Self = Self { c: "r", ..Self::ARGUMENTS };
    /// The parameter row kernel: its [`Node::C`] leaves are the slots of the part shared by
    /// all rows ([`Dag::hoist_x_only`]), which arrive in `shared`.
    pub const SHARED_SLOTS: Self = Self { c: "shared", ..Self::ARGUMENTS };
}

/// Scalar code (`S: simhc::Ring`: constants as `S::constant(c)`, products with a constant as
/// `x.scale_by(c)`) assigning `outputs` (target array, entries), leaves read from the trait
/// methods' arguments.
pub(super) fn render_scalar(dag: &Dag, vars: &VarTable, outputs: &[(TokenStream, &Outputs)]) -> TokenStream {
    Renderer { dag, vars, arrays: LeafArrays::ARGUMENTS, fused: false }.render(outputs)
}

/// Lane-kernel code (`S: simhc::lanes::Lanes`: `S::from_real(c)`, `x.scale(c)`) assigning
/// `outputs`, with fused products and the leaves read from `arrays`.
pub(super) fn render_lanes(dag: &Dag, vars: &VarTable, arrays: LeafArrays, outputs: &[(TokenStream, &Outputs)]) -> TokenStream {
    Renderer { dag, vars, arrays, fused: true }.render(outputs)
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

/// A real constant as a literal, the sign outside (`-0.5`, not a negative literal token).
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
    /// Where the leaves are loaded from.
    arrays: LeafArrays,
    /// Lane kernels (`S: simhc::lanes::Lanes`): a product or real scaling used once, by a sum
    /// or difference, is emitted fused with it (`Lanes::mul_add`, `mul_sub`, `neg_mul_add`,
    /// `scale_add`), so lane types with fused multiply-adds use them (path lanes); the trait's
    /// defaults are the two operations in the unfused order.
    /// Only lane kernels fuse, so this also selects the lane trait's method names
    /// (`from_real`, `scale`) over the ring's (`constant`, `scale_by`).
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

/// The fusions of a lane kernel, by node index (empty for scalar code).
struct Fusions {
    /// The fused operation a sum or difference is emitted as.
    at: Vec<Option<Fusion>>,
    /// Products emitted inside a fusion rather than on their own.
    absorbed: Vec<bool>,
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
    fn fusions(&self, outputs: &[NodeId], live: &[bool]) -> Fusions {
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
        Fusions { at: fusions, absorbed }
    }

    /// Loads of used leaves followed by one `let` per live interior node. A product with a
    /// constant is emitted as `x.scale(c)` (real scaling: 2 multiplications in complex
    /// arithmetic instead of a full complex product); constants are loaded only where they
    /// are used otherwise.
    fn body(&self, outputs: &[NodeId]) -> TokenStream {
        let live = self.dag.reachable(outputs);
        let Fusions { at: fusions, absorbed } =
            if self.fused { self.fusions(outputs, &live) } else { Fusions { at: Vec::new(), absorbed: Vec::new() } };
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
                    let array = format_ident!(
                        "{}",
                        match node {
                            Node::X(_) => self.arrays.x,
                            Node::P(_) => self.arrays.p,
                            Node::C(_) => self.arrays.c,
                            _ => self.arrays.dp,
                        }
                    );
                    let src = quote!(#array[#k]);
                    loads.push(quote!(let #ident = #src;));
                }
                Node::Const(_) if !const_loaded[i] => {}
                Node::Const(bits) => {
                    // Hoisted once per function.
                    let lit = f64_lit(f64::from_bits(*bits));
                    let c = format_ident!("k{}", id.0);
                    loads.push(if self.fused { quote!(let #c: S = S::from_real(#lit);) } else { quote!(let #c: S = S::constant(#lit);) });
                }
                Node::Mul(a, b) if self.dag.const_value(*a).or(self.dag.const_value(*b)).is_some() => {
                    let (c, x) = match self.dag.const_value(*a) {
                        Some(c) => (c, *b),
                        None => (self.dag.const_value(*b).unwrap_or(1.0), *a),
                    };
                    let (lit, x) = (f64_lit(c), self.name(x));
                    let t = format_ident!("t{}", id.0);
                    lets.push(if self.fused { quote!(let #t = #x.scale(#lit);) } else { quote!(let #t = #x.scale_by(#lit);) });
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

    /// The body computing `outputs` followed by their assignments.
    fn render(&self, outputs: &[(TokenStream, &Outputs)]) -> TokenStream {
        let ids: Vec<NodeId> = outputs.iter().flat_map(|(_, v)| v.iter().map(|(_, id)| *id)).collect();
        let body = self.body(&ids);
        let assigns = outputs.iter().map(|(target, entries)| self.assign_dense(target, entries));
        quote!(#body #(#assigns)*)
    }

    /// Emits assignments `target[idx] = node` for a dense output, with one `fill` for zeros.
    fn assign_dense(&self, target: &TokenStream, entries: &Outputs) -> TokenStream {
        let mut zero = false;
        let mut stmts = Vec::new();
        for (idx, id) in entries {
            if self.dag.const_value(*id) == Some(0.0) {
                zero = true;
                continue;
            }
            let v = self.name(*id);
            stmts.push(quote!(#target[#idx] = #v;));
        }
        let zero_value = if self.fused { quote!(S::from_real(0.0)) } else { quote!(S::constant(0.0)) };
        let fill = if zero { quote!(#target.fill(#zero_value);) } else { quote!() };
        quote!(#fill #(#stmts)*)
    }
}
