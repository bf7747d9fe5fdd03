//! The live sequences ("hypotheses"), one row per sequence, struct of arrays.

/// Row widths of the strided fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Widths {
    /// Σ_q d_q: the flattened state of all parameters.
    pub state: usize,
    /// Σ_q d_q²: the flattened per-parameter covariances.
    pub cov: usize,
    /// N: the increments kept by the sliding index.
    pub memory: usize,
    /// s: spatial parameters.
    pub spatial: usize,
    /// D: last measured entries that identify a sequence's future.
    pub depth: usize,
}

/// "No entry yet" in `recent`.
pub const NONE: i64 = -2;
/// A missed (coasted) frame.
pub const MISS: i64 = -1;

/// Live sequences.
#[derive(Debug, Clone, Default)]
pub struct Hypotheses {
    /// Leaf node (the parent node while children are being formed).
    pub node: Vec<i64>,
    pub tree: Vec<i64>,
    pub x: Vec<f64>,
    pub p: Vec<f64>,
    /// Last N increments, oldest first, zero padded on the left.
    pub inc: Vec<f64>,
    pub n_inc: Vec<i64>,
    pub i_tot: Vec<f64>,
    pub llr: Vec<f64>,
    pub hits: Vec<i64>,
    /// Current run of misses.
    pub miss: Vec<i64>,
    pub t_last: Vec<f64>,
    pub pos_last: Vec<f64>,
    pub llr_last: Vec<f64>,
    pub node_last: Vec<i64>,
    /// Global ids of the last D measured frames (NONE = none yet).
    pub recent: Vec<i64>,
    /// Entry of the newest frame: measurement id or MISS.
    pub cur: Vec<i64>,
    pub conf: Vec<bool>,
    /// Frame of the first measurement.
    pub start: Vec<i64>,
}

impl Hypotheses {
    /// Number of sequences.
    pub fn len(&self) -> usize {
        self.llr.len()
    }

    /// True when there is none.
    pub fn is_empty(&self) -> bool {
        self.llr.is_empty()
    }

    /// Empty, with room for `n` rows.
    pub fn with_capacity(n: usize, w: Widths) -> Hypotheses {
        Hypotheses {
            node: Vec::with_capacity(n),
            tree: Vec::with_capacity(n),
            x: Vec::with_capacity(n * w.state),
            p: Vec::with_capacity(n * w.cov),
            inc: Vec::with_capacity(n * w.memory),
            n_inc: Vec::with_capacity(n),
            i_tot: Vec::with_capacity(n),
            llr: Vec::with_capacity(n),
            hits: Vec::with_capacity(n),
            miss: Vec::with_capacity(n),
            t_last: Vec::with_capacity(n),
            pos_last: Vec::with_capacity(n * w.spatial),
            llr_last: Vec::with_capacity(n),
            node_last: Vec::with_capacity(n),
            recent: Vec::with_capacity(n * w.depth),
            cur: Vec::with_capacity(n),
            conf: Vec::with_capacity(n),
            start: Vec::with_capacity(n),
        }
    }

    /// Appends a copy of row `i` of `other`.
    pub fn push_row(&mut self, other: &Hypotheses, i: usize, w: Widths) {
        self.node.push(other.node[i]);
        self.tree.push(other.tree[i]);
        self.x
            .extend_from_slice(&other.x[i * w.state..(i + 1) * w.state]);
        self.p
            .extend_from_slice(&other.p[i * w.cov..(i + 1) * w.cov]);
        self.inc
            .extend_from_slice(&other.inc[i * w.memory..(i + 1) * w.memory]);
        self.n_inc.push(other.n_inc[i]);
        self.i_tot.push(other.i_tot[i]);
        self.llr.push(other.llr[i]);
        self.hits.push(other.hits[i]);
        self.miss.push(other.miss[i]);
        self.t_last.push(other.t_last[i]);
        self.pos_last
            .extend_from_slice(&other.pos_last[i * w.spatial..(i + 1) * w.spatial]);
        self.llr_last.push(other.llr_last[i]);
        self.node_last.push(other.node_last[i]);
        self.recent
            .extend_from_slice(&other.recent[i * w.depth..(i + 1) * w.depth]);
        self.cur.push(other.cur[i]);
        self.conf.push(other.conf[i]);
        self.start.push(other.start[i]);
    }

    /// The rows `idx`, in that order.
    pub fn take(&self, idx: &[usize], w: Widths) -> Hypotheses {
        let mut out = Hypotheses::with_capacity(idx.len(), w);
        for &i in idx {
            out.push_row(self, i, w);
        }
        out
    }

    /// Row `i` of `recent`.
    pub fn recent_row(&self, i: usize, w: Widths) -> &[i64] {
        &self.recent[i * w.depth..(i + 1) * w.depth]
    }
}
