//! The generic learned start: a [`FoldedNetwork`] that reads a declared problem's parameters
//! as network input rows ([`InputRows`]) and predicts its unknowns. Trained by
//! `simhc_regressor::generic` from any scene sampler, through the same [`InputRows`] value;
//! the input and output standardizations are folded into the first and last layers, so the
//! weights file is the whole model.
//!
//! Rows: by default ([`LayoutRows`]) one per declared row, `[row parameters, global
//! parameters]` ([`layout_row_width`] numbers); a problem without rows has one row of its
//! globals. A problem whose raw parameters make poor features (ratios, distances, invariants)
//! implements [`InputRows`] itself. Outputs: by default ([`LayoutOutputs`]) the unknown vector
//! in layout order, once per start hypothesis (a network trained with several, winner-takes-all,
//! outputs that many blocks; [`LearnedStart::hypotheses`]); a
//! [`crate::FieldKind::Quat`] unknown (its loss was sign-invariant) and a field whose norm a
//! parameter-free equation fixes (`t.dot(t) - 1`) are normalized here, the others come out in
//! their own units. A network that outputs another representation (a 6D rotation, a log scale)
//! comes with its own [`OutputDecoding`].

use super::{StartError, StartProvider};
use crate::layout::Layout;
use crate::regressor::{FoldedNetwork, HypothesisBlocks, RegressorError};
use nalgebra::SVector;

/// How a learned start reads a problem's parameters: the network's input rows. The trainer
/// and the runtime call the same value, so the network sees in use what it saw in training.
pub trait InputRows {
    /// Rows per input and numbers per row.
    fn shape(&self) -> (usize, usize);
    /// Writes the rows of parameters `p` into `out` (`rows * width` numbers, row after row);
    /// `false` when `p` has no features: wrong length, a non-finite value, degenerate data.
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool;
}

impl<R: InputRows + ?Sized> InputRows for &R {
    fn shape(&self) -> (usize, usize) {
        (**self).shape()
    }
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
        (**self).write(p, out)
    }
}

impl<R: InputRows + ?Sized> InputRows for Box<R> {
    fn shape(&self) -> (usize, usize) {
        (**self).shape()
    }
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
        (**self).write(p, out)
    }
}

/// The default input rows: the parameters as declared, `[row parameters, global parameters]`
/// per row ([`layout_rows`]).
#[derive(Debug, Clone, Copy)]
pub struct LayoutRows(pub Layout);

impl InputRows for LayoutRows {
    fn shape(&self) -> (usize, usize) {
        (layout_row_count(&self.0), layout_row_width(&self.0))
    }
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
        layout_rows(&self.0, p, out)
    }
}

/// Numbers per network input row for `layout`.
pub fn layout_row_width(layout: &Layout) -> usize {
    layout.per_row + layout.globals_len()
}

/// Rows of the network input for `layout`.
pub fn layout_row_count(layout: &Layout) -> usize {
    layout.rows.max(1)
}

/// Writes the network input of parameters `p` (module docs) into `out`
/// (`layout_row_count * layout_row_width` numbers); `false` for wrong lengths or non-finite
/// values.
pub fn layout_rows(layout: &Layout, p: &[f64], out: &mut [f32]) -> bool {
    let width = layout_row_width(layout);
    if p.len() != layout.param_len() || out.len() != layout_row_count(layout) * width {
        return false;
    }
    let Some(globals) = layout.global_params(p) else { return false };
    for (r, row) in out.chunks_exact_mut(width).enumerate() {
        let own = layout.row_params(p, r).unwrap_or(&[]);
        for (o, v) in row.iter_mut().zip(own.iter().chain(globals)) {
            *o = *v as f32;
        }
    }
    out.iter().all(|v| v.is_finite())
}

/// How a learned start's outputs become unknowns: one start hypothesis is [`OutputDecoding::width`]
/// numbers of the network's outputs. The default ([`LayoutOutputs`]) is the unknowns
/// themselves; a problem whose unknowns make a poor regression target (a quaternion's sign, a
/// scale over decades) trains its network on another representation and decodes it here
/// (GRPS: a 6D rotation, the translation and the log of the scale, into `[q, t, s]`).
pub trait OutputDecoding {
    /// Numbers of one start hypothesis in the network's outputs.
    fn width(&self) -> usize;
    /// The unknowns `x` of one hypothesis `out` (`width()` numbers): `false` when it decodes to
    /// none (a degenerate rotation, a value that is not finite); `x` is then unspecified.
    fn decode(&self, out: &[f64], x: &mut [f64]) -> bool;
}

impl<D: OutputDecoding + ?Sized> OutputDecoding for &D {
    fn width(&self) -> usize {
        (**self).width()
    }
    fn decode(&self, out: &[f64], x: &mut [f64]) -> bool {
        (**self).decode(out, x)
    }
}

/// The default outputs: the unknowns in layout order, put on their spheres
/// ([`Layout::normalize_unknowns`]: quaternions, fields whose norm an equation fixes).
#[derive(Debug, Clone, Copy)]
pub struct LayoutOutputs(pub Layout);

impl OutputDecoding for LayoutOutputs {
    fn width(&self) -> usize {
        self.0.unknown_len()
    }
    fn decode(&self, out: &[f64], x: &mut [f64]) -> bool {
        if out.len() != x.len() || x.len() != self.0.unknown_len() {
            return false;
        }
        x.copy_from_slice(out);
        self.0.normalize_unknowns(x)
    }
}

/// Network input numbers (rows times width) a [`LearnedStart`] keeps on the stack (8 KiB).
pub const STACK_INPUT: usize = 2048;

/// Most start hypotheses per prediction a [`LearnedStart`] takes.
pub const MAX_HYPOTHESES: usize = 8;

/// A learned start for a declared problem whose pipeline data is its parameter vector, reading
/// it through input rows `R` and decoding its outputs with `D`.
#[derive(Debug, Clone)]
pub struct LearnedStart<R = LayoutRows, D = LayoutOutputs> {
    network: FoldedNetwork,
    layout: Layout,
    rows: R,
    outputs: D,
}

impl LearnedStart {
    /// The start of a trained `network` for a problem of this `layout`, reading the layout's
    /// rows; checks the widths.
    pub fn new(network: FoldedNetwork, layout: Layout) -> Result<Self, RegressorError> {
        Self::with_rows(network, layout, LayoutRows(layout))
    }
}

impl<R: InputRows> LearnedStart<R> {
    /// The start of a `network` trained on input rows `rows` for a problem of this `layout`,
    /// outputting its unknowns; checks the widths.
    pub fn with_rows(network: FoldedNetwork, layout: Layout, rows: R) -> Result<Self, RegressorError> {
        Self::with_outputs(network, layout, rows, LayoutOutputs(layout))
    }
}

impl<R: InputRows, D: OutputDecoding> LearnedStart<R, D> {
    /// The start of a `network` trained on input rows `rows` for a problem of this `layout`,
    /// whose outputs `outputs` decodes; checks the widths.
    pub fn with_outputs(network: FoldedNetwork, layout: Layout, rows: R, outputs: D) -> Result<Self, RegressorError> {
        if network.input_width() != rows.shape().1 {
            return Err(RegressorError::Format("network input width differs from the input rows' width"));
        }
        if HypothesisBlocks::of(network.output_width(), outputs.width(), MAX_HYPOTHESES).is_none() {
            return Err(RegressorError::Format("network outputs are not 1 to 8 blocks of a hypothesis (and their scores)"));
        }
        if network.normalizes_output() {
            return Err(RegressorError::Format("a generic learned start decodes its own outputs"));
        }
        Ok(Self { network, layout, rows, outputs })
    }

    /// The network.
    pub fn network(&self) -> &FoldedNetwork {
        &self.network
    }

    /// The input rows.
    pub fn rows(&self) -> &R {
        &self.rows
    }

    /// How the network's outputs hold its start hypotheses.
    pub fn blocks(&self) -> HypothesisBlocks {
        HypothesisBlocks::of(self.network.output_width(), self.outputs.width(), MAX_HYPOTHESES).expect("checked at construction")
    }

    /// Start hypotheses per prediction (1 to [`MAX_HYPOTHESES`]).
    pub fn hypotheses(&self) -> usize {
        self.blocks().count
    }

    /// The predicted unknowns for parameters `p`: the best-scored hypothesis (the first of an
    /// unscored network), decoded ([`LearnedStart::decode`]). Without heap allocation for
    /// inputs of up to [`STACK_INPUT`] numbers.
    pub fn predict(&self, p: &[f64], x: &mut [f64]) -> Result<(), RegressorError> {
        let mut all = [0.0f64; crate::regressor::MAX_WIDTH];
        let (n, blocks) = (self.layout.unknown_len(), self.blocks());
        if x.len() != n {
            return Err(RegressorError::OutputLength { expected: n, got: x.len() });
        }
        let all = &mut all[..blocks.outputs()];
        self.predict_all(p, all)?;
        // Unscored: the network's first.
        let k = blocks.ranked::<MAX_HYPOTHESES>(all, |_| 0.0)[0];
        self.decode(all, k, x)
    }

    /// The network's raw outputs for parameters `p` ([`LearnedStart::blocks`]: the hypotheses
    /// in the network's order, then their scores if scored); [`LearnedStart::decode`] makes
    /// unknowns of one. Without heap allocation, as `predict`.
    pub fn predict_all(&self, p: &[f64], out: &mut [f64]) -> Result<(), RegressorError> {
        let (count, width) = self.rows.shape();
        let len = count * width;
        let (mut stack, mut heap) = ([0.0f32; STACK_INPUT], Vec::new());
        let rows: &mut [f32] = if len <= STACK_INPUT {
            &mut stack[..len]
        } else {
            heap.resize(len, 0.0);
            &mut heap
        };
        if !self.rows.write(p, rows) {
            return Err(RegressorError::NoInputRows);
        }
        // `forward` rejects non-finite rows itself (`RegressorError::NonFinite`).
        self.network.forward(rows, out)
    }

    /// The unknowns `x` of hypothesis `k` of the outputs `out` of [`LearnedStart::predict_all`],
    /// decoded by the start's [`OutputDecoding`] (by default put on their spheres).
    pub fn decode(&self, out: &[f64], k: usize, x: &mut [f64]) -> Result<(), RegressorError> {
        let blocks = self.blocks();
        if out.len() != blocks.outputs() {
            return Err(RegressorError::OutputLength { expected: blocks.outputs(), got: out.len() });
        }
        if x.len() != self.layout.unknown_len() {
            return Err(RegressorError::OutputLength { expected: self.layout.unknown_len(), got: x.len() });
        }
        let block = out.get(k * blocks.width..(k + 1) * blocks.width).filter(|_| k < blocks.count);
        match block {
            Some(block) if self.outputs.decode(block, x) && x.iter().all(|v| v.is_finite()) => Ok(()),
            _ => Err(RegressorError::NoDecoding { hypothesis: k }),
        }
    }
}

impl<R: InputRows, D: OutputDecoding, const NX: usize, const NP: usize> StartProvider<SVector<f64, NP>, NX> for LearnedStart<R, D> {
    fn name(&self) -> &'static str {
        "learned"
    }
    fn start(&self, p: &SVector<f64, NP>) -> Result<SVector<f64, NX>, StartError> {
        let mut x = SVector::<f64, NX>::zeros();
        self.predict(p.as_slice(), x.as_mut_slice()).map_err(|e| StartError { provider: "learned", reason: e.to_string().into() })?;
        Ok(x)
    }
}

/// The target parameters of a problem whose pipeline data is its parameter vector: `p`
/// itself, checked; a non-finite value is reported by row and field through `P`'s layout.
#[derive(Debug, Clone, Copy, Default)]
pub struct ParameterVector<P>(std::marker::PhantomData<fn() -> P>);

impl<P> ParameterVector<P> {
    /// The checker.
    pub fn new() -> Self {
        Self(std::marker::PhantomData)
    }
}

impl<P: crate::ProblemLayout, const NP: usize> super::TargetParameters<SVector<f64, NP>, NP> for ParameterVector<P> {
    type Error = NonFiniteParameter;
    fn params(&self, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, NonFiniteParameter> {
        match p.iter().position(|v| !v.is_finite()) {
            Some(index) => Err(NonFiniteParameter::locate(&P::LAYOUT, index)),
            None => Ok(*p),
        }
    }
}

/// A parameter that is NaN or infinite, and where it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{}field `{field}`: not finite (parameter {index})", match row { Some(r) => format!("row {r}, "), None => "global ".to_string() })]
pub struct NonFiniteParameter {
    /// The row (correspondence), `None` for a global parameter.
    pub row: Option<usize>,
    /// The declared field.
    pub field: &'static str,
    /// Its index in the parameter vector.
    pub index: usize,
}

impl NonFiniteParameter {
    /// Where parameter `index` of `layout` is.
    pub fn locate(layout: &Layout, index: usize) -> Self {
        let rows_len = layout.rows * layout.per_row;
        let (row, within, fields) = if index < rows_len {
            (Some(index / layout.per_row), index % layout.per_row, layout.row)
        } else {
            (None, index - rows_len, layout.globals)
        };
        let field = fields.iter().find(|f| within >= f.offset && within < f.offset + f.kind.len()).map_or("?", |f| f.name);
        Self { row, field, index }
    }
}
