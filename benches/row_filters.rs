//! Criterion benchmarks of the row filters (method page *Row filters*, §2): the quasi-optimal filter on 2048²,
//! the optimal one on 512², one thread, plans built outside the timing.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kalmanfield::field::{sample_into, DrivingNoise, FieldModel};
use kalmanfield::linalg::SymmetricBand;
use kalmanfield::rowfilter::ModeSet;
use kalmanfield::rowfilter::ScalarRowFilter;
use kalmanfield::rowfilter::VectorRowFilter;

fn one_thread<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(f)
}

fn image(model: &FieldModel, side: usize) -> Vec<f64> {
    let mut z = vec![0.0; side * side];
    sample_into(model, &mut z, &[side, side], DrivingNoise::Seeded(3)).unwrap();
    z
}

fn bench_scalar(c: &mut Criterion) {
    let side = 2048;
    let mut group = c.benchmark_group("scalar_row_filter_2048");
    group.throughput(Throughput::Elements((side * side) as u64));
    group.sample_size(10);
    // the defaults (m = 8 for n_y = 1, max(n_x, 2) otherwise) and (1,1) with m = 2
    for (order, ar_order) in [
        (1usize, None),
        (1, Some(2)),
        (2, None),
        (3, None),
        (4, None),
    ] {
        let model = FieldModel::new(&[0.9, 0.9], &[order, order], 1.0).unwrap();
        let z = image(&model, side);
        let mut out = vec![0.0; z.len()];
        let filter = ScalarRowFilter::new(&model, 1.0, side, ar_order, ModeSet::Ends).unwrap();
        filter
            .filter_image(&z, None, &mut out, side, false)
            .unwrap(); // builds the plan
        let m = ar_order.map_or(String::new(), |m| format!(" m={m}"));
        for smooth in [false, true] {
            let id = format!("({order},{order}){m} smooth={smooth}");
            group.bench_with_input(BenchmarkId::from_parameter(id), &smooth, |b, &s| {
                b.iter(|| one_thread(|| filter.filter_image(&z, None, &mut out, side, s).unwrap()))
            });
        }
    }
    group.finish();
}

fn bench_vector(c: &mut Criterion) {
    let side = 512;
    let model = FieldModel::new(&[0.9, 0.9], &[2, 2], 1.0).unwrap();
    let z = image(&model, side);
    let mut out = vec![0.0; z.len()];
    let filter = VectorRowFilter::new(&model, 1.0, side).unwrap();
    let mut group = c.benchmark_group("vector_row_filter_512");
    group.throughput(Throughput::Elements((side * side) as u64));
    group.sample_size(10);
    group.bench_function("(2,2) causal", |b| {
        b.iter(|| {
            one_thread(|| {
                filter
                    .filter_image(&z, &mut out, side, false, false)
                    .unwrap()
            })
        })
    });
    group.finish();
}

/// The banded solve alone (the kernel of the scalar row filter), on the orders and
/// bandwidths of its (1,1)..(4,4) models, with a slowly decaying factor.
fn bench_banded(c: &mut Criterion) {
    let mut group = c.benchmark_group("banded_solve");
    group.sample_size(20);
    for (b, n) in [
        (1usize, 2048usize),
        (2, 2048),
        (3, 4096),
        (5, 4096),
        (7, 4096),
        (11, 6144),
        (19, 8192),
    ] {
        // b = 11, 19: block banded in blocks of g = 3, 4 (block bandwidth g), as the (3,3)
        // and (4,4) filters' systems are
        let g = match b {
            11 => 3,
            19 => 4,
            _ => 1,
        };
        let mut a = SymmetricBand::zeros(n, b);
        for i in 0..n {
            a.add(i, i, if b <= 7 { 2.5 } else { 2.65 });
            for k in i.saturating_sub(b)..i {
                if g == 1 || i / g - k / g <= g {
                    a.add(i, k, -0.8 / ((i - k) * (i - k)) as f64);
                }
            }
        }
        let factor = a.cholesky().unwrap();
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = rhs.clone();
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(format!("b={b} n={n}"), |bench| {
            bench.iter(|| {
                x.copy_from_slice(&rhs);
                factor.solve_in_place(&mut x)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_scalar, bench_vector, bench_banded);
criterion_main!(benches);
