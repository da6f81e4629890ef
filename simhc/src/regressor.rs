//! Allocation-free forward pass of a trained pose regressor, independent of any deep learning
//! framework.
//!
//! The network (trained with burn in the `simhc-regressor` crate) is a PointNet-style regressor:
//!
//! ```text
//! rows [N x C]  --(point layers: dense + ReLU, applied to every row)-->  [N x W]
//!               --(max over the N rows)-->                               [W]
//!               --(head layers: dense, ReLU between them, none last)-->  [K]
//!               --(optional: divide by the Euclidean norm)-->            [K]
//! ```
//!
//! With a *context stage* after the first `k` point layers ([`FoldedNetwork::context_after`]),
//! every row also sees the whole set: the rows' features after layer `k` are max-pooled to `g`,
//! and point layer `k + 1` reads `[h_i, g]` (twice the width) instead of `h_i` (PointNet's
//! segmentation network). Independent rows pooled once cannot compare one correspondence with
//! another; a pose is a function of exactly such comparisons. The forward pass stays
//! allocation-free for any number of rows: it runs the first `k` layers twice (once to pool
//! `g`, once per row again) instead of keeping every row's features, and folds `g`'s half of
//! layer `k + 1` into that layer's bias, since `g` is the same for every row.
//!
//! The point layers are the paper's 1D convolutions with kernel size 1, each followed by batch
//! norm and ReLU; here the batch norm (in inference mode, running statistics) is folded into the
//! preceding dense layer: `W' = W diag(s)`, `b' = (b - mean) s + beta` with
//! `s = gamma / sqrt(var + eps)`.
//!
//! # Binary format ([`FoldedNetwork::from_bytes`], [`FoldedNetwork::to_bytes`])
//!
//! All integers are `u32` and all numbers `f32`, little-endian:
//!
//! ```text
//! magic        8 bytes  b"SHCFOLD1"
//! input_width  u32      C, the width of one input row
//! point_layers u32      number of point layers (>= 1)
//! head_layers  u32      number of head layers (>= 1)
//! flags        u32      bit 0: normalize the output to unit Euclidean norm;
//!                       bit 1: a context stage follows; other bits 0
//! context      u32      only with flag bit 1: k, the point layers before the context stage
//!                       (1 <= k < point_layers)
//! then for every layer, point layers first, then head layers:
//!   inputs     u32
//!   outputs    u32
//!   weights    inputs * outputs f32, row-major [inputs][outputs]: y_j = b_j + sum_i x_i w[i][j]
//!   bias       outputs f32
//! ```
//!
//! Each layer's `inputs` must equal the previous layer's `outputs` (the first point layer's the
//! input width, the first head layer's the last point layer's; point layer `k + 1` of a
//! context stage reads twice its previous layer's outputs), every width is at most
//! [`MAX_WIDTH`], and nothing may follow the last layer.
//!
//! # Input rows
//!
//! A problem's input rows (one per correspondence) and the decoding of the outputs are the
//! problem's own, shared by training and inference (UPnP: `simhc_problems::upnp::features`,
//! GRPS: `simhc_problems::grps::features`); at inference:
//!
//! ```text
//! let net = FoldedNetwork::from_bytes(include_bytes!(".../upnp.folded"))?;   // once
//! let mut rows = vec![0.0f32; width * n];                                   // once per size
//! /* the problem's rows */                                                  // per solve
//! let mut out = [0.0f64; 4];
//! net.forward(&rows, &mut out)?;                   // unit quaternion [w, x, y, z], sign free
//! ```

use crate::lanes::{Isa, IsaKernel};
use thiserror::Error;

/// Largest layer width (and input width) the forward pass supports: activations live in
/// fixed-size stack buffers of this many `f32` per row.
pub const MAX_WIDTH: usize = 256;

/// Rows processed together by the point layers (weights are loaded once per block).
const ROW_BLOCK: usize = 4;

/// Magic bytes at the start of the binary format.
pub const FOLDED_MAGIC: &[u8; 8] = b"SHCFOLD1";

/// Errors of loading or running a [`FoldedNetwork`].
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum RegressorError {
    /// The byte buffer is not a valid folded network (see the module docs).
    #[error("invalid folded network: {0}")]
    Format(&'static str),
    /// No input rows were given (the max-pool needs at least one).
    #[error("no input rows")]
    EmptyInput,
    /// The input length is not a multiple of the row width.
    #[error("input of length {len} is not a whole number of rows of width {width}")]
    RowLength {
        /// Length of the flat input slice.
        len: usize,
        /// Expected row width.
        width: usize,
    },
    /// The output slice has the wrong length.
    #[error("output slice of length {got}, expected {expected}")]
    OutputLength {
        /// Length the network produces.
        expected: usize,
        /// Length of the slice given.
        got: usize,
    },
    /// An input value was NaN or infinite.
    #[error("non-finite input value")]
    NonFinite,
    /// The learned start's input rows could not be made from the parameters
    /// ([`crate::pipeline::InputRows::write`]).
    #[error("no input rows for these parameters (wrong length, a non-finite value or degenerate data)")]
    NoInputRows,
    /// A start hypothesis of the network's outputs decodes to no unknowns
    /// ([`crate::pipeline::OutputDecoding::decode`]: a degenerate rotation, a non-finite value).
    #[error("start hypothesis {hypothesis} of the network decodes to no unknowns (degenerate or not finite)")]
    NoDecoding {
        /// The hypothesis, in the network's order.
        hypothesis: usize,
    },
}

/// One dense layer `y = b + x W` with `W` stored row-major `[inputs][outputs]`.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseLayer {
    inputs: usize,
    outputs: usize,
    weights: Vec<f32>,
    bias: Vec<f32>,
}

impl DenseLayer {
    /// A layer from its weights (`inputs * outputs`, row-major `[inputs][outputs]`) and bias
    /// (`outputs`).
    pub fn new(inputs: usize, outputs: usize, weights: Vec<f32>, bias: Vec<f32>) -> Result<Self, RegressorError> {
        if inputs == 0 || outputs == 0 || inputs > MAX_WIDTH || outputs > MAX_WIDTH {
            return Err(RegressorError::Format("layer width zero or above MAX_WIDTH"));
        }
        if weights.len() != inputs * outputs || bias.len() != outputs {
            return Err(RegressorError::Format("layer weight or bias length mismatch"));
        }
        if weights.iter().chain(&bias).any(|w| !w.is_finite()) {
            return Err(RegressorError::Format("non-finite weight"));
        }
        Ok(Self { inputs, outputs, weights, bias })
    }

    /// Input width.
    pub fn inputs(&self) -> usize {
        self.inputs
    }

    /// Output width.
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// Weights, row-major `[inputs][outputs]`.
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// Bias, `outputs` values.
    pub fn bias(&self) -> &[f32] {
        &self.bias
    }

    /// `y = relu?(b + x W)` for one row.
    #[inline(always)]
    fn apply_row<const FMA: bool>(&self, x: &[f32], y: &mut [f32], relu: bool) {
        let o = self.outputs;
        let y = &mut y[..o];
        y.copy_from_slice(&self.bias);
        for (xi, w) in x[..self.inputs].iter().zip(self.weights.chunks_exact(o)) {
            for (yj, wj) in y.iter_mut().zip(w) {
                *yj = madd::<FMA>(*xi, *wj, *yj);
            }
        }
        if relu {
            for v in y.iter_mut() {
                *v = v.max(0.0);
            }
        }
    }

    /// `y[r] = relu(b + x[r] W)` for a block of [`ROW_BLOCK`] rows, register-tiled over
    /// `TILE` outputs x `ROW_BLOCK` rows so that every weight is loaded once per block.
    #[inline(always)]
    fn apply_block<const TILE: usize, const FMA: bool>(&self, x: &[[f32; MAX_WIDTH]; ROW_BLOCK], y: &mut [[f32; MAX_WIDTH]; ROW_BLOCK]) {
        self.apply_block_part::<TILE, FMA>(self.inputs, &self.bias, x, y);
    }

    /// [`DenseLayer::apply_block`] on the first `n_in` inputs only, with bias `bias`: a context
    /// layer's row half, its pooled half folded into `bias`.
    #[inline(always)]
    fn apply_block_part<const TILE: usize, const FMA: bool>(
        &self,
        n_in: usize,
        bias: &[f32],
        x: &[[f32; MAX_WIDTH]; ROW_BLOCK],
        y: &mut [[f32; MAX_WIDTH]; ROW_BLOCK],
    ) {
        let o = self.outputs;
        let tiled = o - o % TILE;
        for j0 in (0..tiled).step_by(TILE) {
            let mut bias_tile = [0.0f32; TILE];
            bias_tile.copy_from_slice(&bias[j0..j0 + TILE]);
            let mut acc = [bias_tile; ROW_BLOCK];
            for i in 0..n_in {
                let mut w = [0.0f32; TILE];
                w.copy_from_slice(&self.weights[i * o + j0..i * o + j0 + TILE]);
                for r in 0..ROW_BLOCK {
                    let xi = x[r][i];
                    for k in 0..TILE {
                        acc[r][k] = madd::<FMA>(xi, w[k], acc[r][k]);
                    }
                }
            }
            for r in 0..ROW_BLOCK {
                for k in 0..TILE {
                    y[r][j0 + k] = acc[r][k].max(0.0);
                }
            }
        }
        if tiled < o {
            for r in 0..ROW_BLOCK {
                for j in tiled..o {
                    let mut s = bias[j];
                    for i in 0..n_in {
                        s = madd::<FMA>(x[r][i], self.weights[i * o + j], s);
                    }
                    y[r][j] = s.max(0.0);
                }
            }
        }
    }
}

/// `a * b + c`, fused (one rounding) when `FMA` (only used where the CPU has FMA; elsewhere
/// `mul_add` would be a slow library call).
#[inline(always)]
fn madd<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// How a network's outputs hold several start hypotheses ([`HypothesisBlocks::of`]): `count`
/// blocks of one prediction's `width` numbers, then, when `scored`, one score (a logit) per
/// block, which ranks them (higher first). A network with one hypothesis has no score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HypothesisBlocks {
    /// Numbers of one prediction.
    pub width: usize,
    /// Hypotheses.
    pub count: usize,
    /// Whether a score per hypothesis follows the blocks.
    pub scored: bool,
}

impl HypothesisBlocks {
    /// The layout of `outputs` numbers holding predictions of `width` numbers: `width` is one;
    /// a multiple (2 or more) of `width + 1` is that many scored blocks; another multiple of
    /// `width` that many unscored blocks; `None` otherwise, or for more than `max` blocks.
    pub fn of(outputs: usize, width: usize, max: usize) -> Option<Self> {
        let (count, scored) = match outputs {
            _ if width == 0 => return None,
            o if o == width => (1, false),
            // Trainers score every network of two or more hypotheses.
            o if o % (width + 1) == 0 && o / (width + 1) >= 2 => (o / (width + 1), true),
            o if o % width == 0 => (o / width, false),
            _ => return None,
        };
        (count <= max).then_some(Self { width, count, scored })
    }

    /// `count` blocks of `width`, scored when there are two or more (as the trainers make them).
    pub fn trained(width: usize, count: usize) -> Self {
        let count = count.max(1);
        Self { width, count, scored: count > 1 }
    }

    /// The outputs of this layout.
    pub fn outputs(&self) -> usize {
        self.count * self.width + if self.scored { self.count } else { 0 }
    }

    /// The score of hypothesis `k` in the outputs `out`, `None` when unscored.
    pub fn score(&self, out: &[f64], k: usize) -> Option<f64> {
        self.scored.then(|| out[self.count * self.width + k])
    }

    /// The hypotheses of the outputs `out` in rank order, best first: by their scores (higher
    /// first) when scored, otherwise by `cost` (lower first; the caller's measure on the data,
    /// or a constant to keep the network's order). Stable: ties keep the network's order. The
    /// first [`HypothesisBlocks::count`] entries are the ranking; `N` must be at least `count`.
    /// A single hypothesis is its own ranking: `cost` is not called. No heap allocation.
    pub fn ranked<const N: usize>(&self, out: &[f64], mut cost: impl FnMut(usize) -> f64) -> [usize; N] {
        assert!(self.count <= N, "{} hypotheses do not fit a ranking of {N}", self.count);
        let mut order: [usize; N] = std::array::from_fn(|k| k);
        if self.count <= 1 {
            return order;
        }
        let mut key = [0.0f64; N];
        for (k, key) in key.iter_mut().enumerate().take(self.count) {
            *key = match self.score(out, k) {
                Some(s) => -s,
                None => cost(k),
            };
        }
        // Insertion sort of a handful: stable, no allocation. NaN sorts last (`total_cmp`).
        for i in 1..self.count {
            let mut j = i;
            while j > 0 && key[j - 1].total_cmp(&key[j]).is_gt() {
                key.swap(j - 1, j);
                order.swap(j - 1, j);
                j -= 1;
            }
        }
        order
    }
}

/// A trained regressor with batch norm folded into its dense layers (module docs), ready for an
/// allocation-free [`forward`](Self::forward) at batch size 1.
#[derive(Debug, Clone, PartialEq)]
pub struct FoldedNetwork {
    input_width: usize,
    point_layers: Vec<DenseLayer>,
    head_layers: Vec<DenseLayer>,
    normalize_output: bool,
    /// Point layers before the context stage; 0: none (module docs).
    context_after: usize,
}

impl FoldedNetwork {
    /// A network from its layers; checks that the widths chain (module docs).
    pub fn new(
        input_width: usize,
        point_layers: Vec<DenseLayer>,
        head_layers: Vec<DenseLayer>,
        normalize_output: bool,
    ) -> Result<Self, RegressorError> {
        Self::with_context(input_width, point_layers, head_layers, normalize_output, 0)
    }

    /// A network whose context stage follows point layer `context_after` (module docs; 0:
    /// none, as [`FoldedNetwork::new`]): point layer `context_after + 1` reads twice the
    /// width of its previous layer. Checks that the widths chain.
    pub fn with_context(
        input_width: usize,
        point_layers: Vec<DenseLayer>,
        head_layers: Vec<DenseLayer>,
        normalize_output: bool,
        context_after: usize,
    ) -> Result<Self, RegressorError> {
        if input_width == 0 || input_width > MAX_WIDTH {
            return Err(RegressorError::Format("input width zero or above MAX_WIDTH"));
        }
        if point_layers.is_empty() || head_layers.is_empty() {
            return Err(RegressorError::Format("need at least one point and one head layer"));
        }
        if context_after >= point_layers.len() {
            return Err(RegressorError::Format("the context stage must follow a point layer and precede another"));
        }
        let mut width = input_width;
        for (k, layer) in point_layers.iter().chain(&head_layers).enumerate() {
            let expected = if context_after > 0 && k == context_after { 2 * width } else { width };
            if layer.inputs != expected {
                return Err(RegressorError::Format("layer widths do not chain"));
            }
            width = layer.outputs;
        }
        Ok(Self { input_width, point_layers, head_layers, normalize_output, context_after })
    }

    /// Parses the binary format of the module docs (for example an `include_bytes!` of a
    /// shipped weights file). Allocates the weight vectors once.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, RegressorError> {
        let mut reader = Reader { bytes, pos: 0 };
        if reader.take(8)? != FOLDED_MAGIC {
            return Err(RegressorError::Format("bad magic (expected SHCFOLD1)"));
        }
        let input_width = reader.u32()?;
        let n_point = reader.u32()?;
        let n_head = reader.u32()?;
        let flags = reader.u32()?;
        if flags & !3 != 0 {
            return Err(RegressorError::Format("unknown flags"));
        }
        let context_after = if flags & 2 != 0 { reader.u32()? } else { 0 };
        if flags & 2 != 0 && context_after == 0 {
            return Err(RegressorError::Format("a context stage after no point layer"));
        }
        if n_point == 0 || n_head == 0 || n_point + n_head > 64 {
            return Err(RegressorError::Format("bad layer count"));
        }
        let mut layers = Vec::with_capacity(n_point + n_head);
        for _ in 0..n_point + n_head {
            let inputs = reader.u32()?;
            let outputs = reader.u32()?;
            if inputs == 0 || outputs == 0 || inputs > MAX_WIDTH || outputs > MAX_WIDTH {
                return Err(RegressorError::Format("layer width zero or above MAX_WIDTH"));
            }
            let weights = reader.f32s(inputs * outputs)?;
            let bias = reader.f32s(outputs)?;
            layers.push(DenseLayer::new(inputs, outputs, weights, bias)?);
        }
        if reader.pos != bytes.len() {
            return Err(RegressorError::Format("trailing bytes"));
        }
        let head_layers = layers.split_off(n_point);
        Self::with_context(input_width, layers, head_layers, flags & 1 == 1, context_after)
    }

    /// Serializes to the binary format of the module docs.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(FOLDED_MAGIC);
        let flags = usize::from(self.normalize_output) | if self.context_after > 0 { 2 } else { 0 };
        for v in [self.input_width, self.point_layers.len(), self.head_layers.len(), flags] {
            out.extend_from_slice(&(v as u32).to_le_bytes());
        }
        if self.context_after > 0 {
            out.extend_from_slice(&(self.context_after as u32).to_le_bytes());
        }
        for layer in self.point_layers.iter().chain(&self.head_layers) {
            out.extend_from_slice(&(layer.inputs as u32).to_le_bytes());
            out.extend_from_slice(&(layer.outputs as u32).to_le_bytes());
            for v in layer.weights.iter().chain(&layer.bias) {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    /// Width of one input row.
    pub fn input_width(&self) -> usize {
        self.input_width
    }

    /// Number of outputs.
    pub fn output_width(&self) -> usize {
        self.head_layers.last().map_or(0, |l| l.outputs)
    }

    /// Whether the output is divided by its Euclidean norm (a unit quaternion for UPnP).
    pub fn normalizes_output(&self) -> bool {
        self.normalize_output
    }

    /// Point layers before the context stage (module docs); 0: no context stage.
    pub fn context_after(&self) -> usize {
        self.context_after
    }

    /// The point layers (batch norm folded in; each followed by ReLU).
    pub fn point_layers(&self) -> &[DenseLayer] {
        &self.point_layers
    }

    /// The head layers (ReLU between them, none after the last).
    pub fn head_layers(&self) -> &[DenseLayer] {
        &self.head_layers
    }

    /// Number of parameters (weights and biases).
    pub fn num_params(&self) -> usize {
        self.point_layers.iter().chain(&self.head_layers).map(|l| l.weights.len() + l.bias.len()).sum()
    }

    /// Runs the network on `rows` (flat, `N * input_width` numbers, row after row, `N >= 1`;
    /// a `&[[f32; C]]` is passed as `rows.as_flattened()`) and writes the `output_width()`
    /// outputs to `out`.
    ///
    /// No heap allocation: activations live in stack buffers of [`MAX_WIDTH`] floats (14 KiB
    /// of stack). The rows are processed in blocks of four; a last partial block is padded by
    /// repeating its last row, which the max-pool ignores. Arithmetic is in `f32` (fused
    /// multiply-add with 256-bit vectors when the CPU has AVX2 and FMA, detected at run time;
    /// a portable path otherwise), the output normalization in `f64`.
    pub fn forward(&self, rows: &[f32], out: &mut [f64]) -> Result<(), RegressorError> {
        let c = self.input_width;
        if rows.is_empty() {
            return Err(RegressorError::EmptyInput);
        }
        if rows.len() % c != 0 {
            return Err(RegressorError::RowLength { len: rows.len(), width: c });
        }
        if out.len() != self.output_width() {
            return Err(RegressorError::OutputLength { expected: self.output_width(), got: out.len() });
        }
        if rows.iter().any(|v| !v.is_finite()) {
            return Err(RegressorError::NonFinite);
        }
        Isa::Avx2.run_for(Forward { net: self, rows, out });
        Ok(())
    }

    /// The forward pass on validated input (`rows` a non-empty whole number of rows, `out` of
    /// the output width); `TILE` outputs per register tile, `FMA` fused multiply-add.
    #[inline(always)]
    fn forward_impl<const TILE: usize, const FMA: bool>(&self, rows: &[f32], out: &mut [f64]) {
        let k = self.context_after;
        let width = self.point_layers.last().map_or(0, |l| l.outputs);
        let mut pooled = [f32::NEG_INFINITY; MAX_WIDTH];
        if k == 0 {
            self.pool_rows::<TILE, FMA>(rows, &self.point_layers, None, &mut pooled);
        } else {
            // The context: the first k layers pooled over the rows.
            let (first, rest) = self.point_layers.split_at(k);
            let mut context = [f32::NEG_INFINITY; MAX_WIDTH];
            self.pool_rows::<TILE, FMA>(rows, first, None, &mut context);
            // Layer k + 1 reads [h_i, g]: g's half of its weights is the same for every row,
            // so it joins the bias.
            let layer = &rest[0];
            let (half, o) = (layer.inputs / 2, layer.outputs);
            let mut bias = [0.0f32; MAX_WIDTH];
            bias[..o].copy_from_slice(&layer.bias);
            for (g, w) in context[..half].iter().zip(layer.weights[half * o..].chunks_exact(o)) {
                for (b, wj) in bias[..o].iter_mut().zip(w) {
                    *b = madd::<FMA>(*g, *wj, *b);
                }
            }
            self.pool_rows::<TILE, FMA>(rows, &self.point_layers, Some((k, &bias[..o])), &mut pooled);
        }
        let mut x = [0.0f32; MAX_WIDTH];
        let mut y = [0.0f32; MAX_WIDTH];
        x[..width].copy_from_slice(&pooled[..width]);
        let last = self.head_layers.len() - 1;
        let mut in_x = true;
        for (k, layer) in self.head_layers.iter().enumerate() {
            if in_x {
                layer.apply_row::<FMA>(&x[..], &mut y[..], k != last);
            } else {
                layer.apply_row::<FMA>(&y[..], &mut x[..], k != last);
            }
            in_x = !in_x;
        }
        let result = if in_x { &x[..] } else { &y[..] };
        for (o, v) in out.iter_mut().zip(result) {
            *o = f64::from(*v);
        }
        if self.normalize_output {
            let norm = out.iter().map(|v| v * v).sum::<f64>().sqrt();
            let norm = norm.max(1e-12);
            for o in out.iter_mut() {
                *o /= norm;
            }
        }
    }

    /// Runs `layers` on every row of `rows` (blocks of [`ROW_BLOCK`]) and max-pools their
    /// last outputs into `pooled`. With `context = Some((k, bias))`, layer `k` reads only its
    /// row half, with `bias` (the context folded in). A last partial block repeats its last
    /// row, which the max-pool ignores.
    #[inline(always)]
    fn pool_rows<const TILE: usize, const FMA: bool>(
        &self,
        rows: &[f32],
        layers: &[DenseLayer],
        context: Option<(usize, &[f32])>,
        pooled: &mut [f32; MAX_WIDTH],
    ) {
        let c = self.input_width;
        let n = rows.len() / c;
        let width = layers.last().map_or(0, |l| l.outputs);
        let mut a = [[0.0f32; MAX_WIDTH]; ROW_BLOCK];
        let mut b = [[0.0f32; MAX_WIDTH]; ROW_BLOCK];
        for start in (0..n).step_by(ROW_BLOCK) {
            for r in 0..ROW_BLOCK {
                let row = (start + r).min(n - 1);
                a[r][..c].copy_from_slice(&rows[row * c..(row + 1) * c]);
            }
            let mut in_a = true;
            for (j, layer) in layers.iter().enumerate() {
                let (from, to) = if in_a { (&a, &mut b) } else { (&b, &mut a) };
                match context {
                    Some((k, bias)) if j == k => layer.apply_block_part::<TILE, FMA>(layer.inputs / 2, bias, from, to),
                    _ => layer.apply_block::<TILE, FMA>(from, to),
                }
                in_a = !in_a;
            }
            let result = if in_a { &a } else { &b };
            for row in result {
                for (p, v) in pooled[..width].iter_mut().zip(&row[..width]) {
                    *p = p.max(*v);
                }
            }
        }
    }
}

/// Little-endian reader over the binary format.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], RegressorError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or(RegressorError::Format("truncated"))?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u32(&mut self) -> Result<usize, RegressorError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    }

    fn f32s(&mut self, n: usize) -> Result<Vec<f32>, RegressorError> {
        let b = self.take(n.checked_mul(4).ok_or(RegressorError::Format("truncated"))?)?;
        Ok(b.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    }
}

/// The forward pass as a kernel of the crate's run-time dispatcher ([`Isa::run_for`]): 16-wide
/// tiles with fused multiply-adds when compiled for AVX2 + FMA, 8-wide unfused otherwise.
struct Forward<'a> {
    net: &'a FoldedNetwork,
    rows: &'a [f32],
    out: &'a mut [f64],
}

impl IsaKernel for Forward<'_> {
    #[inline(always)]
    fn run(self, isa: Isa) {
        match isa {
            Isa::Baseline => self.net.forward_impl::<8, false>(self.rows, self.out),
            Isa::Avx2 | Isa::Avx512 => self.net.forward_impl::<16, true>(self.rows, self.out),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hypothesis_blocks_read_the_trainers_layouts() {
        let of = |o, w| HypothesisBlocks::of(o, w, 8);
        assert_eq!(of(10, 10), Some(HypothesisBlocks { width: 10, count: 1, scored: false }));
        assert_eq!(of(44, 10), Some(HypothesisBlocks { width: 10, count: 4, scored: true }));
        assert_eq!(of(40, 10), Some(HypothesisBlocks { width: 10, count: 4, scored: false }));
        assert_eq!(of(11, 10), None, "one block is never scored");
        assert_eq!(of(13, 10), None);
        assert_eq!(of(99, 10), None, "9 scored blocks are more than 8");
        assert_eq!(of(0, 0), None);
        for k in 1..=8 {
            let b = HypothesisBlocks::trained(7, k);
            assert_eq!(of(b.outputs(), 7), Some(b), "{k} trained hypotheses read back");
        }
        let b = HypothesisBlocks::trained(2, 2);
        assert_eq!(b.score(&[0.0, 0.0, 0.0, 0.0, 0.25, 0.75], 1), Some(0.75));
    }

    #[test]
    fn hypotheses_rank_by_score_else_by_the_cost_stably() {
        // Three scored blocks of width 1: scores 0.1, 0.9, 0.5 rank 1, 2, 0; the cost is unused.
        let scored = HypothesisBlocks::trained(1, 3);
        let out = [10.0, 11.0, 12.0, 0.1, 0.9, 0.5];
        assert_eq!(&scored.ranked::<8>(&out, |_| panic!("scored blocks ignore the cost"))[..3], &[1, 2, 0]);
        // Unscored: the cost, lower first; equal costs and NaN keep the network's order, NaN last.
        let unscored = HypothesisBlocks { width: 1, count: 4, scored: false };
        let costs = [2.0, f64::NAN, 1.0, 2.0];
        assert_eq!(&unscored.ranked::<8>(&out, |k| costs[k])[..4], &[2, 0, 3, 1]);
        assert_eq!(&unscored.ranked::<4>(&out, |_| 0.0), &[0, 1, 2, 3]);
        let one = HypothesisBlocks::trained(1, 1);
        assert_eq!(one.ranked::<8>(&out, |_| panic!("one hypothesis needs no cost"))[0], 0);
    }

    fn tiny() -> FoldedNetwork {
        // 2 -> 3 (point) -> 2 (head)
        let l1 = DenseLayer::new(2, 3, vec![1.0, -1.0, 0.5, 2.0, 0.0, -0.5], vec![0.0, 0.1, 0.2]).unwrap();
        let h = DenseLayer::new(3, 2, vec![1.0, 0.0, 0.0, 1.0, 1.0, 1.0], vec![0.0, 0.0]).unwrap();
        FoldedNetwork::new(2, vec![l1], vec![h], false).unwrap()
    }

    /// Reference forward pass written in the most direct way.
    /// A context stage keeps every row's features and concatenates the pooled ones.
    fn reference(net: &FoldedNetwork, rows: &[f32]) -> Vec<f64> {
        let dense_relu = |l: &DenseLayer, x: &[f32]| -> Vec<f32> {
            (0..l.outputs())
                .map(|j| {
                    let s: f32 = (0..l.inputs()).map(|i| x[i] * l.weights()[i * l.outputs() + j]).sum();
                    (s + l.bias()[j]).max(0.0)
                })
                .collect()
        };
        let max_pool = |xs: &[Vec<f32>]| -> Vec<f32> {
            let mut p = xs[0].clone();
            for x in xs {
                p.iter_mut().zip(x).for_each(|(a, b)| *a = a.max(*b));
            }
            p
        };
        let c = net.input_width();
        let mut features: Vec<Vec<f32>> = rows.chunks_exact(c).map(<[f32]>::to_vec).collect();
        for (k, l) in net.point_layers().iter().enumerate() {
            if net.context_after() > 0 && k == net.context_after() {
                let g = max_pool(&features);
                features.iter_mut().for_each(|x| x.extend_from_slice(&g));
            }
            features = features.iter().map(|x| dense_relu(l, x)).collect();
        }
        let mut x = max_pool(&features);
        let last = net.head_layers().len() - 1;
        for (k, l) in net.head_layers().iter().enumerate() {
            x = (0..l.outputs())
                .map(|j| {
                    let s: f32 = (0..l.inputs()).map(|i| x[i] * l.weights()[i * l.outputs() + j]).sum();
                    let v = s + l.bias()[j];
                    if k == last {
                        v
                    } else {
                        v.max(0.0)
                    }
                })
                .collect();
        }
        let mut out: Vec<f64> = x.iter().map(|v| f64::from(*v)).collect();
        if net.normalizes_output() {
            let n = out.iter().map(|v| v * v).sum::<f64>().sqrt();
            out.iter_mut().for_each(|v| *v /= n);
        }
        out
    }

    #[test]
    fn tiny_network_by_hand() {
        let net = tiny();
        // row (1, 1): [1+2, -1+0+0.1, 0.5-0.5+0.2] = [3, 0 (relu of -0.9), 0.2]
        // row (0, 1): [2, 0.1, -0.5+0.2 -> 0] ; max = [3, 0.1, 0.2]
        let mut out = [0.0; 2];
        net.forward(&[1.0, 1.0, 0.0, 1.0], &mut out).unwrap();
        assert!((out[0] - 3.2).abs() < 1e-6 && (out[1] - 0.3).abs() < 1e-6, "{out:?}");
    }

    /// Seeded numbers in [-0.5, 0.5) (a linear congruential generator: no dependency).
    fn uniform(seed: u64) -> impl FnMut() -> f32 {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) as f32 / (1u64 << 31) as f32) - 0.5
        }
    }

    /// A layer of `i` inputs and `o` outputs with weights and biases from `rnd`.
    fn random_layer(rnd: &mut impl FnMut() -> f32, i: usize, o: usize) -> DenseLayer {
        DenseLayer::new(i, o, (0..i * o).map(|_| rnd()).collect(), (0..o).map(|_| rnd()).collect()).unwrap()
    }

    #[test]
    fn blocked_kernel_matches_reference_for_odd_sizes() {
        // widths not multiples of the tile, row counts not multiples of the block
        let mut rnd = uniform(12345);
        let point: Vec<DenseLayer> = [(5, 19), (19, 24), (24, 37)].iter().map(|&(i, o)| random_layer(&mut rnd, i, o)).collect();
        let head = vec![random_layer(&mut rnd, 37, 11), random_layer(&mut rnd, 11, 4)];
        let net = FoldedNetwork::new(5, point, head, true).unwrap();
        for n in [1, 3, 4, 7, 16] {
            let rows: Vec<f32> = (0..5 * n).map(|_| 4.0 * rnd()).collect();
            let mut out = [0.0; 4];
            net.forward(&rows, &mut out).unwrap();
            let mut portable = [0.0; 4];
            net.forward_impl::<8, false>(&rows, &mut portable);
            let want = reference(&net, &rows);
            for ((a, p), b) in out.iter().zip(&portable).zip(&want) {
                assert!((a - b).abs() < 1e-5, "n={n}: {out:?} vs {want:?}");
                assert!((p - b).abs() < 1e-5, "n={n}: portable {portable:?} vs {want:?}");
            }
        }
        let back = FoldedNetwork::from_bytes(&net.to_bytes()).unwrap();
        assert_eq!(back, net);
    }

    #[test]
    fn context_stage_matches_reference_for_any_row_count() {
        let mut rnd = uniform(777);
        let mut layer = |i: usize, o: usize| random_layer(&mut rnd, i, o);
        // 3 -> 17 -> 21 | context: [21 + 21] -> 19 -> 23 | head 23 -> 5
        let point = vec![layer(3, 17), layer(17, 21), layer(42, 19), layer(19, 23)];
        let head = vec![layer(23, 5)];
        assert!(FoldedNetwork::new(3, point.clone(), head.clone(), false).is_err(), "widths chain only with the context");
        assert!(FoldedNetwork::with_context(3, point.clone(), head.clone(), false, 1).is_err(), "the context after the wrong layer");
        assert!(FoldedNetwork::with_context(3, point.clone(), head.clone(), false, 4).is_err(), "a context after the last layer");
        let net = FoldedNetwork::with_context(3, point, head, false, 2).unwrap();
        assert_eq!(net.context_after(), 2);
        for n in [1, 2, 5, 8, 13] {
            let rows: Vec<f32> = (0..3 * n).map(|i| 3.0 * ((i * 7919 % 113) as f32 / 113.0 - 0.5)).collect();
            let (mut fast, mut portable) = ([0.0; 5], [0.0; 5]);
            net.forward(&rows, &mut fast).unwrap();
            net.forward_impl::<8, false>(&rows, &mut portable);
            let want = reference(&net, &rows);
            for ((a, p), b) in fast.iter().zip(&portable).zip(&want) {
                assert!((a - b).abs() < 1e-4 * (1.0 + b.abs()), "n={n}: {fast:?} vs {want:?}");
                assert!((p - b).abs() < 1e-4 * (1.0 + b.abs()), "n={n}: portable {portable:?} vs {want:?}");
            }
        }
        let back = FoldedNetwork::from_bytes(&net.to_bytes()).unwrap();
        assert_eq!(back, net);
        let mut bad = net.to_bytes();
        bad[24..28].copy_from_slice(&0u32.to_le_bytes());
        assert!(matches!(FoldedNetwork::from_bytes(&bad), Err(RegressorError::Format(_))), "a context after no layer");
    }

    #[test]
    fn typed_errors() {
        let net = tiny();
        let mut out = [0.0; 2];
        assert_eq!(net.forward(&[], &mut out), Err(RegressorError::EmptyInput));
        assert_eq!(net.forward(&[1.0; 3], &mut out), Err(RegressorError::RowLength { len: 3, width: 2 }));
        assert_eq!(net.forward(&[1.0; 2], &mut [0.0; 3]), Err(RegressorError::OutputLength { expected: 2, got: 3 }));
        assert_eq!(net.forward(&[f32::NAN, 1.0], &mut out), Err(RegressorError::NonFinite));
        let bytes = net.to_bytes();
        assert!(matches!(FoldedNetwork::from_bytes(&bytes[..bytes.len() - 1]), Err(RegressorError::Format(_))));
        let mut extra = bytes.clone();
        extra.push(0);
        assert!(matches!(FoldedNetwork::from_bytes(&extra), Err(RegressorError::Format(_))));
        assert!(matches!(FoldedNetwork::from_bytes(b"NOTMAGIC"), Err(RegressorError::Format(_))));
    }
}
