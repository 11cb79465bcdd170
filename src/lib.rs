//! weft: a cloth-simulation kernel for heterogeneous, anisotropic periodic fabrics.
//!
//! The method is Saito, Umetani & Morishima 2014, "Macroscopic and microscopic deformation
//! coupling in up-sampled cloth simulation" (CAVW 25:437–446). Equation numbers in comments
//! refer to that paper.
//!
//! Two halves:
//! * offline (`std` feature): [`cell`] describes a periodic unit cell, [`homogenize`] solves
//!   its cell problem (§4), [`blob`] writes the result;
//! * runtime (`no_std`, no allocation): [`blob`] reads cells in place, [`world`] steps the
//!   coarse cloth (§5), [`localize`] puts the fine pattern back on it (§6), [`ffi`] exports it to C.
//!
//! Conventions (fixed, see `docs/CONVENTIONS.md`): Voigt order `[11, 22, 12]`, engineering
//! shear strain `[e11, e22, 2 e12]`, membrane stiffness in N/m, areal density in kg/m²,
//! material space `(u, v)` in metres.
#![cfg_attr(not(any(feature = "std", test)), no_std)]
#![forbid(unsafe_op_in_unsafe_fn)]
// One lint policy for the whole library, runtime and std side alike: nothing indexes,
// unwraps or panics. `#[cfg(test)]` modules opt out with their own `#[allow]`.
#![cfg_attr(
    not(test),
    deny(
        clippy::indexing_slicing,
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::unreachable
    )
)]

// The shipped static library is no_std with panic = "abort": the kernel is panic-free by
// construction, and should a panic ever happen it stops here instead of unwinding into C.
// `cargo test` builds with unwinding, where std's handler is used instead.
#[cfg(all(not(feature = "std"), not(test), panic = "abort"))]
#[panic_handler]
fn on_panic(_: &core::panic::PanicInfo<'_>) -> ! {
    extern "C" {
        // The C runtime's `abort` (every program that links the static library has one).
        fn abort() -> !;
    }
    // SAFETY: `abort` takes nothing and never returns.
    unsafe { abort() }
}
// A non-LTO no_std static library can keep a reference to the unwinding personality from the
// precompiled `core` (rust-lang/rust#56152) although nothing unwinds; this stub resolves it.
// It is outside `src/ffi/`, so cbindgen never sees it.
#[cfg(all(not(feature = "std"), not(test), panic = "abort"))]
#[no_mangle]
extern "C" fn rust_eh_personality() {}
#[cfg(all(not(feature = "std"), not(test), panic = "unwind"))]
extern crate std;

pub mod bending;
pub mod blob;
pub mod collide;
mod cpu;
pub mod ffi;
pub mod lattice;
pub mod localize;
pub mod membrane;
pub mod mesh;
pub mod multigrid;
pub mod normals;
pub mod pcg;
#[cfg(feature = "research")]
pub mod research;
pub mod sparse;
mod step;
pub mod strided;
pub mod voigt;
pub mod world;

#[cfg(feature = "std")]
pub mod cell;
#[cfg(feature = "std")]
pub mod homogenize;

pub use voigt::Voigt;
