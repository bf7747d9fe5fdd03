//! The eigenbasis U_y ⊗ U_x of the frame covariance σ² C_y ⊗ C_x (SPEC §2.5) and the
//! transforms of a frame into it and back, O(H·W·(H+W)) each.

use crate::error::{try_zeros, Result};
use crate::field::{AxisModes, FieldModel};
use rayon::prelude::*;

/// Row-major eigenvectors of both spatial axes and the mode variances λ_ab = σ² μ_a ν_b.
#[derive(Debug, Clone)]
pub(crate) struct ModeBasis {
    pub height: usize,
    pub width: usize,
    /// U_y (H × H) and its transpose, row-major.
    uy: Vec<f64>,
    uyt: Vec<f64>,
    /// U_x (W × W) and its transpose, row-major.
    ux: Vec<f64>,
    uxt: Vec<f64>,
    /// λ of mode (a, b) at a·W + b.
    pub variances: Vec<f64>,
}

fn row_major(modes: &AxisModes) -> (Vec<f64>, Vec<f64>) {
    let n = modes.size();
    let u = (0..n * n).map(|k| modes.vectors[(k / n, k % n)]).collect();
    let ut = (0..n * n).map(|k| modes.vectors[(k % n, k / n)]).collect();
    (u, ut)
}

impl ModeBasis {
    /// The basis of the spatial axes (1, 2) of a 3-axis `model` on height × width frames.
    pub fn new(model: &FieldModel, height: usize, width: usize) -> Result<Self> {
        let axes = model.axes();
        let y = AxisModes::new(&axes[1], height)?;
        let x = AxisModes::new(&axes[2], width)?;
        let s2 = model.sigma() * model.sigma();
        let mut variances = try_zeros(height * width, "the mode variances")?;
        for (a, row) in variances.chunks_exact_mut(width).enumerate() {
            for (b, v) in row.iter_mut().enumerate() {
                *v = s2 * y.values[a] * x.values[b];
            }
        }
        let (uy, uyt) = row_major(&y);
        let (ux, uxt) = row_major(&x);
        Ok(Self {
            height,
            width,
            uy,
            uyt,
            ux,
            uxt,
            variances,
        })
    }

    /// Mode coefficients U_yᵀ z U_x of a frame `z` into `out`; `work` holds H·W values.
    pub fn to_modes(&self, z: &[f64], out: &mut [f64], work: &mut [f64]) {
        multiply(z, &self.ux, work, self.width);
        multiply(&self.uyt, work, out, self.width);
    }

    /// The frame U_y M U_xᵀ of mode coefficients `m` into `out`; `work` holds H·W values.
    pub fn to_pixels(&self, m: &[f64], out: &mut [f64], work: &mut [f64]) {
        multiply(m, &self.uxt, work, self.width);
        multiply(&self.uy, work, out, self.width);
    }

    /// Σ_ab U_y[i,a]² v_ab U_x[k,b]²: per-pixel variances of independent modes of variance v.
    pub fn pixel_variances(&self, v: &[f64], out: &mut [f64]) {
        let square = |u: &[f64]| u.iter().map(|e| e * e).collect::<Vec<_>>();
        let mut work = vec![0.0; v.len()];
        multiply(v, &square(&self.uxt), &mut work, self.width);
        multiply(&square(&self.uy), &work, out, self.width);
    }
}

/// out = a · b for row-major a (rows × inner) and b (inner × cols): each output row a sum of
/// rows of b (contiguous saxpys), rows in parallel (the same bits whatever the threads).
fn multiply(a: &[f64], b: &[f64], out: &mut [f64], cols: usize) {
    let inner = b.len() / cols;
    out.par_chunks_mut(cols)
        .zip(a.par_chunks(inner))
        .for_each(|(row, coefficients)| {
            row.fill(0.0);
            for (&c, b_row) in coefficients.iter().zip(b.chunks_exact(cols)) {
                for (o, &v) in row.iter_mut().zip(b_row) {
                    *o += c * v;
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_are_inverse() {
        let model = FieldModel::new(&[0.9, 0.8, 0.7], &[1, 2, 1], 1.5).unwrap();
        let basis = ModeBasis::new(&model, 5, 7).unwrap();
        let z: Vec<f64> = (0..35).map(|k| ((k * 7919) % 13) as f64 - 6.0).collect();
        let (mut m, mut back, mut work) = (vec![0.0; 35], vec![0.0; 35], vec![0.0; 35]);
        basis.to_modes(&z, &mut m, &mut work);
        basis.to_pixels(&m, &mut back, &mut work);
        for (a, b) in z.iter().zip(&back) {
            assert!((a - b).abs() < 1e-12);
        }
        // the pixel variances of the prior are σ² everywhere
        let mut prior = vec![0.0; 35];
        basis.pixel_variances(&basis.variances, &mut prior);
        assert!(prior.iter().all(|v| (v - 2.25).abs() < 1e-12));
    }
}
