//! The live sequences ("hypotheses"), one row per sequence, struct of arrays.

/// Row widths of the strided fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Widths {
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
pub(crate) const NONE: i64 = -2;
/// A missed (coasted) frame.
pub(crate) const MISS: i64 = -1;

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
    pub(crate) fn with_capacity(n: usize, w: Widths) -> Hypotheses {
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
    pub(crate) fn push_row(&mut self, other: &Hypotheses, i: usize, w: Widths) {
        self.node.push(other.node[i]);
        self.tree.push(other.tree[i]);
        extend_row(&mut self.x, &other.x, i, w.state);
        extend_row(&mut self.p, &other.p, i, w.cov);
        extend_row(&mut self.inc, &other.inc, i, w.memory);
        self.n_inc.push(other.n_inc[i]);
        self.i_tot.push(other.i_tot[i]);
        self.llr.push(other.llr[i]);
        self.hits.push(other.hits[i]);
        self.miss.push(other.miss[i]);
        self.t_last.push(other.t_last[i]);
        extend_row(&mut self.pos_last, &other.pos_last, i, w.spatial);
        self.llr_last.push(other.llr_last[i]);
        self.node_last.push(other.node_last[i]);
        extend_row(&mut self.recent, &other.recent, i, w.depth);
        self.cur.push(other.cur[i]);
        self.conf.push(other.conf[i]);
        self.start.push(other.start[i]);
    }

    /// Keeps only the rows `idx` (strictly increasing), in place.
    pub(crate) fn retain_rows(&mut self, idx: &[usize], w: Widths) {
        keep_rows(&mut self.node, idx, 1);
        keep_rows(&mut self.tree, idx, 1);
        keep_rows(&mut self.x, idx, w.state);
        keep_rows(&mut self.p, idx, w.cov);
        keep_rows(&mut self.inc, idx, w.memory);
        keep_rows(&mut self.n_inc, idx, 1);
        keep_rows(&mut self.i_tot, idx, 1);
        keep_rows(&mut self.llr, idx, 1);
        keep_rows(&mut self.hits, idx, 1);
        keep_rows(&mut self.miss, idx, 1);
        keep_rows(&mut self.t_last, idx, 1);
        keep_rows(&mut self.pos_last, idx, w.spatial);
        keep_rows(&mut self.llr_last, idx, 1);
        keep_rows(&mut self.node_last, idx, 1);
        keep_rows(&mut self.recent, idx, w.depth);
        keep_rows(&mut self.cur, idx, 1);
        keep_rows(&mut self.conf, idx, 1);
        keep_rows(&mut self.start, idx, 1);
    }

    /// Row `i` of `recent`.
    pub(crate) fn recent_row(&self, i: usize, w: Widths) -> &[i64] {
        &self.recent[i * w.depth..(i + 1) * w.depth]
    }
}

/// Appends row `i` (width `width`) of `src` to `dst`; an element loop, since rows are a few
/// values long and a `memcpy` call per row costs more than the copy.
#[inline(always)]
fn extend_row<T: Copy>(dst: &mut Vec<T>, src: &[T], i: usize, width: usize) {
    dst.reserve(width);
    for &v in &src[i * width..(i + 1) * width] {
        dst.push(v);
    }
}

/// Moves rows `idx` (strictly increasing, width `width`) to the front and truncates.
fn keep_rows<T: Copy>(v: &mut Vec<T>, idx: &[usize], width: usize) {
    for (to, &from) in idx.iter().enumerate() {
        if to != from {
            for a in 0..width {
                v[to * width + a] = v[from * width + a];
            }
        }
    }
    v.truncate(idx.len() * width);
}
