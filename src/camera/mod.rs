//! Camera frames: reading and writing grey-scale images (`frame`), locating grains in
//! them the Crocker–Grier way as trackpy does (`locate`), linking the located grains
//! into trajectories (`link`), and the camera emulator that renders tracks into frames
//! (`render`).
//!
//! Coordinates follow trackpy's: `x` is the column, `y` the row (pointing down), pixel
//! centres on whole numbers. Nothing here knows of tracks tables or pipelines; the
//! stages (`stages::track`) convert.

mod filters;
pub mod frame;
pub mod link;
pub mod locate;
pub mod render;
pub mod score;

pub use frame::{Frame, FrameSet, list_frames, read_frame, write_frame};
pub use link::{LinkOptions, LinkReport, Linked, link};
pub use locate::{LocateParams, LocateReport, locate, locate_frames};

/// One located grain in one frame, in trackpy's columns and meanings (pixels, the
/// frame's intensity units): what `locate` writes and `link` reads.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Feature {
    pub frame: i64,
    /// Column of the centre, px.
    pub x: f64,
    /// Row of the centre, px (pointing down).
    pub y: f64,
    /// Integrated brightness of the band-passed image within the mask.
    pub mass: f64,
    /// Radius of gyration of the band-passed brightness, px.
    pub size: f64,
    /// Eccentricity, 0 for a circular spot.
    pub ecc: f64,
    /// Peak of the band-passed brightness.
    pub signal: f64,
    /// Integrated brightness of the raw image within the mask.
    pub raw_mass: f64,
    /// trackpy's static-error estimate of the position, px (Savin & Doyle).
    pub ep: f64,
}
