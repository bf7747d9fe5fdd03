//! Extended objects made of moving fragments (SPEC §3.4, [K93] steps 4–10): stage 2 of the
//! detector. An object is a group of segment sequences sharing its derivatives (velocity…);
//! each frame the segments are assigned to the sequences of all groups by the quasi-optimal
//! greedy rule, sequences without a segment are dropped (those of an object hidden by another
//! object's segment coast), segments left alone start new
//! sequences in the group whose gate holds them (or new groups), and the sequences longer
//! than ν + 1 with a similar non-zero velocity form the object's image.
//!
//! The twin is `python/kalmanfield/reference/extended/`: same rules, same order of every
//! loop and tie-break.

mod assignment;
mod codec;
mod config;
mod frame;
mod group;
mod motion;
mod sequence;
mod tracker;

#[cfg(test)]
mod tests;

pub use assignment::{assign, Variant};
pub use config::{GroupConfig, MAX_ORDER};
pub use frame::{background_level, box_smooth, box_smooth_into};
pub use sequence::Measurement;
pub use tracker::{FrameAnswer, GroupReport, GroupTracker};
