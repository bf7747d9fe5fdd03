//! Symmetric banded matrices: the storage of the row systems of the quasi-optimal row
//! filter (SPEC §2.3 generalised) and of their factors.

/// A symmetric matrix with `bandwidth` sub-diagonals, lower band stored row by row:
/// entry (i, k), i - bandwidth ≤ k ≤ i, at `data[i * (bandwidth + 1) + k + bandwidth - i]`.
#[derive(Debug, Clone, PartialEq)]
pub struct SymmetricBand {
    pub(super) size: usize,
    pub(super) bandwidth: usize,
    pub(super) data: Vec<f64>,
}

/// Where entry (i, k), i − b ≤ k ≤ i, of a lower band of bandwidth b is stored (rows of b + 1
/// entries, the diagonal last): the layout of [`SymmetricBand`] and of its Cholesky factor.
#[inline(always)]
pub(crate) fn band_index(b: usize, i: usize, k: usize) -> usize {
    i * (b + 1) + k + b - i
}

impl SymmetricBand {
    /// The zero matrix.
    pub fn zeros(size: usize, bandwidth: usize) -> Self {
        Self {
            size,
            bandwidth,
            data: vec![0.0; size * (bandwidth + 1)],
        }
    }

    /// Matrix order.
    pub fn size(&self) -> usize {
        self.size
    }

    #[inline(always)]
    fn index(&self, i: usize, k: usize) -> usize {
        band_index(self.bandwidth, i, k)
    }

    /// Adds `value` to entries (i, k) and (k, i); |i - k| must be within the band.
    pub fn add(&mut self, i: usize, k: usize, value: f64) {
        let (i, k) = if i >= k { (i, k) } else { (k, i) };
        debug_assert!(i - k <= self.bandwidth);
        let at = self.index(i, k);
        self.data[at] += value;
    }

    /// Row i of the lower band: entries (i, i − bandwidth..=i), the diagonal last (those
    /// before column 0 are padding).
    #[inline(always)]
    pub(crate) fn lower_row_mut(&mut self, i: usize) -> &mut [f64] {
        let width = self.bandwidth + 1;
        &mut self.data[i * width..(i + 1) * width]
    }

    /// Entry (i, k) of the lower band: i − bandwidth ≤ k ≤ i.
    #[inline(always)]
    pub(crate) fn lower_entry(&self, i: usize, k: usize) -> f64 {
        self.data[self.index(i, k)]
    }

    /// Bandwidth (number of sub-diagonals).
    pub fn bandwidth(&self) -> usize {
        self.bandwidth
    }

    /// Entry (i, k) (zero outside the band).
    pub fn get(&self, i: usize, k: usize) -> f64 {
        let (i, k) = if i >= k { (i, k) } else { (k, i) };
        if i - k > self.bandwidth {
            0.0
        } else {
            self.data[self.index(i, k)]
        }
    }

    /// self += other (same order and bandwidth).
    pub(crate) fn add_band(&mut self, other: &SymmetricBand) {
        debug_assert!(self.size == other.size && self.bandwidth == other.bandwidth);
        for (a, b) in self.data.iter_mut().zip(&other.data) {
            *a += b;
        }
    }

    /// y = A x.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        let b = self.bandwidth;
        y.iter_mut().for_each(|v| *v = 0.0);
        for i in 0..self.size {
            let row = &self.data[i * (b + 1)..(i + 1) * (b + 1)];
            let first = i.saturating_sub(b);
            let mut acc = 0.0;
            for k in first..i {
                let a = row[k + b - i];
                acc += a * x[k];
                y[k] += a * x[i];
            }
            y[i] += acc + row[b] * x[i];
        }
    }

    /// The band's entries in the storage of bandwidth `b` ≥ its own (zeros beyond it).
    pub(super) fn widened(&self, b: usize) -> Vec<f64> {
        let own = self.bandwidth;
        if b == own {
            return self.data.clone();
        }
        let mut data = vec![0.0; self.size * (b + 1)];
        for (i, row) in self.data.chunks_exact(own + 1).enumerate() {
            data[band_index(b, i, i) - own..=band_index(b, i, i)].copy_from_slice(row);
        }
        data
    }
}
