//! The bundled discrete-element model.
//!
//! One core serves both papers' systems: grains stored as structure-of-arrays
//! ([`grains`]), a Verlet pair list that carries each contact's history across rebuilds
//! ([`verlet`]), and the contact laws as closed enums with one scalar reference
//! ([`law`]: normal, damping, tangential, contact point; substrate) in the spirit of LAMMPS's granular sub-models. [`pillar`] assembles them
//! into li-granular-pillars Sec. II (grains on a frictional substrate between two bars);
//! [`pack`] is that paper's packing protocol (Sec. II.A). The simulators know nothing of
//! analysis: they emit the canonical `tracks` schema that `ingest`/`kinematics` read.
//!
//! Internal units are SI (m, kg, s, N); the stage layer converts lengths to cm on output.

#[cfg(target_arch = "x86_64")]
mod avx2;
pub mod barrier;
pub mod checkpoint;
pub mod forces;
pub mod grains;
pub mod law;
pub mod pack;
pub mod params;
pub mod pillar;
pub mod pillar_arrays;
#[cfg(target_arch = "x86_64")]
pub mod pillar_avx2;
pub mod pillar_gather;
pub mod pillar_kernels;
pub mod pillar_par;
pub mod pillar_phases;
pub mod shear;
#[cfg(target_arch = "x86_64")]
pub mod shear_avx2;
#[cfg(target_arch = "x86_64")]
mod shear_avx512;
pub mod shear_checkpoint;
pub mod shear_integrate;
#[cfg(target_arch = "x86_64")]
mod shear_integrate_avx2;
pub mod shear_near;
pub mod shear_order;
pub mod shear_pairs;
pub mod shear_slots;
pub mod simd;
pub mod verlet;

#[cfg(test)]
mod tests;
