//! The five pruning rules of the branching tracker (module docstring of the reference):
//! tentative time-out, merging inside a tree, the per-tree cap with protected sequences,
//! cross-tree duplicates, the global cap. Every rule maps a list of child rows (ascending) to
//! the surviving ones; the children are compacted in place once, at the end.

use super::hypotheses::{Hypotheses, Widths};
use super::tracker::{splitmix64, BranchingTracker};
use std::cmp::Ordering;
use std::collections::HashMap;

impl BranchingTracker {
    /// Applies rules 1–5 to the children of one frame.
    pub(super) fn prune(&mut self, c: Hypotheses) -> Hypotheses {
        let tr = self;
        let w = tr.w;
        let idx = time_out(tr, &c);
        let idx = merge_within_trees(&c, w, idx);
        let idx = cap_per_tree(tr, &c, idx);
        let idx = cross_tree_duplicates(tr, &c, idx);
        let idx = global_cap(tr, &c, idx);
        let mut c = c;
        if idx.len() < c.len() {
            c.retain_rows(&idx, w);
        }
        c
    }
}

/// Decreasing score, then earlier row first.
fn by_score(c: &Hypotheses, a: usize, b: usize) -> Ordering {
    c.llr[b].total_cmp(&c.llr[a]).then(a.cmp(&b))
}

/// A 64-bit hash of a row of ids (groups equal rows before the exact comparison).
fn hash_ids(ids: impl Iterator<Item = i64>) -> u64 {
    ids.fold(0x243F_6A88_85A3_08D3, |h, v| splitmix64(h ^ v as u64))
}

/// Rule 1: a sequence not confirmed `confirm_window` frames after its start, or unconfirmed
/// with a score below `delete_llr`, dies.
fn time_out(tr: &BranchingTracker, c: &Hypotheses) -> Vec<usize> {
    let window = tr.cfg.confirm_window as i64;
    let floor = tr.cfg.delete_llr.unwrap_or(f64::NEG_INFINITY);
    (0..c.len())
        .filter(|&i| c.conf[i] || (tr.frame - c.start[i] < window && c.llr[i] >= floor))
        .collect()
}

/// Rule 2: same tree, same last D measurements, same miss run → only the best survives.
fn merge_within_trees(c: &Hypotheses, w: Widths, idx: Vec<usize>) -> Vec<usize> {
    let key = |i: usize| (c.tree[i], c.recent_row(i, w), c.miss[i]);
    // Sorting plain (hash, score rank, row) tuples groups equal keys best first; only a run
    // of equal hashes holding different keys (a collision) needs the keys themselves.
    let mut order: Vec<(u64, i64, usize)> = idx
        .iter()
        .map(|&i| {
            let (tree, recent, miss) = key(i);
            let h = hash_ids([tree, miss].into_iter().chain(recent.iter().copied()));
            (h, descending(c.llr[i]), i)
        })
        .collect();
    order.sort_unstable();
    let mut keep = Vec::with_capacity(order.len());
    for run in order.chunk_by(|a, b| a.0 == b.0) {
        if run.iter().all(|r| key(r.2) == key(run[0].2)) {
            keep.push(run[0].2);
            continue;
        }
        let mut rows: Vec<usize> = run.iter().map(|r| r.2).collect();
        rows.sort_unstable_by(|&a, &b| key(a).cmp(&key(b)).then_with(|| by_score(c, a, b)));
        keep.extend(rows.chunk_by(|&a, &b| key(a) == key(b)).map(|g| g[0]));
    }
    keep.sort_unstable();
    keep
}

/// An integer whose ascending order is the decreasing `total_cmp` order of the score.
fn descending(llr: f64) -> i64 {
    let bits = llr.to_bits() as i64;
    !(bits ^ (((bits >> 63) as u64) >> 1) as i64)
}

/// Rule 3: at most K per tree, plus each tree's best and best exclusive sequence.
fn cap_per_tree(tr: &mut BranchingTracker, c: &Hypotheses, idx: Vec<usize>) -> Vec<usize> {
    let (w, max_per_tree) = (tr.w, tr.cfg.max_per_tree);
    if idx.is_empty() {
        return idx;
    }
    let trees = TreeSlots::new(c, &idx);
    tr.bookkeeping += trees.len();
    let mut count = vec![0usize; trees.len()];
    for &i in &idx {
        count[trees.slot(i)] += 1;
    }
    let crowded = |i: usize| count[trees.slot(i)] > max_per_tree;
    if !idx.iter().any(|&i| crowded(i)) {
        return idx;
    }
    // Only trees with more than K sequences need the ranking (the others keep all).
    let protect = protected(c, w, &idx, &trees, &crowded, &mut tr.bookkeeping);
    let mut order: Vec<(i64, bool, i64, usize)> = idx
        .iter()
        .filter(|&&i| crowded(i))
        .map(|&i| (c.tree[i], !protect[i], descending(c.llr[i]), i))
        .collect();
    order.sort_unstable();
    let mut keep: Vec<usize> = idx.iter().copied().filter(|&i| !crowded(i)).collect();
    for tree in order.chunk_by(|a, b| a.0 == b.0) {
        keep.extend(tree.iter().take(max_per_tree).map(|r| r.3));
    }
    keep.sort_unstable();
    keep
}

/// The distinct trees of some child rows, numbered 0.. in increasing tree id: per-tree
/// tables sized by the trees present, not by the range of ids (old trees live beside new
/// ones, whose ids grow with every frame).
struct TreeSlots {
    /// Slot of each row's tree (rows outside the set: unused).
    slot: Vec<usize>,
    count: usize,
}

impl TreeSlots {
    fn new(c: &Hypotheses, rows: &[usize]) -> Self {
        let mut ids: Vec<i64> = rows.iter().map(|&i| c.tree[i]).collect();
        ids.sort_unstable();
        ids.dedup();
        let mut slot = vec![0; c.len()];
        for &i in rows {
            slot[i] = ids.binary_search(&c.tree[i]).expect("a tree of the rows");
        }
        TreeSlots {
            slot,
            count: ids.len(),
        }
    }
    fn len(&self) -> usize {
        self.count
    }
    fn slot(&self, row: usize) -> usize {
        self.slot[row]
    }
}

/// Per tree slot: the best row, −1 for none (ties: earliest row).
fn best_per_tree(c: &Hypotheses, trees: &TreeSlots, rows: impl Iterator<Item = usize>) -> Vec<i64> {
    let mut best = vec![-1i64; trees.len()];
    for i in rows {
        let b = &mut best[trees.slot(i)];
        if *b < 0 || c.llr[i] > c.llr[*b as usize] {
            *b = i as i64;
        }
    }
    best
}

/// Owner of a measurement claimed by the best sequence of two trees or more.
const CONTESTED: i64 = -1;

/// Rows (indexed by row of `c`) kept whatever their rank: per tree its best one and its best
/// *exclusive* one (sharing none of its last D measurements with the best of another tree).
/// Only rows of `crowded` trees are marked (the only ones the rank can cut).
fn protected(
    c: &Hypotheses,
    w: Widths,
    idx: &[usize],
    trees: &TreeSlots,
    crowded: &impl Fn(usize) -> bool,
    bookkeeping: &mut usize,
) -> Vec<bool> {
    let best = best_per_tree(c, trees, idx.iter().copied());
    let bests: Vec<usize> = best
        .iter()
        .filter(|&&b| b >= 0)
        .map(|&b| b as usize)
        .collect();
    // measurement id → the tree whose best sequence holds it (CONTESTED: several)
    let mut owner: HashMap<i64, i64> = HashMap::new();
    for &i in &bests {
        for &g in c.recent_row(i, w).iter().filter(|&&g| g >= 0) {
            owner
                .entry(g)
                .and_modify(|t| *t = CONTESTED)
                .or_insert(c.tree[i]);
        }
    }
    *bookkeeping += owner.len();
    let exclusive = idx.iter().copied().filter(|&i| {
        crowded(i)
            && c.recent_row(i, w)
                .iter()
                .all(|g| owner.get(g).is_none_or(|&t| t == c.tree[i]))
    });
    let best_exclusive = best_per_tree(c, trees, exclusive);
    let mut is_protected = vec![false; c.len()];
    for &b in best.iter().chain(&best_exclusive).filter(|&&b| b >= 0) {
        is_protected[b as usize] = true;
    }
    is_protected
}

/// Rule 4: of two trees' sequences with the same last D entries, the younger one dies when it
/// has at most ν_max+1 measurements the older one lacks.
fn cross_tree_duplicates(tr: &BranchingTracker, c: &Hypotheses, idx: Vec<usize>) -> Vec<usize> {
    let w = tr.w;
    // (hash of the last D entries, row) of the sequences with at least two measured entries;
    // sorted, equal rows become runs and only runs spanning two trees need the exact rule.
    let mut by_hash: Vec<(u64, usize)> = idx
        .iter()
        .copied()
        .filter(|&i| c.recent_row(i, w).iter().filter(|&&g| g >= 0).count() >= 2)
        .map(|i| (hash_ids(c.recent_row(i, w).iter().copied()), i))
        .collect();
    if by_hash.len() < 2 {
        return idx;
    }
    by_hash.sort_unstable();
    let mut dead = vec![false; c.len()];
    let mut run: Vec<usize> = Vec::new();
    let mut lo = 0;
    while lo < by_hash.len() {
        let mut hi = lo + 1;
        while hi < by_hash.len() && by_hash[hi].0 == by_hash[lo].0 {
            hi += 1;
        }
        let first_tree = c.tree[by_hash[lo].1];
        if by_hash[lo..hi]
            .iter()
            .any(|&(_, i)| c.tree[i] != first_tree)
        {
            run.clear();
            run.extend(by_hash[lo..hi].iter().map(|&(_, i)| i));
            run.sort_unstable_by(|&a, &b| {
                c.recent_row(a, w)
                    .cmp(c.recent_row(b, w))
                    .then(c.start[a].cmp(&c.start[b]))
                    .then_with(|| by_score(c, a, b))
            });
            for members in run.chunk_by(|&a, &b| c.recent_row(a, w) == c.recent_row(b, w)) {
                kill_younger_duplicates(tr, c, members, &mut dead);
            }
        }
        lo = hi;
    }
    idx.into_iter().filter(|&i| !dead[i]).collect()
}

/// One group of sequences with equal last D entries (oldest start first, then by score).
fn kill_younger_duplicates(
    tr: &BranchingTracker,
    c: &Hypotheses,
    members: &[usize],
    dead: &mut [bool],
) {
    if members.iter().all(|&i| c.tree[i] == c.tree[members[0]]) {
        return;
    }
    let mut kept: Vec<usize> = Vec::new();
    for &y in members {
        let killed = kept
            .iter()
            .any(|&o| c.tree[o] != c.tree[y] && dominated(tr, c, y, o));
        if killed {
            dead[y] = true;
        } else {
            kept.push(y);
        }
    }
}

/// True when sequence y has at most ν_max+1 measurements that sequence o lacks (both chains
/// hold one node per frame: compared frame by frame back to the start of y).
fn dominated(tr: &BranchingTracker, c: &Hypotheses, y: usize, o: usize) -> bool {
    let limit = tr.cfg.nu_max() as i64 + 1;
    let nodes = &tr.nodes;
    let mut extra = i64::from(c.cur[y] >= 0 && c.cur[y] != c.cur[o]);
    let (mut ny, mut no) = (c.node[y], c.node[o]);
    while extra <= limit && ny >= 0 && nodes.frame[ny as usize] >= c.start[y] {
        let my = nodes.meas[ny as usize];
        if my >= 0 && (no < 0 || nodes.meas[no as usize] != my) {
            extra += 1;
        }
        ny = nodes.parent[ny as usize];
        no = if no >= 0 {
            nodes.parent[no as usize]
        } else {
            -1
        };
    }
    extra <= limit
}

/// Rule 5: at most `max_hypotheses` (confirmed first, then by score); a confirmed sequence cut
/// by the cap offers its parent node as its tree's candidate, like an ended one.
fn global_cap(tr: &mut BranchingTracker, c: &Hypotheses, mut idx: Vec<usize>) -> Vec<usize> {
    let cap = tr.cfg.max_hypotheses;
    if idx.len() <= cap {
        return idx;
    }
    idx.sort_unstable_by(|&a, &b| c.conf[b].cmp(&c.conf[a]).then_with(|| by_score(c, a, b)));
    for &i in &idx[cap..] {
        if c.conf[i] {
            let parent = c.node[i];
            let llr = tr.nodes.llr[parent as usize];
            tr.offer_candidate(c.tree[i], parent, llr);
        }
    }
    idx.truncate(cap);
    idx.sort_unstable();
    idx
}
