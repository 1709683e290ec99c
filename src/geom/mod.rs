//! Plane geometry: 2-vectors, 2×2 matrices, simulation boxes (open, periodic,
//! Lees–Edwards) and the one minimum-image rule they all use. Everything here is pure arithmetic on `f64`; units are whatever
//! length unit the caller's table uses.

mod image;
mod mat2;
mod simbox;
mod vec2;

pub use image::{MinImage, floor_index, rint};
pub use mat2::Mat2;
pub use simbox::SimBox;
pub use vec2::Vec2;
