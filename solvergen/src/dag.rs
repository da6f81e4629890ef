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
#[derive(Default)]
pub struct Dag {
    /// Nodes in topological order.
    pub nodes: Vec<Node>,
    interned: HashMap<Node, NodeId>,
    monomials: HashMap<Monomial, NodeId>,
    coefficients: HashMap<Vec<(Monomial, u64)>, NodeId>,
}

impl Dag {
    fn intern(&mut self, node: Node) -> NodeId {
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
            (Some(c), _) if c == 1.0 => b,
            (_, Some(c)) if c == 1.0 => a,
            (Some(c), _) if c == -1.0 => self.intern(Node::Neg(b)),
            (_, Some(c)) if c == -1.0 => self.intern(Node::Neg(a)),
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
        let key: Vec<(Monomial, u64)> =
            p.terms.iter().map(|(m, &c)| (m.clone(), (c / lead).to_bits())).collect();
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
                let terms: Vec<(f64, Option<NodeId>)> =
                    p.terms.iter().map(|(m, &c)| (c, self.monomial(m, vars))).collect();
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
            (Some(z), _) if z == 0.0 => b,
            (_, Some(z)) if z == 0.0 => a,
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
