//! The spreads and gains of the possibility-theory ("fuzzy") filter [K95 5–6, end].
//!
//! Spreads add linearly (sup–min convolution of the memberships exp(-a²/s²)); a measurement
//! combines with a prediction like variances do. State: (P_n, P'_n, unused).

use super::gain::{Gain, Seen, Spread};
use super::model::MotionModel;

/// n = 0: P_0² = R²P²/(R² + P²), P'_0 = P' (or, with a velocity measurement, the same
/// combination with R'), α_0 = P_0²/R², β_0 = 0 [K95 5].
pub(crate) fn start(model: &MotionModel, seen_vel: bool) -> (Spread, Gain) {
    let r2 = model.r * model.r;
    let p2 = model.p * model.p;
    let p0_sq = r2 * p2 / (r2 + p2);
    let mut gain = Gain {
        xx: p0_sq / r2,
        ..Gain::default()
    };
    let p_vel = match model.r_vel {
        Some(rv) if seen_vel => {
            let rv2 = rv * rv;
            let pv2 = model.p_vel * model.p_vel;
            let pv0_sq = pv2 * rv2 / (pv2 + rv2);
            gain.vv = pv0_sq / rv2;
            pv0_sq.sqrt()
        }
        _ => model.p_vel,
    };
    ([p0_sq.sqrt(), p_vel, 0.0], gain)
}

/// Q_n = P_{n-1} + P'_{n-1}τ_n + Q, the spread of the predicted position.
pub(crate) fn predicted_spread(model: &MotionModel, spread: &Spread, tau: f64) -> f64 {
    spread[0] + spread[1] * tau + model.q
}

/// n ≥ 1 [K95 6]; a missing channel keeps its predicted spread and gets no gain.
pub(crate) fn advance(model: &MotionModel, spread: &mut Spread, tau: f64, seen: Seen) -> Gain {
    let [p, p_vel, _] = *spread;
    let q_n = predicted_spread(model, spread, tau);
    let q_vel_n = p_vel + model.q_vel;
    let r2 = model.r * model.r;
    let mut gain = Gain::default();
    let mut next = [q_n, q_vel_n, 0.0];
    match model.r_vel {
        None => {
            if seen.pos {
                let h = p + model.q + model.r + model.q_vel * tau;
                let q2 = q_n * q_n;
                let p_sq = r2 * q2 / (r2 + q2);
                let (h2, qv2, t2) = (h * h, q_vel_n * q_vel_n, tau * tau);
                let p_vel_sq = h2 * qv2 / (h2 + qv2 * t2);
                gain.xx = p_sq / r2;
                gain.vx = p_vel_sq * t2 / h2 / tau;
                next = [p_sq.sqrt(), p_vel_sq.sqrt(), 0.0];
            }
        }
        Some(rv) => {
            if seen.pos {
                let q2 = q_n * q_n;
                let p_sq = r2 * q2 / (r2 + q2);
                gain.xx = p_sq / r2;
                next[0] = p_sq.sqrt();
            }
            if seen.vel {
                let (rv2, qv2) = (rv * rv, q_vel_n * q_vel_n);
                let p_vel_sq = rv2 * qv2 / (rv2 + qv2);
                gain.vv = p_vel_sq / rv2;
                next[1] = p_vel_sq.sqrt();
            }
        }
    }
    *spread = next;
    gain
}
