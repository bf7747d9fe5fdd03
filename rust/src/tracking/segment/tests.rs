use super::runs::BLOCK;
use super::*;

const H: usize = 6;
const W: usize = 7;

/// Seven 4-connected segments; (1,4)–(2,3) and (4,6)–(5,5) touch only diagonally.
#[rustfmt::skip]
const FRAME: [f64; H * W] = [
    0., 5., 5., 0., 0., 0., 0.,
    0., 5., 0., 0., 3., 0., 0.,
    0., 0., 0., 3., 0., 0., 0.,
    2., 0., 0., 0., 0., 0., 9.,
    0., 0., 7., 4., 0., 0., 9.,
    0., 0., 7., 0., 0., 9., 0.,
];

fn run(connectivity: u8, min_area: usize) -> Segmentation {
    segment(&FRAME, H, W, 1.0, min_area, connectivity).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-14
}

#[test]
fn four_connectivity_labels_in_raster_order() {
    let s = run(4, 1);
    #[rustfmt::skip]
    let expected = [
        0, 1, 1, 0, 0, 0, 0,
        0, 1, 0, 0, 2, 0, 0,
        0, 0, 0, 3, 0, 0, 0,
        4, 0, 0, 0, 0, 0, 5,
        0, 0, 6, 6, 0, 0, 5,
        0, 0, 6, 0, 0, 7, 0,
    ];
    assert_eq!(s.labels, expected);
    let areas: Vec<usize> = s.segments.iter().map(|g| g.area).collect();
    assert_eq!(areas, [3, 1, 1, 1, 2, 3, 1]);
    assert!(s.segments.iter().enumerate().all(|(i, g)| g.label == i + 1));
}

#[test]
fn eight_connectivity_joins_diagonal_neighbours() {
    let s = run(8, 1);
    #[rustfmt::skip]
    let expected = [
        0, 1, 1, 0, 0, 0, 0,
        0, 1, 0, 0, 2, 0, 0,
        0, 0, 0, 2, 0, 0, 0,
        3, 0, 0, 0, 0, 0, 4,
        0, 0, 5, 5, 0, 0, 4,
        0, 0, 5, 0, 0, 4, 0,
    ];
    assert_eq!(s.labels, expected);
    let g = &s.segments[3];
    assert!(close(g.x, 17.0 / 3.0) && close(g.y, 4.0));
    assert!(close(g.extent_x, (2.0f64 / 9.0).sqrt()));
    assert!(close(g.extent_y, (2.0f64 / 3.0).sqrt()));
    assert_eq!((g.bbox_x0, g.bbox_y0, g.bbox_x1, g.bbox_y1), (5, 3, 6, 5));
}

#[test]
fn min_area_drops_and_renumbers() {
    let s = run(8, 2);
    let areas: Vec<usize> = s.segments.iter().map(|g| g.area).collect();
    assert_eq!(areas, [3, 2, 3, 3]);
    assert_eq!(s.labels[3 * W], 0);
    assert_eq!(s.labels[4 * W + 2], 4);
    let s = run(4, 3);
    assert_eq!(s.segments.len(), 2);
    assert_eq!(s.labels.iter().filter(|&&l| l == 2).count(), 3);
    assert_eq!(s.labels[4 * W + 6], 0);
}

#[test]
fn weighted_centroid_and_extent() {
    // Segment 6 of 4-connectivity: weights 6 at (2,4), 3 at (3,4), 6 at (2,5).
    let g = run(4, 1).segments[5].clone();
    assert!(close(g.x, 2.2) && close(g.y, 4.4));
    assert!(close(g.amplitude, 6.0));
    assert!(close(g.extent_x, 0.4));
    assert!(close(g.extent_y, 0.24f64.sqrt()));
    // Segment 1: equal weights at (1,0), (2,0), (1,1).
    let g = run(4, 1).segments[0].clone();
    assert!(close(g.x, 4.0 / 3.0) && close(g.y, 1.0 / 3.0));
    assert!(close(g.extent_x, (2.0f64 / 9.0).sqrt()));
    assert_eq!((g.bbox_x0, g.bbox_y0, g.bbox_x1, g.bbox_y1), (1, 0, 2, 1));
}

#[test]
fn u_shape_is_one_segment_labelled_from_its_first_pixel() {
    #[rustfmt::skip]
    let frame: [u8; 20] = [
        1, 0, 0, 1, 1,
        1, 0, 1, 0, 1,
        1, 0, 1, 0, 1,
        1, 1, 1, 1, 1,
    ];
    let s = segment(&frame, 4, 5, 0.0, 1, 4).unwrap();
    assert_eq!(s.segments.len(), 1);
    assert!(s
        .labels
        .iter()
        .zip(&frame)
        .all(|(&l, &v)| l == i32::from(v)));
    assert_eq!(s.segments[0].area, 14);
}

#[test]
fn pixel_types_agree() {
    let as_f32: Vec<f32> = FRAME.iter().map(|&v| v as f32).collect();
    let as_u16: Vec<u16> = FRAME.iter().map(|&v| v as u16).collect();
    let reference = run(8, 1);
    assert_eq!(segment(&as_f32, H, W, 1.0, 1, 8).unwrap(), reference);
    assert_eq!(segment(&as_u16, H, W, 1.0, 1, 8).unwrap(), reference);
}

#[test]
fn empty_and_uniform_frames() {
    let s = segment::<f32>(&[], 0, 5, 0.0, 1, 8).unwrap();
    assert!(s.labels.is_empty() && s.segments.is_empty());
    let s = segment(&[0u8; 12], 3, 4, 0.0, 1, 4).unwrap();
    assert!(s.segments.is_empty() && s.labels.iter().all(|&l| l == 0));
    let s = segment(&[2.0; 12], 3, 4, 1.0, 1, 4).unwrap();
    assert_eq!(s.segments.len(), 1);
    let g = &s.segments[0];
    assert!(close(g.x, 1.5) && close(g.y, 1.0));
    assert!(close(g.extent_x, 1.25f64.sqrt()) && close(g.extent_y, (2.0f64 / 3.0).sqrt()));
}

#[test]
fn runs_found_across_block_boundaries() {
    let width = 3 * BLOCK + 5;
    for x in 0..width {
        let mut row = vec![0u16; width];
        row[x] = 1;
        row[(x + 2).min(width - 1)] = 1;
        let s = segment(&row, 1, width, 0.5, 1, 8).unwrap();
        assert_eq!(s.segments[0].bbox_x0, x);
        let on = row.iter().filter(|&&v| v > 0).count();
        assert_eq!(s.labels.iter().filter(|&&l| l > 0).count(), on);
    }
}

#[test]
fn small_spread_keeps_its_digits() {
    // Weights 1e-9 and 1 one pixel apart: extent² = w₁w₂ / (w₁ + w₂)² ≈ 1e-9.
    let g = segment(&[1e-9, 1.0], 1, 2, 0.0, 1, 4).unwrap().segments[0].clone();
    let exact = 1e-9f64.sqrt() / (1.0 + 1e-9);
    assert!((g.extent_x - exact).abs() < 1e-12 * exact);
    assert_eq!(g.extent_y, 0.0);
}

#[test]
fn bad_input_is_an_error() {
    let err = |r: Result<Segmentation>| r.unwrap_err().to_string();
    assert!(err(segment(&FRAME, H, W, 1.0, 1, 6)).contains("connectivity"));
    assert!(err(segment(&FRAME, H, W, 1.0, 0, 8)).contains("min_area"));
    assert!(err(segment(&FRAME, H, W, f64::NAN, 1, 8)).contains("threshold"));
    assert!(err(segment(&FRAME, H, W + 1, 1.0, 1, 8)).contains("values"));
    assert!(err(segment(&[0.0, f64::INFINITY], 1, 2, 1.0, 1, 8)).contains("column 1"));
    assert!(matches!(
        segment(&[f32::NAN], 1, 1, 1.0, 1, 8),
        Err(FieldError::NonFinite(_))
    ));
    assert!(segment(&[0u8], usize::MAX, 2, 1.0, 1, 8).is_err());
}

#[test]
fn a_stack_is_segmented_frame_by_frame() {
    let frames: Vec<f64> = (0..5 * 12 * 9).map(|v| ((v * 7919) % 97) as f64).collect();
    let stack = segment_stack(&frames, 5, 12, 9, 60.0, 1, 8).unwrap();
    for (f, s) in stack.segments.iter().enumerate() {
        let one = segment(&frames[f * 108..(f + 1) * 108], 12, 9, 60.0, 1, 8).unwrap();
        assert_eq!(stack.labels[f * 108..(f + 1) * 108], one.labels);
        assert_eq!(*s, one.segments);
    }
    assert!(segment_stack(&frames, 4, 12, 9, 60.0, 1, 8).is_err());
}
