//! Criterion benchmarks of the branching tracker (method page *Tracking*, §3.1–3.3): 100 frames of point
//! detections, targets at 2 px/frame bouncing off the borders, P_d = 0.9, position noise
//! 0.5 px, uniform clutter; the anchor configuration of `benches/bench_tracking.py`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kalmanfield::tracking::{splitmix64, BranchingTracker, TrackerConfig};

/// Uniform in [0, 1) from a counter.
fn uniform(counter: u64) -> f64 {
    (splitmix64(counter) >> 11) as f64 / (1u64 << 53) as f64
}

/// Standard normal from two counters (Box–Muller).
fn normal(counter: u64) -> f64 {
    let u = uniform(2 * counter).max(1e-300);
    let v = uniform(2 * counter + 1);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Flattened (x, y) detections of each frame.
fn scenario(size: f64, targets: usize, clutter: usize) -> Vec<Vec<f64>> {
    let mut key = 0u64;
    let mut next = || {
        key += 1;
        key
    };
    let mut pos: Vec<[f64; 2]> = (0..targets)
        .map(|_| [size * uniform(next()), size * uniform(next())])
        .collect();
    let mut vel: Vec<[f64; 2]> = (0..targets)
        .map(|_| {
            let a = std::f64::consts::TAU * uniform(next());
            [2.0 * a.cos(), 2.0 * a.sin()]
        })
        .collect();
    (0..100)
        .map(|_| {
            let mut z = Vec::new();
            for (p, v) in pos.iter_mut().zip(vel.iter_mut()) {
                if uniform(next()) < 0.9 {
                    z.extend([p[0] + 0.5 * normal(next()), p[1] + 0.5 * normal(next())]);
                }
                for a in 0..2 {
                    v[a] += 0.1 * normal(next());
                    p[a] += v[a];
                    if p[a] < 0.0 || p[a] > size {
                        v[a] = -v[a];
                        p[a] = p[a].clamp(0.0, size);
                    }
                }
            }
            for _ in 0..clutter {
                z.extend([size * uniform(next()), size * uniform(next())]);
            }
            z
        })
        .collect()
}

fn config(size: f64, clutter: usize) -> TrackerConfig {
    TrackerConfig {
        max_misses: 3,
        clutter_density: Some(clutter as f64 / (size * size)),
        maneuver_std: Some(vec![1.5; 2]),
        maneuver_prob: 0.001,
        confirm_window: 4 + 3 + 1,
        ..TrackerConfig::with_defaults(2)
    }
}

fn bench_tracker(c: &mut Criterion) {
    let mut group = c.benchmark_group("branching_tracker_100_frames");
    group.sample_size(10);
    group.throughput(Throughput::Elements(100));
    for (label, size, targets, clutter) in [
        ("256² 20 targets 50 clutter", 256.0, 20, 50),
        ("512² 50 targets 200 clutter", 512.0, 50, 200),
    ] {
        let frames = scenario(size, targets, clutter);
        let cfg = config(size, clutter);
        group.bench_with_input(BenchmarkId::from_parameter(label), &frames, |b, frames| {
            b.iter(|| {
                let mut tr = BranchingTracker::new(cfg.clone()).unwrap();
                for z in frames {
                    tr.update(z, None).unwrap();
                }
                tr.track_table()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_tracker);
criterion_main!(benches);
