//! Union-find over the runs of a frame (a parent always precedes its child).

/// Root of `i`, halving the path on the way.
pub(super) fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Joins the sets of `a` and `b`; the smaller root (the earlier run) becomes the root.
pub(super) fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb);
    }
}

/// Points every run straight at its root (parents precede children, so one forward pass).
pub(super) fn flatten(parent: &mut [usize]) {
    for i in 0..parent.len() {
        parent[i] = parent[parent[i]];
    }
}
