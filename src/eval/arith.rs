//! Fused or separate multiply–add, and the vector width the kernels are compiled for, chosen
//! once by CPU feature detection.
//!
//! The kernels are written once, generic over [`Arith`], and compiled several times: with
//! AVX-512 (8 lanes per register) and FMA, with AVX2 and FMA, and for baseline x86-64 (separate
//! multiply and add: `f64::mul_add` without the FMA target feature compiles to a slow library
//! call, so that path never calls it). Results with FMA can differ from those without in the last
//! bit; both are within the accuracy the tests assert.

#[cfg(target_arch = "x86_64")]
use crate::eval::kernel::Z8;
use crate::eval::kernel::{LaneNum, Lanes};
use std::sync::atomic::{AtomicU8, Ordering};

/// Multiply–add policy of a kernel instantiation.
pub(crate) trait Arith: Copy {
    /// Four `f64` handled as one vector, with this policy's multiply–add.
    type Col: Col;
    /// The `f64` of a batch chunk, one per configuration, as this instruction set holds them.
    type Lanes: LaneNum;
    /// Whether [`Arith::mul_add`] rounds once (then the exact product error
    /// `a * b − RN(a * b)` is one operation away).
    const FUSED: bool;
    /// Whether this instantiation runs in a function compiled for AVX-512 (where a vector of
    /// [`Lanes`] is one 512-bit register).
    const WIDE: bool = false;
    /// `a * b + c`.
    fn mul_add(a: f64, b: f64, c: f64) -> f64;
}

/// Four `f64` (a padded column of a rigid frame) in one vector. Every operation is the same,
/// entry by entry and bit for bit, as the scalar operation of the owning [`Arith`].
pub(crate) trait Col: Copy {
    fn load(v: &[f64; 4]) -> Self;
    /// The frame of padded columns `[r0, r1, r2, p]` written as its twelve entries in that order
    /// (the first three of each column), in whole-vector stores: a caller's copy of the result
    /// in 16-byte pieces then reads each piece from one store (a load that spans two stores
    /// waits for both to reach the cache, which four 3-entry stores caused on every copy).
    fn store_frame(frame: [Self; 4], out: &mut [f64; 12]);
    /// All four entries.
    fn store(self, out: &mut [f64; 4]);
    fn splat(x: f64) -> Self;
    /// The vector of `e`, put together in registers (for entries loaded one by one: a vector
    /// load of entries just stored one by one waits for every store).
    fn from_entries(e: [f64; 4]) -> Self;
    /// `a * b + c`, entry by entry.
    fn mul_add(a: Self, b: Self, c: Self) -> Self;
    fn mul(a: Self, b: Self) -> Self;
    fn add(a: Self, b: Self) -> Self;
    fn sub(a: Self, b: Self) -> Self;
    fn neg(self) -> Self;
    /// Entries `[1, 2, 0, 3]` (for cross products).
    fn yzx(self) -> Self;
    /// Entries `[2, 0, 1, 3]`.
    fn zxy(self) -> Self;
    /// Whether every entry `x` is [`crate::eval::layout::within`] the limits of the same entry of
    /// `(scale, offset, lower, upper)`.
    fn admitted(x: Self, limits: [Self; 4]) -> bool;
}

/// Two roundings: `a * b` then `+ c`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Separate;

impl Arith for Separate {
    type Col = Portable<Separate>;
    type Lanes = Lanes;
    const FUSED: bool = false;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

/// One rounding (hardware FMA). Only instantiated inside functions compiled with the `fma`
/// and `avx2` target features, or (tests) after [`isa`] has reported them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fused;

impl Arith for Fused {
    #[cfg(target_arch = "x86_64")]
    type Col = Avx;
    #[cfg(not(target_arch = "x86_64"))]
    type Col = Portable<Fused>;
    #[cfg(target_arch = "x86_64")]
    type Lanes = crate::eval::kernel::Y4;
    #[cfg(not(target_arch = "x86_64"))]
    type Lanes = Lanes;
    const FUSED: bool = true;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// [`Fused`] with the batch lanes in AVX-512 registers ([`Z8`]): only instantiated inside
/// functions compiled with the `avx512f` target feature. Every operation is the one [`Fused`]
/// performs, so results are the same bit for bit.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fused512;

#[cfg(target_arch = "x86_64")]
impl Arith for Fused512 {
    type Col = Avx;
    type Lanes = Z8;
    const FUSED: bool = true;
    const WIDE: bool = true;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// [`Col`] as an array, for any [`Arith`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable<A>([f64; 4], std::marker::PhantomData<A>);

impl<A: Arith> Portable<A> {
    /// `[f(0), f(1), f(2), f(3)]`, written out rather than looped (see
    /// `eval::lanes::each_lane`: these inline into every body step of the baseline build).
    #[inline(always)]
    fn map(f: impl Fn(usize) -> f64) -> Self {
        Portable([f(0), f(1), f(2), f(3)], std::marker::PhantomData)
    }
}

impl<A: Arith> Col for Portable<A> {
    #[inline(always)]
    fn admitted(x: Self, [scale, offset, lower, upper]: [Self; 4]) -> bool {
        let ok = |i: usize| {
            crate::eval::layout::within(x.0[i], (scale.0[i], offset.0[i], lower.0[i], upper.0[i]))
        };
        ok(0) & ok(1) & ok(2) & ok(3)
    }
    #[inline(always)]
    fn load(v: &[f64; 4]) -> Self {
        Portable(*v, std::marker::PhantomData)
    }
    #[inline(always)]
    fn store_frame(frame: [Self; 4], out: &mut [f64; 12]) {
        for (column, entries) in frame.iter().zip(out.chunks_exact_mut(3)) {
            entries.copy_from_slice(&column.0[..3]);
        }
    }
    #[inline(always)]
    fn store(self, out: &mut [f64; 4]) {
        *out = self.0;
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Portable([x; 4], std::marker::PhantomData)
    }
    #[inline(always)]
    fn from_entries(e: [f64; 4]) -> Self {
        Portable(e, std::marker::PhantomData)
    }
    #[inline(always)]
    fn mul_add(a: Self, b: Self, c: Self) -> Self {
        Self::map(|k| A::mul_add(a.0[k], b.0[k], c.0[k]))
    }
    #[inline(always)]
    fn mul(a: Self, b: Self) -> Self {
        Self::map(|k| a.0[k] * b.0[k])
    }
    #[inline(always)]
    fn add(a: Self, b: Self) -> Self {
        Self::map(|k| a.0[k] + b.0[k])
    }
    #[inline(always)]
    fn sub(a: Self, b: Self) -> Self {
        Self::map(|k| a.0[k] - b.0[k])
    }
    #[inline(always)]
    fn neg(self) -> Self {
        Self::map(|k| -self.0[k])
    }
    #[inline(always)]
    fn yzx(self) -> Self {
        let v = self.0;
        Portable([v[1], v[2], v[0], v[3]], std::marker::PhantomData)
    }
    #[inline(always)]
    fn zxy(self) -> Self {
        let v = self.0;
        Portable([v[2], v[0], v[1], v[3]], std::marker::PhantomData)
    }
}

/// [`Col`] in an AVX register, with FMA.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx(std::arch::x86_64::__m256d);

/// [`crate::eval::layout::within`] for four values at once, each against the same entry of
/// `(scale, offset, lower, upper)`: the product and the sum rounded separately, then three
/// compares. Used by [`Avx`] and the AVX2 batch lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn within_all_256(
    x: std::arch::x86_64::__m256d,
    [scale, offset, lower, upper]: [std::arch::x86_64::__m256d; 4],
) -> bool {
    use std::arch::x86_64::{
        _CMP_GE_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm256_add_pd, _mm256_and_pd, _mm256_andnot_pd,
        _mm256_cmp_pd, _mm256_movemask_pd, _mm256_mul_pd, _mm256_set1_pd,
    };
    // SAFETY: only called from code compiled with, or dispatched to after detecting, AVX.
    unsafe {
        let value = _mm256_add_pd(_mm256_mul_pd(scale, x), offset);
        let abs = _mm256_andnot_pd(_mm256_set1_pd(-0.0), x);
        let finite = _mm256_cmp_pd::<_CMP_LT_OQ>(abs, _mm256_set1_pd(f64::INFINITY));
        let low = _mm256_cmp_pd::<_CMP_GE_OQ>(value, lower);
        let high = _mm256_cmp_pd::<_CMP_LE_OQ>(value, upper);
        _mm256_movemask_pd(_mm256_and_pd(finite, _mm256_and_pd(low, high))) == 0b1111
    }
}

// SAFETY (every `unsafe` block below): `Avx` is the column type of `Fused` only, and `Fused` runs
// only where `isa()` has reported AVX2 and FMA (inside the `fma_dispatch!` functions, or in tests
// guarded by that check); the pointer operations read and write through references of the
// stated sizes.
#[cfg(target_arch = "x86_64")]
impl Col for Avx {
    #[inline(always)]
    fn admitted(x: Self, [scale, offset, lower, upper]: [Self; 4]) -> bool {
        within_all_256(x.0, [scale.0, offset.0, lower.0, upper.0])
    }
    #[inline(always)]
    fn load(v: &[f64; 4]) -> Self {
        use std::arch::x86_64::_mm256_loadu_pd;
        Avx(unsafe { _mm256_loadu_pd(v.as_ptr()) })
    }
    #[inline(always)]
    fn store_frame([r0, r1, r2, p]: [Self; 4], out: &mut [f64; 12]) {
        use std::arch::x86_64::_mm256_storeu_pd as store;
        use std::arch::x86_64::{_mm256_blend_pd as blend, _mm256_permute4x64_pd as permute};
        // Three vectors of four entries, each a blend of two permuted columns (the compiler
        // chooses the shuffles: six on AVX-512, where it has two-source permutes).
        unsafe {
            // [r0x r0y r0z r1x]
            let a = blend::<0b1000>(r0.0, permute::<0b00_00_00_00>(r1.0));
            // [r1y r1z r2x r2y]
            let b = blend::<0b1100>(
                permute::<0b00_00_10_01>(r1.0),
                permute::<0b01_00_00_00>(r2.0),
            );
            // [r2z px py pz]
            let c = blend::<0b0001>(
                permute::<0b10_01_00_00>(p.0),
                permute::<0b00_00_00_10>(r2.0),
            );
            let out = out.as_mut_ptr();
            store(out, a);
            store(out.add(4), b);
            store(out.add(8), c);
        }
    }
    #[inline(always)]
    fn store(self, out: &mut [f64; 4]) {
        use std::arch::x86_64::_mm256_storeu_pd;
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        use std::arch::x86_64::_mm256_set1_pd;
        Avx(unsafe { _mm256_set1_pd(x) })
    }
    #[inline(always)]
    fn from_entries(e: [f64; 4]) -> Self {
        use std::arch::x86_64::_mm256_set_pd;
        Avx(unsafe { _mm256_set_pd(e[3], e[2], e[1], e[0]) })
    }
    #[inline(always)]
    fn mul_add(a: Self, b: Self, c: Self) -> Self {
        use std::arch::x86_64::_mm256_fmadd_pd;
        Avx(unsafe { _mm256_fmadd_pd(a.0, b.0, c.0) })
    }
    #[inline(always)]
    fn mul(a: Self, b: Self) -> Self {
        use std::arch::x86_64::_mm256_mul_pd;
        Avx(unsafe { _mm256_mul_pd(a.0, b.0) })
    }
    #[inline(always)]
    fn add(a: Self, b: Self) -> Self {
        use std::arch::x86_64::_mm256_add_pd;
        Avx(unsafe { _mm256_add_pd(a.0, b.0) })
    }
    #[inline(always)]
    fn sub(a: Self, b: Self) -> Self {
        use std::arch::x86_64::_mm256_sub_pd;
        Avx(unsafe { _mm256_sub_pd(a.0, b.0) })
    }
    #[inline(always)]
    fn neg(self) -> Self {
        use std::arch::x86_64::{_mm256_set1_pd, _mm256_xor_pd};
        Avx(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
    }
    #[inline(always)]
    fn yzx(self) -> Self {
        use std::arch::x86_64::_mm256_permute4x64_pd;
        Avx(unsafe { _mm256_permute4x64_pd::<0b11_00_10_01>(self.0) })
    }
    #[inline(always)]
    fn zxy(self) -> Self {
        use std::arch::x86_64::_mm256_permute4x64_pd;
        Avx(unsafe { _mm256_permute4x64_pd::<0b11_01_00_10>(self.0) })
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
        $crate::eval::arith::fma_dispatch!(@wide false, $($function)*);
    };
    (@wide $wide:literal, $(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? => $generic:ident) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
                fn with_avx512($($arg: $ty),*) $(-> $ret)? {
                    $generic::<$crate::eval::arith::Fused512>($($arg),*)
                }
                #[target_feature(enable = "avx2,fma")]
                fn with_avx2($($arg: $ty),*) $(-> $ret)? {
                    $generic::<$crate::eval::arith::Fused>($($arg),*)
                }
                match $crate::eval::arith::isa() {
                    // SAFETY: `isa()` reports these features only when the CPU has them.
                    $crate::eval::arith::Isa::Avx512 if $wide => return unsafe { with_avx512($($arg),*) },
                    // SAFETY: as above (AVX-512 is reported only with AVX2 and FMA).
                    $crate::eval::arith::Isa::Avx512 | $crate::eval::arith::Isa::Avx2 => {
                        return unsafe { with_avx2($($arg),*) }
                    }
                    $crate::eval::arith::Isa::Baseline => {}
                }
            }
            // Not inlined, so that the dispatch stays a few instructions (no frame of its own).
            #[inline(never)]
            fn baseline($($arg: $ty),*) $(-> $ret)? {
                $generic::<$crate::eval::arith::Separate>($($arg),*)
            }
            baseline($($arg),*)
        }
    };
    ($($function:tt)*) => {
        $crate::eval::arith::fma_dispatch!(@wide true, $($function)*);
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
