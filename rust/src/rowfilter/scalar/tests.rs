use super::plan::{MAX_ROW_MODELS, MIN_ROW_MODELS};
use super::settling::{
    band_change, drift_scale, max_abs_difference, settled, DRIFT_FLOOR, SETTLE_TOLERANCE,
};
use super::*;
use faer::Mat;
use std::ops::Range;

#[test]
fn a_sequence_is_settled_when_its_geometric_tail_is_within_the_tolerance() {
    assert!(settled(0.0, None, None, 1e-3));
    assert!(!settled(1e-9, None, None, 1e-3)); // one change says nothing of the tail
    let steady = Some(1.6e-3); // q = 0.5 on the row before
    assert!(settled(4e-4, Some(8e-4), steady, 1e-3)); // q = 0.5: tail 8e-4
    assert!(!settled(4e-4, Some(8e-4), None, 1e-3)); // one ratio: not yet a tail
    assert!(!settled(6e-4, Some(1.2e-3), Some(2.4e-3), 1e-3)); // q = 0.5: tail 1.2e-3
    assert!(!settled(1e-4, Some(1.01e-4), steady, 1e-3)); // q ≈ 0.99: tail 1e-2
    assert!(!settled(1e-4, Some(0.5e-4), steady, 1e-3)); // growing: 1e-4 > 1e-6
    assert!(settled(1e-7, Some(0.5e-7), None, 1e-3)); // growing at the rounding floor

    // the ρ_y = 0.9999 rows: q 0.53 → 0.63, slowing down (the band drifts ~600 rows)
    assert!(!settled(3.48e-4, Some(5.54e-4), Some(1.038e-3), 1e-3));
    assert!(settled(3.48e-4, Some(5.54e-4), Some(0.95e-3), 1e-3)); // q steady at 0.6
}

#[test]
fn a_one_row_state_takes_the_longest_row_model_by_default() {
    let bandwidth = |order: &[usize], m: Option<usize>| {
        let model = FieldModel::new(&[0.9, 0.9], order, 1.0).unwrap();
        ScalarRowFilter::new(&model, 1.0, 32, m, ModeSet::Toeplitz)
            .unwrap()
            .bandwidth()
    };
    assert_eq!(bandwidth(&[1, 1], None), MAX_AR_ORDER); // b = n_y (m + 1) − 1
    assert_eq!(bandwidth(&[1, 4], None), MAX_AR_ORDER);
    assert_eq!(bandwidth(&[1, 1], Some(2)), 2);
    assert_eq!(bandwidth(&[2, 1], None), 5); // m = max(n_x, 2)
    assert_eq!(bandwidth(&[3, 4], None), 14);
}

#[test]
fn implied_row_models_propagate_on_nominal_images() {
    // (2,2), ρ_y = 0.9999, σ_θ²/σ_x² = 0.01: the plan's models drift from the filter's
    // own covariance, the implied ones follow it; no weights = the nominal weights
    let model = FieldModel::new(&[0.9999, 0.9], &[2, 2], 1.0).unwrap();
    let (height, width) = (12, 10);
    let make = |row_models| {
        ScalarRowFilter::new(&model, 0.01, width, None, ModeSet::Exact)
            .unwrap()
            .with_row_models(row_models)
    };
    let z: Vec<f64> = (0..height * width)
        .map(|i| ((i * 7919) % 101) as f64 / 50.0 - 1.0)
        .collect();
    let run = |f: &ScalarRowFilter, weights: Option<&[f64]>, smooth| {
        let mut out = vec![0.0; z.len()];
        f.filter_image(&z, weights, &mut out, height, smooth)
            .unwrap();
        out
    };
    let uniform = vec![100.0; z.len()];
    let (implied, plan) = (make(RowModels::Implied), make(RowModels::Propagated));
    let apart = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .fold(0.0f64, |d, (x, y)| d.max((x - y).abs()))
    };
    for smooth in [false, true] {
        let got = run(&implied, None, smooth);
        assert_eq!(got, run(&implied, Some(&uniform), smooth));
        // the plan's systems, or the same models in weighted systems: equal to rounding
        let nominal = run(&plan, None, smooth);
        assert!(apart(&nominal, &run(&plan, Some(&uniform), smooth)) < 1e-12);
        assert!(apart(&got, &nominal) > 1e-6);
    }
    let map = implied.error_variance(height, None).unwrap();
    assert_eq!(map, implied.error_variance(height, Some(&uniform)).unwrap());
}

#[test]
fn very_wide_rows_fit_fewer_row_models() {
    let model = FieldModel::new(&[0.9, 0.9], &[4, 4], 1.0).unwrap();
    let models = |w| {
        ScalarRowFilter::new(&model, 1.0, w, None, ModeSet::Toeplitz)
            .unwrap()
            .max_models()
    };
    // 5 W n_y (b + 1) doubles per model, b = 19: 1 GiB holds 64 up to W = 5242
    assert_eq!(models(2048), MAX_ROW_MODELS);
    assert_eq!(models(5242), MAX_ROW_MODELS);
    assert_eq!(models(8192), 40);
    assert_eq!(models(1 << 20), MIN_ROW_MODELS);
}

#[test]
fn the_drift_is_measured_on_the_part_of_the_band_that_changes() {
    // σ_x²/σ_θ² = 1e4: P_e ≈ Q, so against the band's largest entry the rows' changes
    // looked ~1e3 times smaller than they are, and the models froze after a few rows
    let model = FieldModel::new(&[0.95, 0.95], &[1, 2], 1.0).unwrap();
    let filter = ScalarRowFilter::new(&model, 1e-4, 32, None, ModeSet::Exact).unwrap();
    let innovation = filter.innovation_blocks();
    let (second, third) = (band_of_row(&filter, 2), band_of_row(&filter, 3));
    let largest = max_abs_difference(&second[0], None);
    let varying = drift_scale(&second, &innovation);
    assert!(varying < 1e-2 * largest, "{varying:e} vs {largest:e}");
    assert!(band_change(&third, &second) > SETTLE_TOLERANCE * varying);
    // P_e − Q is S P_f Sᵀ: positive on the diagonal, below the noise variance there
    let diagonal = (0..32).map(|ell| second[0][(ell, 0)] - innovation[0][(ell, 0)]);
    assert!(diagonal.clone().all(|d| d > 0.0 && d < 1e-4));
    assert_eq!(varying, diagonal.fold(0.0, f64::max));
    assert!(filter.plan(32).unwrap().precisions.len() > 10);
    // a band equal to Q: the floor, not zero
    let floor = drift_scale(&innovation, &innovation);
    assert_eq!(
        floor,
        DRIFT_FLOOR * max_abs_difference(&innovation[0], None)
    );
}

/// The band of P_e of prediction row `t` (1-based), whitened.
fn band_of_row(filter: &ScalarRowFilter, t: usize) -> Vec<Mat<f64>> {
    let (_, modal) = filter
        .whitened
        .prediction_errors(filter.noise_var, &filter.mode_var)
        .nth(t - 1)
        .unwrap();
    filter.band(&modal)
}

#[test]
fn the_whitened_riccati_is_the_whitened_modal_one() {
    let model = FieldModel::new(&[0.9, 0.8], &[3, 2], 1.0).unwrap();
    let filter = ScalarRowFilter::new(&model, 0.5, 12, None, ModeSet::Exact).unwrap();
    let rows = filter
        .whitened
        .prediction_errors(filter.noise_var, &filter.mode_var)
        .zip(
            filter
                .dynamics
                .prediction_errors(filter.noise_var, &filter.mode_var),
        );
    let whitening = filter
        .lower()
        .solve_lower_triangular(&StateMatrix::identity());
    let whitening = whitening.unwrap();
    for ((t, whitened), (_, modal)) in rows.take(9) {
        for (got, p) in whitened.iter().zip(&modal) {
            let want = whitening * p * whitening.transpose();
            let gap = (got - want).amax();
            assert!(gap < 1e-10 * want.amax(), "row {t}: {gap}");
        }
    }
}

#[test]
fn the_square_root_fit_is_the_direct_one() {
    let model = FieldModel::new(&[0.9, 0.8], &[2, 2], 1.0).unwrap();
    let filter = ScalarRowFilter::new(&model, 0.5, 20, None, ModeSet::Exact).unwrap();
    for t in [1, 3, 6] {
        let band = band_of_row(&filter, t);
        let direct = filter.precision(&band, None).unwrap();
        let root = filter.precision(&band, Some(0.0)).unwrap();
        let size = direct.size();
        let top = (0..size).map(|i| direct.get(i, i)).fold(0.0, f64::max);
        for i in 0..size {
            for k in i.saturating_sub(filter.bandwidth())..=i {
                let gap = (direct.get(i, k) - root.get(i, k)).abs();
                assert!(gap < 1e-10 * top, "row {t}, ({i}, {k}): {gap}");
            }
        }
    }
}

#[test]
fn a_row_beyond_float64_takes_the_square_root_fit() {
    // ρ = 0.999, n_x = 3: D of the direct fit is ~6e-15 of the variance, its inverse
    // rounding noise, and some rows' systems cannot be factored
    let model = FieldModel::new(&[0.999, 0.999], &[4, 3], 1.0).unwrap();
    let filter = ScalarRowFilter::new(&model, 1e-4, 16, None, ModeSet::Exact).unwrap();
    let mut refitted = 0;
    for (t, modal) in filter
        .whitened
        .prediction_errors(filter.noise_var, &filter.mode_var)
        .take(40)
    {
        let band = filter.band(&modal);
        let direct = filter.precision(&band, None);
        if direct.is_ok_and(|d| filter.system(&d, &[0]).is_ok()) {
            continue;
        }
        let (prior, factors) = filter.sound_systems(&band, &[vec![0]]).unwrap();
        assert!(prior.cholesky().is_ok(), "row {t}");
        assert_eq!(factors.len(), 1);
        refitted += 1;
    }
    assert!(refitted > 0);
}

#[test]
fn high_snr_fits_of_four_rows_stay_positive_definite() {
    // σ_x²/σ_θ² = 1e8: D of the block AR fit has a condition of ~1e8; nalgebra's
    // cofactor inverse (n ≤ 4) made D⁻¹ indefinite and the row system "not positive
    // definite"
    for nx in [1, 2, 3] {
        let model = FieldModel::new(&[0.5, 0.5], &[4, nx], 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 1e-8, 16, None, ModeSet::Exact).unwrap();
        let z: Vec<f64> = (0..12 * 16).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut out = vec![0.0; z.len()];
        filter.filter_image(&z, None, &mut out, 12, true).unwrap();
        // nearly noise-free: the estimate is the image
        let worst = z
            .iter()
            .zip(&out)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(worst < 1e-3, "n_x = {nx}: {worst}");
    }
}

#[test]
fn a_noise_variance_too_small_for_the_start_is_refused_by_new() {
    let model = FieldModel::new(&[0.9, 0.9], &[3, 3], 1.0).unwrap();
    let refused = ScalarRowFilter::new(&model, 1e-30, 16, None, ModeSet::Ends);
    let message = refused.unwrap_err().to_string();
    assert!(message.contains("too small for this filter"), "{message}");
    let filter = ScalarRowFilter::new(&model, 1e-12, 16, None, ModeSet::Ends).unwrap();
    // the plan takes the start made by `new`
    let plan = filter.plan(8).unwrap();
    assert_eq!(plan.precisions[0], filter.start.as_ref().unwrap().0);
}

#[test]
fn a_non_finite_or_out_of_range_pixel_in_any_row_is_an_error() {
    let model = FieldModel::new(&[0.9, 0.8], &[2, 2], 1.0).unwrap();
    let (h, w) = (12usize, 16usize);
    let filter = ScalarRowFilter::new(&model, 0.5, w, None, ModeSet::Exact).unwrap();
    let z: Vec<f64> = (0..h * w).map(|i| (i as f64 * 0.3).sin()).collect();
    let mut out = vec![0.0; h * w];
    filter.filter_image(&z, None, &mut out, h, true).unwrap();
    // the largest pixel taken, in a start row and in a predicted row
    for at in [3usize, 9 * w + 5] {
        let mut z = z.clone();
        z[at] = -crate::rowfilter::MAX_PIXEL;
        filter.filter_image(&z, None, &mut out, h, true).unwrap();
        assert!(out.iter().all(|v| v.is_finite()), "{at}");
    }
    // a start row (1..=n) and a predicted row: NaN, infinite, beyond 2^1000
    for (at, bad) in [
        (3usize, f64::NAN),
        (9 * w + 5, f64::INFINITY),
        (11 * w, f64::NAN),
        (2, 2f64.powi(1001)),
        (7 * w + 1, -f64::MAX),
    ] {
        let mut z = z.clone();
        z[at] = bad;
        let err = filter
            .filter_image(&z, None, &mut out, h, false)
            .unwrap_err();
        assert!(matches!(err, FieldError::NonFinite(_)), "{at}: {err}");
    }
}

/// Max over the rows i of |Λ_i − Λ_{i − n}| in `range` (block columns), relative to Λ's
/// largest entry.
fn periodic_defect(precision: &SymmetricBand, n: usize, range: Range<usize>) -> f64 {
    let (size, b) = (precision.size(), precision.bandwidth());
    let scale = (0..size).fold(0.0f64, |m, i| m.max(precision.get(i, i).abs()));
    let mut most = 0.0f64;
    for i in range.start * n..range.end * n {
        for k in i.saturating_sub(b)..=i {
            if k >= n && i - n >= b {
                let d = precision.get(i, k) - precision.get(i - n, k - n);
                most = most.max(d.abs() / scale);
            }
        }
    }
    most
}

#[test]
fn the_row_models_interior_is_exactly_periodic_and_its_factors_steady() {
    // wide rows of n_y = 3 and 4: Λ's interior rows repeat bit for bit (the columns'
    // fits, scattered by rounding, take the middle one's), the edges keep their effects;
    // both factors get the steady solve (n_y = 4 once its rounding scatter, ~2e-9, is
    // snapped, see `steady_band`)
    for (order, width) in [(3usize, 512usize), (4, 1024)] {
        let model = FieldModel::new(&[0.9, 0.9], &[order, order], 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 1.0, width, None, ModeSet::Exact).unwrap();
        let plan = filter.plan(64).unwrap();
        let (first, last) = (plan.precision(1), plan.precision(64));
        for precision in [first, last] {
            assert_eq!(periodic_defect(precision, order, 80..width - 80), 0.0);
        }
        // (the start rows' prior is stationary: its AR fit has no edge effects)
        assert!(periodic_defect(last, order, 0..20) > 1e-6);
        assert!(plan.factor(64).is_steady());
    }
}

#[test]
fn every_wide_order_solves_by_blocks_as_the_plain_substitution_does() {
    // n_y = 3, 4 with every n_x: B = n_y(m + 1) − 1 = 8, 11, 14, 15, 19 (8, 14 and 15
    // stored padded to a fixed band), blocks of n_y with K = m blocks per step; (2,4):
    // B = 9 padded to 11, blocks of 4 (two columns), K = 2
    let cases = [
        (3usize, 1usize),
        (3, 2),
        (3, 4),
        (4, 1),
        (4, 2),
        (4, 3),
        (2, 4),
    ];
    for (n_y, n_x) in cases {
        let model = FieldModel::new(&[0.9, 0.8], &[n_y, n_x], 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 0.7, 512, None, ModeSet::Ends).unwrap();
        let factor = filter.plan(64).unwrap().factor(64).clone();
        let blocks = factor.block_plan().expect("a block plan");
        let expected = if n_y == 2 { (4, 2) } else { (n_y, n_x.max(2)) };
        assert_eq!((blocks.size(), blocks.reach()), expected, "{n_y},{n_x}");
        let size = 512 * n_y;
        let dense: Vec<f64> = (0..size).map(|i| (i as f64 * 0.37).sin()).collect();
        let observed: Vec<f64> = dense
            .iter()
            .enumerate()
            .map(|(i, v)| if i % n_y == 0 { *v } else { 0.0 })
            .collect();
        for (rhs, first_only) in [(dense, false), (observed, true)] {
            let (mut planned, mut plain) = (rhs.clone(), rhs);
            if first_only {
                factor.solve_observed_in_place(&mut planned, n_y);
            } else {
                factor.solve_in_place(&mut planned);
            }
            factor.solve_unplanned(&mut plain);
            let scale = plain.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let most = planned
                .iter()
                .zip(&plain)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            // (the two summation orders' rounding, amplified by the systems' condition:
            // up to ~3e-12 for (3,4))
            assert!(most < 1e-10 * scale, "{n_y},{n_x} {first_only}: {most:e}");
        }
    }
}

#[test]
fn the_splice_check_refuses_ends_too_short_for_the_edge_effects() {
    // (2,2) at ρ = 0.95: the edge effects of P_e reach ~200 columns, so the ends of a
    // 256-point row (spliced 96 columns from its end) are refused; the first W' from the
    // correlation's reach holds and is taken; a row narrower than 2W' stays whole
    let model = FieldModel::new(&[0.95, 0.95], &[2, 2], 1.0).unwrap();
    let x = &model.axes()[1];
    let width = 4096;
    let filter = ScalarRowFilter::new(&model, 1.0, width, None, ModeSet::Ends).unwrap();
    let first = RowModes::first_span(x, width).unwrap();
    assert_eq!(filter.ends_span(), Some(first));
    let ends = |span| RowModes::ends(x, width, span).unwrap();
    assert!(filter.splice_holds(&ends(first), x, 1.0));
    assert!(!filter.splice_holds(&ends(256), x, 1.0));
    let narrow = ScalarRowFilter::new(&model, 1.0, 2 * first - 1, None, ModeSet::Ends);
    assert_eq!(narrow.unwrap().ends_span(), None);
}

#[test]
fn a_reused_filter_gives_the_fresh_filters_bits() {
    let model = FieldModel::new(&[0.9, 0.7], &[2, 1], 1.0).unwrap();
    let w = 24usize;
    let image = |h: usize, phase: f64| -> Vec<f64> {
        (0..h * w)
            .map(|i| (i as f64 * 0.37 + phase).sin())
            .collect()
    };
    let reused = ScalarRowFilter::new(&model, 0.5, w, None, ModeSet::Exact).unwrap();
    // images of other heights in turn: a reused filter (its cached plan) changes nothing
    for (h, phase) in [(30usize, 0.0), (17, 1.0), (40, 2.0)] {
        let z = image(h, phase);
        let fresh = ScalarRowFilter::new(&model, 0.5, w, None, ModeSet::Exact).unwrap();
        let (mut a, mut b) = (vec![0.0; h * w], vec![0.0; h * w]);
        reused.filter_image(&z, None, &mut a, h, true).unwrap();
        fresh.filter_image(&z, None, &mut b, h, true).unwrap();
        assert_eq!(a, b, "height {h}");
        assert!(a.iter().zip(&z).any(|(x, y)| x != y));
    }
}

#[test]
fn the_error_variance_is_the_optimal_filters_on_the_start_rows_and_near_it_after() {
    use crate::rowfilter::VectorRowFilter;
    for (rhos, orders) in [([0.9, 0.8], [1usize, 1usize]), ([0.8, 0.9], [3, 2])] {
        let model = FieldModel::new(&rhos, &orders, 1.3).unwrap();
        let (h, w, noise_var) = (20usize, 40usize, 0.7);
        let scalar = ScalarRowFilter::new(&model, noise_var, w, None, ModeSet::Exact).unwrap();
        let got = scalar.error_variance(h, None).unwrap();
        // the nominal weights as a map: the same systems, factored per row
        let nominal = vec![1.0 / noise_var; h * w];
        let weighted = scalar.error_variance(h, Some(&nominal)).unwrap();
        for (a, b) in weighted.iter().zip(&got) {
            assert!((a - b).abs() <= 1e-12 * b, "{a} vs {b}");
        }
        let mut optimal = vec![0.0; h * w];
        VectorRowFilter::new(&model, noise_var, w)
            .unwrap()
            .error_variance(h, false, &mut optimal)
            .unwrap();
        for (i, (g, o)) in got.iter().zip(&optimal).enumerate() {
            // the start rows' model is the stationary prior itself (m ≥ n_x); after them
            // Λ_t is a band fit of the optimal P_e,t
            let tolerance = if i < orders[0] * w { 1e-9 } else { 0.02 };
            assert!(
                (g - o).abs() <= tolerance * o,
                "{orders:?} pixel {i}: {g} vs {o}"
            );
        }
    }
}
