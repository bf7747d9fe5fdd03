//! The quasi-optimal assignment of segments to sequences (SPEC §3.4 steps 5–6): every variant
//! (sequence, segment) under its threshold is formed; the best (smallest index I_ρ(μ)) is
//! taken, the variants sharing its sequence or its segment are deleted, and so on.

/// One admissible variant: a sequence (by its position in the frame's list), a segment, the
/// index I_ρ(μ) it would give.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variant {
    pub sequence: usize,
    pub segment: usize,
    pub index: f64,
}

/// The positions in `variants` of the chosen ones, best first. Ties of the index go to the
/// lower sequence, then the lower segment, so the choice does not depend on the order of
/// `variants`. Every sequence must be < `n_sequences`, every segment < `n_segments`.
pub fn assign(variants: &[Variant], n_sequences: usize, n_segments: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..variants.len()).collect();
    order.sort_by(|&a, &b| {
        let (a, b) = (&variants[a], &variants[b]);
        a.index
            .total_cmp(&b.index)
            .then(a.sequence.cmp(&b.sequence))
            .then(a.segment.cmp(&b.segment))
    });
    let mut sequence_used = vec![false; n_sequences];
    let mut segment_used = vec![false; n_segments];
    let mut chosen = Vec::new();
    for k in order {
        let v = &variants[k];
        if !sequence_used[v.sequence] && !segment_used[v.segment] {
            sequence_used[v.sequence] = true;
            segment_used[v.segment] = true;
            chosen.push(k);
        }
    }
    chosen
}
