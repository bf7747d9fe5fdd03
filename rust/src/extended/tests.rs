use super::*;

fn config() -> GroupConfig {
    GroupConfig {
        order: 1,
        dt: 1.0,
        position_std: 0.3,
        process_std: 0.05,
        amplitude_std: 2.0,
        log_area_std: 0.5,
        feature_drift: 0.5,
        confidence: 0.99,
        memory: 4,
        initial_speed_std: 3.0,
        gate_margin: 4.0,
        min_speed: 0.25,
        velocity_tolerance: 0.5,
        cohesion: 1.0,
        max_misses: 2,
        seed_groups: true,
    }
}

fn blob(x: f64, y: f64, half: f64) -> Measurement {
    Measurement {
        x,
        y,
        amplitude: 10.0,
        area: (2.0 * half + 1.0).powi(2),
        bbox: [x - half, y - half, x + half, y + half],
    }
}

/// Fragments at offsets from a centre moving with `v` per frame.
fn object(t: f64, start: [f64; 2], v: [f64; 2], offsets: &[[f64; 2]]) -> Vec<Measurement> {
    offsets
        .iter()
        .map(|o| blob(start[0] + v[0] * t + o[0], start[1] + v[1] * t + o[1], 1.0))
        .collect()
}

const OFFSETS: [[f64; 2]; 3] = [[-3.0, 0.0], [3.0, 0.0], [0.0, 3.0]];

#[test]
fn assignment_is_greedy_by_index() {
    let v = |sequence, segment, index| Variant {
        sequence,
        segment,
        index,
    };
    // best (0,0) = 1 removes (0,1) and (1,0); then (1,1) = 5
    let variants = [v(0, 1, 2.0), v(0, 0, 1.0), v(1, 0, 1.5), v(1, 1, 5.0)];
    assert_eq!(assign(&variants, 2, 2), vec![1, 3]);
    // ties: lower sequence first
    assert_eq!(assign(&[v(1, 0, 1.0), v(0, 0, 1.0)], 2, 1), vec![1]);
}

#[test]
fn fragments_vanish_appear_and_background_is_rejected() {
    let mut t = GroupTracker::new(config()).unwrap();
    let v = [1.5, 0.5];
    let mut last = FrameAnswer::default();
    for frame in 0..12 {
        let f = frame as f64;
        let offsets: Vec<[f64; 2]> = match frame {
            0..=4 => OFFSETS.to_vec(),
            5..=6 => OFFSETS[..2].to_vec(), // the third fragment vanishes
            _ => vec![OFFSETS[0], OFFSETS[1], [0.0, -3.0]], // a new one appears
        };
        let mut segments = object(f, [10.0, 20.0], v, &offsets);
        if frame >= 3 {
            segments.push(blob(24.0 + 0.0 * f, 25.0, 1.0)); // still spot inside the gate
        }
        last = t.step(&segments).unwrap();
        if frame >= 3 {
            let spot = segments.len() - 1;
            assert!(
                !last.segment_member[spot],
                "background spot is a member at {frame}"
            );
        }
        if frame >= 2 {
            assert_eq!(last.groups.iter().filter(|g| g.members > 0).count(), 1);
        }
    }
    let object = last.groups.iter().find(|g| g.members > 0).unwrap();
    assert_eq!(
        object.members, 3,
        "the new fragment joined after ν + 1 frames"
    );
    assert!((object.vx - v[0]).abs() < 0.1 && (object.vy - v[1]).abs() < 0.1);
    assert_eq!(object.frames_detected, 10);
}

#[test]
fn members_need_more_than_order_plus_one_observations() {
    let mut t = GroupTracker::new(config()).unwrap();
    for frame in 0..4 {
        let a = t
            .step(&object(frame as f64, [10.0, 10.0], [2.0, 0.0], &OFFSETS))
            .unwrap();
        // ν = 1: a member needs length ≥ 3, i.e. the third frame (index 2)
        assert_eq!(a.groups[0].members, if frame >= 2 { 3 } else { 0 });
    }
}

#[test]
fn still_objects_are_not_members() {
    let mut t = GroupTracker::new(config()).unwrap();
    for frame in 0..6 {
        let a = t
            .step(&object(frame as f64, [10.0, 10.0], [0.0, 0.0], &OFFSETS))
            .unwrap();
        assert_eq!(a.groups.iter().map(|g| g.members).sum::<usize>(), 0);
    }
}

#[test]
fn crossing_objects_keep_their_groups() {
    let mut t = GroupTracker::new(config()).unwrap();
    let mut ids = None;
    for frame in 0..14 {
        let f = frame as f64;
        let mut segments = object(f, [5.0, 20.0], [2.0, 0.0], &OFFSETS);
        segments.extend(object(f, [31.0, 20.5], [-2.0, 0.0], &OFFSETS));
        let a = t.step(&segments).unwrap();
        if frame >= 2 {
            let groups = [a.segment_group[0], a.segment_group[3]];
            assert!(a.segment_group[..3].iter().all(|&g| g == groups[0]));
            assert!(a.segment_group[3..].iter().all(|&g| g == groups[1]));
            assert_ne!(groups[0], groups[1]);
            match ids {
                None => ids = Some(groups),
                Some(first) => assert_eq!(first, groups, "ids switched at frame {frame}"),
            }
        }
    }
}

/// Two 7×7 objects on one line, 2 px/frame each way: while their centres lie within 8 px
/// they make one segment (union box, mean centroid, summed area), listed first otherwise.
fn head_on(frame: usize) -> Vec<Measurement> {
    let f = frame as f64;
    let (xa, xb) = (5.0 + 2.0 * f, 45.0 - 2.0 * f);
    if (xa - xb).abs() <= 8.0 {
        let mut z = blob(0.5 * (xa + xb), 20.0, 3.0);
        z.area *= 2.0;
        z.bbox[0] = xa.min(xb) - 3.0;
        z.bbox[2] = xa.max(xb) + 3.0;
        vec![z]
    } else {
        vec![blob(xa, 20.0, 3.0), blob(xb, 20.0, 3.0)]
    }
}

#[test]
fn objects_meeting_head_on_keep_their_ids_through_the_merged_segment() {
    let mut t = GroupTracker::new(config()).unwrap();
    let mut ids = None;
    let mut merged_frames = 0;
    for frame in 0..20 {
        let a = t.step(&head_on(frame)).unwrap();
        if a.segment_group.len() == 1 {
            // one object took the merged segment, the other is hidden, not lost
            merged_frames += 1;
            let (first, second) = ids.expect("the objects are known before they meet");
            let live: Vec<i64> = a.groups.iter().map(|g| g.id as i64).collect();
            assert!(
                live.contains(&first) && live.contains(&second),
                "frame {frame}"
            );
        } else if frame >= 2 {
            let groups = (a.segment_group[0], a.segment_group[1]);
            assert_ne!(groups.0, groups.1);
            match ids {
                None => ids = Some(groups),
                Some(first) => assert_eq!(first, groups, "ids lost or switched at frame {frame}"),
            }
        }
    }
    assert_eq!(merged_frames, 5);
}

#[test]
fn bytes_resume_exactly_and_corrupt_bytes_fail() {
    let scene = |frame: usize| {
        let mut s = object(frame as f64, [10.0, 10.0], [1.0, 1.0], &OFFSETS);
        s.push(blob(5.0 + (frame % 3) as f64, 30.0, 0.0));
        s
    };
    let mut a = GroupTracker::new(config()).unwrap();
    for frame in 0..5 {
        a.step(&scene(frame)).unwrap();
    }
    let bytes = a.to_bytes();
    let mut b = GroupTracker::from_bytes(&bytes).unwrap();
    assert_eq!(a, b);
    for frame in 5..10 {
        assert_eq!(
            a.step(&scene(frame)).unwrap(),
            b.step(&scene(frame)).unwrap()
        );
    }
    assert!(GroupTracker::from_bytes(&bytes[..bytes.len() - 3]).is_err());
    assert!(GroupTracker::from_bytes(&[bytes.clone(), vec![0; 8]].concat()).is_err());
    let mut bad = bytes.clone();
    bad[0] ^= 1;
    assert!(GroupTracker::from_bytes(&bad).is_err());
    for cut in (0..bytes.len()).step_by(7) {
        let _ = GroupTracker::from_bytes(&bytes[..cut]);
    }
}

#[test]
fn bad_configuration_and_segments_are_errors() {
    for change in [
        |c: &mut GroupConfig| c.order = 0,
        |c: &mut GroupConfig| c.dt = 0.0,
        |c: &mut GroupConfig| c.confidence = 1.0,
        |c: &mut GroupConfig| c.memory = 0,
        |c: &mut GroupConfig| c.position_std = f64::NAN,
    ] {
        let mut c = config();
        change(&mut c);
        assert!(GroupTracker::new(c).is_err());
    }
    let mut t = GroupTracker::new(config()).unwrap();
    assert!(t.step(&[blob(f64::NAN, 1.0, 1.0)]).is_err());
    let mut z = blob(1.0, 1.0, 1.0);
    z.area = 0.0;
    assert!(t.step(&[z]).is_err());
}

#[test]
fn seeded_group_has_members_at_once_with_stage_one_velocity() {
    let mut t = GroupTracker::new(GroupConfig {
        seed_groups: false,
        ..config()
    })
    .unwrap();
    t.seed(&[blob(10.0, 10.0, 1.0)], [2.0, 0.0], 5).unwrap();
    let a = t.step(&[blob(12.0, 10.0, 1.0)]).unwrap();
    assert_eq!(a.segment_member, vec![true]);
    assert!((a.groups[0].vx - 2.0).abs() < 0.1 && a.groups[0].vy.abs() < 0.1);
    assert!(t.seed(&[blob(1.0, 1.0, 1.0)], [f64::NAN, 0.0], 1).is_err());
    assert!(t.seed(&[blob(1.0, 1.0, 1.0)], [0.0, 0.0], 0).is_err());
}

#[test]
fn box_smooth_and_level_by_hand() {
    // 2 × 3 image, width 3: edge rows/columns repeated
    let image = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
    let out = box_smooth(&image, 2, 3, 3);
    // pixel (0, 0): rows {0, 0, 1} × columns {0, 0, 1} → (2·(2·1 + 2) + (2·4 + 5)) / 9
    assert!((out[0] - (2.0 * (2.0 + 2.0) + (8.0 + 5.0)) / 9.0).abs() < 1e-15);
    assert_eq!(box_smooth(&image, 2, 3, 1), image.to_vec());
    let mut out = [f64::NAN; 6];
    box_smooth_into(&image, 2, 3, 3, &mut out);
    assert_eq!(out.to_vec(), box_smooth(&image, 2, 3, 3));
    assert_eq!(background_level(&image, 2, 3), 3.5);
    assert_eq!(background_level(&image[..5], 1, 5), 3.0);
}
