//! Criterion benchmarks of the trajectory kernels (method page *Fuzzy filter*, §4.1 and §4.4;
//! [K95]): the batched fuzzy filter (shared gains, struct-of-arrays blocks) on 10⁴ series ×
//! 100 samples, the same with per-series times (the series-by-series path), and the CUSUM
//! detector.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use kalmanfield::trajectory::{
    detect_batch, filter_batch, Batch, Detections, DetectorConfig, GainRule, Method, MotionModel,
    Times,
};

const SERIES: usize = 10_000;
const SAMPLES: usize = 100;

/// Deterministic wiggly trajectories (no RNG needed for timing).
fn samples() -> Vec<f64> {
    (0..SERIES * SAMPLES)
        .map(|i| {
            let (s, k) = ((i / SAMPLES) as f64, (i % SAMPLES) as f64);
            0.3 * k + (1.7 * k + s).sin() + (0.37 * k * s).cos()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let z = samples();
    let model = MotionModel::new(GainRule::Fuzzy, 1.0, 1.0, 1.0, 1.0, 1.0, None).unwrap();
    let times: Vec<f64> = (0..SERIES * SAMPLES)
        .map(|i| (i % SAMPLES) as f64)
        .collect();
    let (mut pos, mut vel) = (vec![0.0; z.len()], vec![0.0; z.len()]);
    let mut group = c.benchmark_group("trajectory");
    group.throughput(Throughput::Elements(z.len() as u64));
    group.sample_size(20);
    for (name, t) in [
        ("filter shared times", Times::Regular),
        ("filter per-series times", Times::PerSeries(&times)),
    ] {
        let batch = Batch {
            z: &z,
            z_vel: None,
            times: t,
            n_series: SERIES,
            n_samples: SAMPLES,
        };
        group.bench_function(name, |b| {
            b.iter(|| filter_batch(&model, &batch, &mut pos, &mut vel).unwrap())
        });
    }
    let batch = Batch {
        z: &z,
        z_vel: None,
        times: Times::Regular,
        n_series: SERIES,
        n_samples: SAMPLES,
    };
    let cfg = DetectorConfig::new(Method::Cusum, 0.999, 5, 0.5).unwrap();
    let (mut alarm, mut ratio) = (vec![false; z.len()], vec![0.0; z.len()]);
    group.bench_function("cusum detector", |b| {
        b.iter(|| {
            let out = Detections {
                pos: &mut pos,
                vel: &mut vel,
                alarm: &mut alarm,
                ratio: &mut ratio,
            };
            detect_batch(&model, &cfg, &batch, out).unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
