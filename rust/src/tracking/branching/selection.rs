//! The final answer (SPEC §3.3 step 3): candidates taken greedily, never two sharing a
//! measurement (with the `max_shared` relaxation of the default "llr" ranking).

use super::config::Selection;
use super::nodes::Nodes;
use super::tracker::BranchingTracker;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::cmp::{Ordering, Reverse};
use std::collections::{BinaryHeap, HashSet};

/// One chosen sequence: its node chain (oldest first, in the archive or the live arena) and,
/// per node, whether its measurement is kept (false: given to a better sequence, reported as
/// coasted).
#[derive(Debug, Clone, PartialEq)]
pub struct ChosenTrack {
    pub archived: bool,
    pub chain: Vec<i64>,
    pub kept: Vec<bool>,
}

/// A queue entry, ordered like the reference's tuple (key, −hits, tick).
struct Entry {
    key: f64,
    neg_hits: i64,
    tick: u64,
    archived: bool,
    chain: Vec<i64>,
}

impl Entry {
    fn rank(&self, other: &Self) -> Ordering {
        self.key
            .partial_cmp(&other.key)
            .unwrap_or(Ordering::Equal)
            .then(self.neg_hits.cmp(&other.neg_hits))
            .then(self.tick.cmp(&other.tick))
    }
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.rank(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        self.rank(other)
    }
}

impl BranchingTracker {
    /// (archived, leaf node, score) of every candidate of the final answer.
    fn candidates(&self) -> Vec<(bool, i64, f64)> {
        let mut out: Vec<(bool, i64, f64)> = self
            .finished
            .iter()
            .map(|&(leaf, llr)| (true, leaf, llr))
            .collect();
        for i in 0..self.h.len() {
            if self.h.conf[i] {
                out.push((false, self.h.node[i], self.h.llr[i]));
            }
        }
        for tree in self.trees.values() {
            if tree.confirmed && tree.candidate >= 0 {
                out.push((false, tree.candidate, tree.candidate_llr));
            }
        }
        out
    }

    /// The arena of a candidate's nodes.
    fn arena(&self, archived: bool) -> &Nodes {
        if archived {
            &self.archive
        } else {
            &self.nodes
        }
    }

    /// True when the final answer may take the live sequence ending at `leaf` (enough
    /// measured frames and score).
    pub(crate) fn selectable(&self, leaf: i64, llr: f64) -> bool {
        llr >= self.cfg.final_llr && hits(&self.nodes, &self.nodes.chain(leaf)) >= self.cfg.min_hits
    }

    /// The queue key of a candidate (smaller = taken earlier).
    fn selection_key(&self, index: f64, llr: f64, hits: usize) -> f64 {
        let cfg = &self.cfg;
        if cfg.selection == Selection::Llr {
            return -llr;
        }
        let n_inc = (hits as i64 - cfg.nu_max() as i64 - 1).clamp(1, cfg.memory as i64);
        let dof = (self.k() as i64 * n_inc) as f64;
        match cfg.selection {
            Selection::IndexPerDof => index / dof,
            _ => {
                let cdf = ChiSquared::new(dof).map_or(0.0, |d| d.cdf(index));
                -(1.0 - cdf)
            }
        }
    }

    /// The final greedy choice; chosen sequences ordered by (first frame, first node's
    /// creation).
    pub fn select(&self) -> Vec<ChosenTrack> {
        let cfg = &self.cfg;
        let mut tick = 0u64;
        let mut heap = BinaryHeap::new();
        for (archived, leaf, llr) in self.candidates() {
            let nodes = self.arena(archived);
            let chain = nodes.chain(leaf);
            let hits = hits(nodes, &chain);
            if hits < cfg.min_hits || llr < cfg.final_llr {
                continue;
            }
            let key = self.selection_key(nodes.index[leaf as usize], llr, hits);
            heap.push(Reverse(Entry {
                key,
                neg_hits: -(hits as i64),
                tick,
                archived,
                chain,
            }));
            tick += 1;
        }
        let mut used: HashSet<i64> = HashSet::new();
        let mut chosen = Vec::new();
        while let Some(Reverse(entry)) = heap.pop() {
            let nodes = self.arena(entry.archived);
            let meas: Vec<i64> = entry
                .chain
                .iter()
                .map(|&n| nodes.meas[n as usize])
                .collect();
            let shared: Vec<bool> = meas.iter().map(|m| *m >= 0 && used.contains(m)).collect();
            let n_shared = shared.iter().filter(|&&s| s).count();
            let n_hits = meas.iter().filter(|&&m| m >= 0).count();
            let llr_rule = cfg.selection == Selection::Llr;
            if n_shared == 0
                || (llr_rule && n_shared <= cfg.max_shared && n_hits - n_shared >= cfg.min_hits)
            {
                for (m, s) in meas.iter().zip(&shared) {
                    if *m >= 0 && !s {
                        used.insert(*m);
                    }
                }
                chosen.push(ChosenTrack {
                    archived: entry.archived,
                    chain: entry.chain,
                    kept: shared.iter().map(|s| !s).collect(),
                });
                continue;
            }
            if llr_rule {
                for piece in self.pieces(&entry, &meas, &shared) {
                    heap.push(Reverse(Entry { tick, ..piece }));
                    tick += 1;
                }
            }
        }
        chosen.sort_by_key(|c| {
            let (nodes, first) = (self.arena(c.archived), c.chain[0] as usize);
            (nodes.frame[first], nodes.serial[first])
        });
        chosen
    }

    /// The pieces of a chain cut at its shared measurements that are still worth a track
    /// (trailing misses cut, ≥ min_hits measurements, score gained ≥ final_llr).
    fn pieces(&self, entry: &Entry, meas: &[i64], shared: &[bool]) -> Vec<Entry> {
        let (nodes, chain) = (self.arena(entry.archived), &entry.chain);
        let mut bounds = vec![-1i64];
        bounds.extend((0..chain.len()).filter(|&i| shared[i]).map(|i| i as i64));
        bounds.push(chain.len() as i64);
        let mut out = Vec::new();
        for pair in bounds.windows(2) {
            let (lo, hi) = ((pair[0] + 1) as usize, pair[1] as usize);
            if lo >= hi {
                continue;
            }
            let mut end = hi;
            if hi < chain.len() {
                match (lo..hi).rev().find(|&i| meas[i] >= 0) {
                    Some(last) => end = last + 1,
                    None => continue,
                }
            }
            let piece = &chain[lo..end];
            let hits = (lo..end).filter(|&i| meas[i] >= 0).count();
            let base = if lo > 0 {
                nodes.llr[chain[lo - 1] as usize]
            } else {
                0.0
            };
            let gain = nodes.llr[*piece.last().unwrap() as usize] - base;
            if hits >= self.cfg.min_hits && gain >= self.cfg.final_llr {
                out.push(Entry {
                    key: -gain,
                    neg_hits: -(hits as i64),
                    tick: 0,
                    archived: entry.archived,
                    chain: piece.to_vec(),
                });
            }
        }
        out
    }
}

/// Measured frames of a chain.
fn hits(nodes: &Nodes, chain: &[i64]) -> usize {
    chain
        .iter()
        .filter(|&&n| nodes.meas[n as usize] >= 0)
        .count()
}

/// The chosen sequences frame by frame, coasted frames included (`tracks()`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrackTable {
    pub frame: Vec<i64>,
    pub particle: Vec<i64>,
    /// Filtered state per row (all parameters and their derivatives).
    pub state: Vec<f64>,
    /// Global measurement id, −1 when coasted.
    pub detection: Vec<i64>,
    pub index: Vec<f64>,
    pub score: Vec<f64>,
}

impl BranchingTracker {
    /// The final answer as a table: particle p = p-th chosen sequence in (first frame, first
    /// node) order.
    pub fn track_table(&self) -> TrackTable {
        let mut t = TrackTable::default();
        let ns = self.nodes.n_state;
        for (pid, track) in self.select().into_iter().enumerate() {
            let nodes = self.arena(track.archived);
            for (&node, &kept) in track.chain.iter().zip(&track.kept) {
                let n = node as usize;
                t.frame.push(nodes.frame[n]);
                t.particle.push(pid as i64);
                t.state
                    .extend_from_slice(&nodes.state[n * ns..(n + 1) * ns]);
                t.detection.push(if kept { nodes.meas[n] } else { -1 });
                t.index.push(nodes.index[n]);
                t.score.push(nodes.llr[n]);
            }
        }
        t
    }
}
