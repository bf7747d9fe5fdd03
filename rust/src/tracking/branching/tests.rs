//! The branching tracker end to end: tracks on a small scenario, state round trip, bad input,
//! bounded work under clutter.

use super::tracker::splitmix64;
use super::{BranchingTracker, TrackerConfig};

/// Uniform in [0, 1) from a counter (portable, no RNG state).
fn uniform(counter: u64) -> f64 {
    (splitmix64(counter) >> 11) as f64 / (1u64 << 53) as f64
}

/// Frame f: two targets crossing at frame 10, `clutter` uniform points on [0, 64)².
fn frame(f: usize, clutter: usize) -> Vec<f64> {
    let t = f as f64;
    let mut z = vec![10.0 + 2.0 * t, 10.0 + t, 10.0 + 2.0 * t, 30.0 - t];
    for c in 0..clutter {
        let id = (f * 10_000 + c) as u64 * 2;
        z.push(64.0 * uniform(id));
        z.push(64.0 * uniform(id + 1));
    }
    z
}

fn config() -> TrackerConfig {
    TrackerConfig {
        process_std: vec![0.05; 2],
        measurement_std: vec![0.3; 2],
        clutter_density: Some(1e-3),
        ..TrackerConfig::with_defaults(2)
    }
}

fn run(frames: std::ops::Range<usize>, tr: &mut BranchingTracker, clutter: usize) {
    for f in frames {
        tr.update(&frame(f, clutter), None).unwrap();
    }
}

#[test]
fn crossing_targets_are_tracked_through_clutter() {
    let mut tr = BranchingTracker::new(config()).unwrap();
    run(0..20, &mut tr, 3);
    let t = tr.track_table();
    let ns = tr.nodes.n_state;
    let particles: std::collections::BTreeSet<i64> = t.particle.iter().copied().collect();
    assert_eq!(particles.len(), 2, "{:?}", t.particle);
    for p in particles {
        let rows: Vec<usize> = (0..t.frame.len()).filter(|&r| t.particle[r] == p).collect();
        assert!(rows.len() >= 18);
        // every row within 1 px of the target this particle started on (no swap at the crossing)
        let first = rows[0];
        let target = if t.state[first * ns + 2] < 20.0 { 0 } else { 1 };
        for r in rows {
            let f = t.frame[r] as usize;
            let truth = &frame(f, 0)[2 * target..2 * target + 2];
            let (x, y) = (t.state[r * ns], t.state[r * ns + 2]);
            assert!(
                (x - truth[0]).abs() < 1.0 && (y - truth[1]).abs() < 1.0,
                "frame {f}"
            );
        }
    }
    // no measured detection shared by the two particles
    let mut seen = std::collections::HashSet::new();
    assert!(t
        .detection
        .iter()
        .filter(|&&d| d >= 0)
        .all(|d| seen.insert(*d)));
}

#[test]
fn state_bytes_resume_exactly() {
    let mut a = BranchingTracker::new(config()).unwrap();
    run(0..9, &mut a, 4);
    let bytes = a.state_bytes();
    let mut b = BranchingTracker::new(config()).unwrap();
    b.load_state(&bytes).unwrap();
    run(9..20, &mut a, 4);
    run(9..20, &mut b, 4);
    assert_eq!(a.track_table(), b.track_table());
    assert_eq!(a.stats, b.stats);
}

#[test]
fn corrupt_state_bytes_are_errors() {
    let mut a = BranchingTracker::new(config()).unwrap();
    run(0..6, &mut a, 4);
    let bytes = a.state_bytes();
    let mut b = BranchingTracker::new(config()).unwrap();
    assert!(b.load_state(&bytes[..bytes.len() - 3]).is_err());
    assert!(b.load_state(&[]).is_err());
    let mut wrong_magic = bytes.clone();
    wrong_magic[0] ^= 1;
    assert!(b.load_state(&wrong_magic).is_err());
    let mut other = config();
    other.memory = 3;
    assert!(BranchingTracker::new(other)
        .unwrap()
        .load_state(&bytes)
        .is_err());
    // flipping any single byte never panics (an error, or a state that still checks out)
    for pos in 0..bytes.len() {
        let mut flipped = bytes.clone();
        flipped[pos] ^= 0x80;
        let mut c = BranchingTracker::new(config()).unwrap();
        if c.load_state(&flipped).is_ok() {
            run(6..8, &mut c, 4);
            c.track_table();
        }
    }
    assert_eq!(b.frame, 0, "failed loads leave the tracker untouched");
}

#[test]
fn bad_measurements_are_errors_and_change_nothing() {
    let mut tr = BranchingTracker::new(config()).unwrap();
    run(0..3, &mut tr, 2);
    let before = tr.state_bytes();
    assert!(tr.update(&[1.0, f64::NAN], None).is_err());
    assert!(tr.update(&[1.0, 2.0, 3.0], None).is_err());
    assert!(tr.update(&[1.0, 2.0], Some(1.0)).is_err()); // time 1 < time 2 of frame 2
    assert!(tr.update(&[1.0, 2.0], Some(f64::INFINITY)).is_err());
    assert_eq!(tr.state_bytes(), before);
    tr.update(&[], None).unwrap(); // an empty frame coasts
    assert_eq!(tr.frame, 4);
}

#[test]
fn invalid_configurations_are_errors() {
    let cases: [fn(&mut TrackerConfig); 10] = [
        |c| c.confidence = 1.0,
        |c| c.order = vec![9, 1],
        |c| c.process_std = vec![0.1],
        |c| c.measurement_std = vec![0.0, 0.5],
        |c| c.memory = 0,
        |c| c.memory = super::config::MAX_MEMORY + 1,
        |c| c.delete_llr = Some(f64::NAN),
        |c| c.p_detect = 1.0,
        |c| c.n_spatial = 3,
        |c| c.max_children = Some(0),
    ];
    for (i, edit) in cases.iter().enumerate() {
        let mut c = config();
        edit(&mut c);
        assert!(BranchingTracker::new(c).is_err(), "case {i}");
    }
}

#[test]
fn heavy_clutter_keeps_the_work_bounded() {
    let cfg = TrackerConfig {
        max_hypotheses: 1500,
        max_seeds: 300,
        max_misses: 3,
        ..config()
    };
    let mut tr = BranchingTracker::new(cfg).unwrap();
    run(0..6, &mut tr, 1000);
    for s in &tr.stats {
        assert!(s.seeds <= 300);
        assert!(s.live <= 1500 + 300, "{s:?}");
    }
    assert!(
        tr.stats.iter().skip(1).any(|s| s.children > 1500),
        "the cap must bind"
    );
}
