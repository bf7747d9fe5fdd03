//! A group of sequences moving together: one object (SPEC §3.4 steps 7, 10). It holds the
//! shared derivatives X*_q (velocity, acceleration) used by every member's prediction, the
//! box of its last segments (the gate of new fragments) and its detection count.

use super::config::GroupConfig;
use super::motion::Vector;
use super::sequence::{Measurement, Sequence};

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
    /// Members' total area the object is known to cover (0: none yet); a frame whose members
    /// cover less than `COMPLETE` of it misses a fragment (see `member_centre`).
    pub area: f64,
}

/// Members covering this fraction of the group's area are the whole object.
pub(crate) const COMPLETE: f64 = 0.9;

/// Per frame the group's area decays by this factor towards its members' (an object that
/// lost a third of its area for good is whole again after some 15 frames).
pub(crate) const AREA_DECAY: f64 = 0.98;

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
    /// a pixel or more) than the previous box moved by the shared velocity (`predicted`), a
    /// fragment is missing, not the object: the box keeps the union of both, for at most
    /// `memory` frames in a row.
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

    /// The gap between the two boxes (pixels, the larger of the two axes; 0 when they
    /// overlap): they touch within a margin m iff gap ≤ m.
    pub fn gap(&self, other: &Group) -> f64 {
        let (a, b) = (self.bbox, other.bbox);
        (b[0] - a[2])
            .max(a[0] - b[2])
            .max(b[1] - a[3])
            .max(a[1] - b[3])
            .max(0.0)
    }

    /// The box's larger side in pixels (its bounds are inclusive pixel indices).
    pub fn extent(&self) -> f64 {
        (self.bbox[2] - self.bbox[0]).max(self.bbox[3] - self.bbox[1]) + 1.0
    }

    /// Step 7, (3.5): the shared derivatives become the mean of the confirmed sequences'
    /// own ones, each weighted by its precision 1/P_kk (a sequence just restarted at a
    /// fragment's new segment knows little of the velocity and counts little) — over those
    /// whose velocity lies within `velocity_tolerance` of the previous shared velocity when
    /// there are any (a spot of the background that fell into the gate does not drag the
    /// group), over all otherwise. A group detected before keeps its derivatives while all
    /// its sequences are restarted ones (none longer than ν + 1): the object's velocity
    /// outlives its fragments' sequences.
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
        let restarted = chosen.iter().all(|s| s.length <= config.order + 1);
        if chosen.is_empty() || (restarted && self.frames_detected > 0) {
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

    /// The object's centre from its members (`member[i]` for `sequences[i]`; at least one).
    /// When they cover the object (their area at least `COMPLETE` of the group's), it is their
    /// area-weighted mean filtered centroid and each member's offset from it is recorded;
    /// when a fragment is missing, the area-weighted mean of the members' centroids minus
    /// their offsets (members without one get theirs from that centre; when none has one, the
    /// plain mean). The group's area follows the members' and decays by `AREA_DECAY` per
    /// frame.
    pub fn member_centre(&mut self, member: &[bool], segments: &[Measurement]) -> [f64; 2] {
        let (mut total, mut plain, mut known, mut known_area) = (0.0, [0.0; 2], [0.0; 2], 0.0);
        for (s, _) in self.sequences.iter().zip(member).filter(|(_, &m)| m) {
            let Some(r) = s.segment else { continue };
            let area = segments[r].area;
            total += area;
            for (axis, p) in plain.iter_mut().enumerate() {
                *p += area * s.state[axis][0];
            }
            if let Some(offset) = s.offset {
                known_area += area;
                for (axis, k) in known.iter_mut().enumerate() {
                    *k += area * (s.state[axis][0] - offset[axis]);
                }
            }
        }
        let complete = total >= COMPLETE * self.area;
        self.area = total.max(AREA_DECAY * self.area);
        let centre = if complete || known_area == 0.0 {
            plain.map(|v| v / total)
        } else {
            known.map(|v| v / known_area)
        };
        for (s, _) in self.sequences.iter_mut().zip(member).filter(|(_, &m)| m) {
            if complete || s.offset.is_none() {
                s.offset = Some([s.state[0][0] - centre[0], s.state[1][0] - centre[1]]);
            }
        }
        centre
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
