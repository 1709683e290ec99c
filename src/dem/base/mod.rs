//! What both scenarios are made of: grains ([`grains`], structure of arrays), the
//! boundaries ([`boundary`]), the Verlet pair list with contact history ([`verlet`]) and
//! the cell grid it is built from ([`cell_grid`]), force-snapshot records ([`forces`]).

pub mod boundary;
pub mod cell_grid;
pub mod codec;
pub mod forces;
pub mod grains;
pub mod verlet;
