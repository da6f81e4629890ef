//! Hash-consed expression DAG: the straight-line form of a set of polynomials.
//!
//! Every node is interned, so an identical subexpression is built once (common-subexpression
//! elimination by construction). Polynomials are built in greedy multivariate Horner form
//! ([`Dag::polynomial`]), every sub-polynomial normalised to a leading coefficient of one and
//! memoised, so equal pieces across equations and derivatives are built once (the coefficient
//! of `q1` in `dF/dq0`, `2 c(p)` when `F` holds `c(p) q0^2 q1`, reuses the node `c(p)`). An
//! earlier sum-of-shared-monomials form for the coefficient form measured slower everywhere
//! (GRPS7 complex residual + Jacobian 0.67 against 0.41 us; UPnP tracking 7.5 against 4.4 us)
//! and was removed.
//!
//! The DAG is also a target of its own: [`DagAlgebra`] lowers a declaration onto nodes without
//! expanding it, and [`Dag::gradient`] (reverse mode) and [`Dag::derivative`] (forward mode)
//! differentiate such straight-line code; the emitter uses them for the batch tracker's row
//! kernel from the parameters, where the unexpanded form is cheaper (GRPS: the rotation formed
//! once instead of multiplied into 38 coefficients per row).

use crate::decl::Declaration;
use crate::lower::VarTable;
use crate::poly::{Monomial, Poly, Var};
use std::collections::{BTreeMap, HashMap};

/// Index of a node; children always have smaller indices than their parents.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub u32);

/// One operation.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// Unknown `x[i]`.
    X(u32),
    /// Parameter `p[i]`.
    P(u32),
    /// Parameter direction `dp[i]` (for `dF/dp * dp`).
    Dp(u32),
    /// Coefficient `c[i]` of the coefficient form.
    C(u32),
    /// A real constant (bit pattern, so nodes hash).
    Const(u64),
    /// Sum.
    Add(NodeId, NodeId),
    /// Difference.
    Sub(NodeId, NodeId),
    /// Product.
    Mul(NodeId, NodeId),
    /// Negation.
    Neg(NodeId),
}

/// The DAG under construction.
#[derive(Clone, Debug, Default)]
pub struct Dag {
    /// Nodes in topological order.
    pub nodes: Vec<Node>,
    interned: HashMap<Node, NodeId>,
    monomials: HashMap<Monomial, NodeId>,
    coefficients: HashMap<Vec<(Monomial, u64)>, NodeId>,
}

impl Dag {
    pub(crate) fn intern(&mut self, node: Node) -> NodeId {
        // Commutative operations are stored with ordered operands so `a*b` and `b*a` coincide.
        let node = match node {
            Node::Add(a, b) if b < a => Node::Add(b, a),
            Node::Mul(a, b) if b < a => Node::Mul(b, a),
            n => n,
        };
        if let Some(&id) = self.interned.get(&node) {
            return id;
        }
        let id = NodeId(self.nodes.len() as u32);
        self.nodes.push(node.clone());
        self.interned.insert(node, id);
        id
    }

    /// A constant node.
    pub fn constant(&mut self, c: f64) -> NodeId {
        // -0.0 and 0.0 are the same constant.
        let c = if c == 0.0 { 0.0 } else { c };
        self.intern(Node::Const(c.to_bits()))
    }

    /// The constant value of a node, if it is one.
    pub fn const_value(&self, id: NodeId) -> Option<f64> {
        match self.nodes[id.0 as usize] {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    fn var(&mut self, v: Var, vars: &VarTable) -> NodeId {
        let (nx, np) = (vars.nx() as u32, vars.np() as u32);
        if v < nx {
            self.intern(Node::X(v))
        } else if v < nx + np {
            self.intern(Node::P(v - nx))
        } else {
            self.intern(Node::C(v - nx - np))
        }
    }

    /// Product with constant folding of `1` and `-1`.
    pub fn mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.const_value(a), self.const_value(b)) {
            (Some(x), Some(y)) => self.constant(x * y),
            (Some(0.0), _) | (_, Some(0.0)) => self.constant(0.0),
            (Some(1.0), _) => b,
            (_, Some(1.0)) => a,
            (Some(-1.0), _) => self.intern(Node::Neg(b)),
            (_, Some(-1.0)) => self.intern(Node::Neg(a)),
            _ => self.intern(Node::Mul(a, b)),
        }
    }

    /// `c * a`.
    fn scaled(&mut self, c: f64, a: NodeId) -> NodeId {
        let k = self.constant(c);
        self.mul(k, a)
    }

    /// Node of a monomial (`None` for the monomial 1), shared through its prefixes.
    fn monomial(&mut self, m: &Monomial, vars: &VarTable) -> Option<NodeId> {
        if m.0.is_empty() {
            return None;
        }
        if let Some(&id) = self.monomials.get(m) {
            return Some(id);
        }
        // Peel one factor of the last variable: m = rest * v.
        let &(v, _) = m.0.last()?;
        let rest = m.diff(v).map(|(_, r)| r).unwrap_or_default();
        let vn = self.var(v, vars);
        let id = match self.monomial(&rest, vars) {
            None => vn,
            Some(r) => self.mul(r, vn),
        };
        self.monomials.insert(m.clone(), id);
        Some(id)
    }

    /// Signed sum of `(coefficient, node)` terms in the given order, using `-` for negative
    /// coefficients so that no `-1 *` products appear.
    fn signed_sum(&mut self, terms: Vec<(f64, Option<NodeId>)>) -> NodeId {
        let mut acc: Option<NodeId> = None;
        let mut constant = 0.0;
        for (c, node) in terms {
            let Some(n) = node else {
                constant += c;
                continue;
            };
            let mag = self.scaled(c.abs(), n);
            acc = Some(match acc {
                None if c < 0.0 => self.intern(Node::Neg(mag)),
                None => mag,
                Some(a) if c < 0.0 => self.intern(Node::Sub(a, mag)),
                Some(a) => self.intern(Node::Add(a, mag)),
            });
        }
        match acc {
            None => self.constant(constant),
            Some(a) if constant == 0.0 => a,
            Some(a) if constant < 0.0 => {
                let k = self.constant(-constant);
                self.intern(Node::Sub(a, k))
            }
            Some(a) => {
                let k = self.constant(constant);
                self.intern(Node::Add(a, k))
            }
        }
    }

    /// Builds a polynomial in greedy multivariate Horner form: factor out the variable that
    /// occurs in the most terms, `P = v * Q + R`, and recurse. Sub-polynomials are normalised
    /// to a leading coefficient of one and memoised, so equal pieces (across equations and
    /// derivatives) are built once.
    pub fn polynomial(&mut self, poly: &Poly, vars: &VarTable) -> NodeId {
        if let Some(c) = poly.as_constant() {
            return self.constant(c);
        }
        let (lead, id) = self.horner_normalised(poly, vars);
        self.scaled(lead, id)
    }

    fn horner_normalised(&mut self, p: &Poly, vars: &VarTable) -> (f64, NodeId) {
        let lead = p.terms.values().next().copied().unwrap_or(1.0);
        let key: Vec<(Monomial, u64)> = p.terms.iter().map(|(m, &c)| (m.clone(), (c / lead).to_bits())).collect();
        if let Some(&id) = self.coefficients.get(&key) {
            return (lead, id);
        }
        let normalised = p.scale(1.0 / lead);
        let id = self.horner(&normalised, vars);
        self.coefficients.insert(key, id);
        (lead, id)
    }

    fn horner(&mut self, p: &Poly, vars: &VarTable) -> NodeId {
        // Occurrence count of each variable over the terms.
        let mut counts: BTreeMap<Var, usize> = BTreeMap::new();
        for m in p.terms.keys() {
            for &(v, _) in &m.0 {
                *counts.entry(v).or_default() += 1;
            }
        }
        let best = counts.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))).map(|(&v, &c)| (v, c));
        match best {
            Some((v, count)) if count >= 2 => {
                let mut quotient = Poly::zero();
                let mut rest = Poly::zero();
                for (m, &c) in &p.terms {
                    match m.diff(v) {
                        Some((_, reduced)) => quotient.add_term(reduced, c),
                        None => rest.add_term(m.clone(), c),
                    }
                }
                let vn = self.var(v, vars);
                let q = self.polynomial(&quotient, vars);
                let head = self.mul(vn, q);
                if rest.is_zero() {
                    return head;
                }
                // rest is built with its sign folded into the sum.
                let (lead, r) = match rest.as_constant() {
                    Some(c) => (c, None),
                    None => {
                        let (lead, r) = self.horner_normalised(&rest, vars);
                        (lead, Some(r))
                    }
                };
                self.signed_sum(vec![(1.0, Some(head)), (lead, r)])
            }
            _ => {
                let terms: Vec<(f64, Option<NodeId>)> = p.terms.iter().map(|(m, &c)| (c, self.monomial(m, vars))).collect();
                self.signed_sum(terms)
            }
        }
    }

    /// Marks the nodes needed for `outputs`.
    pub fn reachable(&self, outputs: &[NodeId]) -> Vec<bool> {
        let mut live = vec![false; self.nodes.len()];
        let mut stack: Vec<NodeId> = outputs.to_vec();
        while let Some(id) = stack.pop() {
            let i = id.0 as usize;
            if live[i] {
                continue;
            }
            live[i] = true;
            match self.nodes[i] {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) => stack.extend([a, b]),
                Node::Neg(a) => stack.push(a),
                _ => {}
            }
        }
        live
    }

    /// The direction leaf `dp[i]`.
    pub fn direction(&mut self, i: u32) -> NodeId {
        self.intern(Node::Dp(i))
    }

    /// Sum of two nodes, folding zeros.
    pub fn add(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.const_value(a), self.const_value(b)) {
            (Some(x), Some(y)) => self.constant(x + y),
            (Some(0.0), _) => b,
            (_, Some(0.0)) => a,
            _ => self.intern(Node::Add(a, b)),
        }
    }

    /// Number of arithmetic operations needed for `outputs` (a cost figure for docs and tests).
    pub fn op_count(&self, outputs: &[NodeId]) -> usize {
        let live = self.reachable(outputs);
        self.nodes
            .iter()
            .zip(&live)
            .filter(|(n, &l)| l && matches!(n, Node::Add(..) | Node::Sub(..) | Node::Mul(..) | Node::Neg(..)))
            .count()
    }
}

/// Differentiation on the DAG (automatic differentiation of straight-line code).
impl Dag {
    /// The operand of a negation.
    fn negated_operand(&self, a: NodeId) -> Option<NodeId> {
        match self.nodes[a.0 as usize] {
            Node::Neg(inner) => Some(inner),
            _ => None,
        }
    }

    /// `-a`, folding constants and double negation.
    pub fn neg(&mut self, a: NodeId) -> NodeId {
        if let Some(x) = self.const_value(a) {
            return self.constant(-x);
        }
        match self.negated_operand(a) {
            Some(inner) => inner,
            None => self.intern(Node::Neg(a)),
        }
    }

    // The arithmetic of the unexpanded lowering and of differentiation: zeros and constants
    // folded, and negations moved outward (`a * -b = -(a b)`, `a + -b = a - b`), so that a
    // product meets its sum and the emitter fuses them (`mul_add`, `neg_mul_add`) instead of
    // emitting a negation (the declaration's `skew(v)` and every reverse-mode subtraction
    // make them). The polynomial builder above keeps its own forms.

    /// `a + b`, simplified.
    pub fn plus(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.negated_operand(a), self.negated_operand(b)) {
            (Some(x), Some(y)) => {
                let s = self.plus(x, y);
                self.neg(s)
            }
            (None, Some(y)) => self.minus(a, y),
            (Some(x), None) => self.minus(b, x),
            (None, None) => self.add(a, b),
        }
    }

    /// `a - b`, simplified.
    pub fn minus(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.const_value(a), self.const_value(b)) {
            (Some(x), Some(y)) => return self.constant(x - y),
            (_, Some(0.0)) => return a,
            (Some(0.0), _) => return self.neg(b),
            _ => {}
        }
        match (self.negated_operand(a), self.negated_operand(b)) {
            (_, Some(y)) => self.plus(a, y),
            (Some(x), None) => {
                let s = self.plus(x, b);
                self.neg(s)
            }
            (None, None) => self.intern(Node::Sub(a, b)),
        }
    }

    /// `a * b`, simplified (a constant factor absorbs a negation).
    pub fn times(&mut self, a: NodeId, b: NodeId) -> NodeId {
        // `-(x * y)` with one factor negated: the negated one's operand and the other.
        let (x, y) = match (self.negated_operand(a), self.negated_operand(b)) {
            (Some(x), Some(y)) => return self.times(x, y),
            (None, None) => return self.mul(a, b),
            (Some(x), None) => (x, b),
            (None, Some(y)) => (y, a),
        };
        if let Some(k) = self.const_value(y) {
            let k = self.constant(-k);
            return self.mul(k, x);
        }
        let m = self.times(y, x);
        self.neg(m)
    }

    /// For every node, whether its value depends on a leaf for which `leaf` holds.
    pub fn depends_on(&self, leaf: impl Fn(&Node) -> bool) -> Vec<bool> {
        let mut dep = vec![false; self.nodes.len()];
        for i in 0..self.nodes.len() {
            dep[i] = match self.nodes[i] {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) => dep[a.0 as usize] || dep[b.0 as usize],
                Node::Neg(a) => dep[a.0 as usize],
                ref n => leaf(n),
            };
        }
        dep
    }

    /// Forward mode: the derivative of `root` when each leaf `l` moves with `seed(l)` (`None`:
    /// fixed), e.g. `x[k] -> 1` for `d/dx_k`, `p[i] -> dp[i]` for `dF/dp * dp`.
    pub fn derivative(&mut self, root: NodeId, seed: impl Fn(&mut Dag, &Node) -> Option<NodeId>) -> NodeId {
        let live = self.reachable(&[root]);
        let zero = self.constant(0.0);
        let mut d = vec![zero; root.0 as usize + 1];
        for i in 0..=root.0 as usize {
            if !live[i] {
                continue;
            }
            let node = self.nodes[i].clone();
            d[i] = match node {
                Node::Const(_) => zero,
                Node::Add(a, b) => self.plus(d[a.0 as usize], d[b.0 as usize]),
                Node::Sub(a, b) => self.minus(d[a.0 as usize], d[b.0 as usize]),
                Node::Neg(a) => self.neg(d[a.0 as usize]),
                Node::Mul(a, b) => {
                    let (da, db) = (d[a.0 as usize], d[b.0 as usize]);
                    let l = self.times(da, b);
                    let r = self.times(a, db);
                    self.plus(l, r)
                }
                ref leaf => seed(self, leaf).unwrap_or(zero),
            };
        }
        d[root.0 as usize]
    }

    /// Reverse mode: the gradient of `root` with respect to the leaves `wrt` (one sweep for
    /// all of them, the cost of a few evaluations of `root` however many leaves).
    pub fn gradient(&mut self, root: NodeId, wrt: &[NodeId]) -> Vec<NodeId> {
        let dep = self.depends_on(|n| wrt.iter().any(|w| self.nodes[w.0 as usize] == *n));
        let mut adj: Vec<Option<NodeId>> = vec![None; root.0 as usize + 1];
        if dep[root.0 as usize] {
            adj[root.0 as usize] = Some(self.constant(1.0));
        }
        // Adds `v` (subtracts when `negate`) to the adjoint of `n`.
        let accumulate = |dag: &mut Dag, adj: &mut Vec<Option<NodeId>>, n: NodeId, v: NodeId, negate: bool| {
            let slot = &mut adj[n.0 as usize];
            *slot = Some(match (*slot, negate) {
                (None, false) => v,
                (None, true) => dag.neg(v),
                (Some(prev), false) => dag.plus(prev, v),
                (Some(prev), true) => dag.minus(prev, v),
            });
        };
        for i in (0..=root.0 as usize).rev() {
            let Some(a_i) = adj[i] else { continue };
            let node = self.nodes[i].clone();
            match node {
                Node::Add(a, b) | Node::Sub(a, b) => {
                    if dep[a.0 as usize] {
                        accumulate(self, &mut adj, a, a_i, false);
                    }
                    if dep[b.0 as usize] {
                        accumulate(self, &mut adj, b, a_i, matches!(node, Node::Sub(..)));
                    }
                }
                Node::Mul(a, b) => {
                    if dep[a.0 as usize] {
                        let v = self.times(a_i, b);
                        accumulate(self, &mut adj, a, v, false);
                    }
                    if dep[b.0 as usize] {
                        let v = self.times(a_i, a);
                        accumulate(self, &mut adj, b, v, false);
                    }
                }
                Node::Neg(a) => accumulate(self, &mut adj, a, a_i, true),
                _ => {}
            }
        }
        let zero = self.constant(0.0);
        wrt.iter().map(|w| adj.get(w.0 as usize).copied().flatten().unwrap_or(zero)).collect()
    }

    /// The leaf node of variable `v` of `vars`' numbering.
    pub fn leaf(&mut self, v: Var, vars: &VarTable) -> NodeId {
        self.var(v, vars)
    }

    /// Splits the DAG of `outputs` at the nodes that depend on the unknowns alone: the part a
    /// row kernel shares with every other row, computed once per path instead of once per row.
    /// Interior nodes only: leaves and constants are as cheap to load as a slot.
    pub fn hoist_x_only(&self, outputs: &[NodeId]) -> Hoisted {
        let dag = self;
        let live = dag.reachable(outputs);
        let len = dag.nodes.len();
        let x_only: Vec<bool> = dag.depends_on(|n| matches!(n, Node::P(_) | Node::Dp(_) | Node::C(_))).into_iter().map(|d| !d).collect();
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
        Hoisted { row, map, shared }
    }
}

/// [`Dag::hoist_x_only`]: a row DAG reading the part that depends on the unknowns alone from
/// slots.
#[derive(Debug)]
pub struct Hoisted {
    /// A copy of the DAG in which each node depending on the unknowns alone that a node
    /// depending on the parameters (or an output) reads becomes a leaf `Node::C(slot)`.
    pub row: Dag,
    /// `map[i]`: the copy of node `i` in `row` (`None` for nodes the row does not read).
    pub map: Vec<Option<NodeId>>,
    /// The original nodes of the slots, in slot order.
    pub shared: Vec<NodeId>,
}

/// A declaration lowered onto a DAG without expansion ([`DagAlgebra`]): the equations as
/// nodes, in the order of [`crate::lower::Instance::equations`].
#[derive(Clone, Debug)]
pub struct Unexpanded {
    pub dag: Dag,
    /// The equations, rows first, then the global equations.
    pub equations: Vec<NodeId>,
    pub vars: VarTable,
    /// Equations per row.
    pub eqs_per_row: usize,
}

impl Unexpanded {
    /// Lowers `decl` for `rows` rows with `nx` unknowns (the expanded instance's count). Call
    /// [`crate::lower::check`] first: this assumes a valid body.
    pub fn lower(decl: &Declaration, rows: usize, nx: usize) -> Self {
        let mut dag = Dag::default();
        let (equations, vars, eqs_per_row, _) = crate::lower::evaluate(&mut DagAlgebra { dag: &mut dag, nx }, None, decl, rows);
        Self { dag, equations, vars, eqs_per_row }
    }
}

/// [`crate::lower::Algebra`] on DAG nodes: the declaration lowered without expansion, every
/// operation one node (hash-consed, so repeated subexpressions are shared); `diff` by forward
/// mode on the DAG.
pub struct DagAlgebra<'d> {
    /// The DAG the nodes live in.
    pub dag: &'d mut Dag,
    /// Unknowns `0 .. nx` become [`Node::X`], the rest [`Node::P`].
    pub nx: usize,
}

impl DagAlgebra<'_> {
    /// The leaf of variable `v`.
    fn leaf_node(&self, v: Var) -> Node {
        if (v as usize) < self.nx {
            Node::X(v)
        } else {
            Node::P(v - self.nx as Var)
        }
    }
}

impl crate::lower::Algebra for DagAlgebra<'_> {
    type E = NodeId;
    fn var(&mut self, v: Var) -> NodeId {
        let node = self.leaf_node(v);
        self.dag.intern(node)
    }
    fn constant(&mut self, c: f64) -> NodeId {
        self.dag.constant(c)
    }
    fn as_constant(&self, e: &NodeId) -> Option<f64> {
        self.dag.const_value(*e)
    }
    fn add(&mut self, a: &NodeId, b: &NodeId) -> NodeId {
        self.dag.plus(*a, *b)
    }
    fn sub(&mut self, a: &NodeId, b: &NodeId) -> NodeId {
        self.dag.minus(*a, *b)
    }
    fn mul(&mut self, a: &NodeId, b: &NodeId) -> NodeId {
        self.dag.times(*a, *b)
    }
    fn neg(&mut self, a: &NodeId) -> NodeId {
        self.dag.neg(*a)
    }
    fn scale(&mut self, a: &NodeId, c: f64) -> NodeId {
        let k = self.dag.constant(c);
        self.dag.times(k, *a)
    }
    fn pow(&mut self, a: &NodeId, n: u32) -> NodeId {
        // Square and multiply: `a^n` in about `log2 n` products.
        let mut acc = self.dag.constant(1.0);
        let mut base = *a;
        let mut n = n;
        while n > 0 {
            if n & 1 == 1 {
                acc = self.dag.times(acc, base);
            }
            n >>= 1;
            if n > 0 {
                base = self.dag.times(base, base);
            }
        }
        acc
    }
    fn diff(&mut self, a: &NodeId, v: Var) -> NodeId {
        let target = self.leaf_node(v);
        self.dag.derivative(*a, |dag, leaf| (*leaf == target).then(|| dag.constant(1.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lower::{evaluate, lower};
    use quote::quote;

    /// Evaluates `id` in `f64` with leaves `x`, `p`, `dp`.
    fn eval(dag: &Dag, id: NodeId, x: &[f64], p: &[f64], dp: &[f64]) -> f64 {
        let mut v = vec![0.0; id.0 as usize + 1];
        for i in 0..=id.0 as usize {
            v[i] = match dag.nodes[i] {
                Node::X(k) => x[k as usize],
                Node::P(k) => p[k as usize],
                Node::Dp(k) => dp[k as usize],
                Node::C(_) => f64::NAN,
                Node::Const(bits) => f64::from_bits(bits),
                Node::Add(a, b) => v[a.0 as usize] + v[b.0 as usize],
                Node::Sub(a, b) => v[a.0 as usize] - v[b.0 as usize],
                Node::Mul(a, b) => v[a.0 as usize] * v[b.0 as usize],
                Node::Neg(a) => -v[a.0 as usize],
            };
        }
        v[id.0 as usize]
    }

    /// The unexpanded lowering, its reverse-mode gradient and forward-mode parameter
    /// derivative agree with the expanded polynomials, on a declaration using every construct
    /// (`grad` in the row equations, so `DagAlgebra::diff` too).
    #[test]
    fn unexpanded_lowering_and_its_derivatives_match_the_expansion() {
        let item = quote! {
            mod every_construct {
                pub struct Unknowns { q: Quat, t: Vec3, s: Scalar }
                pub struct Row { f: Vec3, v: Vec3, w: Scalar }
                pub struct Globals { k: Mat<3, 3>, h: Sym<3> }
                pub const ROWS: [usize; 1] = [3];
                pub fn row_equations() -> [Scalar; 2] {
                    let r = rotation(q);
                    let b = (k * r.transpose()) * f;
                    let e = b.dot(h * v) * s.powi(3) / 2.0 - w + f.cross(t)[1] + t.dot(skew(v) * (r * f));
                    [e, grad(e * s, t).sum() - q.norm_squared() * w]
                }
                pub fn global_equations() -> [Scalar; 1] { [q.dot(q) - 1] }
            }
        };
        let mut cx = crate::ctxt::Ctxt::new();
        let options = crate::decl::parse_options(&mut cx, quote!());
        let decl = crate::decl::parse_declaration(&mut cx, options, item).expect("declaration parses");
        cx.check().expect("no errors");
        let poly = lower(&decl, 1);
        let mut dag = Dag::default();
        let (eqs, vars, epr, globals) = evaluate(&mut DagAlgebra { dag: &mut dag, nx: poly.vars.nx() }, None, &decl, 1);
        assert_eq!((epr, globals, eqs.len()), (poly.eqs_per_row, poly.global_eqs, poly.equations.len()));
        let (nx, np) = (vars.nx(), vars.np());
        assert_eq!((nx, np), (poly.vars.nx(), poly.vars.np()));
        let xs: Vec<NodeId> = (0..nx).map(|i| dag.leaf(i as Var, &vars)).collect();
        for trial in 0..20 {
            // A small deterministic spread of points, away from special values.
            let val = |i: usize, salt: f64| ((i as f64 + 1.3) * (trial as f64 + salt)).sin() * 1.7;
            let x: Vec<f64> = (0..nx).map(|i| val(i, 0.71)).collect();
            let p: Vec<f64> = (0..np).map(|i| val(i, 2.39)).collect();
            let dp: Vec<f64> = (0..np).map(|i| val(i, 5.17)).collect();
            let at = |v: Var| if (v as usize) < nx { x[v as usize] } else { p[v as usize - nx] };
            for (e, (&node, expanded)) in eqs.iter().zip(&poly.equations).enumerate() {
                let close = |a: f64, b: f64, what: &str| {
                    assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "equation {e} {what}: {a} vs {b}, trial {trial}");
                };
                close(eval(&dag, node, &x, &p, &dp), expanded.eval(at), "value");
                let grad = dag.gradient(node, &xs);
                for (k, &g) in grad.iter().enumerate() {
                    close(eval(&dag, g, &x, &p, &dp), expanded.diff(k as Var).eval(at), "gradient");
                }
                let moved = dag.derivative(node, |dag, leaf| match *leaf {
                    Node::P(m) => Some(dag.direction(m)),
                    _ => None,
                });
                let expected: f64 = (0..np).map(|m| expanded.diff((nx + m) as Var).eval(at) * dp[m]).sum();
                close(eval(&dag, moved, &x, &p, &dp), expected, "parameter derivative");
            }
        }
    }

    /// Reverse mode sums the contributions of a node used several times.
    #[test]
    fn gradient_accumulates_shared_nodes() {
        let mut dag = Dag::default();
        let (x, y) = (dag.intern(Node::X(0)), dag.intern(Node::X(1)));
        let xy = dag.mul(x, y);
        let f = dag.mul(xy, x); // x^2 y
        let g = dag.minus(f, xy); // x^2 y - x y
        let grad = dag.gradient(g, &[x, y]);
        let (px, py) = (3.0, -2.0);
        assert_eq!(eval(&dag, grad[0], &[px, py], &[], &[]), 2.0 * px * py - py);
        assert_eq!(eval(&dag, grad[1], &[px, py], &[], &[]), px * px - px);
    }
}
