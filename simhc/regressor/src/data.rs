//! A generic in-memory data set of `(rows [N x C] f32, target [T] f32)` samples, built from a
//! caller-supplied sample function, and its conversion into burn batches.
//!
//! The data set does no normalization of its own: the sample function returns rows that are
//! already in the network's input convention, so inference only has to call the same function
//! that built the training rows (for UPnP, `simhc_problems::upnp::features`, see
//! [`crate::upnp`]).

use burn::prelude::*;
use thiserror::Error;

/// A sample function returned rows or a target of the wrong size.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum DataError {
    /// Sample `index` has `got` row numbers instead of `points * channels`.
    #[error("sample {index}: {got} row numbers, expected {expected}")]
    RowSize {
        /// Sample index.
        index: usize,
        /// Length returned.
        got: usize,
        /// `points * channels`.
        expected: usize,
    },
    /// Sample `index` has a target of length `got` instead of `target_width`.
    #[error("sample {index}: target of length {got}, expected {expected}")]
    TargetSize {
        /// Sample index.
        index: usize,
        /// Length returned.
        got: usize,
        /// `target_width`.
        expected: usize,
    },
    /// A row or target number was not finite.
    #[error("sample {index}: non-finite value")]
    NonFinite {
        /// Sample index.
        index: usize,
    },
}

/// One sample: flat rows (`points * channels`, row after row) and the target.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Input rows, flat.
    pub rows: Vec<f32>,
    /// Regression target.
    pub target: Vec<f32>,
}

/// Samples with a fixed number of rows, row width and target width, stored contiguously.
#[derive(Debug, Clone, PartialEq)]
pub struct InMemoryDataset {
    points: usize,
    channels: usize,
    target_width: usize,
    inputs: Vec<f32>,
    targets: Vec<f32>,
}

impl InMemoryDataset {
    /// Builds `count` samples by calling `sample(i)` for `i = 0..count` in order (so a seeded
    /// RNG captured by the closure gives a reproducible data set). Every sample must have
    /// `points * channels` finite row numbers and `target_width` finite target numbers.
    pub fn from_fn<F>(count: usize, points: usize, channels: usize, target_width: usize, mut sample: F) -> Result<Self, DataError>
    where
        F: FnMut(usize) -> Sample,
    {
        let row_len = points * channels;
        let mut inputs = Vec::with_capacity(count * row_len);
        let mut targets = Vec::with_capacity(count * target_width);
        for index in 0..count {
            let s = sample(index);
            if s.rows.len() != row_len {
                return Err(DataError::RowSize { index, got: s.rows.len(), expected: row_len });
            }
            if s.target.len() != target_width {
                return Err(DataError::TargetSize { index, got: s.target.len(), expected: target_width });
            }
            if s.rows.iter().chain(&s.target).any(|v| !v.is_finite()) {
                return Err(DataError::NonFinite { index });
            }
            inputs.extend_from_slice(&s.rows);
            targets.extend_from_slice(&s.target);
        }
        Ok(Self { points, channels, target_width, inputs, targets })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.targets.len() / self.target_width.max(1)
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Rows per sample.
    pub fn points(&self) -> usize {
        self.points
    }

    /// Numbers per row.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Numbers per target.
    pub fn target_width(&self) -> usize {
        self.target_width
    }

    /// The flat rows of sample `i`.
    pub fn rows(&self, i: usize) -> &[f32] {
        let n = self.points * self.channels;
        &self.inputs[i * n..(i + 1) * n]
    }

    /// The target of sample `i`.
    pub fn target(&self, i: usize) -> &[f32] {
        &self.targets[i * self.target_width..(i + 1) * self.target_width]
    }

    /// The samples `indices` as an input tensor `[B, N, C]` and a target tensor `[B, T]`.
    pub fn batch(&self, indices: &[usize], device: &Device) -> (Tensor<3>, Tensor<2>) {
        let n = self.points * self.channels;
        let mut x = Vec::with_capacity(indices.len() * n);
        let mut y = Vec::with_capacity(indices.len() * self.target_width);
        for &i in indices {
            x.extend_from_slice(self.rows(i));
            y.extend_from_slice(self.target(i));
        }
        let b = indices.len();
        (
            Tensor::from_data(TensorData::new(x, [b, self.points, self.channels]), device),
            Tensor::from_data(TensorData::new(y, [b, self.target_width]), device),
        )
    }
}
