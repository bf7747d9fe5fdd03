//! The branching tracker: per frame, predict, gate and branch every live sequence, prune,
//! start new sequences (SPEC §3.1–3.3).

use super::config::{TrackerConfig, MAX_TIME};
use super::gating::{for_each_ball, keep_nearest, Candidate};
use super::hypotheses::{Hypotheses, Widths, MISS, NONE};
use super::motion::{motion_matrices, predict, update};
use super::nodes::{remapped, Nodes};
use crate::error::{FieldError, Result};
use statrs::function::gamma::gamma;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Per-frame counters (for benchmarks and the clutter-robustness report).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameStats {
    pub measurements: usize,
    pub live_before: usize,
    pub children: usize,
    pub live: usize,
    pub seeds: usize,
    /// Records the frame's bookkeeping visited (track trees scanned, slots of the per-tree
    /// and per-measurement maps of pruning, nodes scanned by a compaction): a deterministic
    /// measure of the work besides branching, which must not grow with the frames before.
    pub bookkeeping: usize,
}

impl FrameStats {
    /// The number of counters of a frame.
    pub const COUNTERS: usize = 6;

    /// The counters in their order: measurements, live before, children, live after, new
    /// sequences, bookkeeping.
    pub fn counters(&self) -> [i64; Self::COUNTERS] {
        [
            self.measurements,
            self.live_before,
            self.children,
            self.live,
            self.seeds,
            self.bookkeeping,
        ]
        .map(|v| v as i64)
    }
}

/// The per-frame online answer (greedy over the live confirmed sequences).
#[derive(Debug, Clone, Default)]
pub struct OnlineAnswer {
    pub frame: Vec<i64>,
    pub tree: Vec<i64>,
    /// k values per row: the filtered parameters.
    pub position: Vec<f64>,
    pub coasted: Vec<bool>,
    pub llr: Vec<f64>,
}

/// The tracker's whole state (everything the pickled form holds besides the configuration).
#[derive(Debug, Clone)]
pub struct BranchingTracker {
    pub cfg: TrackerConfig,
    pub(crate) dims: Vec<usize>,
    pub(crate) state_off: Vec<usize>,
    pub(crate) cov_off: Vec<usize>,
    pub(crate) w: Widths,
    pub(crate) alpha: Vec<f64>,
    pub(crate) p0: Vec<f64>,
    /// The live arena: nodes of the live trees and their candidates.
    pub nodes: Nodes,
    /// The finished tracks' chains (`finished` points into it).
    pub archive: Nodes,
    pub h: Hypotheses,
    pub frame: i64,
    pub t: Option<f64>,
    pub n_meas: i64,
    /// Global id of the first measurement of every frame so far.
    pub frame_offsets: Vec<i64>,
    pub(crate) lo: Vec<f64>,
    pub(crate) hi: Vec<f64>,
    /// The live track trees (those holding a live sequence), by id.
    pub(crate) trees: BTreeMap<i64, Tree>,
    /// Track-tree ids handed out so far (the next tree's id).
    pub(crate) n_trees: i64,
    /// (leaf node in `archive`, score) of ended track trees' best confirmed sequences.
    pub finished: Vec<(i64, f64)>,
    pub online: OnlineAnswer,
    pub(crate) compact_at: usize,
    pub stats: Vec<FrameStats>,
    /// The current frame's `FrameStats::bookkeeping` count.
    pub(crate) bookkeeping: usize,
}

/// One live track tree: whether it has held a confirmed sequence, and its candidate for
/// the final answer (the best ended or capped confirmed sequence so far).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Tree {
    pub(crate) confirmed: bool,
    /// Leaf node of the candidate, −1 for none.
    pub(crate) candidate: i64,
    pub(crate) candidate_llr: f64,
}

impl Tree {
    pub(crate) const NEW: Tree = Tree {
        confirmed: false,
        candidate: -1,
        candidate_llr: 0.0,
    };
}

/// Predicted moments of every live sequence, per parameter, for one frame.
struct Prediction {
    x: Vec<f64>,
    p: Vec<f64>,
    s: Vec<f64>,
    /// With the manoeuvre (velocity-jump) branch: its P and S.
    p_man: Vec<f64>,
    s_man: Vec<f64>,
}

impl Prediction {
    fn is_finite(&self) -> bool {
        [&self.x, &self.p, &self.s, &self.p_man, &self.s_man]
            .iter()
            .all(|v| v.iter().all(|e| e.is_finite()))
    }
}

/// One frame's measurements and clock.
struct FrameInput<'a> {
    z: &'a [f64],
    t: f64,
    gid0: i64,
}

impl BranchingTracker {
    /// A tracker with no frame yet.
    pub fn new(cfg: TrackerConfig) -> Result<Self> {
        cfg.validate()?;
        let dims = cfg.dims();
        let k = cfg.k();
        let mut state_off = vec![0];
        let mut cov_off = vec![0];
        for &d in &dims {
            state_off.push(state_off.last().unwrap() + d);
            cov_off.push(cov_off.last().unwrap() + d * d);
        }
        let w = Widths {
            state: state_off[k],
            cov: cov_off[k],
            memory: cfg.memory,
            spatial: cfg.n_spatial,
            depth: cfg.merge_depth,
        };
        // prior of a start: the measurement, diffuse derivatives (the start is least squares)
        let mut p0 = vec![0.0; w.cov];
        for (q, &d) in dims.iter().enumerate() {
            let block = &mut p0[cov_off[q]..cov_off[q + 1]];
            block[0] = cfg.measurement_std[q] * cfg.measurement_std[q];
            for i in 1..d {
                block[i * d + i] = (10.0 * cfg.max_speed).powi(2);
            }
        }
        Ok(BranchingTracker {
            alpha: cfg.thresholds()?,
            nodes: Nodes::new(w.state),
            archive: Nodes::new(w.state),
            h: Hypotheses::default(),
            frame: 0,
            t: None,
            n_meas: 0,
            frame_offsets: Vec::new(),
            lo: vec![f64::INFINITY; k],
            hi: vec![f64::NEG_INFINITY; k],
            trees: BTreeMap::new(),
            n_trees: 0,
            finished: Vec::new(),
            online: OnlineAnswer::default(),
            compact_at: 200_000,
            stats: Vec::new(),
            bookkeeping: 0,
            dims,
            state_off,
            cov_off,
            w,
            p0,
            cfg,
        })
    }

    /// Number of parameters k.
    pub fn k(&self) -> usize {
        self.cfg.k()
    }

    /// Processes one frame: `z` holds m measurement vectors of k parameters (row-major);
    /// `time` defaults to the previous time + dt (0 for the first frame).
    pub fn update(&mut self, z: &[f64], time: Option<f64>) -> Result<()> {
        let k = self.k();
        if z.len() % k != 0 {
            return Err(FieldError::Shape(format!(
                "measurements must have {k} columns, got {} values",
                z.len()
            )));
        }
        if z.iter().any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(
                "measurements must be finite (no NaN or inf)".into(),
            ));
        }
        let t = match (time, self.t) {
            (Some(t), _) => t,
            (None, Some(prev)) => prev + self.cfg.dt,
            (None, None) => 0.0,
        };
        if !t.is_finite() {
            return Err(FieldError::NonFinite(format!(
                "time must be finite, got {t}"
            )));
        }
        if t.abs() > MAX_TIME {
            return Err(FieldError::InvalidParameter(format!(
                "time must lie within ±{MAX_TIME:e}, got {t}"
            )));
        }
        if let Some(prev) = self.t {
            if t <= prev {
                return Err(FieldError::InvalidParameter(format!(
                    "time must increase: got {t} after {prev}"
                )));
            }
        }
        let tau = self.t.map_or(0.0, |prev| t - prev);
        let prediction = self.predict_all(&self.h, tau, t);
        if !prediction.is_finite() {
            return Err(FieldError::InvalidParameter(format!(
                "the time step {tau:e} is too long for the motion model: the predicted \
                 covariances overflow float64 (rescale the time or the parameters)"
            )));
        }
        let m = z.len() / k;
        let gid0 = self.n_meas;
        self.frame_offsets.push(gid0);
        for row in z.chunks_exact(k) {
            for ((lo, hi), &v) in self.lo.iter_mut().zip(self.hi.iter_mut()).zip(row) {
                *lo = lo.min(v);
                *hi = hi.max(v);
            }
        }
        let input = FrameInput { z, t, gid0 };
        let mut stats = FrameStats {
            measurements: m,
            live_before: self.h.len(),
            ..Default::default()
        };
        self.bookkeeping = 0;
        let h = std::mem::take(&mut self.h);
        let mut h = if h.is_empty() {
            h
        } else {
            let (children, ended) = self.branch(&h, &input, &prediction);
            stats.children = children.len();
            self.terminate(&h, &ended);
            let children = self.prune(children);
            self.commit(children)
        };
        self.close_dead_trees(&h);
        let new = self.seed_candidates(&h, m, gid0);
        stats.seeds = new.len();
        self.seed(&mut h, &input, &new);
        self.h = h;
        self.online_answer();
        stats.live = self.h.len();
        self.n_meas += m as i64;
        self.t = Some(t);
        self.frame += 1;
        if self.nodes.len() > self.compact_at {
            self.compact();
        }
        stats.bookkeeping = self.bookkeeping;
        self.stats.push(stats);
        Ok(())
    }

    /// (ln λ, ln λ_s): logarithms of the clutter density in parameter space and in the
    /// spatial sub-space (sums of logarithms: the products of spans overflow for k ≥ 3 wide
    /// ones); `measured` = all measurements so far, this frame's included. With a given λ,
    /// each non-spatial extent is floored at the measurement's resolution √(2π)·σ_q (the
    /// width of its noise law, 1 / peak density): an extent seen of ~0 would otherwise make
    /// λ_s ~0 and add ~ −ln λ_s to the score of every start point.
    fn log_density(&self, measured: i64) -> (f64, f64) {
        let s = self.cfg.n_spatial;
        let k = self.k();
        let ln_span = |q: usize, floor: f64| (self.hi[q] - self.lo[q]).max(floor).ln();
        if let Some(lam) = self.cfg.clutter_density {
            let sqrt_2pi = (2.0 * std::f64::consts::PI).sqrt();
            let extra: f64 = (s..k)
                .map(|q| ln_span(q, sqrt_2pi * self.cfg.measurement_std[q]))
                .sum();
            return (lam.ln(), lam.ln() + extra);
        }
        let rate = (measured as f64 / (self.frame + 1).max(1) as f64).max(1.0);
        let spatial: f64 = (0..s).map(|q| ln_span(q, 1.0)).sum();
        let other: f64 = (s..k).map(|q| ln_span(q, 1.0)).sum();
        (rate.ln() - spatial - other, rate.ln() - spatial)
    }

    fn predict_all(&self, h: &Hypotheses, tau: f64, t: f64) -> Prediction {
        let (k, w, n) = (self.k(), self.w, h.len());
        let maneuver = self.cfg.maneuver_std.as_ref();
        let mut pr = Prediction {
            x: vec![0.0; n * w.state],
            p: vec![0.0; n * w.cov],
            s: vec![0.0; n * k],
            p_man: vec![0.0; if maneuver.is_some() { n * w.cov } else { 0 }],
            s_man: vec![0.0; if maneuver.is_some() { n * k } else { 0 }],
        };
        for q in 0..k {
            let d = self.dims[q];
            let (f, qn) = motion_matrices(
                self.cfg.order[q],
                tau,
                self.cfg.process_std[q],
                self.cfg.diffusion_std[q],
            );
            let r = self.cfg.measurement_std[q].powi(2);
            let (so, co) = (self.state_off[q], self.cov_off[q]);
            for i in 0..n {
                let xs = i * w.state + so..i * w.state + so + d;
                let cs = i * w.cov + co..i * w.cov + co + d * d;
                predict(
                    &f,
                    &qn,
                    &h.x[xs.clone()],
                    &h.p[cs.clone()],
                    &mut pr.x[xs],
                    &mut pr.p[cs.clone()],
                );
                pr.s[i * k + q] = pr.p[cs.start] + r;
                if let Some(man) = maneuver {
                    let mut g = [0.0; 2];
                    g[0] = if d > 1 { t - h.t_last[i] } else { 1.0 };
                    g[1] = 1.0;
                    let m2 = man[q] * man[q];
                    let gl = d.min(2);
                    for a in 0..d {
                        for b in 0..d {
                            let jump = if a < gl && b < gl {
                                m2 * g[a] * g[b]
                            } else {
                                0.0
                            };
                            pr.p_man[cs.start + a * d + b] = pr.p[cs.start + a * d + b] + jump;
                        }
                    }
                    pr.s_man[i * k + q] = pr.p_man[cs.start] + r;
                }
            }
        }
        pr
    }

    /// Predict, gate and branch every live sequence (SPEC §3.1, §3.2, §3.3 step 2). Returns
    /// the children (with the parent node in `node`) and the sequences that end.
    fn branch(
        &self,
        h: &Hypotheses,
        input: &FrameInput,
        pr: &Prediction,
    ) -> (Hypotheses, Vec<usize>) {
        let (k, s, w, n) = (self.k(), self.cfg.n_spatial, self.w, h.len());
        let cfg = &self.cfg;
        let (ln_lam, ln_lam_s) = self.log_density(input.gid0 + (input.z.len() / k) as i64);
        let nu_max = cfg.nu_max() as i64;
        let r_max = (0..s)
            .map(|q| cfg.measurement_std[q].powi(2))
            .fold(f64::NEG_INFINITY, f64::max);
        let man = cfg.maneuver_std.is_some();
        let mut gate = vec![0.0; n];
        let mut centre = vec![0.0; n * s];
        let mut radius = vec![0.0; n];
        let mut r_ls = vec![0.0; n];
        for i in 0..n {
            let n_new = (h.n_inc[i] + 1).min(cfg.memory as i64) as usize;
            let kept: f64 = h.inc[i * w.memory + 1..(i + 1) * w.memory].iter().sum();
            gate[i] = (self.alpha[n_new] - kept).max(0.0);
            let s_max = (0..s)
                .map(|q| {
                    let v = pr.s[i * k + q];
                    if man {
                        v.max(pr.s_man[i * k + q])
                    } else {
                        v
                    }
                })
                .fold(f64::NEG_INFINITY, f64::max);
            r_ls[i] = cfg.max_speed * (input.t - h.t_last[i]) + 3.0 * (2.0 * r_max).sqrt();
            if h.hits[i] <= nu_max {
                centre[i * s..(i + 1) * s].copy_from_slice(&h.pos_last[i * s..(i + 1) * s]);
                radius[i] = r_ls[i];
            } else {
                for q in 0..s {
                    centre[i * s + q] = pr.x[i * w.state + self.state_off[q]];
                }
                radius[i] = (gate[i] * s_max).sqrt();
            }
        }
        let variants: &[(bool, f64)] = if man {
            &[(false, 0.0), (true, cfg.maneuver_prob.ln())]
        } else {
            &[(false, 0.0)]
        };
        let s_of = |is_man: bool| if is_man { &pr.s_man } else { &pr.s };
        // (sequence i, candidate) per variant, by i then j
        let mut chosen: Vec<Vec<(usize, Candidate)>> = vec![Vec::new(); variants.len()];
        let mut cand = Vec::new();
        for_each_ball(input.z, k, s, &centre, &radius, |i, found| {
            let ls = h.hits[i] <= nu_max;
            for (&(is_man, _), out) in variants.iter().zip(chosen.iter_mut()) {
                if is_man && ls {
                    continue;
                }
                let sv = &s_of(is_man)[i * k..(i + 1) * k];
                cand.clear();
                for &(j, d2) in found {
                    if ls {
                        cand.push(Candidate {
                            key: d2,
                            j,
                            inc: f64::NAN,
                        });
                        continue;
                    }
                    let zj = &input.z[j * k..(j + 1) * k];
                    let mut inc = 0.0;
                    for q in 0..k {
                        let v = zj[q] - pr.x[i * w.state + self.state_off[q]];
                        inc += v * v / sv[q];
                    }
                    if inc <= gate[i] {
                        cand.push(Candidate { key: inc, j, inc });
                    }
                }
                keep_nearest(&mut cand, cfg.max_children);
                out.extend(cand.iter().map(|&c| (i, c)));
            }
        });
        let n_chosen: usize = chosen.iter().map(Vec::len).sum();
        let mut children = Hypotheses::with_capacity(n_chosen + n, w);
        let mut has_hit = vec![false; n];
        let ln_ball = (PI.powf(s as f64 / 2.0) / gamma(s as f64 / 2.0 + 1.0)).ln();
        let ln_pd = cfg.p_detect.ln();
        for (&(is_man, penalty), pairs) in variants.iter().zip(&chosen) {
            let p_var = if is_man { &pr.p_man } else { &pr.p };
            let s_var = s_of(is_man);
            for &(i, Candidate { j, inc, .. }) in pairs {
                let ls = h.hits[i] <= nu_max;
                let zj = &input.z[j * k..(j + 1) * k];
                let sv = &s_var[i * k..(i + 1) * k];
                has_hit[i] = true;
                children.push_row(h, i, w);
                let c = children.len() - 1;
                for q in 0..k {
                    let d = self.dims[q];
                    let xs = i * w.state + self.state_off[q];
                    let cs = i * w.cov + self.cov_off[q];
                    let v = zj[q] - pr.x[xs];
                    update(
                        &pr.x[xs..xs + d],
                        &p_var[cs..cs + d * d],
                        sv[q],
                        v,
                        &mut children.x[c * w.state + self.state_off[q]..][..d],
                        &mut children.p[c * w.cov + self.cov_off[q]..][..d * d],
                    );
                }
                let dl = if ls {
                    ln_pd - (ln_ball + s as f64 * r_ls[i].ln() + ln_lam_s)
                } else {
                    let log_s: f64 = sv.iter().map(|&v| (2.0 * PI * v).ln()).sum();
                    ln_pd - ln_lam - 0.5 * log_s - 0.5 * inc + penalty
                };
                self.finish_hit(
                    &mut children,
                    c,
                    if ls { None } else { Some(inc) },
                    dl,
                    zj,
                    input,
                    j,
                );
            }
        }
        let ln_miss = (-cfg.p_detect).ln_1p();
        let mut ended = Vec::new();
        for (i, &miss) in h.miss.iter().enumerate().take(n) {
            if miss < cfg.max_misses as i64 {
                children.push_row(h, i, w);
                let c = children.len() - 1;
                children.x[c * w.state..(c + 1) * w.state]
                    .copy_from_slice(&pr.x[i * w.state..(i + 1) * w.state]);
                children.p[c * w.cov..(c + 1) * w.cov]
                    .copy_from_slice(&pr.p[i * w.cov..(i + 1) * w.cov]);
                children.llr[c] += ln_miss;
                children.miss[c] += 1;
                children.cur[c] = MISS;
                self.confirm(&mut children, c);
            } else if !has_hit[i] {
                ended.push(i);
            }
        }
        (children, ended)
    }

    /// Bookkeeping of a child that took measurement j (increment `inc`, None for a start point).
    #[allow(clippy::too_many_arguments)]
    fn finish_hit(
        &self,
        c: &mut Hypotheses,
        row: usize,
        inc: Option<f64>,
        dl: f64,
        zj: &[f64],
        input: &FrameInput,
        j: usize,
    ) {
        let w = self.w;
        if let Some(inc) = inc {
            let window = &mut c.inc[row * w.memory..(row + 1) * w.memory];
            window.rotate_left(1);
            window[w.memory - 1] = inc;
            c.n_inc[row] += 1;
            c.i_tot[row] += inc;
        }
        c.llr[row] += dl;
        c.hits[row] += 1;
        c.miss[row] = 0;
        c.t_last[row] = input.t;
        c.pos_last[row * w.spatial..(row + 1) * w.spatial].copy_from_slice(&zj[..w.spatial]);
        c.llr_last[row] = c.llr[row];
        c.node_last[row] = -1;
        let gid = input.gid0 + j as i64;
        let recent = &mut c.recent[row * w.depth..(row + 1) * w.depth];
        recent.rotate_left(1);
        recent[w.depth - 1] = gid;
        c.cur[row] = gid;
        self.confirm(c, row);
    }

    fn confirm(&self, c: &mut Hypotheses, row: usize) {
        c.conf[row] = c.conf[row]
            || (c.hits[row] >= self.cfg.n_confirm as i64 && c.llr[row] >= self.cfg.confirm_llr);
    }

    /// Records ended confirmed sequences as their tree's candidate (best score wins).
    fn terminate(&mut self, h: &Hypotheses, ended: &[usize]) {
        let mut term: Vec<usize> = ended.iter().copied().filter(|&i| h.conf[i]).collect();
        term.sort_by(|&a, &b| h.llr_last[a].total_cmp(&h.llr_last[b]));
        for i in term {
            self.offer_candidate(h.tree[i], h.node_last[i], h.llr_last[i]);
        }
    }

    /// Makes (node, score) the tree's candidate if it beats the current one.
    pub(crate) fn offer_candidate(&mut self, tree: i64, node: i64, llr: f64) {
        let tree = self.live_tree(tree);
        if tree.candidate < 0 || llr > tree.candidate_llr {
            tree.candidate = node;
            tree.candidate_llr = llr;
        }
    }

    /// The record of a live tree (every sequence's tree is live until `close_dead_trees`).
    fn live_tree(&mut self, tree: i64) -> &mut Tree {
        self.trees
            .get_mut(&tree)
            .expect("a live sequence's track tree is live")
    }

    /// Stores the surviving children as nodes.
    fn commit(&mut self, mut c: Hypotheses) -> Hypotheses {
        let w = self.w;
        for i in 0..c.len() {
            let index: f64 = c.inc[i * w.memory..(i + 1) * w.memory].iter().sum();
            let id = self.nodes.add(
                c.node[i],
                self.frame,
                c.cur[i],
                &c.x[i * w.state..(i + 1) * w.state],
                index,
                c.llr[i],
            );
            if c.cur[i] >= 0 {
                c.node_last[i] = id;
            }
            c.node[i] = id;
            if c.conf[i] {
                self.live_tree(c.tree[i]).confirmed = true;
            }
        }
        c
    }

    /// Trees that lost every sequence: their best ended confirmed sequence is final (moved to
    /// the archive if the final answer can take it), and their record goes.
    fn close_dead_trees(&mut self, h: &Hypotheses) {
        let mut live = h.tree.clone();
        live.sort_unstable();
        live.dedup();
        self.bookkeeping += self.trees.len();
        let mut ended = Vec::new();
        self.trees.retain(|id, tree| {
            let alive = live.binary_search(id).is_ok();
            if !alive && tree.confirmed && tree.candidate >= 0 {
                ended.push((tree.candidate, tree.candidate_llr));
            }
            alive
        });
        for (leaf, llr) in ended {
            if self.selectable(leaf, llr) {
                let archived = self.archive.append_chain(&self.nodes, leaf);
                self.finished.push((archived, llr));
            }
        }
    }

    /// Measurements of this frame no confirmed sequence uses (at most `max_seeds`: those with
    /// the smallest splitmix64 hash of (seed, global id), a deterministic random subset).
    fn seed_candidates(&self, h: &Hypotheses, m: usize, gid0: i64) -> Vec<usize> {
        let mut used = vec![false; m];
        for i in 0..h.len() {
            if h.conf[i] && h.cur[i] >= gid0 {
                used[(h.cur[i] - gid0) as usize] = true;
            }
        }
        let mut new: Vec<usize> = (0..m).filter(|&j| !used[j]).collect();
        if new.len() > self.cfg.max_seeds {
            let key = |j: usize| splitmix64(self.cfg.seed ^ (gid0 + j as i64) as u64);
            new.sort_by_key(|&j| (key(j), j));
            new.truncate(self.cfg.max_seeds);
            new.sort_unstable();
        }
        new
    }

    /// Starts one sequence (and one track tree) per measurement in `new` (SPEC §3.3 step 3).
    fn seed(&mut self, h: &mut Hypotheses, input: &FrameInput, new: &[usize]) {
        let (k, w) = (self.k(), self.w);
        for &j in new {
            let zj = &input.z[j * k..(j + 1) * k];
            let tree = self.n_trees;
            self.n_trees += 1;
            self.trees.insert(tree, Tree::NEW);
            let mut x = vec![0.0; w.state];
            for q in 0..k {
                x[self.state_off[q]] = zj[q];
            }
            let gid = input.gid0 + j as i64;
            let id = self.nodes.add(-1, self.frame, gid, &x, 0.0, 0.0);
            h.node.push(id);
            h.tree.push(tree);
            h.x.extend_from_slice(&x);
            h.p.extend_from_slice(&self.p0);
            h.inc.extend(std::iter::repeat_n(0.0, w.memory));
            h.n_inc.push(0);
            h.i_tot.push(0.0);
            h.llr.push(0.0);
            h.hits.push(1);
            h.miss.push(0);
            h.t_last.push(input.t);
            h.pos_last.extend_from_slice(&zj[..w.spatial]);
            h.llr_last.push(0.0);
            h.node_last.push(id);
            h.recent.extend(std::iter::repeat_n(NONE, w.depth - 1));
            h.recent.push(gid);
            h.cur.push(gid);
            h.conf.push(false);
            h.start.push(self.frame);
        }
    }

    /// Confirmed live sequences in decreasing score, at most one per tree, none sharing one of
    /// its last D measurements with a sequence taken before.
    pub fn greedy_answer(&self) -> Vec<usize> {
        greedy(&self.h, self.w, 0..self.h.len())
    }

    fn online_answer(&mut self) {
        let (k, w) = (self.k(), self.w);
        for i in self.greedy_answer() {
            self.online.frame.push(self.frame);
            self.online.tree.push(self.h.tree[i]);
            for q in 0..k {
                self.online
                    .position
                    .push(self.h.x[i * w.state + self.state_off[q]]);
            }
            self.online.coasted.push(self.h.cur[i] < 0);
            self.online.llr.push(self.h.llr[i]);
        }
    }

    /// Drops the nodes no live sequence or live tree's candidate can reach.
    pub fn compact(&mut self) {
        let candidates = self.trees.values().filter(|t| t.candidate >= 0);
        let roots = self
            .h
            .node
            .iter()
            .chain(&self.h.node_last)
            .copied()
            .chain(candidates.map(|t| t.candidate))
            .collect::<Vec<i64>>();
        self.bookkeeping += self.nodes.len();
        let remap = self.nodes.compact(roots);
        for id in self.h.node.iter_mut().chain(self.h.node_last.iter_mut()) {
            *id = remapped(&remap, *id);
        }
        for tree in self.trees.values_mut() {
            tree.candidate = remapped(&remap, tree.candidate);
        }
        self.compact_at = 200_000.max(4 * self.nodes.len());
    }

    /// (frame, row within the frame) of a global measurement id.
    pub fn detection_frame(&self, gid: i64) -> Option<(usize, i64)> {
        if gid < 0 || gid >= self.n_meas {
            return None;
        }
        let f = self.frame_offsets.partition_point(|&o| o <= gid) - 1;
        Some((f, gid - self.frame_offsets[f]))
    }
}

/// The confirmed sequences among `rows` (ascending) in decreasing score (ties: the earlier
/// row), at most one per tree, none sharing one of its last D measurements with a sequence
/// taken before: the online answer.
pub(crate) fn greedy(h: &Hypotheses, w: Widths, rows: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut idx: Vec<usize> = rows.filter(|&i| h.conf[i]).collect();
    idx.sort_by(|&a, &b| h.llr[b].total_cmp(&h.llr[a]));
    let mut trees = std::collections::HashSet::new();
    let mut meas = std::collections::HashSet::new();
    let mut out = Vec::new();
    for i in idx {
        let recent = h.recent_row(i, w);
        if trees.contains(&h.tree[i]) || recent.iter().any(|g| *g >= 0 && meas.contains(g)) {
            continue;
        }
        trees.insert(h.tree[i]);
        meas.extend(recent.iter().copied().filter(|&g| g >= 0));
        out.push(i);
    }
    out
}

/// The splitmix64 finaliser (a portable hash for the deterministic seed subset).
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
