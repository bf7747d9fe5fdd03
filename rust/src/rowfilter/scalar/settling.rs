//! When a row-to-row sequence (the band of P_e, the per-mode covariances) has settled:
//! the drift scale and the geometric-tail test that freeze the row models.

use faer::Mat;

/// Drift of the band from the one the row model was fitted to (relative to `drift_scale`)
/// beyond which the model is refitted, and the tolerance within which the band must have
/// settled (`settled`) for the model to be frozen.
pub(super) const SETTLE_TOLERANCE: f64 = 1e-3;

/// The most the ratio of successive changes may rise from one row to the next for their
/// geometric tail to be trusted (`settled`).
pub(super) const RATIO_RISE: f64 = 0.05;

/// The drift scale (`drift_scale`) is at least this fraction of the band's largest entry, so
/// the band's rounding stays far below the refit tolerance.
pub(super) const DRIFT_FLOOR: f64 = 1e-9;

/// Largest entry-wise difference between two bands of blocks.
pub(super) fn band_change(band: &[Mat<f64>], other: &[Mat<f64>]) -> f64 {
    band.iter()
        .zip(other)
        .fold(0.0, |most, (a, b)| most.max(max_abs_difference(a, Some(b))))
}

/// The scale the row-to-row changes of the band of P_e,t are measured against: the largest
/// entry of the band of P_e,t − Q = S P_f,t−1 Sᵀ, the part of the prediction error that
/// changes from row to row (the innovation Q is the same on every row), at least
/// [`DRIFT_FLOOR`] times the band's largest entry. Against the band's largest entry alone, at
/// high SNR (where P_e ≈ Q) the changes that matter looked 10²–10⁴ times smaller than they
/// are and the models froze early.
pub(super) fn drift_scale(band: &[Mat<f64>], innovation: &[Mat<f64>]) -> f64 {
    let varying = max_abs_difference(&band[0], Some(&innovation[0]));
    varying.max(DRIFT_FLOOR * max_abs_difference(&band[0], None))
}

/// Whether a sequence whose latest relative change is `change` (the two before: `previous`,
/// `earlier`) lies within `tolerance` of its limit: change / (1 − q) ≤ tolerance, q = change /
/// previous, the geometric tail the last two changes imply, provided q is not rising (by
/// more than [`RATIO_RISE`] against previous / earlier: a contraction that slows down is a
/// slower mode taking over, and its tail is longer); at q ≥ 0.999 (not contracting yet, or
/// changes at the rounding floor) change ≤ 1e-3 tolerance. One row's change ≤ tolerance
/// alone froze slowly converging Riccatis (ρ = 0.999) far from their limit, and the tail
/// without the rising check froze a band that drifts for ~600 rows (ρ_y = 0.9999) at its
/// fifth row: losses of 33 % and 84 % against the optimal filter (design notes).
pub(super) fn settled(
    change: f64,
    previous: Option<f64>,
    earlier: Option<f64>,
    tolerance: f64,
) -> bool {
    if change == 0.0 {
        return true;
    }
    let Some(previous) = previous else {
        return false;
    };
    let ratio = |a: f64, b: f64| if b > 0.0 { (a / b).min(1.0) } else { 1.0 };
    let q = ratio(change, previous);
    if q < 0.999 {
        match earlier {
            Some(earlier) if q <= ratio(previous, earlier) + RATIO_RISE => {}
            _ => return false,
        }
    }
    change <= tolerance * (1.0 - q).max(1e-3)
}

/// The recent row-to-row changes of a converging sequence, for [`settled`].
#[derive(Debug, Default)]
pub(super) struct Settling {
    previous: Option<f64>,
    earlier: Option<f64>,
}

impl Settling {
    /// Records `change`; whether the sequence now lies within `tolerance` of its limit.
    pub(super) fn settled_after(&mut self, change: f64, tolerance: f64) -> bool {
        let done = settled(change, self.previous, self.earlier, tolerance);
        (self.earlier, self.previous) = (self.previous, Some(change));
        done
    }
}

/// max |a − b| over the entries (max |a| without b).
pub(super) fn max_abs_difference(a: &Mat<f64>, b: Option<&Mat<f64>>) -> f64 {
    let mut most = 0.0f64;
    for c in 0..a.ncols() {
        for r in 0..a.nrows() {
            let other = b.map_or(0.0, |b| b[(r, c)]);
            most = most.max((a[(r, c)] - other).abs());
        }
    }
    most
}
