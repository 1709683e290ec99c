//! Hot kernels compiled twice: for the baseline x86-64 the binary targets (SSE2, so it
//! runs anywhere) and for AVX2, picked at run time by what the processor has. Rust never
//! fuses a multiply and an add on its own and vector lanes round as scalars do, so both
//! versions give the same numbers bit for bit; AVX2 does four lanes at a time.
//!
//! A third level, `Avx512`, compiles the same 256-bit code with AVX-512 F/VL/DQ enabled:
//! LLVM then has 32 vector registers instead of 16 (the pair kernels spilled), mask
//! registers and three-input logic, for the same operations on the same lanes, so the
//! same numbers (tested). It is used for the sheared disks' intrinsics kernels
//! (`avx2_entry_point!`; 13–25 % faster) but not the pillar's (0–2.5 %, not worth a
//! second copy: they are plain `#[target_feature(enable = "avx2")]` functions), and not
//! the autovectorised loops of `multiversion!`, which turned slower with it. 512-bit
//! vectors only where written by hand: the sheared disks' force kernel `shear_avx512`
//! (loads and shuffles, no gathers; AVX-512 gathers, which LLVM made of the pair
//! kernels' indexed loads, made the sheared-disk step 12–16 % slower on AMD EPYC Zen 4,
//! and hand-written ones were 9 % slower on the project's Intel machines).

use std::sync::atomic::{AtomicU8, Ordering};

/// Two numbers of a grain, one aligned 16-byte load (a packed record for the AVX2
/// kernels, e.g. a position (x, y)).
#[repr(C, align(16))]
#[derive(Debug, Clone, Copy, Default)]
pub struct Pos(pub [f64; 2]);

/// Four numbers of a grain or a pair slot, one aligned 32-byte load (a packed record
/// for the AVX2 kernels, e.g. (v_x, v_y, ω, R) or a force (f_x, f_y, T, 0)).
#[repr(C, align(32))]
#[derive(Debug, Clone, Copy, Default)]
pub struct Quad(pub [f64; 4]);

/// Instruction sets the kernels are compiled for, narrowest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    Baseline = 1,
    Avx2 = 2,
    /// AVX2 code compiled with AVX-512 F, VL and DQ available.
    Avx512 = 3,
}

/// 0 not yet detected, else the `Level` in use.
static STATE: AtomicU8 = AtomicU8::new(0);

/// What this processor supports.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        let avx2 = std::is_x86_feature_detected!("avx2");
        if avx2
            && std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512vl")
            && std::is_x86_feature_detected!("avx512dq")
        {
            return Level::Avx512;
        }
        if avx2 {
            return Level::Avx2;
        }
    }
    Level::Baseline
}

/// Use at most `max` from now on (the processor's best when it has less): for tests
/// that the versions give the same numbers, and for timing one against another.
pub fn use_at_most(max: Level) {
    STATE.store(max.min(detected()) as u8, Ordering::Relaxed);
}

impl Level {
    /// The name users write (`PILLAR_PIPE_SIMD`) and manifests record.
    pub fn name(self) -> &'static str {
        match self {
            Level::Baseline => "baseline",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    fn parse(s: &str) -> Option<Level> {
        match s.trim() {
            "baseline" => Some(Level::Baseline),
            "avx2" => Some(Level::Avx2),
            "avx512" => Some(Level::Avx512),
            _ => None,
        }
    }
}

/// The level the environment variable `PILLAR_PIPE_SIMD` (`baseline`, `avx2`,
/// `avx512`) caps this process at, for timing one kernel against another and for
/// ruling a kernel out; an unknown value is an error, not a silent default.
pub fn cap_from_env() -> Result<Option<Level>, String> {
    match std::env::var("PILLAR_PIPE_SIMD") {
        Err(_) => Ok(None),
        Ok(v) => Level::parse(&v)
            .map(Some)
            .ok_or_else(|| format!("PILLAR_PIPE_SIMD = '{v}': expected baseline, avx2 or avx512")),
    }
}

/// The level in use: the processor's best, capped by `PILLAR_PIPE_SIMD` (which the
/// CLI checks at start, so an unknown value never gets here) or `use_at_most`.
#[inline(always)]
pub fn level() -> Level {
    match STATE.load(Ordering::Relaxed) {
        1 => Level::Baseline,
        2 => Level::Avx2,
        3 => Level::Avx512,
        _ => {
            let mut l = detected();
            if let Ok(Some(cap)) = cap_from_env() {
                l = l.min(cap);
            }
            STATE.store(l as u8, Ordering::Relaxed);
            l
        }
    }
}

/// `pub fn name(a: A, …) -> R { body }` defined so that the body is compiled for the
/// baseline and for AVX2, and the call picks one at run time. Arguments must be
/// plain identifiers.
#[macro_export]
macro_rules! multiversion {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$m])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            #[allow(clippy::too_many_arguments)]
            fn imp($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                #[allow(clippy::too_many_arguments)]
                fn avx2($($arg: $ty),*) $(-> $ret)? {
                    imp($($arg),*)
                }
                match $crate::dem::backend::simd::level() {
                    // SAFETY: the processor has these (checked at run time). Not an
                    // AVX-512 build for Level::Avx512: LLVM then autovectorises these
                    // loops with 512-bit registers, which made the sheared-disk step 4 %
                    // slower on the project's Intel machines.
                    $crate::dem::backend::simd::Level::Avx512 | $crate::dem::backend::simd::Level::Avx2 => {
                        return unsafe { avx2($($arg),*) }
                    }
                    $crate::dem::backend::simd::Level::Baseline => {}
                }
            }
            imp($($arg),*)
        }
    };
}

/// `pub unsafe fn name(a: A, …) -> R { body }` for a kernel written with AVX2
/// intrinsics: the body is compiled twice, for AVX2 and for [`Level::Avx512`] (same
/// operations, same numbers; see the module notes), and the call runs the one the level
/// in use picks. Arguments must be plain identifiers; the safety contract is the body's,
/// which includes AVX2.
#[macro_export]
macro_rules! avx2_entry_point {
    ($(#[$m:meta])* $vis:vis unsafe fn $name:ident $(<$(const $g:ident: $gt:ty),*>)?
        ($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$m])*
        #[allow(clippy::too_many_arguments)]
        $vis unsafe fn $name $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            #[allow(clippy::too_many_arguments, unused_unsafe)]
            unsafe fn imp $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? $body
            #[target_feature(enable = "avx2")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn avx2 $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? {
                // SAFETY: the caller keeps the body's contract.
                unsafe { imp $(::<$($g),*>)? ($($arg),*) }
            }
            #[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn avx512 $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? {
                // SAFETY: the caller keeps the body's contract.
                unsafe { imp $(::<$($g),*>)? ($($arg),*) }
            }
            // SAFETY: the caller keeps the body's contract (AVX2 present); the level is
            // Avx512 only where the processor has those features too.
            unsafe {
                if $crate::dem::backend::simd::level() == $crate::dem::backend::simd::Level::Avx512 {
                    avx512 $(::<$($g),*>)? ($($arg),*)
                } else {
                    avx2 $(::<$($g),*>)? ($($arg),*)
                }
            }
        }
    };
}
