//! The tracker's whole state as bytes (pickling): a tag, the configuration, the counters and
//! every group and sequence, little-endian. Loading checks the tag, every length against the
//! bytes left, every value (finite, in range) and the configuration, so a corrupt or foreign
//! buffer is an error, never a panic or a wrong tracker.

use super::config::{GroupConfig, MAX_MEMORY};
use super::group::Group;
use super::motion::{Matrix, Vector, DIM};
use super::sequence::Sequence;
use super::tracker::GroupTracker;
use crate::{FieldError, Result};

const TAG: &[u8; 8] = b"KFEXT\x00\x00\x03";

struct Writer(Vec<u8>);

impl Writer {
    fn u(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn vector(&mut self, v: &Vector) {
        v.iter().for_each(|&x| self.f(x));
    }
    fn matrix(&mut self, m: &Matrix) {
        m.iter().for_each(|row| self.vector(row));
    }
}

struct Reader<'a>(&'a [u8]);

fn corrupt(what: &str) -> FieldError {
    FieldError::InvalidParameter(format!("not a valid extended-tracker state: {what}"))
}

impl Reader<'_> {
    fn take8(&mut self) -> Result<[u8; 8]> {
        if self.0.len() < 8 {
            return Err(corrupt("truncated"));
        }
        let (head, rest) = self.0.split_at(8);
        self.0 = rest;
        Ok(head.try_into().unwrap_or([0; 8]))
    }
    fn u(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take8()?))
    }
    fn usize(&mut self, most: u64, what: &str) -> Result<usize> {
        let v = self.u()?;
        if v > most {
            return Err(corrupt(what));
        }
        Ok(v as usize)
    }
    /// A count of items of at least `item_bytes` each: bounded by the bytes left.
    fn count(&mut self, item_bytes: usize, what: &str) -> Result<usize> {
        let most = (self.0.len() / item_bytes.max(1)) as u64;
        self.usize(most, what)
    }
    fn f(&mut self) -> Result<f64> {
        let v = f64::from_le_bytes(self.take8()?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(corrupt("a non-finite number"))
        }
    }
    fn vector(&mut self) -> Result<Vector> {
        let mut v = [0.0; DIM];
        for x in &mut v {
            *x = self.f()?;
        }
        Ok(v)
    }
    fn matrix(&mut self) -> Result<Matrix> {
        let mut m = [[0.0; DIM]; DIM];
        for row in &mut m {
            *row = self.vector()?;
        }
        Ok(m)
    }
}

fn write_config(w: &mut Writer, c: &GroupConfig) {
    w.u(c.order as u64);
    for v in [
        c.dt,
        c.position_std,
        c.process_std,
        c.amplitude_std,
        c.log_area_std,
        c.feature_drift,
        c.confidence,
    ] {
        w.f(v);
    }
    w.u(c.memory as u64);
    for v in [
        c.initial_speed_std,
        c.gate_margin,
        c.min_speed,
        c.velocity_tolerance,
        c.cohesion,
    ] {
        w.f(v);
    }
    w.u(c.max_misses as u64);
    w.u(u64::from(c.seed_groups));
}

fn read_config(r: &mut Reader<'_>) -> Result<GroupConfig> {
    let order = r.usize(16, "order")?;
    let [dt, position_std, process_std, amplitude_std, log_area_std, feature_drift, confidence] =
        [r.f()?, r.f()?, r.f()?, r.f()?, r.f()?, r.f()?, r.f()?];
    let memory = r.usize(MAX_MEMORY as u64, "memory")?;
    let [initial_speed_std, gate_margin, min_speed, velocity_tolerance, cohesion] =
        [r.f()?, r.f()?, r.f()?, r.f()?, r.f()?];
    let max_misses = r.usize(1 << 20, "max_misses")?;
    let seed_groups = r.usize(1, "seed_groups")? == 1;
    let config = GroupConfig {
        order,
        dt,
        position_std,
        process_std,
        amplitude_std,
        log_area_std,
        feature_drift,
        confidence,
        memory,
        initial_speed_std,
        gate_margin,
        min_speed,
        velocity_tolerance,
        cohesion,
        max_misses,
        seed_groups,
    };
    config.validate()?;
    Ok(config)
}

fn write_sequence(w: &mut Writer, s: &Sequence) {
    w.u(s.id);
    for axis in 0..2 {
        w.vector(&s.state[axis]);
        w.matrix(&s.cov[axis]);
    }
    s.feature.iter().for_each(|&v| w.f(v));
    s.feature_var.iter().for_each(|&v| w.f(v));
    s.bbox.iter().for_each(|&v| w.f(v));
    w.u(s.length as u64);
    w.u(s.window.len() as u64);
    for &(value, dof) in &s.window {
        w.f(value);
        w.u(dof as u64);
    }
    w.u(s.segment.map_or(u64::MAX, |r| r as u64));
    w.u(u64::from(s.offset.is_some()));
    s.offset.unwrap_or_default().iter().for_each(|&v| w.f(v));
}

fn read_sequence(r: &mut Reader<'_>, memory: usize, next_id: u64) -> Result<Sequence> {
    let id = r.u()?;
    if id >= next_id {
        return Err(corrupt("a sequence id beyond the counter"));
    }
    let mut state = [[0.0; DIM]; 2];
    let mut cov = [[[0.0; DIM]; DIM]; 2];
    for axis in 0..2 {
        state[axis] = r.vector()?;
        cov[axis] = r.matrix()?;
    }
    let feature = [r.f()?, r.f()?];
    let feature_var = [r.f()?, r.f()?];
    let bbox = [r.f()?, r.f()?, r.f()?, r.f()?];
    if bbox[0] > bbox[2] || bbox[1] > bbox[3] {
        return Err(corrupt("a sequence box out of order"));
    }
    let length = r.usize(u64::MAX >> 1, "length")?;
    let n = r.usize(memory as u64, "window")?;
    let mut window = Vec::with_capacity(n);
    for _ in 0..n {
        window.push((r.f()?, r.usize(4, "dof")?));
    }
    let segment = match r.u()? {
        u64::MAX => None,
        v => Some(usize::try_from(v).map_err(|_| corrupt("segment"))?),
    };
    let has_offset = r.usize(1, "offset flag")? == 1;
    let offset = [r.f()?, r.f()?];
    Ok(Sequence {
        id,
        state,
        cov,
        feature,
        feature_var,
        bbox,
        length,
        window,
        segment,
        offset: has_offset.then_some(offset),
    })
}

impl GroupTracker {
    /// The configuration and the dynamic state as bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer(TAG.to_vec());
        write_config(&mut w, &self.config);
        for v in [
            self.next_group,
            self.next_sequence,
            self.frame,
            self.groups.len() as u64,
        ] {
            w.u(v);
        }
        for g in &self.groups {
            w.u(g.id);
            g.shared.iter().for_each(|v| w.vector(v));
            w.u(g.sequences.len() as u64);
            g.sequences.iter().for_each(|s| write_sequence(&mut w, s));
            g.bbox.iter().for_each(|&v| w.f(v));
            w.u(g.misses as u64);
            w.u(g.frames_detected as u64);
            w.u(g.held as u64);
            w.f(g.area);
        }
        w.0
    }

    /// A tracker from `to_bytes`' output; every part checked.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let mut r = Reader(bytes);
        if r.take8()? != *TAG {
            return Err(corrupt("wrong tag"));
        }
        let mut tracker = GroupTracker::new(read_config(&mut r)?)?;
        tracker.next_group = r.u()?;
        tracker.next_sequence = r.u()?;
        tracker.frame = r.u()?;
        let n_groups = r.count(8 * 12, "group count")?;
        let memory = tracker.config.memory;
        for _ in 0..n_groups {
            let id = r.u()?;
            if id >= tracker.next_group {
                return Err(corrupt("a group id beyond the counter"));
            }
            let shared = [r.vector()?, r.vector()?];
            let n = r.count(8 * 37, "sequence count")?;
            let mut sequences = Vec::with_capacity(n);
            for _ in 0..n {
                sequences.push(read_sequence(&mut r, memory, tracker.next_sequence)?);
            }
            let bbox = [r.f()?, r.f()?, r.f()?, r.f()?];
            let misses = r.usize(u64::MAX >> 1, "misses")?;
            let frames_detected = r.usize(u64::MAX >> 1, "frames_detected")?;
            let held = r.usize(memory as u64, "held")?;
            let area = r.f()?;
            if area < 0.0 {
                return Err(corrupt("a negative group area"));
            }
            tracker.groups.push(Group {
                id,
                shared,
                sequences,
                bbox,
                misses,
                frames_detected,
                held,
                area,
            });
        }
        if !r.0.is_empty() {
            return Err(corrupt("trailing bytes"));
        }
        Ok(tracker)
    }
}
