//! Tracking of moving objects (SPEC §3): the segmentation of each frame into bright
//! segments and the branching tracker that links them into tracks.

mod branching;
mod segment;

pub use branching::{
    splitmix64, BranchingTracker, ChosenTrack, FrameStats, Hypotheses, Nodes, OnlineAnswer,
    Selection, TrackTable, TrackerConfig, MAX_MOTION_ORDER,
};
pub use segment::{segment, segment_stack, Pixel, Segment, Segmentation, StackSegmentation};
