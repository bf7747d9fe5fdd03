//! Detection of moving objects by branching segment sequences (SPEC §3.1–3.3, [K93]).
//!
//! The twin of `python/kalmanfield/reference/branching.py`: same rules, same order of the
//! children and of every tie-break, so both give the same tracks on the same measurements.
//! The module docstring of the reference explains the rules (gate = χ² index test, least-squares
//! start, score, the five pruning rules, the final greedy choice).

mod codec;
mod config;
mod gating;
mod hypotheses;
mod motion;
mod nodes;
mod pruning;
mod selection;
mod tracker;

#[cfg(test)]
mod tests;

pub use config::{Selection, TrackerConfig};
pub use hypotheses::Hypotheses;
pub use motion::MAX_MOTION_ORDER;
pub use nodes::Nodes;
pub use selection::{ChosenTrack, TrackTable};
pub use tracker::{splitmix64, BranchingTracker, FrameStats, OnlineAnswer};
