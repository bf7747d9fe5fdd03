//! Detection of moving objects by branching segment sequences (SPEC §3.1–3.3, [K93]).
//!
//! The twin of `python/kalmanfield/reference/branching.py`: same rules, same order of the
//! children and of every tie-break, so both give the same tracks on the same measurements.
//! The module docstring of the reference explains the rules (gate = χ² index test, least-squares
//! start, score, the five pruning rules, the final greedy choice).

pub mod codec;
pub mod config;
mod gating;
pub mod hypotheses;
pub mod motion;
pub mod nodes;
pub mod pruning;
pub mod selection;
pub mod tracker;

#[cfg(test)]
mod tests;

pub use config::{Selection, TrackerConfig};
pub use tracker::BranchingTracker;
