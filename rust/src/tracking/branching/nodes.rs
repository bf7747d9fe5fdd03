//! The node arena of the track trees: one node per (sequence, frame), linked to its parent, so
//! sequences that share a past share its nodes. The tracker keeps two: the live arena (the
//! live trees, compacted now and then) and the archive of finished tracks (each chain copied
//! there whole when its tree ends, so compacting the live arena never rescans the answer).

/// Struct-of-arrays node store (ids are indices; −1 = none).
#[derive(Debug, Clone, Default)]
pub struct Nodes {
    pub n_state: usize,
    pub parent: Vec<i64>,
    pub frame: Vec<i64>,
    /// Global measurement id, or −1 for a missed (coasted) frame.
    pub meas: Vec<i64>,
    /// Filtered state (all parameters, n_state per node).
    pub state: Vec<f64>,
    /// Sliding index I (sum of the last N increments, SPEC §3.2).
    pub index: Vec<f64>,
    /// Score (log-likelihood ratio against clutter).
    pub llr: Vec<f64>,
    /// Creation number over the whole run (node ids change with compaction and archiving;
    /// the order of creation is the final answer's tie-break).
    pub serial: Vec<i64>,
    /// The next creation number.
    pub next_serial: i64,
}

impl Nodes {
    /// An empty store for states of `n_state` values.
    pub fn new(n_state: usize) -> Self {
        Nodes {
            n_state,
            ..Default::default()
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// True when there are no nodes.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// Appends one node and returns its id.
    pub fn add(
        &mut self,
        parent: i64,
        frame: i64,
        meas: i64,
        state: &[f64],
        index: f64,
        llr: f64,
    ) -> i64 {
        let id = self.len() as i64;
        self.parent.push(parent);
        self.frame.push(frame);
        self.meas.push(meas);
        self.state.extend_from_slice(state);
        self.index.push(index);
        self.llr.push(llr);
        self.serial.push(self.next_serial);
        self.next_serial += 1;
        id
    }

    /// Copies the sequence ending at `leaf` of `from` here, oldest node first and contiguous;
    /// returns its leaf's id here.
    pub fn append_chain(&mut self, from: &Nodes, leaf: i64) -> i64 {
        let ns = self.n_state;
        let mut parent = -1;
        for old in from.chain(leaf) {
            let o = old as usize;
            self.parent.push(parent);
            self.frame.push(from.frame[o]);
            self.meas.push(from.meas[o]);
            self.state
                .extend_from_slice(&from.state[o * ns..(o + 1) * ns]);
            self.index.push(from.index[o]);
            self.llr.push(from.llr[o]);
            self.serial.push(from.serial[o]);
            parent = self.len() as i64 - 1;
        }
        parent
    }

    /// Node ids of the sequence ending at `leaf`, oldest first.
    pub fn chain(&self, mut leaf: i64) -> Vec<i64> {
        let mut out = Vec::new();
        while leaf >= 0 {
            out.push(leaf);
            leaf = self.parent[leaf as usize];
        }
        out.reverse();
        out
    }

    /// Keeps the nodes reachable from `roots` (relative order kept); returns the old → new id
    /// map (−1 = dropped).
    pub fn compact(&mut self, roots: impl IntoIterator<Item = i64>) -> Vec<i64> {
        let n = self.len();
        let mut keep = vec![false; n];
        for root in roots {
            let mut id = root;
            while id >= 0 && !keep[id as usize] {
                keep[id as usize] = true;
                id = self.parent[id as usize];
            }
        }
        let mut remap = vec![-1i64; n];
        let mut next = 0i64;
        for (old, &k) in keep.iter().enumerate() {
            if k {
                remap[old] = next;
                next += 1;
            }
        }
        let ns = self.n_state;
        let mut w = 0;
        for (old, _) in keep.iter().enumerate().take(n).filter(|(_, &k)| k) {
            let p = self.parent[old];
            self.parent[w] = if p >= 0 { remap[p as usize] } else { -1 };
            self.frame[w] = self.frame[old];
            self.meas[w] = self.meas[old];
            self.index[w] = self.index[old];
            self.llr[w] = self.llr[old];
            self.serial[w] = self.serial[old];
            self.state.copy_within(old * ns..(old + 1) * ns, w * ns);
            w += 1;
        }
        self.parent.truncate(w);
        self.frame.truncate(w);
        self.meas.truncate(w);
        self.index.truncate(w);
        self.llr.truncate(w);
        self.serial.truncate(w);
        self.state.truncate(w * ns);
        remap
    }
}

/// Maps an id through `remap` (−1 stays −1).
pub(crate) fn remapped(remap: &[i64], id: i64) -> i64 {
    if id >= 0 {
        remap[id as usize]
    } else {
        -1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_and_compaction() {
        let mut nodes = Nodes::new(1);
        let a = nodes.add(-1, 0, 5, &[1.0], 0.0, 0.0);
        let b = nodes.add(a, 1, -1, &[2.0], 0.0, 1.0);
        let _dead = nodes.add(a, 1, 6, &[9.0], 0.0, 1.0);
        let c = nodes.add(b, 2, 7, &[3.0], 0.5, 2.0);
        assert_eq!(nodes.chain(c), vec![a, b, c]);
        let remap = nodes.compact([c]);
        assert_eq!(remap, vec![0, 1, -1, 2]);
        assert_eq!(nodes.chain(2), vec![0, 1, 2]);
        assert_eq!(nodes.state, vec![1.0, 2.0, 3.0]);
        assert_eq!(nodes.meas, vec![5, -1, 7]);
        assert_eq!(nodes.serial, vec![0, 1, 3]);
        let mut archive = Nodes::new(1);
        archive.add(-1, 0, 9, &[0.0], 0.0, 0.0);
        let leaf = archive.append_chain(&nodes, 2);
        assert_eq!(archive.chain(leaf), vec![1, 2, 3]);
        assert_eq!(archive.state, vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(archive.serial, vec![0, 0, 1, 3]);
    }
}
