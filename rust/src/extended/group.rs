//! A group of sequences moving together: one object (SPEC §3.4 steps 7, 10). It holds the
//! shared derivatives X*_q (velocity, acceleration) used by every member's prediction, the
//! box of its last segments (the gate of new fragments) and its detection count.

use super::config::GroupConfig;
use super::motion::Vector;
use super::sequence::Sequence;

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Group {
    pub id: u64,
    /// Per axis: (unused, velocity, acceleration) shared by the group.
    pub shared: [Vector; 2],
    pub sequences: Vec<Sequence>,
    /// x0, y0, x1, y1 of the union of its last segments.
    pub bbox: [f64; 4],
    /// Frames in a row without a confirmed sequence.
    pub misses: usize,
    /// Frames in which it was detected (had a member).
    pub frames_detected: usize,
    /// Frames in a row its box was held at the predicted extent (at most N).
    pub held: usize,
}

/// Rounding slack (pixels) when box widths are compared.
const WIDTH_TOLERANCE: f64 = 1e-9;

pub(crate) fn velocity(state: &[Vector; 2]) -> [f64; 2] {
    [state[0][1], state[1][1]]
}

pub(crate) fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

pub(crate) fn union(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0].min(b[0]),
        a[1].min(b[1]),
        a[2].max(b[2]),
        a[3].max(b[3]),
    ]
}

/// Whether (x, y) lies in box `b` grown by `margin`.
pub(crate) fn in_box(b: [f64; 4], x: f64, y: f64, margin: f64) -> bool {
    x >= b[0] - margin && x <= b[2] + margin && y >= b[1] - margin && y <= b[3] + margin
}

impl Group {
    /// The box moved by the shared velocity over one step `dt`.
    pub fn predicted_box(&self, dt: f64) -> [f64; 4] {
        let v = velocity(&self.shared);
        let b = self.bbox;
        [
            b[0] + v[0] * dt,
            b[1] + v[1] * dt,
            b[2] + v[0] * dt,
            b[3] + v[1] * dt,
        ]
    }

    /// The box after a frame whose segments span `seen`: when `seen` is narrower or lower (by
    /// a pixel or more) than the previous box moved by the shared velocity (`predicted`), a fragment is missing, not
    /// the object: the box keeps the union of both, for at most `memory` frames in a row.
    pub fn hold(&mut self, seen: [f64; 4], predicted: [f64; 4], memory: usize) {
        // boxes are in whole pixels: narrower means by one pixel at least (up to rounding:
        // the shifted box's width is a whole number ± 1 ulp-level errors)
        let smaller = seen[2] - seen[0] <= predicted[2] - predicted[0] - 1.0 + WIDTH_TOLERANCE
            || seen[3] - seen[1] <= predicted[3] - predicted[1] - 1.0 + WIDTH_TOLERANCE;
        if smaller && self.held < memory {
            self.bbox = union(seen, predicted);
            self.held += 1;
        } else {
            self.bbox = seen;
            self.held = 0;
        }
    }

    pub fn centre(&self) -> [f64; 2] {
        [
            0.5 * (self.bbox[0] + self.bbox[2]),
            0.5 * (self.bbox[1] + self.bbox[3]),
        ]
    }

    /// Whether the two boxes, this one grown by `margin`, overlap.
    pub fn touches(&self, other: &Group, margin: f64) -> bool {
        let (a, b) = (self.bbox, other.bbox);
        a[0] - margin <= b[2]
            && b[0] <= a[2] + margin
            && a[1] - margin <= b[3]
            && b[1] <= a[3] + margin
    }

    /// Step 7, (3.5): the shared derivatives become the mean of the confirmed sequences'
    /// own ones, each weighted by its precision 1/P_kk (a sequence just restarted at a
    /// fragment's new segment knows little of the velocity and counts little) — over those whose velocity lies within `velocity_tolerance` of the previous
    /// shared velocity when there are any (a spot of the background that fell into the gate
    /// does not drag the group), over all otherwise.
    pub fn refresh_shared(&mut self, config: &GroupConfig) {
        let previous = velocity(&self.shared);
        let near: Vec<&Sequence> = self
            .sequences
            .iter()
            .filter(|s| distance(velocity(&s.state), previous) <= config.velocity_tolerance)
            .collect();
        let chosen: Vec<&Sequence> = if near.is_empty() {
            self.sequences.iter().collect()
        } else {
            near
        };
        if chosen.is_empty() {
            return;
        }
        for axis in 0..2 {
            for k in 1..=config.order {
                let (mut sum, mut weight) = (0.0, 0.0);
                for s in &chosen {
                    let w = 1.0 / s.cov[axis][k][k].max(f64::MIN_POSITIVE);
                    sum += w * s.state[axis][k];
                    weight += w;
                }
                self.shared[axis][k] = sum / weight;
            }
        }
    }

    /// Step 10: a confirmed sequence longer than ν + 1 whose own speed exceeds `min_speed`
    /// and whose velocity lies within `velocity_tolerance` of the group's.
    pub fn is_member(&self, s: &Sequence, config: &GroupConfig) -> bool {
        let v = velocity(&s.state);
        s.segment.is_some()
            && s.length > config.order + 1
            && v[0].hypot(v[1]) > config.min_speed
            && distance(v, velocity(&self.shared)) <= config.velocity_tolerance
    }
}
