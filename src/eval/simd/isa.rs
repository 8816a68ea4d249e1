//! The instruction set the kernels run with, chosen once by CPU feature detection (and forced
//! for tests and benchmarks), and [`fma_dispatch`], which compiles a generic kernel once per
//! instruction set and calls the copy the CPU supports.
//!
//! The kernels are written once, generic over [`Arith`](crate::eval::simd::traits::Arith), and
//! compiled several times: with AVX-512 (8 lanes per register) and FMA, with AVX2 and FMA, and for
//! baseline x86-64 (separate multiply and add: `f64::mul_add` without the FMA target feature
//! compiles to a slow library call, so that path never calls it). Results with FMA can differ
//! from those without in the last bit; both are within the accuracy the tests assert.

use std::sync::atomic::{AtomicU8, Ordering};

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

/// A choice made once from what the CPU reports, which tests and benchmarks can override:
/// `current` is 0 until first read, then what `resolve` makes of the forced value (0 for none)
/// and the detected one. Reading it is one load and a comparison; `detect` runs once (`cpuid`
/// leaves a virtual machine for the hypervisor, microseconds each time).
struct Detected {
    detected: AtomicU8,
    forced: AtomicU8,
    current: AtomicU8,
    detect: fn() -> u8,
    resolve: fn(forced: u8, detected: u8) -> u8,
}

impl Detected {
    const fn new(detect: fn() -> u8, resolve: fn(u8, u8) -> u8) -> Detected {
        Detected {
            detected: AtomicU8::new(0),
            forced: AtomicU8::new(0),
            current: AtomicU8::new(0),
            detect,
            resolve,
        }
    }

    #[inline(always)]
    fn get(&self) -> u8 {
        match self.current.load(Ordering::Relaxed) {
            0 => self.update(),
            current => current,
        }
    }

    #[cold]
    #[inline(never)]
    fn update(&self) -> u8 {
        let detected = match self.detected.load(Ordering::Relaxed) {
            0 => {
                let d = (self.detect)();
                self.detected.store(d, Ordering::Relaxed);
                d
            }
            d => d,
        };
        let current = (self.resolve)(self.forced.load(Ordering::Relaxed), detected);
        self.current.store(current, Ordering::Relaxed);
        current
    }

    fn force(&self, forced: u8) {
        self.forced.store(forced, Ordering::Relaxed);
        self.update();
    }
}

/// The instruction set as an `Isa` value: the detected one, or at most the forced one.
static LEVEL: Detected = Detected::new(detect_level, |forced, detected| match forced {
    0 => detected,
    forced => forced.min(detected),
});

/// 1 (one 512-bit register) or 2 (two 256-bit halves): by vendor, unless forced.
static TRIG: Detected = Detected::new(detect_trig, |forced, detected| match forced {
    0 => detected,
    forced => forced,
});

/// The instruction set the kernels use on this machine (detected once), unless lowered with
/// [`force_isa`].
#[must_use]
#[inline]
pub fn isa() -> Isa {
    // One load and two comparisons on every kernel call; the detection only on the first.
    match LEVEL.get() {
        3 => Isa::Avx512,
        2 => Isa::Avx2,
        _ => Isa::Baseline,
    }
}

/// Makes the kernels use at most `isa` (for comparing paths in tests and benchmarks); `None`
/// restores detection. A request above what the CPU supports is lowered to what it supports.
pub fn force_isa(isa: Option<Isa>) {
    LEVEL.force(isa.map_or(0, |i| i as u8));
}

/// Whether a single evaluation on the AVX-512 path computes the `sin`/`cos` of at most eight
/// joint angles in two 256-bit halves rather than one 512-bit register (detected once: yes on
/// Intel CPUs, no on others), unless set with [`force_narrow_trig`]. Batches and evaluations that
/// need more than eight angles always use 512-bit registers. Both give the same bits.
///
/// On an Intel Xeon (Emerald Rapids) a single evaluation that executes any 512-bit instruction
/// took about 10 ns longer, whatever the amount of 512-bit work: one 512-bit multiply added to an
/// evaluation otherwise on 256-bit registers made the Panda, UR5 and Kinova URDFs 15–23% slower.
/// Eight angles in 512 bits save less than that, more than eight save more
/// (`docs/performance.md`, "What bounds each figure", and the file's git history).
#[must_use]
#[inline]
pub fn narrow_trig() -> bool {
    TRIG.get() == 2
}

/// Sets [`narrow_trig`] (for comparing the two in tests and benchmarks); `None` restores the
/// choice by vendor.
pub fn force_narrow_trig(narrow: Option<bool>) {
    TRIG.force(narrow.map_or(0, |n| 1 + u8::from(n)));
}

fn detect_trig() -> u8 {
    if is_intel() { 2 } else { 1 }
}

/// Size in bytes of the CPU's largest cache (the last level, shared by its cores), as CPUID
/// describes it (leaf 4 on Intel, 0x8000_001D on AMD and others with topology extensions);
/// 32 MiB when it does not, or on other architectures. Read once.
pub(crate) fn last_level_cache_bytes() -> usize {
    static BYTES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *BYTES.get_or_init(|| detect_last_level_cache().unwrap_or(32 << 20))
}

fn detect_last_level_cache() -> Option<usize> {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__cpuid, __cpuid_count};
        let leaf = if is_intel() {
            (__cpuid(0).eax >= 4).then_some(4)
        } else {
            let topology_extensions = __cpuid(0x8000_0001).ecx & (1 << 22) != 0;
            (__cpuid(0x8000_0000).eax >= 0x8000_001D && topology_extensions).then_some(0x8000_001D)
        }?;
        let mut largest = None;
        // Each sub-leaf describes one cache, until one of type 0; a bound against bad firmware.
        for sub in 0..16 {
            let r = __cpuid_count(leaf, sub);
            if r.eax & 0x1f == 0 {
                break;
            }
            let field =
                |x: u32, shift: u32, bits: u32| ((x >> shift) & ((1 << bits) - 1)) as usize + 1;
            let bytes = field(r.ebx, 22, 10)
                * field(r.ebx, 12, 10)
                * field(r.ebx, 0, 12)
                * (r.ecx as usize + 1);
            let level = (r.eax >> 5) & 7;
            if largest.is_none_or(|(l, _)| level > l) {
                largest = Some((level, bytes));
            }
        }
        largest.map(|(_, bytes)| bytes)
    }
    #[cfg(not(target_arch = "x86_64"))]
    None
}

/// Whether the CPU's vendor string is Intel's.
fn is_intel() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        let id = std::arch::x86_64::__cpuid(0);
        let vendor = [id.ebx, id.edx, id.ecx].map(u32::to_le_bytes);
        vendor.as_flattened() == b"GenuineIntel"
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

fn detect_level() -> u8 {
    detect() as u8
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

/// Defines `$vis fn $name(args) -> ret` that runs `$generic::<Fused512>(args)` inside a function
/// compiled for AVX-512 or `$generic::<Fused>(args)` in one compiled for AVX2 (both with FMA),
/// whichever [`isa`] selects, and
/// `$generic::<Separate>(args)` on baseline x86-64. `$generic` must be `#[inline(always)]` so that
/// its body is compiled with the caller's target features. With `avx2` before `fn`, AVX-512
/// machines run the AVX2 variant too (for code on 256-bit columns only, where the AVX-512 build
/// brings no wider vectors; the two give the same bits).
macro_rules! fma_dispatch {
    (avx2 $($function:tt)*) => {
        $crate::eval::simd::isa::fma_dispatch!(@wide false, $($function)*);
    };
    (@wide $wide:literal, $(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? => $generic:ident) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
                fn with_avx512($($arg: $ty),*) $(-> $ret)? {
                    $generic::<$crate::eval::simd::fused::Fused512>($($arg),*)
                }
                #[target_feature(enable = "avx2,fma")]
                fn with_avx2($($arg: $ty),*) $(-> $ret)? {
                    $generic::<$crate::eval::simd::fused::Fused>($($arg),*)
                }
                match $crate::eval::simd::isa::isa() {
                    // SAFETY: `isa()` reports these features only when the CPU has them.
                    $crate::eval::simd::isa::Isa::Avx512 if $wide => return unsafe { with_avx512($($arg),*) },
                    // SAFETY: as above (AVX-512 is reported only with AVX2 and FMA).
                    $crate::eval::simd::isa::Isa::Avx512 | $crate::eval::simd::isa::Isa::Avx2 => {
                        return unsafe { with_avx2($($arg),*) }
                    }
                    $crate::eval::simd::isa::Isa::Baseline => {}
                }
            }
            // Not inlined, so that the dispatch stays a few instructions (no frame of its own).
            #[inline(never)]
            fn baseline($($arg: $ty),*) $(-> $ret)? {
                $generic::<$crate::eval::simd::portable::Separate>($($arg),*)
            }
            baseline($($arg),*)
        }
    };
    ($($function:tt)*) => {
        $crate::eval::simd::isa::fma_dispatch!(@wide true, $($function)*);
    };
}

pub(crate) use fma_dispatch;

#[cfg(test)]
mod tests {
    /// The last-level cache read from CPUID is the one Linux reports for the first CPU (from the
    /// same source, decoded independently), where it reports one.
    #[cfg(all(target_os = "linux", target_arch = "x86_64"))]
    #[test]
    fn last_level_cache_matches_linux() {
        let dir = std::path::Path::new("/sys/devices/system/cpu/cpu0/cache");
        let read = |index: &std::path::Path, name: &str| {
            std::fs::read_to_string(index.join(name)).map(|s| s.trim().to_string())
        };
        let mut largest: Option<(u32, usize)> = None;
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let (Ok(level), Ok(size)) = (read(&entry.path(), "level"), read(&entry.path(), "size"))
            else {
                continue;
            };
            let level: u32 = level.parse().unwrap();
            let kib: usize = size.trim_end_matches('K').parse().unwrap();
            if largest.is_none_or(|(l, _)| level > l) {
                largest = Some((level, kib << 10));
            }
        }
        let bytes = super::last_level_cache_bytes();
        assert!(bytes >= 256 << 10, "{bytes}");
        // The decoded size itself, not the fallback (which may be the same number).
        if let Some((_, linux)) = largest {
            assert_eq!(super::detect_last_level_cache(), Some(linux));
            assert_eq!(bytes, linux);
        }
    }
}
