//! The bundled discrete-element model: one core, two scenarios.
//!
//! - [`law`]: the contact laws as closed enums and **the scalar reference** for a pair
//!   contact and a wall contact (normal, damping, tangential, contact point; the
//!   substrate's Coulomb friction). The physics of a contact lives here and only here.
//! - [`base`]: what both scenarios are made of: grains as structure of arrays, the Verlet
//!   pair list with its per-contact history and the boundaries (open, periodic,
//!   Lees–Edwards), force-snapshot records, the checkpoint codec.
//! - [`pillar`]: li-granular-pillars Sec. II — grains on a frictional substrate between
//!   two bars (set-up, packing protocol, bars and substrate, the step's phases and their
//!   threads, observables, checkpoints).
//! - [`shear`]: vagberg-sheared-disks — frictionless disks under Lees–Edwards shear (the
//!   integrator of Eqs. 21–24, near lists, observables, checkpoints).
//! - [`backend`]: fast paths, not physics: SIMD level detection, the hand-written AVX2 and
//!   AVX-512 kernels (each says which law it implements and must match the reference bit
//!   for bit), the spin barrier the pillar's threads share. Anything a kernel does not
//!   implement runs the reference.
//!
//! Dependencies point one way: law → base → scenario; the backends serve the scenarios.
//! The simulators know nothing of analysis: they emit the canonical `tracks` schema that
//! `ingest`/`kinematics` read. Internal units are SI (m, kg, s, N) for the pillar and
//! d_s = m = τ_e = 1 for the sheared disks; the stage layer converts on output.

pub mod backend;
pub mod base;
pub mod law;
pub mod pillar;
pub mod shear;

#[cfg(test)]
mod tests;
