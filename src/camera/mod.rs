//! Camera frames: reading and writing grey-scale images (`frame`), locating grains in
//! them the Crocker–Grier way as trackpy does (`locate`), linking the located grains
//! into trajectories (`link`), and the camera emulator that renders tracks into frames
//! (`render`).
//!
//! Coordinates follow trackpy's: `x` is the column, `y` the row (pointing down), pixel
//! centres on whole numbers. Nothing here knows of tracks tables or pipelines; the
//! stages (`stages::track`) convert.

pub mod frame;

pub use frame::{Frame, FrameSet, list_frames, read_frame, write_frame};
