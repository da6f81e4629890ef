//! Lowering: type-check the equation bodies and expand them into polynomials.
//!
//! Expressions are evaluated symbolically to [`Value`]s (scalars, vectors, matrices of
//! [`Poly`]). A type error is recorded with the span of the offending tokens and yields
//! [`Value::Poison`], which silences follow-up errors, so one pass reports every independent
//! mistake.

use crate::ctxt::Ctxt;
use crate::decl::{Declaration, EquationFn, Field, Shape};
use crate::poly::{Poly, Var};

/// The arithmetic the evaluator lowers to: expanded polynomials ([`PolyAlgebra`], the
/// instance every emitter starts from) or nodes of an expression DAG that keep the declared
/// structure ([`crate::dag::DagAlgebra`]: `rotation(q)` formed once, products not expanded).
pub trait Algebra {
    /// One scalar expression.
    type E: Clone + std::fmt::Debug;
    /// Variable `v` (unknowns first, then parameters).
    fn var(&mut self, v: Var) -> Self::E;
    /// A real constant.
    fn constant(&mut self, c: f64) -> Self::E;
    /// The value of a constant expression.
    fn as_constant(&self, e: &Self::E) -> Option<f64>;
    /// `a + b`.
    fn add(&mut self, a: &Self::E, b: &Self::E) -> Self::E;
    /// `a - b`.
    fn sub(&mut self, a: &Self::E, b: &Self::E) -> Self::E;
    /// `a * b`.
    fn mul(&mut self, a: &Self::E, b: &Self::E) -> Self::E;
    /// `-a`.
    fn neg(&mut self, a: &Self::E) -> Self::E;
    /// `c * a` for a real constant `c`.
    fn scale(&mut self, a: &Self::E, c: f64) -> Self::E;
    /// `a^n`.
    fn pow(&mut self, a: &Self::E, n: u32) -> Self::E;
    /// `da/dv`.
    fn diff(&mut self, a: &Self::E, v: Var) -> Self::E;
}

/// Expanded polynomials: every operation expands (the declaration's default lowering).
#[derive(Clone, Copy, Debug, Default)]
pub struct PolyAlgebra;

impl Algebra for PolyAlgebra {
    type E = Poly;
    fn var(&mut self, v: Var) -> Poly {
        Poly::var(v)
    }
    fn constant(&mut self, c: f64) -> Poly {
        Poly::constant(c)
    }
    fn as_constant(&self, e: &Poly) -> Option<f64> {
        e.as_constant()
    }
    fn add(&mut self, a: &Poly, b: &Poly) -> Poly {
        a + b
    }
    fn sub(&mut self, a: &Poly, b: &Poly) -> Poly {
        a - b
    }
    fn mul(&mut self, a: &Poly, b: &Poly) -> Poly {
        a * b
    }
    fn neg(&mut self, a: &Poly) -> Poly {
        -a
    }
    fn scale(&mut self, a: &Poly, c: f64) -> Poly {
        a.scale(c)
    }
    fn pow(&mut self, a: &Poly, n: u32) -> Poly {
        a.pow(n)
    }
    fn diff(&mut self, a: &Poly, v: Var) -> Poly {
        a.diff(v)
    }
}

/// A symbolic value.
#[derive(Clone, Debug)]
pub enum Value<E = Poly> {
    /// A scalar.
    Scalar(E),
    /// A vector.
    Vector(Vec<E>),
    /// A row-major matrix.
    Matrix {
        /// Row count.
        rows: usize,
        /// Column count.
        cols: usize,
        /// Entries, row-major.
        data: Vec<E>,
    },
    /// Result of an erroneous expression (already reported).
    Poison,
}

impl<E: Clone> Value<E> {
    fn type_name(&self) -> String {
        match self {
            Value::Scalar(_) => "a scalar".into(),
            Value::Vector(v) => format!("a {}-vector", v.len()),
            Value::Matrix { rows, cols, .. } => format!("a {rows}x{cols} matrix"),
            Value::Poison => "an invalid value".into(),
        }
    }

    /// All entries, row-major, as equations.
    pub fn flatten(self) -> Vec<E> {
        match self {
            Value::Scalar(p) => vec![p],
            Value::Vector(v) => v,
            Value::Matrix { data, .. } => data,
            Value::Poison => Vec::new(),
        }
    }

    fn map(&self, mut f: impl FnMut(&E) -> E) -> Value<E> {
        match self {
            Value::Scalar(p) => Value::Scalar(f(p)),
            Value::Vector(v) => Value::Vector(v.iter().map(f).collect()),
            Value::Matrix { rows, cols, data } => Value::Matrix { rows: *rows, cols: *cols, data: data.iter().map(f).collect() },
            Value::Poison => Value::Poison,
        }
    }
}

/// What a name refers to.
#[derive(Clone, Debug)]
struct Binding<E> {
    name: String,
    value: Value<E>,
    /// The first variable of an unknown symbol (for `grad`), `None` for parameters and lets.
    unknown_vars: Option<Vec<Var>>,
}

/// Names of the scalar variables of one instance, unknowns first.
#[derive(Clone, Debug, Default)]
pub struct VarTable {
    /// `q[0]`, ..., in vector order.
    pub unknown_names: Vec<String>,
    /// `row0.f[0]`, ..., `m[0][1]`, in vector order.
    pub param_names: Vec<String>,
    /// Number of coefficient variables (the coefficient form only), numbered after the
    /// parameters.
    pub coefficients: usize,
}

impl VarTable {
    /// Number of unknowns.
    pub fn nx(&self) -> usize {
        self.unknown_names.len()
    }
    /// Number of parameters.
    pub fn np(&self) -> usize {
        self.param_names.len()
    }
    /// Whether variable `v` is an unknown.
    pub fn is_unknown(&self, v: Var) -> bool {
        (v as usize) < self.nx()
    }
    /// Whether variable `v` is a parameter.
    pub fn is_param(&self, v: Var) -> bool {
        (self.nx()..self.nx() + self.np()).contains(&(v as usize))
    }
}

/// One instantiated, fully expanded system.
#[derive(Clone, Debug)]
pub struct Instance {
    /// Row count (0 without rows).
    pub rows: usize,
    /// Variables.
    pub vars: VarTable,
    /// `F(x; p)`, rows first (row-major, `eqs_per_row` each), then global equations.
    pub equations: Vec<Poly>,
    /// Equations contributed by each row.
    pub eqs_per_row: usize,
    /// Equations not tied to a row.
    pub global_eqs: usize,
}

fn field_value<A: Algebra>(alg: &mut A, field: &Field, prefix: &str, vars: &mut Vec<String>, offset: usize) -> (Value<A::E>, Vec<Var>) {
    let name = field.ident.to_string();
    let mut new_var = |label: String| {
        let v = (offset + vars.len()) as Var;
        vars.push(format!("{prefix}{label}"));
        v
    };
    match field.shape {
        Shape::Scalar => {
            let v = new_var(name.clone());
            (Value::Scalar(alg.var(v)), vec![v])
        }
        Shape::Vector(_) | Shape::Quat => {
            let n = field.shape.scalar_count();
            let vs: Vec<Var> = (0..n).map(|i| new_var(format!("{name}[{i}]"))).collect();
            (Value::Vector(vs.iter().map(|&v| alg.var(v)).collect()), vs)
        }
        Shape::Matrix(r, c) => {
            let vs: Vec<Var> = (0..r * c).map(|k| new_var(format!("{name}[{}][{}]", k / c, k % c))).collect();
            (Value::Matrix { rows: r, cols: c, data: vs.iter().map(|&v| alg.var(v)).collect() }, vs)
        }
        Shape::Sym(n) => {
            let mut upper = vec![0 as Var; n * n];
            let mut vs = Vec::new();
            for i in 0..n {
                for j in i..n {
                    let v = new_var(format!("{name}[{i}][{j}]"));
                    upper[i * n + j] = v;
                    upper[j * n + i] = v;
                    vs.push(v);
                }
            }
            (Value::Matrix { rows: n, cols: n, data: upper.iter().map(|&v| alg.var(v)).collect() }, vs)
        }
    }
}

/// Checks the equation bodies once (a one-row instance) and reports every error; the returned
/// instance gives the equation counts.
pub fn check(cx: &mut Ctxt, decl: &Declaration) -> Instance {
    let n = if decl.row_fields.is_empty() { 0 } else { 1 };
    lower_with(Some(cx), decl, n)
}

/// Lowers the declaration for `rows` rows. Call [`check`] first: this assumes a valid body.
pub fn lower(decl: &Declaration, rows: usize) -> Instance {
    lower_with(None, decl, rows)
}

fn lower_with(cx: Option<&mut Ctxt>, decl: &Declaration, rows: usize) -> Instance {
    let (equations, vars, eqs_per_row, global_eqs) = evaluate(&mut PolyAlgebra, cx, decl, rows);
    Instance { rows, vars, equations, eqs_per_row, global_eqs }
}

/// The equations of `rows` rows then the global equations in algebra `alg`, the variables,
/// and the equation counts per row and global. Call [`check`] first when `cx` is `None`.
pub fn evaluate<A: Algebra>(
    alg: &mut A,
    mut cx: Option<&mut Ctxt>,
    decl: &Declaration,
    rows: usize,
) -> (Vec<A::E>, VarTable, usize, usize) {
    let mut unknown_names = Vec::new();
    let mut base = Vec::new();
    for f in &decl.unknowns {
        let (value, vars) = field_value(alg, f, "", &mut unknown_names, 0);
        base.push(Binding { name: f.ident.to_string(), value, unknown_vars: Some(vars) });
    }
    let nx = unknown_names.len();
    let mut param_names = Vec::new();
    let mut row_bindings = Vec::new();
    for r in 0..rows {
        let mut this_row = Vec::new();
        for f in &decl.row_fields {
            let (value, _) = field_value(alg, f, &format!("row{r}."), &mut param_names, nx);
            this_row.push(Binding { name: f.ident.to_string(), value, unknown_vars: None });
        }
        row_bindings.push(this_row);
    }
    for f in &decl.globals {
        let (value, _) = field_value(alg, f, "", &mut param_names, nx);
        base.push(Binding { name: f.ident.to_string(), value, unknown_vars: None });
    }
    let mut equations = Vec::new();
    let mut eqs_per_row = 0;
    if let Some(eqs) = &decl.row_equations {
        for row in &row_bindings {
            let mut scope: Vec<Binding<A::E>> = base.iter().cloned().chain(row.iter().cloned()).collect();
            let mut ev = Evaluator { alg: &mut *alg, cx: cx.as_deref_mut(), scope: &mut scope };
            let row_eqs = ev.equation_fn(eqs);
            eqs_per_row = row_eqs.len();
            equations.extend(row_eqs);
        }
    }
    let mut global_eqs = 0;
    if let Some(eqs) = &decl.global_equations {
        let mut scope = base.clone();
        let mut ev = Evaluator { alg: &mut *alg, cx, scope: &mut scope };
        let g = ev.equation_fn(eqs);
        global_eqs = g.len();
        equations.extend(g);
    }
    let vars = VarTable { unknown_names, param_names, coefficients: 0 };
    (equations, vars, eqs_per_row, global_eqs)
}

struct Evaluator<'a, 'c, A: Algebra> {
    alg: &'a mut A,
    cx: Option<&'c mut Ctxt>,
    scope: &'a mut Vec<Binding<A::E>>,
}

impl<A: Algebra> Evaluator<'_, '_, A> {
    fn error<T: quote::ToTokens>(&mut self, tokens: T, msg: impl std::fmt::Display) -> Value<A::E> {
        if let Some(cx) = self.cx.as_deref_mut() {
            cx.error_spanned_by(tokens, msg);
        }
        Value::Poison
    }

    fn equation_fn(&mut self, f: &EquationFn) -> Vec<A::E> {
        let Some(value) = self.block(&f.block) else { return Vec::new() };
        let poisoned = matches!(value, Value::Poison);
        let eqs = value.flatten();
        if let Some((k, span)) = f.declared_count {
            if !poisoned && eqs.len() != k {
                if let Some(cx) = self.cx.as_deref_mut() {
                    cx.error_at(span, format!("declared {k} equations, the body yields {}", eqs.len()));
                }
            }
        }
        eqs
    }

    fn block(&mut self, block: &syn::Block) -> Option<Value<A::E>> {
        let depth = self.scope.len();
        let mut tail = None;
        for (i, stmt) in block.stmts.iter().enumerate() {
            let last = i + 1 == block.stmts.len();
            match stmt {
                syn::Stmt::Local(local) => self.local(local),
                syn::Stmt::Expr(e, None) if last => tail = Some(self.expr(e)),
                other => {
                    self.error(other, "only `let` bindings and a final expression are allowed here");
                }
            }
        }
        self.scope.truncate(depth);
        if tail.is_none() {
            if let Some(cx) = self.cx.as_deref_mut() {
                cx.error_at(block.brace_token.span.close(), "expected a final expression giving the equations");
            }
        }
        tail
    }

    fn local(&mut self, local: &syn::Local) {
        let ident = match &local.pat {
            syn::Pat::Ident(p) if p.by_ref.is_none() && p.subpat.is_none() => p.ident.clone(),
            syn::Pat::Type(t) => match &*t.pat {
                syn::Pat::Ident(p) => p.ident.clone(),
                other => {
                    self.error(other, "expected a plain name");
                    return;
                }
            },
            other => {
                self.error(other, "expected a plain name: `let name = expr;`");
                return;
            }
        };
        let value = match &local.init {
            Some(init) if init.diverge.is_none() => self.expr(&init.expr),
            _ => self.error(local, "a `let` needs a value: `let name = expr;`"),
        };
        self.scope.push(Binding { name: ident.to_string(), value, unknown_vars: None });
    }

    fn const_of(&self, v: &Value<A::E>) -> Option<f64> {
        match v {
            Value::Scalar(p) => self.alg.as_constant(p),
            _ => None,
        }
    }

    fn lookup(&self, name: &str) -> Option<&Binding<A::E>> {
        self.scope.iter().rev().find(|b| b.name == name)
    }

    fn expr(&mut self, e: &syn::Expr) -> Value<A::E> {
        match e {
            syn::Expr::Paren(p) => self.expr(&p.expr),
            syn::Expr::Group(g) => self.expr(&g.expr),
            syn::Expr::Lit(l) => match literal(&l.lit) {
                Some(c) => Value::Scalar(self.alg.constant(c)),
                None => self.error(l, "expected a number"),
            },
            syn::Expr::Path(p) => match p.path.get_ident() {
                Some(id) => match self.lookup(&id.to_string()) {
                    Some(b) => b.value.clone(),
                    None => self.error(id, format!("unknown identifier `{id}`: not an unknown, parameter or `let` binding")),
                },
                None => self.error(p, "expected a name"),
            },
            syn::Expr::Unary(u) => match u.op {
                syn::UnOp::Neg(_) => {
                    let v = self.expr(&u.expr);
                    v.map(|p| self.alg.neg(p))
                }
                _ => self.error(u, "unsupported operator; equations use + - * and integer powers"),
            },
            syn::Expr::Binary(b) => self.binary(b),
            syn::Expr::MethodCall(m) => self.method(m),
            syn::Expr::Call(c) => self.call(c),
            syn::Expr::Array(a) => self.array(a),
            syn::Expr::Index(i) => self.index(i),
            syn::Expr::Block(b) if b.label.is_none() => {
                self.block(&b.block).unwrap_or(Value::Poison)
            }
            other => self.error(other, "unsupported expression in an equation; use + - *, .powi(n), .dot, .cross, .transpose(), skew(v), rotation(q), grad(e, x), [..] and indexing"),
        }
    }

    fn binary(&mut self, b: &syn::ExprBinary) -> Value<A::E> {
        use syn::BinOp;
        let op = &b.op;
        if let BinOp::Div(_) = op {
            let lhs = self.expr(&b.left);
            let rhs = self.expr(&b.right);
            return match self.const_of(&rhs) {
                Some(c) if c != 0.0 => lhs.map(|p| self.alg.scale(p, 1.0 / c)),
                _ => self.error(&b.right, "division only by a nonzero constant: the system must stay polynomial"),
            };
        }
        let (lhs, rhs) = (self.expr(&b.left), self.expr(&b.right));
        if matches!(lhs, Value::Poison) || matches!(rhs, Value::Poison) {
            return Value::Poison;
        }
        match op {
            BinOp::Add(_) | BinOp::Sub(_) => {
                let sub = matches!(op, BinOp::Sub(_));
                let alg = &mut *self.alg;
                let mut f = |a: &A::E, c: &A::E| if sub { alg.sub(a, c) } else { alg.add(a, c) };
                match (&lhs, &rhs) {
                    (Value::Scalar(a), Value::Scalar(c)) => Value::Scalar(f(a, c)),
                    (Value::Vector(a), Value::Vector(c)) if a.len() == c.len() => {
                        Value::Vector(a.iter().zip(c).map(|(a, c)| f(a, c)).collect())
                    }
                    (Value::Matrix { rows, cols, data: a }, Value::Matrix { rows: r2, cols: c2, data: c }) if rows == r2 && cols == c2 => {
                        Value::Matrix { rows: *rows, cols: *cols, data: a.iter().zip(c).map(|(a, c)| f(a, c)).collect() }
                    }
                    _ => self
                        .error(b, format!("cannot {} {} and {}", if sub { "subtract" } else { "add" }, lhs.type_name(), rhs.type_name())),
                }
            }
            BinOp::Mul(_) => match (&lhs, &rhs) {
                (Value::Scalar(s), other) | (other, Value::Scalar(s)) => other.map(|p| self.alg.mul(s, p)),
                (Value::Matrix { rows, cols, data }, Value::Vector(v)) if *cols == v.len() => {
                    Value::Vector((0..*rows).map(|r| dot(self.alg, &data[r * cols..(r + 1) * cols], v)).collect())
                }
                (Value::Matrix { rows, cols, data: a }, Value::Matrix { rows: r2, cols: c2, data: c }) if cols == r2 => {
                    let mut out = Vec::with_capacity(rows * c2);
                    for i in 0..*rows {
                        for j in 0..*c2 {
                            let col: Vec<A::E> = (0..*r2).map(|k| c[k * c2 + j].clone()).collect();
                            out.push(dot(self.alg, &a[i * cols..(i + 1) * cols], &col));
                        }
                    }
                    Value::Matrix { rows: *rows, cols: *c2, data: out }
                }
                (Value::Vector(_), Value::Vector(_)) => {
                    self.error(b, format!("cannot multiply {} by {}: use `.dot(..)` or `.cross(..)`", lhs.type_name(), rhs.type_name()))
                }
                _ => self.error(b, format!("cannot multiply {} by {}", lhs.type_name(), rhs.type_name())),
            },
            BinOp::BitXor(_) => self.error(op, "`^` is not a power in Rust; use `.powi(n)`"),
            _ => self.error(op, "unsupported operator; equations use + - * and integer powers"),
        }
    }

    fn method(&mut self, m: &syn::ExprMethodCall) -> Value<A::E> {
        let recv = self.expr(&m.receiver);
        let args: Vec<Value<A::E>> = m.args.iter().map(|a| self.expr(a)).collect();
        let name = m.method.to_string();
        if matches!(recv, Value::Poison) || args.iter().any(|a| matches!(a, Value::Poison)) {
            return Value::Poison;
        }
        let arity = match name.as_str() {
            "dot" | "cross" => 1,
            "powi" => 1,
            "transpose" | "norm_squared" | "sum" => 0,
            _ => {
                return self.error(&m.method, format!("unknown method `{name}`; supported: dot, cross, transpose, powi, norm_squared, sum"))
            }
        };
        if args.len() != arity {
            return self.error(m, format!("`{name}` takes {arity} argument(s)"));
        }
        match (name.as_str(), &recv, args.first()) {
            ("dot", Value::Vector(a), Some(Value::Vector(c))) if a.len() == c.len() => Value::Scalar(dot(self.alg, a, c)),
            ("dot", _, Some(other)) => {
                self.error(m, format!("`dot` needs two vectors of the same length, found {} and {}", recv.type_name(), other.type_name()))
            }
            ("cross", Value::Vector(a), Some(Value::Vector(c))) if a.len() == 3 && c.len() == 3 => {
                let mut minor = |i: usize, j: usize| {
                    let (l, r) = (self.alg.mul(&a[i], &c[j]), self.alg.mul(&a[j], &c[i]));
                    self.alg.sub(&l, &r)
                };
                Value::Vector(vec![minor(1, 2), minor(2, 0), minor(0, 1)])
            }
            ("cross", _, Some(other)) => {
                self.error(m, format!("`cross` needs two 3-vectors, found {} and {}", recv.type_name(), other.type_name()))
            }
            ("powi", Value::Scalar(a), Some(_)) => match m.args.first().and_then(int_literal) {
                Some(n) => Value::Scalar(self.alg.pow(a, n)),
                None => self.error(&m.args, "`powi` takes a non-negative integer literal"),
            },
            ("powi", _, _) => self.error(m, format!("`powi` needs a scalar, found {}", recv.type_name())),
            ("norm_squared", Value::Vector(a), None) => Value::Scalar(dot(self.alg, a, a)),
            ("sum", Value::Vector(a), None) => {
                let zero = self.alg.constant(0.0);
                Value::Scalar(a.iter().fold(zero, |acc, p| self.alg.add(&acc, p)))
            }
            ("transpose", Value::Matrix { rows, cols, data }, None) => {
                let mut out = Vec::with_capacity(data.len());
                for j in 0..*cols {
                    for i in 0..*rows {
                        out.push(data[i * cols + j].clone());
                    }
                }
                Value::Matrix { rows: *cols, cols: *rows, data: out }
            }
            // A vector is a column: its transpose is a 1xn matrix.
            ("transpose", Value::Vector(v), None) => Value::Matrix { rows: 1, cols: v.len(), data: v.clone() },
            _ => self.error(m, format!("`{name}` does not apply to {}", recv.type_name())),
        }
    }

    fn call(&mut self, c: &syn::ExprCall) -> Value<A::E> {
        let syn::Expr::Path(path) = &*c.func else {
            return self.error(&c.func, "expected a function name");
        };
        let Some(name) = path.path.get_ident().map(|i| i.to_string()) else {
            return self.error(&c.func, "expected a function name");
        };
        if name == "grad" {
            return self.grad(c);
        }
        let args: Vec<Value<A::E>> = c.args.iter().map(|a| self.expr(a)).collect();
        if args.iter().any(|a| matches!(a, Value::Poison)) {
            return Value::Poison;
        }
        match (name.as_str(), args.as_slice()) {
            ("skew", [Value::Vector(v)]) if v.len() == 3 => {
                let z = self.alg.constant(0.0);
                let neg: Vec<A::E> = v.iter().map(|e| self.alg.neg(e)).collect();
                Value::Matrix {
                    rows: 3,
                    cols: 3,
                    data: vec![
                        z.clone(),
                        neg[2].clone(),
                        v[1].clone(),
                        v[2].clone(),
                        z.clone(),
                        neg[0].clone(),
                        neg[1].clone(),
                        v[0].clone(),
                        z,
                    ],
                }
            }
            ("skew", [a]) => self.error(c, format!("`skew` needs a 3-vector, found {}", a.type_name())),
            ("rotation", [Value::Vector(q)]) if q.len() == 4 => Value::Matrix { rows: 3, cols: 3, data: rotation(self.alg, q) },
            ("rotation", [a]) => self.error(c, format!("`rotation` needs a quaternion (4-vector), found {}", a.type_name())),
            ("skew" | "rotation", _) => self.error(c, format!("`{name}` takes one argument")),
            _ => self.error(&c.func, format!("unknown function `{name}`; supported: skew, rotation, grad")),
        }
    }

    /// `grad(e, x)`: exact gradient of a scalar expression with respect to an unknown symbol.
    fn grad(&mut self, c: &syn::ExprCall) -> Value<A::E> {
        if c.args.len() != 2 {
            return self.error(c, "`grad` takes two arguments: `grad(scalar_expr, unknown)`");
        }
        let e = self.expr(&c.args[0]);
        let target = &c.args[1];
        let vars = match target {
            syn::Expr::Path(p) => p.path.get_ident().and_then(|id| self.lookup(&id.to_string())).and_then(|b| b.unknown_vars.clone()),
            _ => None,
        };
        let Some(vars) = vars else {
            return self.error(target, "the second argument of `grad` must name an unknown");
        };
        match e {
            Value::Scalar(p) if vars.len() == 1 => Value::Scalar(self.alg.diff(&p, vars[0])),
            Value::Scalar(p) => Value::Vector(vars.iter().map(|&v| self.alg.diff(&p, v)).collect()),
            Value::Poison => Value::Poison,
            other => self.error(&c.args[0], format!("`grad` needs a scalar expression, found {}", other.type_name())),
        }
    }

    fn array(&mut self, a: &syn::ExprArray) -> Value<A::E> {
        let elems: Vec<Value<A::E>> = a.elems.iter().map(|e| self.expr(e)).collect();
        if elems.iter().any(|e| matches!(e, Value::Poison)) {
            return Value::Poison;
        }
        if elems.iter().all(|e| matches!(e, Value::Scalar(_))) {
            return Value::Vector(elems.into_iter().flat_map(Value::flatten).collect());
        }
        let len = match elems.first() {
            Some(Value::Vector(v)) => v.len(),
            _ => 0,
        };
        if len > 0 && elems.iter().all(|e| matches!(e, Value::Vector(v) if v.len() == len)) {
            let rows = elems.len();
            return Value::Matrix { rows, cols: len, data: elems.into_iter().flat_map(Value::flatten).collect() };
        }
        self.error(a, "an array holds scalars (a vector) or vectors of one length (matrix rows)")
    }

    fn index(&mut self, i: &syn::ExprIndex) -> Value<A::E> {
        let base = self.expr(&i.expr);
        let idx: Vec<Option<usize>> = match &*i.index {
            syn::Expr::Tuple(t) => t.elems.iter().map(|e| int_literal(e).map(|n| n as usize)).collect(),
            e => vec![int_literal(e).map(|n| n as usize)],
        };
        if idx.iter().any(Option::is_none) {
            return self.error(&i.index, "indices must be integer literals");
        }
        let idx: Vec<usize> = idx.into_iter().flatten().collect();
        match (&base, idx.as_slice()) {
            (Value::Poison, _) => Value::Poison,
            (Value::Vector(v), [k]) if *k < v.len() => Value::Scalar(v[*k].clone()),
            (Value::Matrix { rows, cols, data }, [r]) if r < rows => Value::Vector(data[r * cols..(r + 1) * cols].to_vec()),
            (Value::Matrix { rows, cols, data }, [r, c]) if r < rows && c < cols => Value::Scalar(data[r * cols + c].clone()),
            _ => self.error(i, format!("index out of range or wrong number of indices for {}", base.type_name())),
        }
    }
}

fn dot<A: Algebra>(alg: &mut A, a: &[A::E], b: &[A::E]) -> A::E {
    let zero = alg.constant(0.0);
    a.iter().zip(b).fold(zero, |acc, (x, y)| {
        let m = alg.mul(x, y);
        alg.add(&acc, &m)
    })
}

/// The unnormalized rotation matrix of `q = [w, x, y, z]`, row-major; entries are quadratic in
/// `q` and equal the rotation for unit `q`.
fn rotation<A: Algebra>(alg: &mut A, q: &[A::E]) -> Vec<A::E> {
    let mut m = |a: usize, b: usize| alg.mul(&q[a], &q[b]);
    let (ww, xx, yy, zz) = (m(0, 0), m(1, 1), m(2, 2), m(3, 3));
    let (xy, wz, xz, wy, yz, wx) = (m(1, 2), m(0, 3), m(1, 3), m(0, 2), m(2, 3), m(0, 1));
    // Sums `s_..` and differences `d_..` of the products.
    let mut add = |a: &A::E, b: &A::E| alg.add(a, b);
    let (s_wwxx, s_yyzz) = (add(&ww, &xx), add(&yy, &zz));
    let (s_xywz, s_xzwy, s_yzwx) = (add(&xy, &wz), add(&xz, &wy), add(&yz, &wx));
    let mut sub = |a: &A::E, b: &A::E| alg.sub(a, b);
    let (d_wwxx, d_yyzz) = (sub(&ww, &xx), sub(&yy, &zz));
    let (d_xywz, d_xzwy, d_yzwx) = (sub(&xy, &wz), sub(&xz, &wy), sub(&yz, &wx));
    let r00 = sub(&s_wwxx, &s_yyzz);
    let (r11, r22) = (alg.add(&d_wwxx, &d_yyzz), alg.sub(&d_wwxx, &d_yyzz));
    let mut two = |p: &A::E| alg.scale(p, 2.0);
    vec![r00, two(&d_xywz), two(&s_xzwy), two(&s_xywz), r11, two(&d_yzwx), two(&d_xzwy), two(&s_yzwx), r22]
}

fn literal(lit: &syn::Lit) -> Option<f64> {
    match lit {
        syn::Lit::Int(i) => i.base10_parse::<i64>().ok().map(|v| v as f64),
        syn::Lit::Float(f) => f.base10_parse::<f64>().ok(),
        _ => None,
    }
}

fn int_literal(e: &syn::Expr) -> Option<u32> {
    match e {
        syn::Expr::Lit(syn::ExprLit { lit: syn::Lit::Int(i), .. }) => i.base10_parse().ok(),
        syn::Expr::Paren(p) => int_literal(&p.expr),
        _ => None,
    }
}
