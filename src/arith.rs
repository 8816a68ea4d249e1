//! Fused or separate multiply–add, chosen once per call by CPU feature detection.
//!
//! The kernels are written once, generic over [`Arith`], and compiled twice: with the `fma`
//! target feature (one rounding per `a * b + c`, faster and more accurate) and without it (for
//! x86-64 machines that lack FMA). `f64::mul_add` without the target feature compiles to a slow
//! library call, so the plain version never calls it.

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

/// Whether this CPU has hardware FMA (cached by the standard library after the first call).
#[inline]
pub(crate) fn has_fma() -> bool {
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    {
        std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(target_arch = "aarch64")]
    {
        // FMA is part of the AArch64 base instruction set.
        true
    }
    #[cfg(not(any(target_arch = "x86", target_arch = "x86_64", target_arch = "aarch64")))]
    {
        false
    }
}

/// Defines `$vis fn $name(args) -> ret` that runs `$generic::<Fused>(args)` inside a function
/// compiled with the `fma` target feature when the CPU has FMA, and `$generic::<Separate>(args)`
/// otherwise. `$generic` must be `#[inline(always)]` so that its body is compiled with the
/// caller's target features.
macro_rules! fma_dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? => $generic:ident) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
            {
                #[target_feature(enable = "fma")]
                fn with_fma($($arg: $ty),*) $(-> $ret)? {
                    $generic::<$crate::arith::Fused>($($arg),*)
                }
                if $crate::arith::has_fma() {
                    // SAFETY: the CPU supports FMA (checked at run time just above).
                    return unsafe { with_fma($($arg),*) };
                }
            }
            #[cfg(target_arch = "aarch64")]
            {
                return $generic::<$crate::arith::Fused>($($arg),*);
            }
            #[allow(unreachable_code)]
            $generic::<$crate::arith::Separate>($($arg),*)
        }
    };
}
pub(crate) use fma_dispatch;
