//! Fast paths, not physics. [`simd`] picks the instruction-set level once per process
//! (`PILLAR_PIPE_SIMD` caps it) and compiles hot loops for each; the hand-written kernels
//! below implement one contact law each (named in their docs, checked with
//! `ContactLaw::is_*` before they are called) and give the scalar reference's numbers
//! bit for bit, which `dem::tests` checks at every level; [`barrier`] is the spin barrier
//! the pillar's threads share. `unsafe` lives here and in the scenarios' thread
//! plumbing, each `unsafe fn` with its `# Safety` contract.

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
pub mod barrier;
#[cfg(target_arch = "x86_64")]
pub mod pillar_avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod pillar_gather_avx2;
pub mod pillar_threads;
#[cfg(target_arch = "x86_64")]
pub mod shear_avx2;
#[cfg(target_arch = "x86_64")]
mod shear_avx512;
#[cfg(target_arch = "x86_64")]
pub(crate) mod shear_integrate_avx2;
pub mod simd;
pub mod team;

/// Threads a simulator runs on: `setting`, at most `cap`; or, for `setting` 0, one per
/// core (`RAYON_NUM_THREADS` where set, as every parallel part of the program reads
/// it), at most `auto_cap`. At least one.
pub fn threads_for(setting: usize, auto_cap: usize, cap: usize) -> usize {
    match setting {
        0 => std::env::var("RAYON_NUM_THREADS")
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .filter(|&t| t > 0)
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |c| c.get()))
            .min(auto_cap)
            .max(1),
        t => t.min(cap).max(1),
    }
}
