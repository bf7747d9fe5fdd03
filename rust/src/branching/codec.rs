//! The tracker's dynamic state as bytes (the pickled form; the configuration travels
//! separately). Little-endian, length-prefixed arrays, a magic tag and the state widths, so a
//! byte string from another configuration or a truncated one is an error, not a panic.

use super::hypotheses::{Hypotheses, NONE};
use super::tracker::{BranchingTracker, FrameStats, OnlineAnswer};
use crate::error::{FieldError, Result};

const MAGIC: &[u8; 8] = b"KFBRT001";

#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        v.iter()
            .for_each(|x| self.0.extend_from_slice(&x.to_le_bytes()));
    }
    fn i64s(&mut self, v: &[i64]) {
        self.u64(v.len() as u64);
        v.iter()
            .for_each(|x| self.0.extend_from_slice(&x.to_le_bytes()));
    }
    fn bools(&mut self, v: &[bool]) {
        self.u64(v.len() as u64);
        self.0.extend(v.iter().map(|&b| u8::from(b)));
    }
}

struct Reader<'a>(&'a [u8]);

fn corrupt() -> FieldError {
    FieldError::InvalidParameter(
        "the tracker state is truncated or was saved by another version/configuration".into(),
    )
}

impl Reader<'_> {
    fn bytes(&mut self, n: usize) -> Result<&[u8]> {
        if self.0.len() < n {
            return Err(corrupt());
        }
        let (head, tail) = self.0.split_at(n);
        self.0 = tail;
        Ok(head)
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.bytes(8)?.try_into().unwrap()))
    }
    fn len(&mut self, item: usize) -> Result<usize> {
        let n = self.u64()? as usize;
        if n.checked_mul(item).is_none_or(|b| b > self.0.len()) {
            return Err(corrupt());
        }
        Ok(n)
    }
    fn f64s(&mut self) -> Result<Vec<f64>> {
        let n = self.len(8)?;
        let raw = self.bytes(8 * n)?;
        Ok(raw
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect())
    }
    fn i64s(&mut self) -> Result<Vec<i64>> {
        let n = self.len(8)?;
        let raw = self.bytes(8 * n)?;
        Ok(raw
            .chunks_exact(8)
            .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
            .collect())
    }
    fn bools(&mut self) -> Result<Vec<bool>> {
        let n = self.len(1)?;
        Ok(self.bytes(n)?.iter().map(|&b| b != 0).collect())
    }
}

impl BranchingTracker {
    /// The dynamic state as bytes.
    pub fn state_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.0.extend_from_slice(MAGIC);
        let wd = self.w;
        w.i64s(&[wd.state, wd.cov, wd.memory, wd.spatial, wd.depth].map(|v| v as i64));
        let n = &self.nodes;
        for v in [&n.parent, &n.frame, &n.meas] {
            w.i64s(v);
        }
        for v in [&n.state, &n.index, &n.llr] {
            w.f64s(v);
        }
        let h = &self.h;
        for v in [
            &h.node,
            &h.tree,
            &h.n_inc,
            &h.hits,
            &h.miss,
            &h.node_last,
            &h.recent,
        ] {
            w.i64s(v);
        }
        for v in [&h.cur, &h.start] {
            w.i64s(v);
        }
        for v in [
            &h.x,
            &h.p,
            &h.inc,
            &h.i_tot,
            &h.llr,
            &h.t_last,
            &h.pos_last,
            &h.llr_last,
        ] {
            w.f64s(v);
        }
        w.bools(&h.conf);
        w.i64s(&[
            self.frame,
            self.n_meas,
            self.compact_at as i64,
            i64::from(self.t.is_some()),
        ]);
        w.f64s(&[self.t.unwrap_or(0.0)]);
        w.i64s(&self.frame_offsets);
        w.f64s(&self.lo);
        w.f64s(&self.hi);
        w.bools(&self.tree_conf);
        w.i64s(&self.tree_cand);
        w.f64s(&self.tree_cand_llr);
        w.bools(&self.tree_alive);
        w.i64s(&self.finished.iter().map(|f| f.0).collect::<Vec<_>>());
        w.f64s(&self.finished.iter().map(|f| f.1).collect::<Vec<_>>());
        let o = &self.online;
        w.i64s(&o.frame);
        w.i64s(&o.tree);
        w.f64s(&o.position);
        w.bools(&o.coasted);
        w.f64s(&o.llr);
        let stats: Vec<i64> = self
            .stats
            .iter()
            .flat_map(|s| [s.measurements, s.live_before, s.children, s.live, s.seeds])
            .map(|v| v as i64)
            .collect();
        w.i64s(&stats);
        w.0
    }

    /// Restores the dynamic state saved by `state_bytes` (the configuration must be the same).
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<()> {
        let mut r = Reader(bytes);
        if r.bytes(MAGIC.len())? != MAGIC {
            return Err(corrupt());
        }
        let wd = self.w;
        let widths = [wd.state, wd.cov, wd.memory, wd.spatial, wd.depth].map(|v| v as i64);
        if r.i64s()? != widths {
            return Err(corrupt());
        }
        let mut t = self.clone();
        t.nodes.parent = r.i64s()?;
        t.nodes.frame = r.i64s()?;
        t.nodes.meas = r.i64s()?;
        t.nodes.state = r.f64s()?;
        t.nodes.index = r.f64s()?;
        t.nodes.llr = r.f64s()?;
        let mut h = Hypotheses {
            node: r.i64s()?,
            tree: r.i64s()?,
            n_inc: r.i64s()?,
            hits: r.i64s()?,
            miss: r.i64s()?,
            node_last: r.i64s()?,
            recent: r.i64s()?,
            cur: r.i64s()?,
            start: r.i64s()?,
            ..Default::default()
        };
        h.x = r.f64s()?;
        h.p = r.f64s()?;
        h.inc = r.f64s()?;
        h.i_tot = r.f64s()?;
        h.llr = r.f64s()?;
        h.t_last = r.f64s()?;
        h.pos_last = r.f64s()?;
        h.llr_last = r.f64s()?;
        h.conf = r.bools()?;
        t.h = h;
        let scalars = r.i64s()?;
        let time = r.f64s()?;
        if scalars.len() != 4 || time.len() != 1 {
            return Err(corrupt());
        }
        t.frame = scalars[0];
        t.n_meas = scalars[1];
        t.compact_at = scalars[2] as usize;
        t.t = (scalars[3] != 0).then_some(time[0]);
        t.frame_offsets = r.i64s()?;
        t.lo = r.f64s()?;
        t.hi = r.f64s()?;
        t.tree_conf = r.bools()?;
        t.tree_cand = r.i64s()?;
        t.tree_cand_llr = r.f64s()?;
        t.tree_alive = r.bools()?;
        let leaves = r.i64s()?;
        let scores = r.f64s()?;
        t.finished = leaves.into_iter().zip(scores).collect();
        t.online = OnlineAnswer {
            frame: r.i64s()?,
            tree: r.i64s()?,
            position: r.f64s()?,
            coasted: r.bools()?,
            llr: r.f64s()?,
        };
        t.stats = r
            .i64s()?
            .chunks_exact(5)
            .map(|c| FrameStats {
                measurements: c[0] as usize,
                live_before: c[1] as usize,
                children: c[2] as usize,
                live: c[3] as usize,
                seeds: c[4] as usize,
            })
            .collect();
        if !r.0.is_empty() || !t.is_consistent() {
            return Err(corrupt());
        }
        *self = t;
        Ok(())
    }

    /// Sizes and ids agree with each other (guards a loaded state against out-of-range ids).
    fn is_consistent(&self) -> bool {
        let (w, n, nodes) = (self.w, self.h.len(), self.nodes.len() as i64);
        let h = &self.h;
        let node_ok = |id: &i64| *id >= -1 && *id < nodes;
        let trees = self.tree_conf.len();
        let sizes = h.node.len() == n
            && h.tree.len() == n
            && h.x.len() == n * w.state
            && h.p.len() == n * w.cov
            && h.inc.len() == n * w.memory
            && h.pos_last.len() == n * w.spatial
            && h.recent.len() == n * w.depth
            && [&h.n_inc, &h.hits, &h.miss, &h.node_last, &h.cur, &h.start]
                .iter()
                .all(|v| v.len() == n)
            && [&h.i_tot, &h.t_last, &h.llr_last]
                .iter()
                .all(|v| v.len() == n)
            && h.conf.len() == n
            && self.nodes.state.len() == self.nodes.len() * w.state
            && [&self.nodes.frame, &self.nodes.meas]
                .iter()
                .all(|v| v.len() == self.nodes.len())
            && [&self.nodes.index, &self.nodes.llr]
                .iter()
                .all(|v| v.len() == self.nodes.len())
            && self.tree_cand.len() == trees
            && self.tree_cand_llr.len() == trees
            && self.tree_alive.len() == trees
            && self.lo.len() == self.k()
            && self.hi.len() == self.k()
            && self.online.position.len() == self.online.frame.len() * self.k();
        sizes
            && self.counters_consistent()
            && self
                .nodes
                .parent
                .iter()
                .enumerate()
                .all(|(i, p)| *p < i as i64 && node_ok(p))
            && h.node.iter().chain(&h.node_last).all(node_ok)
            && self.tree_cand.iter().all(node_ok)
            && self.finished.iter().all(|f| node_ok(&f.0))
            && h.tree.iter().all(|&t| t >= 0 && (t as usize) < trees)
    }

    /// Frame and measurement counters, ids and per-sequence counts lie in their ranges.
    fn counters_consistent(&self) -> bool {
        let (h, frame, n_meas) = (&self.h, self.frame, self.n_meas);
        let meas_ok = |g: &i64| *g >= NONE && *g < n_meas;
        let frame_ok = |f: &i64| *f >= 0 && *f <= frame;
        let offsets = &self.frame_offsets;
        frame >= 0
            && n_meas >= 0
            && offsets.len() as i64 == frame
            && self.stats.len() as i64 == frame
            && offsets.first().is_none_or(|&o| o == 0)
            && offsets
                .windows(2)
                .zip(&self.stats)
                .all(|(w, s)| w[1] == w[0] + s.measurements as i64)
            && n_meas
                == offsets
                    .last()
                    .zip(self.stats.last())
                    .map_or(0, |(&o, s)| o + s.measurements as i64)
            && self.t.is_some() == (frame > 0)
            && self.t.is_none_or(f64::is_finite)
            && self.compact_at > 0
            && h.recent.iter().chain(&h.cur).all(meas_ok)
            && self.nodes.meas.iter().all(meas_ok)
            && self.nodes.frame.iter().all(frame_ok)
            && h.start.iter().all(frame_ok)
            && self.online.frame.iter().all(frame_ok)
            && h.n_inc.iter().all(|&v| v >= 0)
            && h.hits.iter().all(|&v| v >= 0)
            && h.miss
                .iter()
                .all(|&v| v >= 0 && v <= self.cfg.max_misses as i64)
            && h.x.iter().chain(&h.p).chain(&h.inc).all(|v| v.is_finite())
            && h.llr
                .iter()
                .chain(&h.t_last)
                .chain(&h.pos_last)
                .all(|v| v.is_finite())
            && h.t_last.iter().all(|&v| self.t.is_some_and(|t| v <= t))
    }
}
