//! Hot kernels compiled twice: for the baseline x86-64 the binary targets (SSE2, so it
//! runs anywhere) and for AVX2, picked at run time by what the processor has. Rust never
//! fuses a multiply and an add on its own and vector lanes round as scalars do, so both
//! versions give the same numbers bit for bit; AVX2 does four lanes at a time.
//!
//! No AVX-512 version: LLVM turns the pair kernels' indexed loads into AVX-512 gathers,
//! which on this project's machines (AMD EPYC, Zen 4) made the sheared-disk step 12–16 %
//! slower than AVX2's loads and inserts (`bench shear`, N = 1024 and 16,384).

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
}

/// 0 not yet detected, else the `Level` in use.
static STATE: AtomicU8 = AtomicU8::new(0);

/// What this processor supports.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") {
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

/// The level in use (detected once).
#[inline(always)]
pub fn level() -> Level {
    match STATE.load(Ordering::Relaxed) {
        1 => Level::Baseline,
        2 => Level::Avx2,
        _ => {
            let l = detected();
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
                match $crate::dem::simd::level() {
                    // SAFETY: the processor has these (checked at run time).
                    $crate::dem::simd::Level::Avx2 => return unsafe { avx2($($arg),*) },
                    $crate::dem::simd::Level::Baseline => {}
                }
            }
            imp($($arg),*)
        }
    };
}
