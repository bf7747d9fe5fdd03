//! The search-recurrent fragment tracker (SPEC §5, source [F]): per frame and target, the
//! non-linear link (correlation-extreme search of the template inside a window around the
//! Kalman prediction) and the linear link (a Kalman filter on the found positions, whose
//! prediction places the next window). Rules where the source is silent (method page
//! *Template tracker*):
//!
//! - The first frame is the one the initial position refers to: it is searched around that
//!   position without a prediction step.
//! - Window: `Gate::window` — ± gate·√S around the predicted position, S the predicted
//!   measurement covariance; it grows with S while frames are coasted.
//! - Validation gate: the in-window peak is the highest score among the positions inside the
//!   gate ellipse νᵀ S⁻¹ ν ≤ gate² (ν the position's innovation, shrunk by half a pixel per
//!   axis: `Gate::admits`); the window's corners and its refinement margin hold no
//!   measurement.
//! - Manoeuvre (held hypothesis): when the in-gate peak collapses, the gate of a second
//!   prediction is searched — the target stopped or turned at its last estimated position:
//!   that position and its covariance, the velocity (and acceleration) restarted from the
//!   prior, predicted one frame. If its in-gate peak scores at least ρ̄ (an alternative to the
//!   motion model needs a confident peak: a collapse threshold let false peaks near the last
//!   position in at SNR 0.3, on held-out runs), it is the frame's measurement and that
//!   prediction the one updated (the window reported is its window); otherwise the rules
//!   below go on with the first prediction.
//! - Collapse: the in-window peak score (NCC) below `collapse` times the reference score ρ̄,
//!   or no position to search (window off the frame, smaller than the template, no scored
//!   position in the gate).
//!   ρ̄ is the running mean of accepted scores, ρ̄ ← (1 − β)ρ̄ + β·score, β = 1/10, started at
//!   the first accepted score (the first frame's peak is accepted unless it collapses for
//!   want of a window).
//! - Re-acquisition: a collapse triggers a search of the whole frame; its peak is accepted
//!   when its score is at least `collapse`·ρ̄ and it stands out of the surface: z =
//!   (peak − median) / (1.4826 · MAD) ≥ `reacquire_z`, the median and MAD (median absolute
//!   deviation) taken over the 64 × 64-point subsample of the surface; by default
//!   `reacquire_z` = √(2 ln M) + 1 for a surface of M positions (the typical largest of M
//!   independent standard normal scores, plus one). The state restarts
//!   there (zero velocity and acceleration, the initial covariance). Otherwise the frame is
//!   coasted.
//! - Lost lock: a coasted frame keeps the prediction's mean, and the prior variances of the
//!   velocity (and acceleration), `initial_std[1..]²`, are added to the predicted ones: a
//!   collapse is taken as a possible manoeuvre the motion model did not foresee (a reversal,
//!   a turn), so the next gate widens by the prior's uncertainty of the motion, frame after
//!   frame while the collapse lasts.
//! - Template update (optional, rate α): after an accepted in-window measurement whose score
//!   is at least ρ̄ (before its own update), the template becomes (1 − α)·template + α·patch,
//!   the patch being the frame under the template at the rounded measured position.

use super::fragment::Template;
use super::frame::{Frame, Window};
use super::gate::Gate;
use super::peak::distinctness;
use super::region::Region;
use super::surface::{Correlator, Match, Method};
use crate::image::Pixel;
use crate::kalman::{self, Gaussian, LinearGaussian};
use crate::{FieldError, Result};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Weight of the newest accepted score in the reference score ρ̄.
pub const REFERENCE_WEIGHT: f64 = 0.1;

/// The motion model of each axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// (position, velocity), white-noise acceleration.
    Velocity,
    /// (position, velocity, acceleration), white-noise jerk: SPEC §5's λ.
    Acceleration,
}

impl Motion {
    /// "velocity" or "acceleration".
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "velocity" => Ok(Self::Velocity),
            "acceleration" => Ok(Self::Acceleration),
            other => Err(FieldError::InvalidParameter(format!(
                "model must be 'velocity' or 'acceleration', got {other:?}"
            ))),
        }
    }

    /// Entries of the state per axis.
    pub fn per_axis(self) -> usize {
        match self {
            Self::Velocity => 2,
            Self::Acceleration => 3,
        }
    }
}

/// The tracker's settings (see the module docs for the rules they enter).
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerConfig {
    pub motion: Motion,
    /// √q, q the power spectral density of the white noise driving the highest derivative.
    pub process_std: f64,
    /// Std of a found position (pixels).
    pub measurement_std: f64,
    pub dt: f64,
    pub gate: f64,
    /// Prior std of position, velocity (and acceleration), also used on re-acquisition.
    pub initial_std: Vec<f64>,
    pub collapse: f64,
    /// None: √(2 ln M) + 1 for a surface of M positions.
    pub reacquire_z: Option<f64>,
    pub update_template: Option<f64>,
    pub subpixel: bool,
}

fn invalid(message: String) -> FieldError {
    FieldError::InvalidParameter(message)
}

impl TrackerConfig {
    fn check(&self) -> Result<()> {
        let positive = [
            ("process_std", self.process_std, true),
            ("measurement_std", self.measurement_std, false),
            ("dt", self.dt, false),
            ("gate", self.gate, false),
        ];
        for (name, v, zero_ok) in positive {
            if !(v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0)) && v <= 1e100) {
                return Err(invalid(format!(
                    "{name} must be {} and at most 1e100, got {v}",
                    if zero_ok { "non-negative" } else { "positive" }
                )));
            }
        }
        let k = self.motion.per_axis();
        if self.initial_std.len() != k
            || self
                .initial_std
                .iter()
                .any(|&s| !(s.is_finite() && s > 0.0 && s <= 1e100))
        {
            return Err(invalid(format!(
                "initial_std must be {k} positive stds (position, velocity{}), got {:?}",
                if k == 3 { ", acceleration" } else { "" },
                self.initial_std
            )));
        }
        if !(0.0..1.0).contains(&self.collapse) {
            return Err(invalid(format!(
                "collapse must lie in [0, 1), got {}",
                self.collapse
            )));
        }
        if let Some(z) = self.reacquire_z {
            if !(z.is_finite() && z >= 0.0) {
                return Err(invalid(format!(
                    "reacquire_z must be non-negative and finite (or None), got {z}"
                )));
            }
        }
        if let Some(a) = self.update_template {
            if !(a > 0.0 && a <= 1.0) {
                return Err(invalid(format!(
                    "update_template must lie in (0, 1] (or be None), got {a}"
                )));
            }
        }
        Ok(())
    }

    /// The linear link's model: per axis x, y (in that order) the motion model, positions
    /// observed with std `measurement_std`.
    pub fn model(&self) -> Result<LinearGaussian> {
        let q = self.process_std * self.process_std;
        match self.motion {
            Motion::Velocity => kalman::constant_velocity(self.dt, q, 2, self.measurement_std),
            Motion::Acceleration => {
                kalman::constant_acceleration(self.dt, q, 2, self.measurement_std)
            }
        }
    }

    /// N((x, 0…, y, 0…), diag(initial_std²) per axis).
    pub fn initial(&self, x: f64, y: f64) -> Gaussian {
        let k = self.motion.per_axis();
        let mut mean = DVector::zeros(2 * k);
        mean[0] = x;
        mean[k] = y;
        let variances: Vec<f64> = (0..2 * k)
            .map(|i| self.initial_std[i % k].powi(2))
            .collect();
        Gaussian {
            mean,
            cov: DMatrix::from_diagonal(&DVector::from_vec(variances)),
        }
    }
}

/// One tracked template: the template, the state estimate and the reference score ρ̄.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    pub template: Template,
    pub state: Gaussian,
    /// ρ̄ (None before the first accepted score).
    pub reference: Option<f64>,
}

/// What one frame did to one target.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The posterior (or, on a coasted frame, the coasted state).
    pub state: Gaussian,
    /// The in-window peak score (NaN when no window could be searched).
    pub score: f64,
    /// The accepted measurement (top-left x, y), None when coasted.
    pub measurement: Option<[f64; 2]>,
    /// The in-window search region (None when off the frame).
    pub window: Option<Window>,
    /// The score collapsed (the frame was searched whole).
    pub collapsed: bool,
    /// The whole-frame peak was accepted and the state restarted there.
    pub reacquired: bool,
    /// The whole-frame peak's score when the score collapsed (NaN otherwise).
    pub frame_score: f64,
}

/// The in-window part of a frame for one target.
struct Local {
    predicted: Gaussian,
    window: Option<Window>,
    found: Option<Match>,
    /// The frame under the template at the rounded peak (only with template updates).
    patch: Option<Vec<f64>>,
}

/// A bank of templates tracked on the same frames (one target: the single-object tracker).
#[derive(Debug, Clone)]
pub struct TemplateTracker {
    config: TrackerConfig,
    model: LinearGaussian,
    targets: Vec<Target>,
    frames: u64,
}

impl TemplateTracker {
    /// Targets `templates[i]` at top-left `positions[i]` in the first frame to come.
    pub fn new(
        config: TrackerConfig,
        templates: Vec<Template>,
        positions: &[[f64; 2]],
    ) -> Result<Self> {
        config.check()?;
        if templates.is_empty() || templates.len() != positions.len() {
            return Err(invalid(format!(
                "one position per template is needed, got {} templates and {} positions",
                templates.len(),
                positions.len()
            )));
        }
        if let Some(k) = templates.iter().position(|t| t.constant) {
            return Err(invalid(format!(
                "template {k} is constant (every pixel equal): its normalised \
                 cross-correlation is undefined"
            )));
        }
        if positions
            .iter()
            .flatten()
            .any(|v| !(v.is_finite() && v.abs() <= 1e9))
        {
            return Err(invalid("positions must be finite, within ±1e9".into()));
        }
        let model = config.model()?;
        let targets = templates
            .into_iter()
            .zip(positions)
            .map(|(template, &[x, y])| Target {
                template,
                state: config.initial(x, y),
                reference: None,
            })
            .collect();
        Ok(Self {
            config,
            model,
            targets,
            frames: 0,
        })
    }

    /// The settings.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// The linear link's model.
    pub fn model(&self) -> &LinearGaussian {
        &self.model
    }

    /// The targets (template, state, ρ̄).
    pub fn targets(&self) -> &[Target] {
        &self.targets
    }

    /// Frames processed.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Tracks every target through one more frame; on an error nothing changes.
    pub fn update<T: Pixel>(&mut self, frame: &Frame<'_, T>) -> Result<Vec<Step>> {
        let shape = (frame.height, frame.width);
        for (k, t) in self.targets.iter().enumerate() {
            if t.template.h > shape.0 || t.template.w > shape.1 {
                return Err(FieldError::Shape(format!(
                    "template {k} ({}, {}) is larger than the ({}, {}) frame",
                    t.template.h, t.template.w, shape.0, shape.1
                )));
            }
        }
        let first = self.frames == 0;
        let local = |t: &Target| self.search_window(t, frame, first);
        let locals: Vec<Local> = if self.targets.len() > 1 {
            self.targets.par_iter().map(local).collect::<Result<_>>()?
        } else {
            self.targets.iter().map(local).collect::<Result<_>>()?
        };
        let collapsed: Vec<bool> = self
            .targets
            .iter()
            .zip(&locals)
            .map(|(t, l)| self.collapsed(t, l.found.as_ref()))
            .collect();
        let whole = self.search_frame(frame, &collapsed)?;
        let mut steps = Vec::with_capacity(self.targets.len());
        let mut targets = self.targets.clone();
        for (((target, local), collapsed), whole) in
            targets.iter_mut().zip(locals).zip(collapsed).zip(whole)
        {
            steps.push(self.advance(target, local, collapsed, whole)?);
        }
        self.targets = targets;
        self.frames += 1;
        Ok(steps)
    }

    /// The prediction and the in-window search of one target; when its score collapses, the
    /// held hypothesis (module docs, *Manoeuvre*) is searched too and taken if its peak
    /// scores at least ρ̄.
    fn search_window<T: Pixel>(
        &self,
        t: &Target,
        frame: &Frame<'_, T>,
        first: bool,
    ) -> Result<Local> {
        if first {
            return self.search_gate(t, frame, t.state.clone());
        }
        let local = self.search_gate(t, frame, kalman::predict(&self.model, &t.state))?;
        if !self.collapsed(t, local.found.as_ref()) {
            return Ok(local);
        }
        let held = self.search_gate(t, frame, self.held(&t.state))?;
        let confident = match (held.found, t.reference) {
            (Some(m), Some(reference)) => m.score >= reference,
            _ => false,
        };
        Ok(if confident { held } else { local })
    }

    /// The prediction of the held hypothesis: the target stopped or turned at its last
    /// estimated position — that position and its covariance, the velocity (and
    /// acceleration) restarted from the prior (zero mean, prior variances), predicted one
    /// frame.
    fn held(&self, state: &Gaussian) -> Gaussian {
        let k = self.config.motion.per_axis();
        let mut restarted = self.config.initial(state.mean[0], state.mean[k]);
        for a in [0, k] {
            for b in [0, k] {
                restarted.cov[(a, b)] = state.cov[(a, b)];
            }
        }
        kalman::predict(&self.model, &restarted)
    }

    /// The search of one target inside the gate of `predicted`.
    fn search_gate<T: Pixel>(
        &self,
        t: &Target,
        frame: &Frame<'_, T>,
        predicted: Gaussian,
    ) -> Result<Local> {
        let (h, w) = (t.template.h, t.template.w);
        let gate = Gate::new(&self.model, &predicted, self.config.gate);
        let window = gate.window((h, w), (frame.height, frame.width));
        let usable = window.filter(|win| win.rows() >= h && win.cols() >= w);
        let (mut found, mut patch) = (None, None);
        if let Some(win) = usable {
            let region = Region::new(frame, win, h, w)?;
            let surface = Correlator::new(&region).surface(&t.template, Method::Ncc)?;
            found = surface.peak_where(self.config.subpixel, |x, y| gate.admits(x, y));
            if let (Some(m), Some(_)) = (found, self.config.update_template) {
                patch = patch_at(&region, m, (h, w));
            }
        }
        Ok(Local {
            predicted,
            window,
            found,
            patch,
        })
    }

    /// Whether a target's in-window peak collapsed (module docs).
    fn collapsed(&self, t: &Target, found: Option<&Match>) -> bool {
        match (found, t.reference) {
            (None, _) => true,
            (Some(m), Some(reference)) => m.score < self.config.collapse * reference,
            (Some(_), None) => false,
        }
    }

    /// The whole-frame peaks (and by how much their distinctness z exceeds the threshold) of
    /// the targets whose score collapsed; one
    /// conversion of the frame and one frame spectrum serve them all.
    fn search_frame<T: Pixel>(
        &self,
        frame: &Frame<'_, T>,
        collapsed: &[bool],
    ) -> Result<Vec<Option<(Match, f64)>>> {
        if !collapsed.iter().any(|&c| c) {
            return Ok(vec![None; collapsed.len()]);
        }
        let full = Window::full(frame.height, frame.width);
        let region = Region::new(frame, full, 1, 1)?;
        let mut correlator = Correlator::new(&region);
        let mut out = Vec::with_capacity(collapsed.len());
        for (t, &c) in self.targets.iter().zip(collapsed) {
            if !c {
                out.push(None);
                continue;
            }
            let surface = correlator.surface(&t.template, Method::Ncc)?;
            let threshold = self.config.reacquire_z.unwrap_or_else(|| {
                let positions = (surface.rows * surface.cols) as f64;
                (2.0 * positions.ln()).sqrt() + 1.0
            });
            out.push(surface.peak(self.config.subpixel).map(|m| {
                let z = distinctness(&surface.values, (surface.rows, surface.cols), m.score);
                (m, z - threshold)
            }));
        }
        Ok(out)
    }

    /// The new state of one target and its step record.
    fn advance(
        &self,
        target: &mut Target,
        local: Local,
        collapsed: bool,
        whole: Option<(Match, f64)>,
    ) -> Result<Step> {
        let score = local.found.map_or(f64::NAN, |m| m.score);
        let mut step = Step {
            state: local.predicted.clone(),
            score,
            measurement: None,
            window: local.window,
            collapsed,
            reacquired: false,
            frame_score: whole.map_or(f64::NAN, |(m, _)| m.score),
        };
        if !collapsed {
            let m = local.found.expect("a peak that did not collapse exists");
            let z = DVector::from_vec(vec![m.x, m.y]);
            let posterior = kalman::update(&self.model, &local.predicted, &z)?.posterior;
            let reference = target.reference;
            if let (Some(alpha), Some(patch)) = (self.config.update_template, local.patch) {
                if reference.is_none_or(|r| m.score >= r) {
                    target.template = blended(&target.template, &patch, alpha)?;
                }
            }
            target.reference = Some(match reference {
                Some(r) => (1.0 - REFERENCE_WEIGHT) * r + REFERENCE_WEIGHT * m.score,
                None => m.score,
            });
            target.state = posterior.clone();
            step.state = posterior;
            step.measurement = Some([m.x, m.y]);
            return Ok(step);
        }
        let floor = self.config.collapse * target.reference.unwrap_or(0.0);
        match whole {
            Some((m, excess)) if m.score >= floor && excess >= 0.0 => {
                target.state = self.config.initial(m.x, m.y);
                step.state = target.state.clone();
                step.measurement = Some([m.x, m.y]);
                step.reacquired = true;
            }
            _ => {
                target.state = self.lost(local.predicted);
                step.state = target.state.clone();
            }
        }
        Ok(step)
    }

    /// The coasted state of a collapsed frame (module docs, *Lost lock*): the prediction,
    /// with the prior variances of the velocity (and acceleration) added to theirs.
    fn lost(&self, mut predicted: Gaussian) -> Gaussian {
        let k = self.config.motion.per_axis();
        for axis in 0..2 {
            for i in 1..k {
                predicted.cov[(axis * k + i, axis * k + i)] += self.config.initial_std[i].powi(2);
            }
        }
        predicted
    }

    /// The dynamic state as numbers: frames, then per target ρ̄ (NaN before the first),
    /// the state mean, its covariance (row-major) and the template (row-major).
    pub fn state_values(&self) -> Vec<f64> {
        let mut v = vec![self.frames as f64];
        for t in &self.targets {
            v.push(t.reference.unwrap_or(f64::NAN));
            v.extend(t.state.mean.iter());
            v.extend(t.state.cov.transpose().iter());
            v.extend(&t.template.raw);
        }
        v
    }

    /// Restores numbers saved by `state_values` from a tracker of the same settings and
    /// template shapes; checked (lengths, finite, a covariance), nothing changes on error.
    pub fn load_state(&mut self, values: &[f64]) -> Result<()> {
        let corrupt = || invalid("the tracker state does not fit this tracker's settings".into());
        let n = 2 * self.config.motion.per_axis();
        let expected = 1 + self
            .targets
            .iter()
            .map(|t| 1 + n + n * n + t.template.h * t.template.w)
            .sum::<usize>();
        if values.len() != expected {
            return Err(corrupt());
        }
        let frames = values[0];
        if !(frames >= 0.0 && frames.fract() == 0.0 && frames < 2f64.powi(53)) {
            return Err(corrupt());
        }
        let mut rest = &values[1..];
        let mut take = |k: usize| {
            let (head, tail) = rest.split_at(k);
            rest = tail;
            head
        };
        let mut targets = Vec::with_capacity(self.targets.len());
        for t in &self.targets {
            let reference = take(1)[0];
            let mean = DVector::from_column_slice(take(n));
            let cov = DMatrix::from_row_slice(n, n, take(n * n));
            let template = Template::new(
                take(t.template.h * t.template.w).to_vec(),
                t.template.h,
                t.template.w,
            )?;
            if !(reference.is_nan() || (reference.is_finite() && reference.abs() <= 1.0)) {
                return Err(corrupt());
            }
            targets.push(Target {
                template,
                state: Gaussian::new(mean, cov)?,
                reference: (!reference.is_nan()).then_some(reference),
            });
        }
        self.targets = targets;
        self.frames = frames as u64;
        Ok(())
    }
}

/// The region's pixels under an h × w template at the rounded position of `m` (None when they
/// are not all in the region or one is NaN).
fn patch_at(region: &Region, m: Match, (h, w): (usize, usize)) -> Option<Vec<f64>> {
    let x = m.x.round() as isize - region.window.x0 as isize;
    let y = m.y.round() as isize - region.window.y0 as isize;
    let (x, y) = (usize::try_from(x).ok()?, usize::try_from(y).ok()?);
    if x + w > region.cols || y + h > region.rows {
        return None;
    }
    let mut patch = Vec::with_capacity(h * w);
    for r in y..y + h {
        let row = r * region.cols;
        for c in x..x + w {
            let missing = region.missing.as_ref().is_some_and(|m| m[row + c] > 0.0);
            if missing {
                return None;
            }
            patch.push(region.values[row + c] + region.shift);
        }
    }
    Some(patch)
}

/// (1 − α)·template + α·patch, kept when the blend would be constant.
fn blended(template: &Template, patch: &[f64], alpha: f64) -> Result<Template> {
    let values = template
        .raw
        .iter()
        .zip(patch)
        .map(|(&t, &p)| (1.0 - alpha) * t + alpha * p)
        .collect();
    let next = Template::new(values, template.h, template.w)?;
    Ok(if next.constant {
        template.clone()
    } else {
        next
    })
}
