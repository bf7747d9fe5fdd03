//! Criterion benchmarks of the template domain (method page *Template tracker*): full-frame
//! NCC of 512 × 512 frames (a direct-sum template and an FFT one), and a tracker's window
//! search (64 × 64 region, 32 × 32 template).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use kalmanfield::template::{match_template, Frame, Method, Template, Window};

/// A deterministic value in [−1, 1) from a counter.
fn noise(k: usize) -> f64 {
    let x = (k as u64)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .rotate_left(17);
    (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

fn bench_match(c: &mut Criterion) {
    let (height, width) = (512, 512);
    let pixels: Vec<f32> = (0..height * width).map(|k| noise(k) as f32).collect();
    let frame = Frame::new(&pixels, height, width).unwrap();
    let cut = |size: usize| {
        let values = (0..size * size)
            .map(|k| pixels[(200 + k / size) * width + 300 + k % size] as f64)
            .collect();
        Template::new(values, size, size).unwrap()
    };
    let mut group = c.benchmark_group("match_template_512");
    group.sample_size(20);
    for size in [8, 32] {
        let template = cut(size);
        group.bench_with_input(BenchmarkId::new("ncc", size), &template, |b, t| {
            b.iter(|| match_template(&frame, t, None, Method::Ncc, true).unwrap())
        });
    }
    let template = cut(32);
    let window = Window {
        x0: 284,
        y0: 184,
        x1: 348,
        y1: 248,
    };
    group.bench_function("window_64_template_32", |b| {
        b.iter(|| match_template(&frame, &template, Some(window), Method::Ncc, true).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_match);
criterion_main!(benches);
