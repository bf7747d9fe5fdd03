//! Gating of one frame: the measurements each live sequence branches on (SPEC §3.2, §3.3
//! step 2), at most `max_children` per sequence and variant, the nearest ones.
//!
//! The cap is not in [K93]: without it a gate that holds thousands of measurements (a wide
//! measurement std, a start point's speed gate in dense clutter) makes one child per
//! (sequence, measurement) pair before any pruning rule runs, gigabytes per frame. Rule 3
//! keeps at most `max_per_tree` + 2 children per tree anyway, so a cap of a few times
//! `max_per_tree` drops only children that would have been pruned.

use std::cmp::Ordering;

/// A measurement a sequence may branch on: its rank key (the increment δ, or for a start
/// point the squared distance to the last position), its index j in the frame and δ (NaN for
/// a start point, which adds no increment).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    pub key: f64,
    pub j: usize,
    pub inc: f64,
}

/// Calls `visit(i, found)` for every centre i with the measurements j (increasing) whose
/// first s coordinates lie within radius_i of centre_i, each with its squared distance.
pub(crate) fn for_each_ball(
    z: &[f64],
    k: usize,
    s: usize,
    centre: &[f64],
    radius: &[f64],
    mut visit: impl FnMut(usize, &[(usize, f64)]),
) {
    let m = z.len() / k;
    let mut by_x: Vec<usize> = (0..m).collect();
    by_x.sort_by(|&a, &b| z[a * k].total_cmp(&z[b * k]));
    let xs: Vec<f64> = by_x.iter().map(|&j| z[j * k]).collect();
    let mut found = Vec::new();
    for (i, &r) in radius.iter().enumerate() {
        let c = &centre[i * s..(i + 1) * s];
        let first = xs.partition_point(|&x| x < c[0] - r);
        let last = xs.partition_point(|&x| x <= c[0] + r).max(first);
        found.clear();
        for &j in &by_x[first..last] {
            let d2: f64 = (0..s).map(|q| (z[j * k + q] - c[q]).powi(2)).sum();
            if d2 <= r * r {
                found.push((j, d2));
            }
        }
        found.sort_unstable_by_key(|&(j, _)| j);
        visit(i, &found);
    }
}

fn nearer(a: &Candidate, b: &Candidate) -> Ordering {
    a.key.total_cmp(&b.key).then(a.j.cmp(&b.j))
}

/// Keeps the `cap` candidates of smallest key (ties: the smaller j), in increasing j;
/// `None` keeps them all.
pub(crate) fn keep_nearest(cand: &mut Vec<Candidate>, cap: Option<usize>) {
    let Some(cap) = cap else { return };
    if cand.len() <= cap {
        return;
    }
    cand.select_nth_unstable_by(cap - 1, nearer);
    cand.truncate(cap);
    cand.sort_unstable_by_key(|c| c.j);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cands(keys: &[f64]) -> Vec<Candidate> {
        keys.iter()
            .enumerate()
            .map(|(j, &key)| Candidate { key, j, inc: key })
            .collect()
    }

    #[test]
    fn keeps_the_nearest_in_measurement_order() {
        let mut c = cands(&[5.0, 1.0, 4.0, 1.0, 0.5, 9.0]);
        keep_nearest(&mut c, Some(3));
        let js: Vec<usize> = c.iter().map(|c| c.j).collect();
        assert_eq!(js, vec![1, 3, 4]);
        // a tie at the cut goes to the smaller j
        let mut c = cands(&[2.0, 1.0, 2.0, 2.0]);
        keep_nearest(&mut c, Some(2));
        assert_eq!(c.iter().map(|c| c.j).collect::<Vec<_>>(), vec![0, 1]);
    }

    #[test]
    fn no_cap_or_few_candidates_keep_everything() {
        let mut c = cands(&[3.0, 2.0, 1.0]);
        keep_nearest(&mut c, None);
        assert_eq!(c.len(), 3);
        keep_nearest(&mut c, Some(3));
        assert_eq!(c.iter().map(|c| c.j).collect::<Vec<_>>(), vec![0, 1, 2]);
    }

    #[test]
    fn balls_match_brute_force() {
        let z: Vec<f64> = (0..40).map(|v| ((v * 37) % 23) as f64 * 0.5).collect();
        let (k, s) = (2, 2);
        let centre = [3.0, 4.0, 9.0, 1.0, -50.0, 0.0];
        let radius = [2.5, 4.0, 1.0];
        let mut seen = Vec::new();
        for_each_ball(&z, k, s, &centre, &radius, |i, found| {
            seen.push((i, found.to_vec()))
        });
        assert_eq!(seen.len(), 3);
        for (i, found) in seen {
            let expected: Vec<(usize, f64)> = (0..z.len() / k)
                .filter_map(|j| {
                    let d2 = (z[j * k] - centre[i * s]).powi(2)
                        + (z[j * k + 1] - centre[i * s + 1]).powi(2);
                    (d2 <= radius[i] * radius[i]).then_some((j, d2))
                })
                .collect();
            assert_eq!(found, expected);
        }
    }
}
