//! What both scenarios are made of: grains ([`grains`], structure of arrays), the Verlet
//! pair list with contact history and the boundaries ([`verlet`]), force-snapshot
//! records ([`forces`]).

pub mod codec;
pub mod forces;
pub mod grains;
pub mod verlet;
