//! Criterion benchmarks of the random-field kernels (run with `cargo bench`).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kalmanfield::field::{sample_into, stream_frame_into, DrivingNoise, FieldModel};
use kalmanfield::identification::{difference_gram, lag_products};

fn one_thread<R>(f: impl FnOnce() -> R + Send) -> R
where
    R: Send,
{
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(f)
}

fn bench_sample(c: &mut Criterion) {
    let mut group = c.benchmark_group("sample_2d");
    group.sample_size(10);
    for order in [1usize, 2, 4] {
        let model = FieldModel::new(&[0.9, 0.9], &[order, order], 1.0).unwrap();
        let side = 2048;
        group.throughput(Throughput::Elements((side * side) as u64));
        let mut out64 = vec![0.0f64; side * side];
        group.bench_function(BenchmarkId::new("f64_1thread", order), |b| {
            b.iter(|| {
                one_thread(|| {
                    sample_into(&model, &mut out64, &[side, side], DrivingNoise::Seeded(1)).unwrap()
                })
            })
        });
        group.bench_function(BenchmarkId::new("f64_all_threads", order), |b| {
            b.iter(|| {
                sample_into(&model, &mut out64, &[side, side], DrivingNoise::Seeded(1)).unwrap()
            })
        });
        let mut out32 = vec![0.0f32; side * side];
        group.bench_function(BenchmarkId::new("f32_1thread", order), |b| {
            b.iter(|| {
                one_thread(|| {
                    sample_into(&model, &mut out32, &[side, side], DrivingNoise::Seeded(1)).unwrap()
                })
            })
        });
    }
    group.finish();
}

fn bench_noise(c: &mut Criterion) {
    let mut group = c.benchmark_group("white_noise");
    let len = 1 << 16;
    group.throughput(Throughput::Elements(len as u64));
    let mut line = vec![0.0f64; len];
    group.bench_function("fill_line", |b| {
        b.iter(|| DrivingNoise::Seeded(1).fill(&mut line, 0))
    });
    group.finish();
}

fn bench_stream(c: &mut Criterion) {
    let mut group = c.benchmark_group("stream_1024");
    group.sample_size(20);
    let model = FieldModel::new(&[0.95, 0.9, 0.9], &[1, 2, 2], 1.0).unwrap();
    let side = 1024;
    let previous = vec![0.5f64; side * side];
    let mut frame = vec![0.0f64; side * side];
    group.throughput(Throughput::Elements(1));
    group.bench_function("frame_1thread", |b| {
        b.iter(|| {
            one_thread(|| {
                stream_frame_into(
                    &model,
                    &mut frame,
                    &[side, side],
                    &[&previous],
                    5,
                    DrivingNoise::Seeded(1),
                )
                .unwrap()
            })
        })
    });
    group.finish();
}

/// The identification statistics (§1.6) of a 2048² field, one thread, per axis.
fn bench_identification(c: &mut Criterion) {
    let shape = [2048usize, 2048];
    let model = FieldModel::new(&[0.9, 0.8], &[2, 3], 1.0).unwrap();
    let mut field = vec![0.0f64; shape[0] * shape[1]];
    sample_into(&model, &mut field, &shape, DrivingNoise::Seeded(1)).unwrap();
    let mut group = c.benchmark_group("identification_2048");
    group.throughput(Throughput::Elements(field.len() as u64));
    group.sample_size(10);
    for axis in [0usize, 1] {
        group.bench_with_input(
            BenchmarkId::new("difference_gram_m4", axis),
            &axis,
            |b, &a| b.iter(|| one_thread(|| difference_gram(&field, &shape, a, 4).unwrap())),
        );
        group.bench_with_input(BenchmarkId::new("lag_products_16", axis), &axis, |b, &a| {
            b.iter(|| one_thread(|| lag_products(&field, &shape, a, 16).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    bench_sample,
    bench_noise,
    bench_stream,
    bench_identification
);
criterion_main!(benches);
