//! Fused or separate multiply–add, and the vector width the kernels are compiled for, chosen
//! once by CPU feature detection.
//!
//! The kernels are written once, generic over [`Arith`], and compiled several times: with
//! AVX-512 (8 lanes per register) and FMA, with AVX2 and FMA, and for baseline x86-64 (separate
//! multiply and add: `f64::mul_add` without the FMA target feature compiles to a slow library
//! call, so that path never calls it). Results with FMA can differ from those without in the last
//! bit; both are within the accuracy the tests assert.

use std::sync::atomic::{AtomicU8, Ordering};

/// Multiply–add policy of a kernel instantiation.
pub(crate) trait Arith: Copy {
    /// `a * b + c`.
    fn mul_add(a: f64, b: f64, c: f64) -> f64;
}

/// Two roundings: `a * b` then `+ c`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Separate;

impl Arith for Separate {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

/// One rounding (hardware FMA). Only instantiated inside functions compiled with the `fma`
/// target feature.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fused;

impl Arith for Fused {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// The instruction sets a kernel can be compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[repr(u8)]
pub enum Isa {
    /// Baseline: SSE2 on x86-64 (2 lanes), separate multiply and add.
    Baseline = 1,
    /// AVX2 and FMA (4 lanes).
    Avx2 = 2,
    /// AVX-512 (8 lanes) and FMA.
    Avx512 = 3,
}

impl Isa {
    /// Short name for reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "avx2+fma",
            Isa::Avx512 => "avx512",
        }
    }
}

static DETECTED: AtomicU8 = AtomicU8::new(0);
static FORCED: AtomicU8 = AtomicU8::new(0);

/// The instruction set the kernels use on this machine (detected once), unless lowered with
/// [`force_isa`].
#[must_use]
pub fn isa() -> Isa {
    let forced = FORCED.load(Ordering::Relaxed);
    let detected = match DETECTED.load(Ordering::Relaxed) {
        0 => {
            let d = detect() as u8;
            DETECTED.store(d, Ordering::Relaxed);
            d
        }
        d => d,
    };
    let level = if forced != 0 {
        forced.min(detected)
    } else {
        detected
    };
    match level {
        3 => Isa::Avx512,
        2 => Isa::Avx2,
        _ => Isa::Baseline,
    }
}

/// Makes the kernels use at most `isa` (for comparing paths in tests and benchmarks); `None`
/// restores detection. A request above what the CPU supports is lowered to what it supports.
pub fn force_isa(isa: Option<Isa>) {
    FORCED.store(isa.map_or(0, |i| i as u8), Ordering::Relaxed);
}

fn detect() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx512f") && has!("avx512dq") && has!("avx512vl") && has!("fma") {
            return Isa::Avx512;
        }
        if has!("avx2") && has!("fma") {
            return Isa::Avx2;
        }
    }
    Isa::Baseline
}

/// Defines `$vis fn $name(args) -> ret` that runs `$generic::<Fused>(args)` inside a function
/// compiled for AVX-512 or AVX2 (with FMA), whichever [`isa`] selects, and
/// `$generic::<Separate>(args)` on baseline x86-64. `$generic` must be `#[inline(always)]` so that
/// its body is compiled with the caller's target features.
macro_rules! fma_dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? => $generic:ident) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
                fn with_avx512($($arg: $ty),*) $(-> $ret)? {
                    $generic::<$crate::arith::Fused>($($arg),*)
                }
                #[target_feature(enable = "avx2,fma")]
                fn with_avx2($($arg: $ty),*) $(-> $ret)? {
                    $generic::<$crate::arith::Fused>($($arg),*)
                }
                match $crate::arith::isa() {
                    // SAFETY: `isa()` reports these features only when the CPU has them.
                    $crate::arith::Isa::Avx512 => return unsafe { with_avx512($($arg),*) },
                    // SAFETY: as above.
                    $crate::arith::Isa::Avx2 => return unsafe { with_avx2($($arg),*) },
                    $crate::arith::Isa::Baseline => {}
                }
            }
            $generic::<$crate::arith::Separate>($($arg),*)
        }
    };
}
pub(crate) use fma_dispatch;
