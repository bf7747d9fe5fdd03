//! The tracker's dynamic state as bytes (the pickled form; the configuration travels
//! separately). Little-endian, length-prefixed arrays, a magic tag and the state widths, so a
//! byte string from another configuration or a truncated one is an error, not a panic; a
//! loaded state is checked whole (every count against the arrays it indexes, every id in its
//! range, every float finite) before it replaces the tracker's, so a corrupt one is an error
//! at load time, never a panic or NaN tracks later.
//!
//! Version 2 stores the live track trees only (id, confirmed, candidate), the finished
//! tracks' chains in their own arena and every node's creation number; version 1 (every tree
//! ever made with an alive flag, the finished chains in the live arena, five statistics per
//! frame) still loads.

use super::config::MAX_TIME;
use super::hypotheses::{Hypotheses, MISS, NONE};
use super::nodes::Nodes;
use super::tracker::{BranchingTracker, FrameStats, OnlineAnswer, Tree};
use crate::error::{FieldError, Result};

const MAGIC: &[u8; 8] = b"KFBRT002";
const MAGIC_V1: &[u8; 8] = b"KFBRT001";

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
    fn nodes(&mut self, n: &Nodes) {
        for v in [&n.parent, &n.frame, &n.meas] {
            self.i64s(v);
        }
        for v in [&n.state, &n.index, &n.llr] {
            self.f64s(v);
        }
        self.i64s(&n.serial);
        self.i64s(&[n.next_serial]);
    }
}

struct Reader<'a>(&'a [u8]);

fn corrupt() -> FieldError {
    FieldError::InvalidParameter(
        "the tracker state is truncated or was saved by another version/configuration".into(),
    )
}

fn inconsistent(what: &str) -> FieldError {
    FieldError::InvalidParameter(format!("the tracker state is corrupt: {what}"))
}

/// `Err(inconsistent(what))` unless `ok`.
fn check(ok: bool, what: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(inconsistent(what))
    }
}

/// Parents come before their children (a chain always ends, at a root).
fn check_parents(nodes: &Nodes) -> Result<()> {
    check(
        nodes
            .parent
            .iter()
            .enumerate()
            .all(|(i, &p)| p >= -1 && p < i as i64),
        "node parents",
    )
}

fn all_finite<'a>(values: impl IntoIterator<Item = &'a f64>) -> bool {
    values.into_iter().all(|v| v.is_finite())
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
    /// An arena of version 1: no creation numbers (its ids are in creation order).
    fn nodes_v1(&mut self, n_state: usize) -> Result<Nodes> {
        let mut n = Nodes::new(n_state);
        n.parent = self.i64s()?;
        n.frame = self.i64s()?;
        n.meas = self.i64s()?;
        n.state = self.f64s()?;
        n.index = self.f64s()?;
        n.llr = self.f64s()?;
        n.serial = (0..n.parent.len() as i64).collect();
        n.next_serial = n.parent.len() as i64;
        Ok(n)
    }
    fn nodes(&mut self, n_state: usize) -> Result<Nodes> {
        let mut n = self.nodes_v1(n_state)?;
        n.serial = self.i64s()?;
        let next = self.i64s()?;
        check(next.len() == 1, "node count")?;
        n.next_serial = next[0];
        Ok(n)
    }
}

impl BranchingTracker {
    /// The dynamic state as bytes.
    pub fn state_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.0.extend_from_slice(MAGIC);
        let wd = self.w;
        w.i64s(&[wd.state, wd.cov, wd.memory, wd.spatial, wd.depth].map(|v| v as i64));
        w.nodes(&self.nodes);
        w.nodes(&self.archive);
        let h = &self.h;
        for v in [
            &h.node,
            &h.tree,
            &h.n_inc,
            &h.hits,
            &h.miss,
            &h.node_last,
            &h.recent,
            &h.cur,
            &h.start,
        ] {
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
        w.i64s(&[self.n_trees]);
        w.i64s(&self.trees.keys().copied().collect::<Vec<_>>());
        w.bools(&self.trees.values().map(|t| t.confirmed).collect::<Vec<_>>());
        w.i64s(&self.trees.values().map(|t| t.candidate).collect::<Vec<_>>());
        w.f64s(
            &self
                .trees
                .values()
                .map(|t| t.candidate_llr)
                .collect::<Vec<_>>(),
        );
        w.i64s(&self.finished.iter().map(|f| f.0).collect::<Vec<_>>());
        w.f64s(&self.finished.iter().map(|f| f.1).collect::<Vec<_>>());
        let o = &self.online;
        w.i64s(&o.frame);
        w.i64s(&o.tree);
        w.f64s(&o.position);
        w.bools(&o.coasted);
        w.f64s(&o.llr);
        let stats: Vec<i64> = self.stats.iter().flat_map(FrameStats::counters).collect();
        w.i64s(&stats);
        w.0
    }

    /// Restores the dynamic state saved by `state_bytes` (the configuration must be the same).
    /// Nothing changes unless the whole state loads and passes every check.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<()> {
        let mut r = Reader(bytes);
        let magic = r.bytes(MAGIC.len())?;
        let v1 = magic == MAGIC_V1;
        if magic != MAGIC && !v1 {
            return Err(corrupt());
        }
        let wd = self.w;
        let widths = [wd.state, wd.cov, wd.memory, wd.spatial, wd.depth].map(|v| v as i64);
        if r.i64s()? != widths {
            return Err(corrupt());
        }
        let mut t = self.clone();
        if v1 {
            t.nodes = r.nodes_v1(wd.state)?;
            t.archive = Nodes::new(wd.state);
        } else {
            t.nodes = r.nodes(wd.state)?;
            t.archive = r.nodes(wd.state)?;
        }
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
        check(scalars[2] > 0, "compaction threshold")?;
        t.compact_at = scalars[2] as usize;
        t.t = (scalars[3] != 0).then_some(time[0]);
        t.frame_offsets = r.i64s()?;
        t.lo = r.f64s()?;
        t.hi = r.f64s()?;
        if v1 {
            t.read_trees_v1(&mut r)?;
        } else {
            t.read_trees(&mut r)?;
        }
        let leaves = r.i64s()?;
        let scores = r.f64s()?;
        check(leaves.len() == scores.len(), "finished tracks")?;
        t.finished = leaves.into_iter().zip(scores).collect();
        if v1 {
            t.archive_v1_finished()?;
        }
        t.online = OnlineAnswer {
            frame: r.i64s()?,
            tree: r.i64s()?,
            position: r.f64s()?,
            coasted: r.bools()?,
            llr: r.f64s()?,
        };
        let per_frame = if v1 { 5 } else { 6 };
        let stats = r.i64s()?;
        check(stats.iter().all(|&v| v >= 0), "frame statistics")?;
        check(stats.len() % per_frame == 0, "frame statistics")?;
        t.stats = stats
            .chunks_exact(per_frame)
            .map(|c| FrameStats {
                measurements: c[0] as usize,
                live_before: c[1] as usize,
                children: c[2] as usize,
                live: c[3] as usize,
                seeds: c[4] as usize,
                bookkeeping: c.get(5).map_or(0, |&v| v as usize),
            })
            .collect();
        if !r.0.is_empty() {
            return Err(corrupt());
        }
        t.check_state()?;
        *self = t;
        Ok(())
    }

    /// Version 2: the live trees.
    fn read_trees(&mut self, r: &mut Reader) -> Result<()> {
        let n_trees = r.i64s()?;
        check(n_trees.len() == 1, "tree count")?;
        self.n_trees = n_trees[0];
        let ids = r.i64s()?;
        let confirmed = r.bools()?;
        let candidate = r.i64s()?;
        let candidate_llr = r.f64s()?;
        let n = ids.len();
        check(
            confirmed.len() == n && candidate.len() == n && candidate_llr.len() == n,
            "tree records",
        )?;
        check(ids.windows(2).all(|w| w[0] < w[1]), "tree ids")?;
        self.trees = (0..n)
            .map(|i| {
                let tree = Tree {
                    confirmed: confirmed[i],
                    candidate: candidate[i],
                    candidate_llr: candidate_llr[i],
                };
                (ids[i], tree)
            })
            .collect();
        Ok(())
    }

    /// Version 1: every tree ever made; the live ones are kept.
    fn read_trees_v1(&mut self, r: &mut Reader) -> Result<()> {
        let confirmed = r.bools()?;
        let candidate = r.i64s()?;
        let candidate_llr = r.f64s()?;
        let alive = r.bools()?;
        let n = confirmed.len();
        check(
            candidate.len() == n && candidate_llr.len() == n && alive.len() == n,
            "tree records",
        )?;
        self.n_trees = n as i64;
        self.trees = (0..n)
            .filter(|&i| alive[i])
            .map(|i| {
                let tree = Tree {
                    confirmed: confirmed[i],
                    candidate: candidate[i],
                    candidate_llr: candidate_llr[i],
                };
                (i as i64, tree)
            })
            .collect();
        Ok(())
    }

    /// Version 1 kept the finished tracks' chains in the live arena: copied to the archive
    /// (the live arena's next compaction drops them there).
    fn archive_v1_finished(&mut self) -> Result<()> {
        let n_nodes = self.nodes.len() as i64;
        check(
            self.finished
                .iter()
                .all(|&(leaf, _)| leaf >= 0 && leaf < n_nodes),
            "finished tracks",
        )?;
        check_parents(&self.nodes)?;
        for f in &mut self.finished {
            f.0 = self.archive.append_chain(&self.nodes, f.0);
        }
        Ok(())
    }

    /// Every check of a loaded state; the first that fails names what is wrong.
    fn check_state(&self) -> Result<()> {
        self.check_sizes()?;
        self.check_clock()?;
        self.check_nodes()?;
        self.check_sequences()?;
        self.check_trees()?;
        self.check_answers()
    }

    /// Every array has the length its count implies.
    fn check_sizes(&self) -> Result<()> {
        let (w, n, h, nodes) = (self.w, self.h.len(), &self.h, &self.nodes);
        check(
            h.node.len() == n
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
                && h.conf.len() == n,
            "sizes of the live sequences",
        )?;
        for nodes in [nodes, &self.archive] {
            let m = nodes.len();
            check(
                nodes.state.len() == m * w.state
                    && [&nodes.frame, &nodes.meas, &nodes.serial]
                        .iter()
                        .all(|v| v.len() == m)
                    && [&nodes.index, &nodes.llr].iter().all(|v| v.len() == m),
                "sizes of the nodes",
            )?;
        }
        let o = &self.online;
        let rows = o.frame.len();
        check(
            o.tree.len() == rows
                && o.coasted.len() == rows
                && o.llr.len() == rows
                && o.position.len() == rows * self.k(),
            "sizes of the online answer",
        )?;
        check(
            self.lo.len() == self.k() && self.hi.len() == self.k(),
            "sizes of the bounding box",
        )
    }

    /// Frame and measurement counters, time and bounding box.
    fn check_clock(&self) -> Result<()> {
        let (frame, n_meas, offsets) = (self.frame, self.n_meas, &self.frame_offsets);
        // (2^53: far beyond any run, and the counters' sums stay exact and never overflow)
        let counter_ok = |v: i64| (0..=1i64 << 53).contains(&v);
        check(
            counter_ok(frame) && counter_ok(n_meas),
            "frame or measurement count",
        )?;
        // every tree starts from a measurement
        check((0..=n_meas).contains(&self.n_trees), "tree count")?;
        check(
            offsets.len() as i64 == frame
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
                        .map_or(0, |(&o, s)| o + s.measurements as i64),
            "frame offsets",
        )?;
        check(
            self.t.is_some() == (frame > 0) && self.t.is_none_or(|t| t.abs() <= MAX_TIME),
            "time",
        )?;
        let empty = self.lo.iter().all(|&v| v == f64::INFINITY)
            && self.hi.iter().all(|&v| v == f64::NEG_INFINITY);
        let spans = all_finite(self.lo.iter().chain(&self.hi))
            && self.lo.iter().zip(&self.hi).all(|(lo, hi)| lo <= hi);
        check(if n_meas == 0 { empty } else { spans }, "bounding box")
    }

    /// Both arenas: parents before children, ids, frames and creation numbers in range,
    /// finite values.
    fn check_nodes(&self) -> Result<()> {
        let next = self.nodes.next_serial;
        check(
            (0..=1i64 << 62).contains(&next)
                && self.nodes.serial.windows(2).all(|w| w[0] < w[1])
                && self.nodes.serial.last().is_none_or(|&s| s < next)
                && self.archive.serial.iter().all(|&s| (0..next).contains(&s)),
            "node creation numbers",
        )?;
        for nodes in [&self.nodes, &self.archive] {
            check_parents(nodes)?;
            check(
                nodes.frame.iter().all(|&f| f >= 0 && f < self.frame.max(1)),
                "node frames",
            )?;
            check(
                nodes.meas.iter().all(|&g| g >= MISS && g < self.n_meas),
                "node measurements",
            )?;
            check(
                all_finite(nodes.state.iter().chain(&nodes.llr))
                    && nodes.index.iter().all(|&v| v.is_finite() && v >= 0.0),
                "node values",
            )?;
        }
        Ok(())
    }

    /// The live sequences: ids, counters and values.
    fn check_sequences(&self) -> Result<()> {
        let (h, w, frame, n_meas) = (&self.h, self.w, self.frame, self.n_meas);
        let n_nodes = self.nodes.len() as i64;
        check(
            h.node
                .iter()
                .chain(&h.node_last)
                .all(|&id| id >= 0 && id < n_nodes),
            "sequence nodes",
        )?;
        check(
            h.recent
                .iter()
                .all(|&g| g == NONE || (g >= 0 && g < n_meas))
                && h.cur.iter().all(|&g| g >= MISS && g < n_meas),
            "sequence measurements",
        )?;
        let counts_ok = (0..h.len()).all(|i| {
            (0..frame).contains(&h.start[i])
                && (1..=frame).contains(&h.hits[i])
                && (0..=h.hits[i]).contains(&h.n_inc[i])
                && (0..=self.cfg.max_misses as i64).contains(&h.miss[i])
        });
        check(counts_ok, "sequence counters")?;
        check(
            all_finite(
                h.x.iter()
                    .chain(&h.llr)
                    .chain(&h.llr_last)
                    .chain(&h.pos_last),
            ) && h
                .inc
                .iter()
                .chain(&h.i_tot)
                .all(|&v| v.is_finite() && v >= 0.0)
                && h.t_last
                    .iter()
                    .all(|&v| v.is_finite() && self.t.is_some_and(|t| v <= t)),
            "sequence values",
        )?;
        let variances_ok = h.p.chunks_exact(w.cov.max(1)).all(|p| {
            (0..self.k()).all(|q| {
                let (d, co) = (self.dims[q], self.cov_off[q]);
                let block = &p[co..co + d * d];
                // variances ≥ 0 up to the rounding of the Kalman update
                let floor = -1e-9 * block.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                all_finite(block) && (0..d).all(|a| block[a * d + a] >= floor)
            })
        });
        check(variances_ok, "sequence covariances")
    }

    /// The live trees are exactly the trees of the live sequences.
    fn check_trees(&self) -> Result<()> {
        let n_nodes = self.nodes.len() as i64;
        check(
            self.trees.keys().all(|&id| id >= 0 && id < self.n_trees),
            "tree ids",
        )?;
        let mut live = self.h.tree.clone();
        live.sort_unstable();
        live.dedup();
        check(live.iter().eq(self.trees.keys()), "live trees")?;
        check(
            self.trees
                .values()
                .all(|t| t.candidate >= -1 && t.candidate < n_nodes && t.candidate_llr.is_finite()),
            "tree candidates",
        )
    }

    /// The finished tracks and the online answer.
    fn check_answers(&self) -> Result<()> {
        let n_nodes = self.archive.len() as i64;
        check(
            self.finished
                .iter()
                .all(|&(leaf, llr)| leaf >= 0 && leaf < n_nodes && llr.is_finite()),
            "finished tracks",
        )?;
        let o = &self.online;
        check(
            o.frame.iter().all(|&f| f >= 0 && f < self.frame)
                && o.tree.iter().all(|&tr| tr >= 0 && tr < self.n_trees)
                && all_finite(o.position.iter().chain(&o.llr)),
            "online answer",
        )
    }
}
