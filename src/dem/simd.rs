//! Hot kernels compiled twice: for the baseline x86-64 the binary targets (SSE2, so it
//! runs anywhere) and for AVX2, picked at run time when the processor has it. Rust never
//! fuses a multiply and an add on its own and vector lanes round as scalars do, so both
//! versions give the same numbers bit for bit; the AVX2 one does four lanes at a time.

use std::sync::atomic::{AtomicU8, Ordering};

/// 0 not yet detected, 1 AVX2, 2 baseline.
static STATE: AtomicU8 = AtomicU8::new(0);

/// Use the baseline versions from now on (or AVX2 again where the processor has it):
/// for tests that the two give the same numbers, and for timing one against the other.
pub fn use_avx2(enabled: bool) {
    STATE.store(0, Ordering::Relaxed);
    let yes = enabled && has_avx2();
    STATE.store(if yes { 1 } else { 2 }, Ordering::Relaxed);
}

/// Whether this processor runs the AVX2 versions (detected once).
#[inline(always)]
pub fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        match STATE.load(Ordering::Relaxed) {
            1 => true,
            2 => false,
            _ => {
                let yes = std::is_x86_feature_detected!("avx2");
                STATE.store(if yes { 1 } else { 2 }, Ordering::Relaxed);
                yes
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `pub fn name(a: A, …) -> R { body }` defined so that the body is compiled for the
/// baseline and for AVX2 and the call picks one at run time. Arguments must be plain
/// identifiers.
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
                if $crate::dem::simd::has_avx2() {
                    // SAFETY: the processor has AVX2 (checked at run time).
                    return unsafe { avx2($($arg),*) };
                }
            }
            imp($($arg),*)
        }
    };
}
