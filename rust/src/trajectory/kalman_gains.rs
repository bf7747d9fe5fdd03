//! The covariances and gains of the Kalman filter of the same model: state (x, x'), transition
//! F = [[1, τ], [0, 1]], process covariance diag(Q², Q'²), initial covariance diag(P², P'²),
//! measurement variance R² (and R'² for velocities). State: (Σ_xx, Σ_xv, Σ_vv).

use super::gain::{Gain, Seen, Spread};
use super::model::MotionModel;

/// Σ^e = F Σ F^T + diag(Q², Q'²).
pub(crate) fn predict(model: &MotionModel, s: &Spread, tau: f64) -> Spread {
    let [xx, xv, vv] = *s;
    [
        xx + tau * (2.0 * xv + tau * vv) + model.q * model.q,
        xv + tau * vv,
        vv + model.q_vel * model.q_vel,
    ]
}

/// The measurement update of Σ^e with the observed channels; returns the gain K.
pub(crate) fn correct(model: &MotionModel, s: &mut Spread, seen: Seen) -> Gain {
    let [xx, xv, vv] = *s;
    let r2 = model.r * model.r;
    let vel = model.r_vel.filter(|_| seen.vel).map(|rv| rv * rv);
    match (seen.pos, vel) {
        (false, None) => Gain::default(),
        (true, None) => {
            let sv = xx + r2;
            *s = [xx * r2 / sv, xv * r2 / sv, vv - xv * xv / sv];
            Gain {
                xx: xx / sv,
                vx: xv / sv,
                ..Gain::default()
            }
        }
        (false, Some(rv2)) => {
            let sv = vv + rv2;
            *s = [xx - xv * xv / sv, xv * rv2 / sv, vv * rv2 / sv];
            Gain {
                xv: xv / sv,
                vv: vv / sv,
                ..Gain::default()
            }
        }
        (true, Some(rv2)) => {
            // S = Σ^e + diag(R², R'²), K = Σ^e S⁻¹, Σ = Σ^e - K Σ^e
            let (sxx, sxv, svv) = (xx + r2, xv, vv + rv2);
            let det = sxx * svv - sxv * sxv;
            let (ixx, ixv, ivv) = (svv / det, -sxv / det, sxx / det);
            let g = Gain {
                xx: xx * ixx + xv * ixv,
                xv: xx * ixv + xv * ivv,
                vx: xv * ixx + vv * ixv,
                vv: xv * ixv + vv * ivv,
            };
            *s = [
                xx - (g.xx * xx + g.xv * xv),
                xv - (g.xx * xv + g.xv * vv),
                vv - (g.vx * xv + g.vv * vv),
            ];
            g
        }
    }
}

/// n = 0: the prior diag(P², P'²) corrected with z_0 (and z'_0).
pub(crate) fn start(model: &MotionModel, seen_vel: bool) -> (Spread, Gain) {
    let mut s = [model.p * model.p, 0.0, model.p_vel * model.p_vel];
    let seen = Seen {
        pos: true,
        vel: seen_vel,
    };
    let g = correct(model, &mut s, seen);
    (s, g)
}

/// n ≥ 1: predict over τ, then correct.
pub(crate) fn advance(model: &MotionModel, spread: &mut Spread, tau: f64, seen: Seen) -> Gain {
    *spread = predict(model, spread, tau);
    correct(model, spread, seen)
}
