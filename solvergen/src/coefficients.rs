//! The coefficient form of an instance: `F(x; p) = Fc(x; c(p))`, `Fc` affine in the
//! coefficients `c`. On a straight parameter segment `c(t)` is a polynomial in `t`, so the
//! tracker interpolates the coefficients rather than re-expanding `F` at every step; the row
//! kernels need the coefficients of a row to repeat from row to row ([`repeats_per_row`]).

use crate::lower::{Instance, VarTable};
use crate::poly::{Monomial, Poly, Var};
use std::collections::{BTreeMap, HashMap};

/// The coefficient form of one instance.
#[derive(Clone, Debug)]
pub struct CoefficientSplit {
    /// `c_k(p)`, each normalised to a leading coefficient of one; variables are parameters.
    pub table: Vec<Poly>,
    /// `Fc(x; c)` over unknowns and coefficient variables (numbered after the parameters).
    pub equations: Vec<Poly>,
    /// The part of `Fc` linear in `c` (constant-coefficient terms removed).
    pub linear: Vec<Poly>,
    /// Variables, with `coefficients` set.
    pub vars: VarTable,
}

/// Groups every equation by monomials in the unknowns; each non-constant group coefficient
/// (a polynomial in the parameters) becomes a coefficient variable, shared when two groups
/// have proportional coefficients.
pub fn split_coefficients(inst: &Instance) -> CoefficientSplit {
    let base = (inst.vars.nx() + inst.vars.np()) as Var;
    let mut table: Vec<Poly> = Vec::new();
    let mut index: HashMap<Vec<(Monomial, u64)>, usize> = HashMap::new();
    let mut equations = Vec::new();
    let mut linear = Vec::new();
    for f in &inst.equations {
        let mut groups: BTreeMap<Monomial, Poly> = BTreeMap::new();
        for (m, &c) in &f.terms {
            let (xm, pm) = m.split(|v| inst.vars.is_unknown(v));
            groups.entry(xm).or_default().add_term(pm, c);
        }
        let mut eq = Poly::zero();
        let mut lin = Poly::zero();
        for (xm, coef) in groups {
            if let Some(c) = coef.as_constant() {
                eq.add_term(xm, c);
                continue;
            }
            let lead = coef.terms.values().next().copied().unwrap_or(1.0);
            let normalised = coef.scale(1.0 / lead);
            let key: Vec<(Monomial, u64)> = normalised.terms.iter().map(|(m, &c)| (m.clone(), c.to_bits())).collect();
            let k = *index.entry(key).or_insert_with(|| {
                table.push(normalised);
                table.len() - 1
            });
            let term = xm.mul(&Monomial::var(base + k as Var));
            eq.add_term(term.clone(), lead);
            lin.add_term(term, lead);
        }
        equations.push(eq);
        linear.push(lin);
    }
    let mut vars = inst.vars.clone();
    vars.coefficients = table.len();
    CoefficientSplit { table, equations, linear, vars }
}

/// Whether the coefficient table of the full instance is `rows` consecutive copies of the
/// one-row table, row `r`'s with the row-0 parameters renamed to row `r`'s (and globals moved
/// after all rows): then row `r`'s coefficients are `c[r * nc1 .. (r + 1) * nc1]` in the same
/// order as the one-row kernel's.
pub fn repeats_per_row(full: &CoefficientSplit, one: &CoefficientSplit, inst: &Instance, one_inst: &Instance, row_len: usize) -> bool {
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
