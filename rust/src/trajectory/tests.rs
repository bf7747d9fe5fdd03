//! Unit tests of the trajectory kernels (the NumPy twin checks the same in Python).

use super::batch::{filter_batch, Batch, Times};
use super::gain_recursion::gain_sequence;
use super::model::{GainRule, MotionModel};
use super::*;

fn model(rule: GainRule, p: f64, pv: f64, q: f64, qv: f64, r: f64) -> MotionModel {
    MotionModel::new(rule, p, q, r, pv, qv, None).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

#[test]
fn fuzzy_gains_follow_the_recursion_by_hand() {
    // P = P' = Q = Q' = R = 1, τ = 1: P_0² = 1/2, α_0 = 1/2; Q_1 = √½ + 1 + 1,
    // P_1² = Q_1²/(1 + Q_1²), H_1 = √½ + 3, Q'_1 = 2, P'_1² = 4H²/(H² + 4), β_1 = P'_1²/H²
    let m = model(GainRule::Fuzzy, 1.0, 1.0, 1.0, 1.0, 1.0);
    let g = gain_sequence(&m, &[0.0, 1.0]).unwrap();
    assert!(close(g[0].xx, 0.5, 1e-15) && g[0].vx == 0.0);
    let p0 = 0.5f64.sqrt();
    let q1 = p0 + 2.0;
    let h1 = p0 + 3.0;
    let pv1 = 4.0 * h1 * h1 / (h1 * h1 + 4.0);
    assert!(close(g[1].xx, q1 * q1 / (1.0 + q1 * q1), 1e-15));
    assert!(close(g[1].vx, pv1 / (h1 * h1), 1e-15));
}

#[test]
fn kalman_gains_match_the_riccati_fixed_point() {
    // 1-D, P = Q = R = 1: the steady gain solves K = M/(M + 1), M = K + 1 → K = (√5 - 1)/2
    let m = model(GainRule::Kalman, 1.0, 0.0, 1.0, 0.0, 1.0);
    let times: Vec<f64> = (0..60).map(f64::from).collect();
    let g = gain_sequence(&m, &times).unwrap();
    assert!(close(g[59].xx, (5f64.sqrt() - 1.0) / 2.0, 1e-14));
    assert_eq!(g[59].vx, 0.0);
}

#[test]
fn effective_memory_of_the_source_example() {
    let times: Vec<f64> = (0..60).map(f64::from).collect();
    let fuzzy = gain_sequence(&model(GainRule::Fuzzy, 1.0, 0.0, 1.0, 0.0, 1.0), &times).unwrap();
    let kalman = gain_sequence(&model(GainRule::Kalman, 1.0, 0.0, 1.0, 0.0, 1.0), &times).unwrap();
    assert_eq!(effective_memory(fuzzy[59].xx, 0.0, 1.0, 0.01).unwrap(), 3);
    assert_eq!(effective_memory(kalman[59].xx, 0.0, 1.0, 0.01).unwrap(), 5);
    assert!(effective_memory(0.5, -1.0, 1.0, 0.01).is_err());
}

fn series(n_series: usize, n: usize, seed: u64) -> Vec<f64> {
    // a deterministic wiggly signal (no RNG needed)
    (0..n_series * n)
        .map(|i| {
            let (s, k) = ((i / n) as f64, (i % n) as f64);
            0.3 * k + (1.7 * k + s).sin() * 2.0 + (seed as f64 + s * 0.1).cos()
        })
        .collect()
}

#[test]
fn batch_equals_series_by_series_and_missing_samples_are_predicted() {
    for rule in [GainRule::Fuzzy, GainRule::Kalman] {
        let m = model(rule, 2.0, 1.0, 0.5, 0.2, 1.0);
        let (k, n) = (19, 23);
        let mut z = series(k, n, 1);
        z[3 * n + 7] = f64::NAN; // a missing sample in block 0
        z[12 * n] = f64::NAN; // a leading missing sample in block 1
        let batch = Batch {
            z: &z,
            z_vel: None,
            times: Times::Regular,
            n_series: k,
            n_samples: n,
        };
        let (mut pos, mut vel) = (vec![0.0; k * n], vec![0.0; k * n]);
        filter_batch(&m, &batch, &mut pos, &mut vel).unwrap();
        for s in 0..k {
            let mut f = SeriesFilter::new();
            for t in 0..n {
                let (x, v) = f.step(&m, t as f64, z[s * n + t], f64::NAN).unwrap();
                assert_eq!(x.to_bits(), pos[s * n + t].to_bits(), "{rule:?} {s} {t}");
                assert_eq!(v.to_bits(), vel[s * n + t].to_bits());
            }
        }
        // the missing sample is the prediction; the leading one has no estimate
        let i = 3 * n + 7;
        assert_eq!(pos[i], pos[i - 1] + vel[i - 1]);
        assert!(pos[12 * n].is_nan() && pos[12 * n + 1].is_finite());
    }
}

#[test]
fn bad_times_and_samples_are_errors() {
    let m = model(GainRule::Fuzzy, 1.0, 1.0, 1.0, 1.0, 1.0);
    let mut f = SeriesFilter::new();
    f.step(&m, 0.0, 1.0, f64::NAN).unwrap();
    assert!(f.step(&m, 0.0, 1.0, f64::NAN).is_err());
    assert!(f.step(&m, -1.0, 1.0, f64::NAN).is_err());
    assert!(f.step(&m, f64::NAN, 1.0, f64::NAN).is_err());
    assert!(f.step(&m, 1.0, f64::INFINITY, f64::NAN).is_err());
    assert!(MotionModel::new(GainRule::Fuzzy, 0.0, 1.0, 1.0, 0.0, 0.0, None).is_err());
    assert!(MotionModel::new(GainRule::Fuzzy, 1.0, 1.0, 1.0, -1.0, 0.0, None).is_err());
    assert!(MotionModel::new(GainRule::Fuzzy, 1.0, 1.0, 1.0, 0.0, 0.0, Some(0.0)).is_err());
}

#[test]
fn cusum_run_lengths_match_the_tables() {
    // one-sided ARL_0 for k = 0.5: h = 4 → 336, h = 5 → 930 (Montgomery, table of the
    // two-sided CUSUM: 168 and 465)
    assert!(close(cusum_arl(4.0, 0.5).unwrap(), 336.0, 0.01));
    assert!(close(cusum_arl(5.0, 0.5).unwrap(), 930.0, 0.01));
    let h = cusum_threshold(1.0 - 1.0 / 465.0, 0.5).unwrap();
    assert!(close(h, 5.0, 0.01), "{h}");
}

#[test]
fn streaming_state_round_trips() {
    let m = model(GainRule::Fuzzy, 1.0, 1.0, 1.0, 1.0, 1.0);
    let cfg = DetectorConfig::new(Method::Chi2, 0.99, 4, 0.5).unwrap();
    let mut bank = DetectorBank::new(
        DetectorSettings {
            model: m,
            config: cfg,
        },
        2,
    );
    let z = series(2, 30, 3);
    for t in 0..10 {
        bank.step(t as f64, &[z[t], z[30 + t]], None).unwrap();
    }
    let mut copy = DetectorBank::new(
        DetectorSettings {
            model: m,
            config: cfg,
        },
        1,
    );
    copy.load(&bank.save()).unwrap();
    for t in 10..30 {
        let a = bank.step(t as f64, &[z[t], z[30 + t]], None).unwrap();
        let b = copy.step(t as f64, &[z[t], z[30 + t]], None).unwrap();
        assert_eq!(a, b);
    }
    assert!(copy.load(&bank.save()[1..]).is_err());
    // numbers no run leaves: (per lane) t_last, started, step, x̂, x̂', the spreads, …
    let saved = bank.save();
    let lane = saved.len() / 2;
    for (i, v) in [
        (3, -4e161),
        (4, f64::INFINITY),
        (5, -1.0),
        (0, 1e300),
        (lane, 5.5),
    ] {
        let mut bad = saved.clone();
        bad[i] = v;
        assert!(copy.load(&bad).is_err(), "value {i} = {v}");
    }
    assert!(copy.load(&saved).is_ok());
}

#[test]
fn velocity_measurements_and_per_series_times_match_series_by_series() {
    let m = MotionModel::new(GainRule::Kalman, 1.0, 0.5, 1.0, 2.0, 0.3, Some(0.7)).unwrap();
    let (k, n) = (10, 17);
    let z = series(k, n, 2);
    let zv: Vec<f64> = z.iter().map(|v| 0.1 * v).collect();
    let times: Vec<f64> = (0..k * n)
        .map(|i| (i % n) as f64 * 1.5 + 0.1 * ((i % n) as f64).sin())
        .collect();
    for t in [Times::Regular, Times::PerSeries(&times)] {
        let batch = Batch {
            z: &z,
            z_vel: Some(&zv),
            times: t,
            n_series: k,
            n_samples: n,
        };
        let (mut pos, mut vel) = (vec![0.0; k * n], vec![0.0; k * n]);
        filter_batch(&m, &batch, &mut pos, &mut vel).unwrap();
        for s in 0..k {
            let mut f = SeriesFilter::new();
            for i in 0..n {
                let (x, v) = f
                    .step(&m, batch.time(s, i), z[s * n + i], zv[s * n + i])
                    .unwrap();
                assert_eq!((x, v), (pos[s * n + i], vel[s * n + i]));
            }
        }
    }
}

#[test]
fn detectors_restart_at_a_large_jump() {
    let m = model(GainRule::Fuzzy, 1.0, 0.5, 0.2, 0.05, 3.0); // R = 3 covers the wiggles
    let mut z = series(1, 60, 4);
    for v in &mut z[30..] {
        *v += 100.0;
    }
    for method in [Method::Fuzzy, Method::Chi2, Method::Cusum] {
        let cfg = DetectorConfig::new(method, 0.99, 3, 0.5).unwrap();
        let mut bank = DetectorBank::new(
            DetectorSettings {
                model: m,
                config: cfg,
            },
            1,
        );
        let out: Vec<Outcome> = (0..60)
            .map(|t| bank.step(t as f64, &[z[t]], None).unwrap()[0])
            .collect();
        assert!(out[30].alarm, "{method:?}");
        // the alarm sample starts a new segment: its estimate is the sample itself
        assert_eq!((out[30].x, out[30].v), (z[30], 0.0));
    }
}
