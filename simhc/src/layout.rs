//! What the unknowns and parameters of a compiled problem are: names, kinds and where they
//! sit in the vectors. `#[simhc_problem]` emits a [`ProblemLayout`] for each instance, so
//! generic code (the learned start, input readers, reports) can treat a quaternion as a
//! quaternion without knowing the problem.

/// The kind of a declared symbol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FieldKind {
    /// One scalar.
    Scalar,
    /// A vector of the given length.
    Vector(usize),
    /// A quaternion `[w, x, y, z]`: `rotation(q)` of a unit `q`. Unknown quaternions carry the
    /// sign symmetry `q -> -q` and, with the `q.q - 1` equation, unit norm.
    Quat,
    /// A general `rows x cols` matrix, row-major.
    Matrix(usize, usize),
    /// A symmetric `n x n` matrix: only the upper triangle, row-major, is stored.
    Sym(usize),
}

impl FieldKind {
    /// Scalars the field occupies.
    pub const fn len(self) -> usize {
        match self {
            FieldKind::Scalar => 1,
            FieldKind::Vector(n) => n,
            FieldKind::Quat => 4,
            FieldKind::Matrix(r, c) => r * c,
            FieldKind::Sym(n) => n * (n + 1) / 2,
        }
    }

    /// Whether the field is empty (never, for a declared field).
    pub const fn is_empty(self) -> bool {
        self.len() == 0
    }
}

/// One declared symbol and where it sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldLayout {
    /// Its name in the declaration.
    pub name: &'static str,
    /// Its kind.
    pub kind: FieldKind,
    /// Offset of its first scalar: in the unknown vector (unknowns), within one row's block
    /// (row fields), or from the start of the globals block (globals).
    pub offset: usize,
}

/// A parameter-free equation `a (v . v) - b = 0` over all scalars of unknown field `v`
/// (`q.dot(q) - 1`, `t.dot(t) - 1`): it fixes `|v| = norm`, and a start must meet it by
/// itself, since the online simulator moves parameters only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldNorm {
    /// Index of the field in [`Layout::unknowns`].
    pub field: usize,
    /// Index of the equation in `F` (rows first, then globals).
    pub equation: usize,
    /// The norm it fixes, `sqrt(b / a)`.
    pub norm: f64,
}

/// The layout of one problem instance's vectors.
///
/// Unknowns `x`: the fields in declaration order. Parameters `p`: `rows` blocks of
/// `per_row` scalars (row `r`'s field `f` at `r * per_row + f.offset`), then the globals (field
/// `g` at `rows * per_row + g.offset`). Equations `F`: `rows` blocks of `equations_per_row`, then
/// the global equations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// The unknowns.
    pub unknowns: &'static [FieldLayout],
    /// The fields of one row.
    pub row: &'static [FieldLayout],
    /// The global parameters.
    pub globals: &'static [FieldLayout],
    /// Rows of this instance.
    pub rows: usize,
    /// Scalars per row.
    pub per_row: usize,
    /// Equations per row.
    pub equations_per_row: usize,
    /// The equations in which no parameter occurs (indices into `F`), such as `q.dot(q) - 1`.
    pub parameter_free: &'static [usize],
    /// Those of them that fix the norm of an unknown field.
    pub norms: &'static [FieldNorm],
}

impl Layout {
    /// Scalars in the unknown vector.
    pub fn unknown_len(&self) -> usize {
        self.unknowns.iter().map(|f| f.kind.len()).sum()
    }

    /// Scalars in the globals block.
    pub fn globals_len(&self) -> usize {
        self.globals.iter().map(|f| f.kind.len()).sum()
    }

    /// Scalars in the parameter vector.
    pub fn param_len(&self) -> usize {
        self.rows * self.per_row + self.globals_len()
    }

    /// The parameters of row `r` (`None` past the last row or for a short `p`).
    pub fn row_params<'p>(&self, p: &'p [f64], r: usize) -> Option<&'p [f64]> {
        (r < self.rows).then(|| p.get(r * self.per_row..(r + 1) * self.per_row)).flatten()
    }

    /// The global parameters (`None` for a short `p`).
    pub fn global_params<'p>(&self, p: &'p [f64]) -> Option<&'p [f64]> {
        p.get(self.rows * self.per_row..self.param_len())
    }

    /// Where equation `k` of `F` comes from, for messages: `"row 3, equation 0"` or `"global
    /// equation 1"` (counted from 0).
    pub fn equation_name(&self, k: usize) -> String {
        let in_rows = self.rows * self.equations_per_row;
        if k < in_rows {
            format!("row {}, equation {}", k / self.equations_per_row, k % self.equations_per_row)
        } else {
            format!("global equation {}", k - in_rows)
        }
    }

    /// Puts every unknown field whose norm an equation fixes ([`Layout::norms`]) on its sphere,
    /// and every quaternion on the unit sphere (`rotation(q)` reads a unit `q`); `false` when
    /// one of them is zero or `x` is not finite.
    pub fn normalize_unknowns(&self, x: &mut [f64]) -> bool {
        let quats = self.unknowns.iter().filter(|f| f.kind == FieldKind::Quat).map(|f| (f.offset, 4, 1.0));
        let fixed = self.norms.iter().map(|n| {
            let f = &self.unknowns[n.field];
            (f.offset, f.kind.len(), n.norm)
        });
        for (offset, len, norm) in quats.chain(fixed) {
            let Some(v) = x.get_mut(offset..offset + len) else { return false };
            let have = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            if !(have > 0.0 && have.is_finite()) {
                return false;
            }
            v.iter_mut().for_each(|a| *a *= norm / have);
        }
        x.iter().all(|v| v.is_finite())
    }

    /// This instance's parameters taken from those of a larger instance of the same problem
    /// (`p`: more rows, the same globals at its end): its first `rows` rows and the globals.
    /// `None` when `NQ` is not this instance's parameter count or `p` is shorter.
    pub fn first_rows<const NQ: usize>(&self, p: &[f64]) -> Option<nalgebra::SVector<f64, NQ>> {
        let head = self.rows * self.per_row;
        let globals = self.globals_len();
        if NQ != self.param_len() || p.len() < NQ {
            return None;
        }
        Some(nalgebra::SVector::from_fn(|i, _| if i < head { p[i] } else { p[p.len() - globals + (i - head)] }))
    }
}

/// The layout of a compiled problem instance (emitted by `#[simhc_problem]`).
pub trait ProblemLayout {
    /// Its layout.
    const LAYOUT: Layout;
}
