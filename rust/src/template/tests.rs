//! The surface against brute-force sums (the NumPy twin checks the same at 1e-10 in Python).

use super::*;

/// A deterministic pseudo-random value in [−1, 1).
fn noise(k: usize) -> f64 {
    let x = (k as u64)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .rotate_left(17);
    (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

fn brute_ncc(f: &[f64], cols: usize, t: &[f64], h: usize, w: usize, x: usize, y: usize) -> f64 {
    let n = (h * w) as f64;
    let window: Vec<f64> = (0..h * w)
        .map(|k| f[(y + k / w) * cols + x + k % w])
        .collect();
    let fm = window.iter().sum::<f64>() / n;
    let tm = t.iter().sum::<f64>() / n;
    let num: f64 = window.iter().zip(t).map(|(a, b)| (a - fm) * (b - tm)).sum();
    let fv: f64 = window.iter().map(|a| (a - fm).powi(2)).sum();
    let tv: f64 = t.iter().map(|b| (b - tm).powi(2)).sum();
    num / (fv * tv).sqrt()
}

#[test]
fn ncc_matches_brute_force_on_both_routes() {
    let (rows, cols) = (70, 90);
    let f: Vec<f64> = (0..rows * cols).map(|k| 5.0 + noise(k)).collect();
    for (h, w) in [(3, 4), (21, 25)] {
        let t: Vec<f64> = (0..h * w).map(|k| noise(k + 7777)).collect();
        let frame = Frame::new(&f, rows, cols).unwrap();
        let template = Template::new(t.clone(), h, w).unwrap();
        let window = Window {
            x0: 3,
            y0: 0,
            x1: 90,
            y1: 61,
        };
        let (_, s) = match_template(&frame, &template, Some(window), Method::Ncc, false).unwrap();
        for y in 0..s.rows {
            for x in 0..s.cols {
                let e = brute_ncc(&f, cols, &t, h, w, x + 3, y);
                assert!(
                    (s.values[y * s.cols + x] - e).abs() < 1e-11,
                    "{h}x{w} at {x},{y}"
                );
            }
        }
    }
    assert!(!surface::use_fft(70, 90, 3, 4));
    assert!(surface::use_fft(70, 90, 21, 25));
}

#[test]
fn embedded_template_is_found_with_score_one() {
    let (rows, cols) = (50, 60);
    let f: Vec<u8> = (0..rows * cols)
        .map(|k| (noise(k) * 100.0 + 120.0) as u8)
        .collect();
    let (x0, y0, h, w) = (17, 9, 8, 11);
    let t: Vec<f64> = (0..h * w)
        .map(|k| f[(y0 + k / w) * cols + x0 + k % w] as f64)
        .collect();
    let frame = Frame::new(&f, rows, cols).unwrap();
    let template = Template::new(t, h, w).unwrap();
    let (m, _) = match_template(&frame, &template, None, Method::Ncc, false).unwrap();
    assert_eq!((m.x, m.y), (x0 as f64, y0 as f64));
    assert!((m.score - 1.0).abs() < 1e-12);
}

#[test]
fn flat_windows_score_zero_and_nan_windows_nan() {
    let (rows, cols) = (20, 20);
    let mut f: Vec<f32> = (0..rows * cols).map(|k| noise(k) as f32).collect();
    for r in 0..8 {
        for c in 0..8 {
            f[r * cols + c] = 3.25;
        }
    }
    f[15 * cols + 15] = f32::NAN;
    let t: Vec<f64> = (0..9).map(|k| noise(k + 99)).collect();
    let frame = Frame::new(&f, rows, cols).unwrap();
    let template = Template::new(t, 3, 3).unwrap();
    let (_, s) = match_template(&frame, &template, None, Method::Ncc, true).unwrap();
    assert_eq!(s.values[0], 0.0);
    assert_eq!(s.values[5 * s.cols + 5], 0.0);
    assert!(s.values[14 * s.cols + 14].is_nan());
    assert!(s.values[13 * s.cols + 15].is_nan());
    assert!(!s.values[12 * s.cols + 12].is_nan());
}

#[test]
fn bad_inputs_are_errors() {
    let f = vec![0.5f64; 100];
    let frame = Frame::new(&f, 10, 10).unwrap();
    let t = Template::new(vec![1.0, 2.0, 3.0, 4.0], 2, 2).unwrap();
    let outside = Window {
        x0: 5,
        y0: 5,
        x1: 11,
        y1: 9,
    };
    assert!(match_template(&frame, &t, Some(outside), Method::Ncc, true).is_err());
    let small = Window {
        x0: 5,
        y0: 5,
        x1: 6,
        y1: 9,
    };
    assert!(match_template(&frame, &t, Some(small), Method::Ncc, true).is_err());
    let flat = Template::new(vec![2.0; 4], 2, 2).unwrap();
    assert!(match_template(&frame, &flat, None, Method::Ncc, true).is_err());
    assert!(match_template(&frame, &flat, None, Method::Correlation, true).is_ok());
    assert!(Template::new(vec![], 0, 3).is_err());
    assert!(Template::new(vec![f64::NAN], 1, 1).is_err());
    let inf = [1.0, f64::INFINITY, 0.0, 0.0];
    assert!(Frame::new(&inf, 2, 2).is_ok_and(|fr| {
        let one = Template::new(vec![1.0], 1, 1).unwrap();
        match_template(&fr, &one, None, Method::Correlation, true).is_err()
    }));
    let nan = [f64::NAN; 4];
    let fr = Frame::new(&nan, 2, 2).unwrap();
    let one = Template::new(vec![1.0], 1, 1).unwrap();
    assert!(match_template(&fr, &one, None, Method::Correlation, true).is_err());
}

#[test]
fn portable_and_fused_direct_sums_agree() {
    use super::direct::{Lines, OutputRow};
    use crate::simd::{dispatch, run_plain};
    let (rows, cols, h, w) = (12, 75, 5, 7);
    let a: Vec<f64> = (0..rows * cols).map(noise).collect();
    let t: Vec<f64> = (0..h * w).map(|k| noise(k + 99)).collect();
    let lines = |y| Lines {
        a: &a,
        cols,
        y,
        t: &t,
        h,
        w,
    };
    for y in 0..rows - h + 1 {
        let (mut plain, mut best) = (vec![0.0; cols - w + 1], vec![0.0; cols - w + 1]);
        run_plain(OutputRow {
            lines: lines(y),
            row: &mut plain,
        });
        dispatch(OutputRow {
            lines: lines(y),
            row: &mut best,
        });
        for x in 0..cols - w + 1 {
            let exact: f64 = (0..h * w)
                .map(|k| a[(y + k / w) * cols + x + k % w] * t[k])
                .sum();
            // 35 products of values ≤ 1: rounding of either build is far below 1e-13
            assert!((plain[x] - exact).abs() < 1e-13, "plain ({y}, {x})");
            assert!((best[x] - exact).abs() < 1e-13, "dispatched ({y}, {x})");
        }
    }
}
