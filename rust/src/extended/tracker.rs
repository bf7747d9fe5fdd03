//! The stage-2 tracker, frame by frame (SPEC §3.4 steps 4–10): assignment of the frame's
//! segments to the live sequences of every group (one joint greedy assignment, so two
//! crossing objects compete for the segments), occlusions (an object hidden in another's
//! segment coasts), Kalman updates, shared derivatives, dropped and new sequences, new groups,
//! group merges, and the per-frame answer.

use super::assignment::{assign, Variant};
use super::config::GroupConfig;
use super::group::{distance, in_box, union, velocity, Group};
use super::motion::{motion, Matrix, DIM};
use super::sequence::{Filters, Measurement};
use crate::{FieldError, Result};

/// Stage 2 over a stream of frames.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupTracker {
    pub(crate) config: GroupConfig,
    pub(crate) thresholds: Vec<f64>,
    pub(crate) f: Matrix,
    pub(crate) q: Matrix,
    pub(crate) groups: Vec<Group>,
    pub(crate) next_group: u64,
    pub(crate) next_sequence: u64,
    pub(crate) frame: u64,
}

/// What a group looks like after a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupReport {
    pub id: u64,
    /// Object centre: from the members' filtered centroids and offsets
    /// (`Group::member_centre`); without a member the area-weighted mean of the confirmed
    /// sequences' centroids, else the box centre.
    pub x: f64,
    pub y: f64,
    pub vx: f64,
    pub vy: f64,
    pub members: usize,
    pub frames_detected: usize,
}

/// The answer for one frame: per segment its group, sequence (−1 never happens once the
/// segment started a sequence; −1 when it was left alone) and membership; per group a report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameAnswer {
    pub segment_group: Vec<i64>,
    pub segment_sequence: Vec<i64>,
    pub segment_member: Vec<bool>,
    pub groups: Vec<GroupReport>,
    /// (absorbed group, group it joined) of this frame's merges, in order.
    pub merged: Vec<(u64, u64)>,
    /// Ids of the groups hidden in this frame by another object's segment (occlusion).
    pub hidden: Vec<u64>,
}

impl GroupTracker {
    pub fn new(config: GroupConfig) -> Result<Self> {
        config.validate()?;
        let thresholds = config.thresholds()?;
        let (f, q) = motion(config.order, config.dt, config.process_std);
        Ok(Self {
            config,
            thresholds,
            f,
            q,
            groups: Vec::new(),
            next_group: 0,
            next_sequence: 0,
            frame: 0,
        })
    }

    pub fn config(&self) -> &GroupConfig {
        &self.config
    }

    /// Frames processed.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// Live groups.
    pub fn n_groups(&self) -> usize {
        self.groups.len()
    }

    /// Live sequences of all groups.
    pub fn n_sequences(&self) -> usize {
        self.groups.iter().map(|g| g.sequences.len()).sum()
    }

    fn filters(&self) -> Filters<'_> {
        Filters {
            config: &self.config,
            f: self.f,
            q: self.q,
        }
    }

    /// Starts a group at the given segments with known velocity (stage 1's answer, step 4).
    /// `length` is the number of observations stage 1 already made of the object (≥ 1): the
    /// seeded sequences continue its trajectory, so they count that many observations
    /// (features joined, members at once when longer than ν + 1), their features with the
    /// variance of one observation.
    pub fn seed(
        &mut self,
        segments: &[Measurement],
        velocity: [f64; 2],
        length: usize,
    ) -> Result<u64> {
        check(segments)?;
        if !(velocity[0].is_finite() && velocity[1].is_finite()) {
            return Err(FieldError::NonFinite("seed velocity is not finite".into()));
        }
        if velocity[0].abs() > 1e12 || velocity[1].abs() > 1e12 {
            return Err(FieldError::InvalidParameter(
                "seed velocity beyond 1e12 in magnitude".into(),
            ));
        }
        if !(1..=1 << 40).contains(&length) {
            return Err(FieldError::InvalidParameter(format!(
                "seed length must be 1..=2**40, got {length}"
            )));
        }
        let mut shared = [[0.0; DIM]; 2];
        shared[0][1] = velocity[0];
        shared[1][1] = velocity[1];
        let id = self.new_group(shared, segments.first().map_or([0.0; 4], |z| z.bbox));
        let g = self.groups.len() - 1;
        let feature_var = [
            self.config.amplitude_std.powi(2),
            self.config.log_area_std.powi(2),
        ];
        for z in segments {
            self.start_sequence(g, z, true);
            if length > 1 {
                if let Some(s) = self.groups[g].sequences.last_mut() {
                    s.length = length;
                    s.feature_var = feature_var;
                }
            }
        }
        Ok(id)
    }

    fn new_group(&mut self, shared: [[f64; DIM]; 2], bbox: [f64; 4]) -> u64 {
        let id = self.next_group;
        self.next_group += 1;
        self.groups.push(Group {
            id,
            shared,
            sequences: Vec::new(),
            bbox,
            misses: 0,
            frames_detected: 0,
            held: 0,
            area: 0.0,
        });
        id
    }

    fn start_sequence(&mut self, g: usize, z: &Measurement, grow: bool) -> u64 {
        let id = self.next_sequence;
        self.next_sequence += 1;
        let shared = self.groups[g].shared;
        let mut s = self.filters().start(id, z, &shared);
        s.segment = None;
        let group = &mut self.groups[g];
        group.sequences.push(s);
        if grow {
            group.bbox = union(group.bbox, z.bbox);
        }
        id
    }

    /// Processes one frame's segments; see the module docs.
    pub fn step(&mut self, segments: &[Measurement]) -> Result<FrameAnswer> {
        check(segments)?;
        let m = segments.len();
        let mut answer = FrameAnswer {
            segment_group: vec![-1; m],
            segment_sequence: vec![-1; m],
            segment_member: vec![false; m],
            groups: Vec::new(),
            merged: Vec::new(),
            hidden: Vec::new(),
        };
        let dt = self.config.dt;
        let predicted: Vec<(u64, [f64; 4])> = self
            .groups
            .iter()
            .map(|g| (g.id, g.predicted_box(dt)))
            .collect();
        let chosen = self.variants_chosen(segments);
        let (merged, hidden) = self.occlusions(segments, &chosen);
        answer.hidden = self
            .groups
            .iter()
            .zip(&hidden)
            .filter(|(_, &h)| h)
            .map(|(g, _)| g.id)
            .collect();
        self.apply_assignment(segments, &chosen, &merged, &hidden);
        self.refresh_groups(&hidden);
        self.split_groups(segments);
        self.start_new(segments, &predicted, &mut answer);
        answer.merged = self.merge_groups();
        self.report(segments, &mut answer);
        self.frame += 1;
        Ok(answer)
    }

    /// Steps 5–6: every admissible variant of every group's sequences, then the greedy choice.
    /// Returns (group, sequence position, segment, increment, dof) of the chosen ones.
    fn variants_chosen(&self, segments: &[Measurement]) -> Vec<(usize, usize, usize, f64, usize)> {
        let filters = self.filters();
        let mut flat = Vec::new();
        let mut variants = Vec::new();
        let mut increments = Vec::new();
        for (g, group) in self.groups.iter().enumerate() {
            for (i, s) in group.sequences.iter().enumerate() {
                let p = filters.predict(s, &group.shared);
                for (r, z) in segments.iter().enumerate() {
                    let (value, dof) = filters.increment(s, &p, z);
                    let index = p.window_index + value;
                    if index <= self.thresholds[p.window_dof + dof] {
                        variants.push(Variant {
                            sequence: flat.len(),
                            segment: r,
                            index,
                        });
                        increments.push((value, dof));
                    }
                }
                flat.push((g, i));
            }
        }
        let chosen = assign(&variants, flat.len(), segments.len());
        chosen
            .into_iter()
            .map(|k| {
                let v = &variants[k];
                let (g, i) = flat[v.sequence];
                (g, i, v.segment, increments[k].0, increments[k].1)
            })
            .collect()
    }

    /// Occlusions: an object (a group detected in N frames at least, moving) without a
    /// confirmed sequence is *hidden* by a segment confirmed by a group of another velocity
    /// when the predicted centroid of one of its sequences lies in the segment's box or that
    /// box covers half of the object's predicted box; that segment is *merged* (two objects
    /// in one segment). Returns (merged per segment, hidden per group).
    fn occlusions(
        &self,
        segments: &[Measurement],
        chosen: &[(usize, usize, usize, f64, usize)],
    ) -> (Vec<bool>, Vec<bool>) {
        let filters = self.filters();
        let mut merged = vec![false; segments.len()];
        let mut hidden = vec![false; self.groups.len()];
        let mut confirmed = vec![false; self.groups.len()];
        for &(g, ..) in chosen {
            confirmed[g] = true;
        }
        // an object: detected in N frames at least, moving
        let object = |g: &Group| {
            let v = velocity(&g.shared);
            g.frames_detected >= self.config.memory && v[0].hypot(v[1]) > self.config.min_speed
        };
        for (b, group) in self.groups.iter().enumerate() {
            if confirmed[b] || !object(group) {
                continue;
            }
            let v = velocity(&group.shared);
            let centres: Vec<[f64; 2]> = group
                .sequences
                .iter()
                .map(|s| filters.predict(s, &group.shared).centre)
                .collect();
            let predicted = group.predicted_box(self.config.dt);
            for &(a, _, r, _, _) in chosen {
                if distance(velocity(&self.groups[a].shared), v) <= self.config.velocity_tolerance {
                    continue;
                }
                let z = segments[r].bbox;
                let inside = centres.iter().any(|c| in_box(z, c[0], c[1], 0.0));
                if inside || covers_half(z, predicted) {
                    merged[r] = true;
                    hidden[b] = true;
                }
            }
        }
        (merged, hidden)
    }

    /// Steps 7–8: updates the confirmed sequences (a sequence on a merged segment coasts: the
    /// segment measures neither object), drops the others (those of a hidden group coast).
    fn apply_assignment(
        &mut self,
        segments: &[Measurement],
        chosen: &[(usize, usize, usize, f64, usize)],
        merged: &[bool],
        hidden: &[bool],
    ) {
        let config = self.config.clone();
        let filters = Filters {
            config: &config,
            f: self.f,
            q: self.q,
        };
        for group in &mut self.groups {
            for s in &mut group.sequences {
                s.segment = None;
            }
        }
        for &(g, i, r, value, dof) in chosen {
            let s = &mut self.groups[g].sequences[i];
            if merged[r] {
                filters.coast(s);
            } else {
                filters.update(s, &segments[r], (value, dof));
            }
            s.segment = Some(r);
        }
        for (group, &hidden) in self.groups.iter_mut().zip(hidden) {
            if hidden {
                group.sequences.iter_mut().for_each(|s| filters.coast(s));
            } else {
                group.sequences.retain(|s| s.segment.is_some());
            }
        }
    }

    /// Step 7 (3.5) per group, its box (held at the object's extent while fragments are
    /// missing, see `Group::hold`; a coasting sequence counts with its moved box), its
    /// misses; groups missed too long die (hidden ones after `max_misses` or 2N frames,
    /// whichever is more).
    fn refresh_groups(&mut self, hidden: &[bool]) {
        let config = self.config.clone();
        for group in &mut self.groups {
            if group.sequences.iter().all(|s| s.segment.is_none()) {
                group.misses += 1;
                let v = velocity(&group.shared);
                for (k, shift) in [v[0], v[1], v[0], v[1]].iter().enumerate() {
                    group.bbox[k] += shift * config.dt;
                }
                continue;
            }
            group.misses = 0;
            let predicted = group.predicted_box(config.dt);
            group.refresh_shared(&config);
            let mut boxes = group
                .sequences
                .iter()
                .filter(|s| s.segment.is_some())
                .map(|s| s.bbox);
            if let Some(first) = boxes.next() {
                let seen = boxes.fold(first, union);
                group.hold(seen, predicted, config.memory);
            }
        }
        let hidden_limit = config.max_misses.max(2 * config.memory);
        let mut hidden = hidden.iter();
        self.groups.retain(|g| {
            let limit = if hidden.next() == Some(&true) {
                hidden_limit
            } else {
                config.max_misses
            };
            g.misses <= limit
        });
    }

    /// A confirmed sequence longer than ν + 1 whose own velocity lies beyond
    /// `velocity_tolerance` from its group's leaves it and starts a group of its own, with its
    /// own derivatives (two objects that were born touching part; the merge rule joins
    /// groups again when they agree).
    fn split_groups(&mut self, segments: &[Measurement]) {
        let config = self.config.clone();
        let mut leaving = Vec::new();
        for group in &mut self.groups {
            let shared = velocity(&group.shared);
            let (stay, go): (Vec<_>, Vec<_>) = group.sequences.drain(..).partition(|s| {
                s.length <= config.order + 1
                    || distance(velocity(&s.state), shared) <= config.velocity_tolerance
            });
            group.sequences = stay;
            leaving.extend(go);
        }
        for mut s in leaving {
            s.offset = None;
            let mut shared = s.state;
            shared[0][0] = 0.0;
            shared[1][0] = 0.0;
            let bbox = s.segment.map_or(
                [s.state[0][0], s.state[1][0], s.state[0][0], s.state[1][0]],
                |r| segments[r].bbox,
            );
            self.new_group(shared, bbox);
            if let Some(g) = self.groups.last_mut() {
                g.sequences.push(s);
            }
        }
    }

    /// Step 8: segments left alone start sequences in the group whose gate holds them (the
    /// nearest box centre; that group counts as seen: its misses restart), or new groups
    /// (`seed_groups`). A group's gate: the box of its segments of this frame united with its
    /// previous box moved by the shared velocity (`predicted`, by group id), grown by the
    /// margin — the object's extent even when only a part of it was confirmed.
    fn start_new(
        &mut self,
        segments: &[Measurement],
        predicted: &[(u64, [f64; 4])],
        answer: &mut FrameAnswer,
    ) {
        let mut used = vec![false; segments.len()];
        for group in &self.groups {
            for s in &group.sequences {
                if let Some(r) = s.segment {
                    used[r] = true;
                }
            }
        }
        let old = self.groups.len();
        for (r, z) in segments.iter().enumerate() {
            if used[r] {
                continue;
            }
            let mut best: Option<(f64, usize)> = None;
            for (g, group) in self.groups.iter().enumerate() {
                let gate = predicted
                    .iter()
                    .find(|(id, _)| *id == group.id)
                    .map_or(group.bbox, |(_, b)| union(group.bbox, *b));
                if in_box(gate, z.x, z.y, self.config.gate_margin) {
                    let d = distance(group.centre(), z.position());
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, g));
                    }
                }
            }
            let g = match best {
                Some((_, g)) => g,
                None if self.config.seed_groups => {
                    self.new_group([[0.0; DIM]; 2], z.bbox);
                    self.groups.len() - 1
                }
                None => continue,
            };
            let id = self.start_sequence(g, z, g >= old);
            let group = &mut self.groups[g];
            // the object is seen, only its fragments changed (they merged, split or jumped)
            group.misses = 0;
            if let Some(s) = group.sequences.last_mut() {
                s.segment = Some(r);
            }
            answer.segment_group[r] = group.id as i64;
            answer.segment_sequence[r] = id as i64;
        }
    }

    /// Groups whose shared velocities agree, both with a sequence longer than ν + 1, whose
    /// boxes lie within `gate_margin` or within `cohesion` × the smaller one's extent of each
    /// other, become one: the younger joins the older (SPEC §3.4, step 10 at the level of
    /// groups) and its sequences' offsets from the centre are recorded afresh.
    fn merge_groups(&mut self) -> Vec<(u64, u64)> {
        let config = &self.config;
        let mut merged = Vec::new();
        let mature = |g: &Group| g.sequences.iter().any(|s| s.length > config.order + 1);
        let mut i = 0;
        while i < self.groups.len() {
            let mut j = i + 1;
            while j < self.groups.len() {
                let (a, b) = (&self.groups[i], &self.groups[j]);
                let agree =
                    distance(velocity(&a.shared), velocity(&b.shared)) <= config.velocity_tolerance;
                let reach = config
                    .gate_margin
                    .max(config.cohesion * a.extent().min(b.extent()));
                if a.gap(b) <= reach && mature(a) && mature(b) && agree {
                    let b = self.groups.remove(j);
                    let a = &mut self.groups[i];
                    merged.push((b.id, a.id));
                    let (na, nb) = (a.sequences.len() as f64, b.sequences.len() as f64);
                    for axis in 0..2 {
                        for k in 1..DIM {
                            a.shared[axis][k] =
                                (na * a.shared[axis][k] + nb * b.shared[axis][k]) / (na + nb);
                        }
                    }
                    // one set of offsets survives: the older group's, unless only the
                    // younger had members
                    let keep_b = a.area == 0.0 && b.area > 0.0;
                    let mut joining = b.sequences;
                    let fresh = if keep_b {
                        &mut a.sequences
                    } else {
                        &mut joining
                    };
                    fresh.iter_mut().for_each(|s| s.offset = None);
                    if keep_b {
                        a.area = b.area;
                    }
                    a.sequences.extend(joining);
                    a.bbox = union(a.bbox, b.bbox);
                    a.frames_detected = a.frames_detected.max(b.frames_detected);
                    a.misses = a.misses.min(b.misses);
                    a.held = a.held.min(b.held);
                } else {
                    j += 1;
                }
            }
            i += 1;
        }
        merged
    }

    /// Step 10 and the answer: members, detection, centre (`Group::member_centre`; without
    /// a member, the area-weighted mean of the segments it holds, else its box centre).
    fn report(&mut self, segments: &[Measurement], answer: &mut FrameAnswer) {
        for group in &mut self.groups {
            let member: Vec<bool> = group
                .sequences
                .iter()
                .map(|s| group.is_member(s, &self.config))
                .collect();
            let (mut ax, mut ay, mut aw) = (0.0, 0.0, 0.0);
            for (s, &m) in group.sequences.iter().zip(&member) {
                let Some(r) = s.segment else { continue };
                let area = segments[r].area;
                answer.segment_group[r] = group.id as i64;
                answer.segment_sequence[r] = s.id as i64;
                answer.segment_member[r] = m;
                ax += area * s.state[0][0];
                ay += area * s.state[1][0];
                aw += area;
            }
            let members = member.iter().filter(|&&m| m).count();
            let centre = if members > 0 {
                group.frames_detected += 1;
                group.member_centre(&member, segments)
            } else if aw > 0.0 {
                [ax / aw, ay / aw]
            } else {
                group.centre()
            };
            let v = velocity(&group.shared);
            answer.groups.push(GroupReport {
                id: group.id,
                x: centre[0],
                y: centre[1],
                vx: v[0],
                vy: v[1],
                members,
                frames_detected: group.frames_detected,
            });
        }
    }
}

/// Whether box `a` covers at least half of box `b`'s area (boxes as x0, y0, x1, y1).
fn covers_half(a: [f64; 4], b: [f64; 4]) -> bool {
    let w = a[2].min(b[2]) - a[0].max(b[0]);
    let h = a[3].min(b[3]) - a[1].max(b[1]);
    w >= 0.0 && h >= 0.0 && w * h >= 0.5 * (b[2] - b[0]) * (b[3] - b[1])
}

/// Finite measurements with a positive area and an ordered box.
fn check(segments: &[Measurement]) -> Result<()> {
    for (r, z) in segments.iter().enumerate() {
        let values = [
            z.x,
            z.y,
            z.amplitude,
            z.area,
            z.bbox[0],
            z.bbox[1],
            z.bbox[2],
            z.bbox[3],
        ];
        if values.iter().any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(format!(
                "segment {r} has a NaN or infinite value"
            )));
        }
        if z.area < 1.0 || z.bbox[0] > z.bbox[2] || z.bbox[1] > z.bbox[3] {
            return Err(FieldError::InvalidParameter(format!(
                "segment {r}: area must be ≥ 1 and the box ordered (x0 ≤ x1, y0 ≤ y1)"
            )));
        }
        if values.iter().any(|v| v.abs() > 1e12) {
            return Err(FieldError::InvalidParameter(format!(
                "segment {r} has a value beyond 1e12 in magnitude"
            )));
        }
    }
    Ok(())
}
