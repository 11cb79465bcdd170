//! What the processor can do, detected once at run time: the hot kernels have an AVX2 build
//! beside their x86-64 baseline (SSE2) one, chosen per call (the way meshoptimizer picks its
//! SIMD paths), so an engine that links the generic static library still gets the wider
//! instruction set where the machine has it.
//!
//! Both builds run the same source with the same operations in the same order: AVX2 only
//! changes the encoding (three-operand VEX forms, broadcasts from memory), never the
//! arithmetic. FMA is deliberately not enabled (it would round `a·b + c` once instead of twice),
//! so results are bit-identical whichever build runs, and a world steps identically on any
//! x86-64 machine. `no_std`: the detection reads `cpuid` and `xgetbv` directly.

/// Defines the kernel `$name` as a dispatcher over two builds of the `#[inline(always)]`
/// function `$body` (same parameters): `$avx2`, compiled for AVX2, where [`avx2`] says the
/// processor has it, else `$body` itself (the baseline build).
macro_rules! multiversion {
    ($(#[$attr:meta])* $vis:vis fn $name:ident, $avx2:ident => $body:ident
        ($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty) => {
        $(#[$attr])*
        $vis fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if $crate::cpu::avx2() {
                // SAFETY: the processor supports AVX2 (detected by `cpu::avx2`).
                return unsafe { $avx2($($arg),*) };
            }
            $body($($arg),*)
        }

        /// The AVX2 build of the kernel above (its parameters are the kernel's, however many).
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        #[allow(clippy::too_many_arguments)]
        fn $avx2($($arg: $ty),*) -> $ret {
            $body($($arg),*)
        }
    };
}
pub(crate) use multiversion;

#[cfg(all(target_arch = "x86_64", not(miri), not(target_feature = "avx2")))]
mod detect {
    use core::sync::atomic::{AtomicU8, Ordering};

    /// 0: not yet detected, 1: no AVX2, 2: AVX2.
    static AVX2: AtomicU8 = AtomicU8::new(0);

    /// Whether the processor and the operating system support AVX2 (cached after the first
    /// call; a race only detects twice).
    #[inline]
    pub(crate) fn avx2() -> bool {
        match AVX2.load(Ordering::Relaxed) {
            0 => {
                let yes = probe();
                AVX2.store(if yes { 2 } else { 1 }, Ordering::Relaxed);
                yes
            }
            v => v == 2,
        }
    }

    #[cold]
    fn probe() -> bool {
        use core::arch::x86_64::{__cpuid, __cpuid_count};
        // SAFETY: `cpuid` exists on every x86-64 processor; leaf 7 is read only when leaf 0
        // says it exists.
        #[allow(unused_unsafe)]
        let (max_leaf, leaf1) = unsafe { (__cpuid(0).eax, __cpuid(1)) };
        const OSXSAVE: u32 = 1 << 27;
        const AVX: u32 = 1 << 28;
        if max_leaf < 7 || leaf1.ecx & OSXSAVE == 0 || leaf1.ecx & AVX == 0 {
            return false;
        }
        // The OS saves the YMM registers on a context switch (XCR0 bits 1 and 2).
        let xcr0_low: u32;
        // SAFETY: `xgetbv` with ECX = 0 is valid whenever CPUID reports OSXSAVE (checked
        // above); it only reads XCR0 into EDX:EAX.
        unsafe {
            core::arch::asm!(
                "xgetbv",
                in("ecx") 0u32,
                out("eax") xcr0_low,
                out("edx") _,
                options(nomem, nostack, preserves_flags),
            );
        }
        if xcr0_low & 0b110 != 0b110 {
            return false;
        }
        // SAFETY: leaf 7 exists (max_leaf ≥ 7).
        #[allow(unused_unsafe)]
        let leaf7 = unsafe { __cpuid_count(7, 0) };
        leaf7.ebx & (1 << 5) != 0
    }
}

/// Whether the AVX2 builds of the kernels may run here: detected on x86-64 (always true when
/// the whole crate is built for AVX2, e.g. `-C target-cpu=x86-64-v3`), false elsewhere and
/// under Miri.
#[inline]
pub(crate) fn avx2() -> bool {
    #[cfg(all(target_arch = "x86_64", not(miri), not(target_feature = "avx2")))]
    {
        detect::avx2()
    }
    #[cfg(all(target_arch = "x86_64", not(miri), target_feature = "avx2"))]
    {
        true
    }
    #[cfg(not(all(target_arch = "x86_64", not(miri))))]
    {
        false
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn detection_is_stable() {
        // Cached after the first call: the same answer every time.
        let first = super::avx2();
        for _ in 0..3 {
            assert_eq!(super::avx2(), first);
        }
    }
}
