//! x̄_0, x̄'_0: the least-squares start of a segment [K95 5] ("practically by least squares on
//! z_0, z_1, z_2").
//!
//! The fit uses the observed samples among the segment's first three (the first one is always
//! observed: a segment starts at an observed sample). With a velocity in the model and at
//! least two observed samples it fits a line in time (x̄_0 its value at t_0, x̄'_0 its slope);
//! otherwise a constant (their mean) with x̄'_0 = 0.

/// (x̄_0, x̄'_0) from the times `t` and samples `z` (NaN = missing; `z[0]` observed).
pub(crate) fn least_squares_start(has_velocity: bool, t: &[f64], z: &[f64]) -> (f64, f64) {
    let mut count = 0.0;
    let (mut sum_t, mut sum_z) = (0.0, 0.0);
    for (&ti, &zi) in t.iter().zip(z) {
        if !zi.is_nan() {
            count += 1.0;
            sum_t += ti - t[0];
            sum_z += zi;
        }
    }
    let (mean_t, mean_z) = (sum_t / count, sum_z / count);
    if !has_velocity || count < 2.0 {
        return (mean_z, 0.0);
    }
    let (mut stt, mut stz) = (0.0, 0.0);
    for (&ti, &zi) in t.iter().zip(z) {
        if !zi.is_nan() {
            let dt = ti - t[0] - mean_t;
            stt += dt * dt;
            stz += dt * (zi - mean_z);
        }
    }
    let slope = stz / stt;
    (mean_z - slope * mean_t, slope)
}
