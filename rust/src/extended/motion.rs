//! The centroid motion model of one axis (SPEC §3.1, §3.5): Taylor transition F and the
//! process covariance of the source's model, where the ν-th derivative takes a random step
//! w_ν ~ N(0, σ²) each frame and every lower derivative moves by its Taylor share:
//! W = g w_ν, g_i = τ^(ν−i)/(ν−i)!, Q = σ² g gᵀ (for ν = 1: x += x′τ + w τ, x′ += w, (3.7)).

// Index loops over axes and parameters mirror the formulas and the NumPy twin.
#![allow(clippy::needless_range_loop)]

/// State length bound: ν + 1 ≤ 3.
pub(crate) const DIM: usize = 3;

pub(crate) type Vector = [f64; DIM];
pub(crate) type Matrix = [[f64; DIM]; DIM];

fn factorial(n: usize) -> f64 {
    (1..=n).map(|k| k as f64).product()
}

/// (F, Q) of order ν, step τ and derivative std σ (unused entries zero).
pub(crate) fn motion(order: usize, tau: f64, sigma: f64) -> (Matrix, Matrix) {
    let d = order + 1;
    let mut f = [[0.0; DIM]; DIM];
    let mut g = [0.0; DIM];
    for i in 0..d {
        for j in i..d {
            f[i][j] = tau.powi((j - i) as i32) / factorial(j - i);
        }
        g[i] = tau.powi((order - i) as i32) / factorial(order - i);
    }
    let mut q = [[0.0; DIM]; DIM];
    for i in 0..d {
        for j in 0..d {
            q[i][j] = sigma * sigma * g[i] * g[j];
        }
    }
    (f, q)
}

/// F x.
pub(crate) fn apply(f: &Matrix, x: &Vector, d: usize) -> Vector {
    let mut out = [0.0; DIM];
    for i in 0..d {
        for j in 0..d {
            out[i] += f[i][j] * x[j];
        }
    }
    out
}

/// F P Fᵀ + Q.
pub(crate) fn propagate(f: &Matrix, p: &Matrix, q: &Matrix, d: usize) -> Matrix {
    let mut fp = [[0.0; DIM]; DIM];
    for i in 0..d {
        for j in 0..d {
            for k in 0..d {
                fp[i][j] += f[i][k] * p[k][j];
            }
        }
    }
    let mut out = [[0.0; DIM]; DIM];
    for i in 0..d {
        for j in 0..d {
            let mut s = q[i][j];
            for k in 0..d {
                s += fp[i][k] * f[j][k];
            }
            out[i][j] = s;
        }
    }
    out
}
