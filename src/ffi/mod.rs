//! The C ABI: `weft_*` functions, `Weft*` types and `WEFT_*` constants, declared in
//! `include/weft.h` (generated from this folder by cbindgen 0.29.4 with `cbindgen.toml`;
//! `tests/header.rs` fails when the committed header is stale, `WEFT_BLESS=1` rewrites it).
//!
//! This layer only converts and checks: every pointer is tested for NULL (and alignment where
//! it is typed), every enum-like input arrives as `u32` and is validated, every count and
//! stride is checked with overflow-free arithmetic, and outputs are written only on success.
//! The physics, and the formats of the blocks C callers own (bindings, frames), are the safe
//! slice-based kernel's (`crate::world`, `crate::localize`); nothing here allocates and
//! nothing panics (the kernel is panic-free by construction; the shipped no_std build aborts
//! should it ever happen, so no unwind crosses the boundary).
//!
//! Memory is the caller's. A world lives entirely inside the block the engine hands to
//! `weft_world_create`: the `WeftWorld` header (at the block's start, which must be
//! `WEFT_WORLD_MEMORY_ALIGN`-aligned), then the kernel's arrays (`Capacity::world_bytes`).
//! The kernel reads the caller's (strided) vertex buffers in place, so nothing else is kept.
//! The blob is borrowed in place, never copied.
//!
//! One file per concept: `types` (the `#[repr(C)]` structs and the world handle), `result`
//! (`WeftResult`, `WeftErrorDetail`, messages, kernel errors as details), `convert` (pointer
//! and stride checks, handle lookup, C <-> kernel conversions), `blob`, `world` (defaults,
//! memory size, create/destroy, step, settings, sleep, counts), `edit` (vertex I/O, pins,
//! colliders), `localize` (binding, frames, localization, tiled meshes). This file holds the
//! constants, the cookies and their compile-time agreement with the kernel.
//!
//! Comments starting with `///` become the header's documentation: they are written for a C
//! programmer who never reads the Rust.

use core::mem::{align_of, size_of};

use crate::localize::blocks;

// The files, in the order cbindgen reads them (after this file's own items): the header lists
// the functions in this order, so each `mod` stands alone (rustfmt sorts adjacent ones).
mod types;

mod convert;

mod result;

mod blob;

mod world;

mod edit;

mod localize;

mod layout;

pub use blob::*;
pub use edit::*;
pub use localize::*;
pub use result::*;
pub use types::*;
pub use world::*;

/// Major version of this library (semantic versioning).
pub const WEFT_VERSION_MAJOR: u32 = 0;
/// Minor version of this library.
pub const WEFT_VERSION_MINOR: u32 = 1;
/// Patch version of this library.
pub const WEFT_VERSION_PATCH: u32 = 0;
/// The version this header describes, `(major << 16) | (minor << 8) | patch`. Compare it with
/// `weft_version()` at start-up to catch a header/library mismatch.
pub const WEFT_VERSION: u32 =
    (WEFT_VERSION_MAJOR << 16) | (WEFT_VERSION_MINOR << 8) | WEFT_VERSION_PATCH;

/// The cell-blob format version this library reads (`weft_blob_parse` refuses any other with
/// `WEFT_RESULT_BLOB_VERSION`).
pub const WEFT_BLOB_VERSION: u32 = 1;
/// Required alignment (bytes) of a blob's first byte. `malloc` memory always qualifies.
pub const WEFT_BLOB_ALIGN: usize = 8;

/// "No index": the value of a `WeftErrorDetail` field that does not apply.
pub const WEFT_NONE: u32 = 0xFFFF_FFFF;

/// Effect bit: gravity (`WeftSettings.gravity`).
pub const WEFT_EFFECT_GRAVITY: u32 = 1 << 0;
/// Effect bit: hinge bending (the cells' bending stiffness).
pub const WEFT_EFFECT_BENDING: u32 = 1 << 1;
/// Effect bit: Rayleigh damping (`damping_mass`, `damping_stiffness`).
pub const WEFT_EFFECT_DAMPING: u32 = 1 << 2;
/// Effect bit: pins hold their vertices on their targets. Off: pins are kept but ignored.
pub const WEFT_EFFECT_PINS: u32 = 1 << 3;
/// Effect bit: collisions with the world's colliders. Off: colliders are kept but ignored.
pub const WEFT_EFFECT_COLLISION: u32 = 1 << 4;
/// Effect bit: wind and air drag (`wind`, `drag`).
pub const WEFT_EFFECT_WIND: u32 = 1 << 5;
/// Effect bit: the rotation-invariant membrane (Green strain: the warped stiffness of §5.2),
/// needed for large rotations. Off: plain linear FEM in the rest plane (for accuracy studies; a
/// cloth turned away from its rest plane then stores spurious strain energy, and releases it).
pub const WEFT_EFFECT_WARPING: u32 = 1 << 6;
/// Effect bit: a cloth at rest goes to sleep (`sleep_velocity`, `sleep_frames`) and costs
/// nothing until an edit or `weft_world_wake` wakes it.
pub const WEFT_EFFECT_SLEEP: u32 = 1 << 7;
/// Every effect bit; any other bit set is `WEFT_RESULT_INVALID_SETTING`.
pub const WEFT_EFFECT_ALL: u32 = (1 << 8) - 1;

/// `WeftShape.kind`: a half-space, solid where `dot(normal, x) < offset`.
pub const WEFT_SHAPE_PLANE: u32 = 0;
/// `WeftShape.kind`: a sphere.
pub const WEFT_SHAPE_SPHERE: u32 = 1;
/// `WeftShape.kind`: a segment swept by a sphere.
pub const WEFT_SHAPE_CAPSULE: u32 = 2;
/// `WeftShape.kind`: a hollow sphere; the cloth is kept inside it.
pub const WEFT_SHAPE_SHELL: u32 = 3;

/// Default `WeftCapacity.max_vertices` (a 64 × 64-vertex cloth).
pub const WEFT_DEFAULT_MAX_VERTICES: u32 = 4096;
/// Default `WeftCapacity.max_triangles`.
pub const WEFT_DEFAULT_MAX_TRIANGLES: u32 = 8064;
/// Default `WeftCapacity.max_edges`.
pub const WEFT_DEFAULT_MAX_EDGES: u32 = 12160;
/// Default `WeftCapacity.max_colliders`.
pub const WEFT_DEFAULT_MAX_COLLIDERS: u32 = 8;
/// Default `WeftCapacity.max_pins`.
pub const WEFT_DEFAULT_MAX_PINS: u32 = 64;

/// Required alignment (bytes) of a world's memory block. `malloc` on 64-bit desktop and console
/// platforms returns 16-aligned memory; otherwise use `aligned_alloc` / `_Alignas`.
pub const WEFT_WORLD_MEMORY_ALIGN: usize = 16;
/// Bytes at the start of a world's memory block reserved for the world header (the
/// `WeftWorld` the handle points to). Part of every `weft_world_memory_size` result.
pub const WEFT_WORLD_HEADER_SIZE: usize = 2048;
/// `weft_world_memory_size` of the default capacity (`WEFT_DEFAULT_MAX_*`) on 64-bit targets,
/// in bytes, a multiple of `WEFT_WORLD_MEMORY_ALIGN`: lets a default-capacity world live in a
/// static array. It changes between library versions; query `weft_world_memory_size` for any
/// other capacity.
pub const WEFT_DEFAULT_WORLD_MEMORY_SIZE: usize = 3_900_784;

/// A world's origin at create is the centre of the cloth's bounding box rounded to a multiple
/// of this many metres (`weft_world_get_origin`); a step moves it once the cloth's centre is
/// farther than this from it.
pub const WEFT_ORIGIN_GRID: f64 = 4.0;

/// `strain_measure` of `weft_localize_prepare`: each coarse triangle's deformation gradient is
/// split into rotation and stretch (F = R U, polar decomposition); the macro strain is U - I
/// (Biot) and R carries the micro displacement into 3D, so the fine pattern follows the cell
/// problem's linear solution; use this one unless you want the paper verbatim. (The coarse step
/// itself measures Green strain; the two agree to first order.) Either measure takes one
/// strain per coarse triangle (blended to its vertices): where the macro strain varies across
/// a triangle (e.g. a stiff laminate hanging under its own weight, strain rising by `S ρ g` per
/// metre up the cloth, `S` the compliance along the pull, `ρ` the areal density) a layer's
/// strain is off by up to `± S ρ g t / 2` for a triangle `t` metres tall: refine the coarse
/// cloth where that matters.
pub const WEFT_STRAIN_COROTATED: u32 = 0;
/// `strain_measure` of `weft_localize_prepare`: the paper verbatim, Green strain (FᵀF - I)/2
/// (Eq. 19) carried into 3D by F itself. Agrees with `WEFT_STRAIN_COROTATED` to first order
/// only: under stretch it overshoots the micro fluctuation, and the stiff layers' small strain
/// comes out far too small — by 7 % at 1 % stretch and 14 % at 2 % across a 10:1 laminate
/// (tests/localize.rs), and by 62 % on the hard layer at 1 % stretch of a stiffer laminate (an
/// outside measurement). Use it only to reproduce the paper.
pub const WEFT_STRAIN_GREEN: u32 = 1;

/// `weft_world_set_solver`: CG preconditioned by an aggregation multigrid K-cycle (the default).
pub const WEFT_SOLVER_MULTIGRID: u32 = 0;
/// `weft_world_set_solver`: CG preconditioned by the inverse 3×3 diagonal blocks.
pub const WEFT_SOLVER_BLOCK_JACOBI: u32 = 1;
/// `weft_world_set_solver`: `WEFT_SOLVER_MULTIGRID` with its finest level smoothed along lines
/// of dominant couplings, for materials much stiffer along one direction than across it
/// (experimental: less robust than the default on extreme scenes, see the README).
pub const WEFT_SOLVER_MULTIGRID_LINES: u32 = 2;

/// `WeftLocalizeOutput.normal_mode`: each fine normal is the barycentric blend of the coarse
/// vertex normals (smooth; about 1.8 × the cost of positions alone: 1.72 × measured by
/// `examples/bench_localize.rs`, 1.84 × by an outside client).
pub const WEFT_NORMALS_BLENDED: u32 = 0;
/// `WeftLocalizeOutput.normal_mode`: normals recomputed from the localized fine triangles
/// (`WeftLocalizeOutput.fine_indices`), so they show the micro pattern's relief; about 6 × the
/// cost of positions alone.
pub const WEFT_NORMALS_RECOMPUTED: u32 = 1;

/// `WeftLocalizeOutput.collider_mode`: colliders play no part in localization (the default,
/// at no cost). Between the coarse vertices, which the step keeps outside the colliders, the
/// fine surface can then cut into a collider the coarse cloth wraps (centimetres into a pole
/// or a leg at a coarse spacing of 7–12 cm).
pub const WEFT_COLLIDERS_IGNORED: u32 = 0;
/// `WeftLocalizeOutput.collider_mode`: each fine vertex that ends inside one of the world's
/// colliders (their shapes as last set, kept at their thickness) is pushed out along its
/// blended coarse normal (along the collider's own normal where the two meet at a grazing
/// angle), one collider after the other. The push depends on the vertex's position and normal
/// only, so vertices shared across coarse triangles, ranges or seams stay together (no
/// cracks); vertices outside every collider are written exactly as with
/// `WEFT_COLLIDERS_IGNORED`. Cost: a distance query per vertex and collider.
pub const WEFT_COLLIDERS_OUTSIDE: u32 = 1;

/// Bytes at the start of a bindings block: its vertex count and a key of the cloth (mesh, rest
/// (u, v), materials and blob) it was made for. Part of every `weft_bind_memory_size` result.
pub const WEFT_BIND_HEADER_SIZE: usize = 16;
/// Bytes per fine vertex in a bindings block (its coarse triangle, barycentric place and the
/// cell's characteristic displacements there).
pub const WEFT_BIND_VERTEX_SIZE: usize = 36;
/// Required alignment (bytes) of a bindings block. `malloc` memory always qualifies.
pub const WEFT_BIND_MEMORY_ALIGN: usize = 4;
/// Bytes at the start of a frames block (which world it was prepared for). Part of every
/// `weft_localize_frames_size` result.
pub const WEFT_LOCALIZE_FRAMES_HEADER_SIZE: usize = 32;
/// Bytes per coarse vertex in a frames block.
pub const WEFT_LOCALIZE_FRAME_SIZE: usize = 80;
/// Required alignment (bytes) of a frames block. `malloc` on 64-bit desktop and console
/// platforms returns 16-aligned memory; otherwise use `aligned_alloc` / `_Alignas`.
pub const WEFT_LOCALIZE_FRAMES_ALIGN: usize = 16;

const WORLD_DEF_COOKIE: u32 = 0x5746_4431; // "WFD1"
const COLLIDER_DEF_COOKIE: u32 = 0x5746_4331; // "WFC1"
const BLOB_COOKIE: u32 = 0x5746_4231; // "WFB1"
const WORLD_COOKIE: u64 = 0x5745_4654_574f_524c; // "WEFTWORL"
const LOCALIZE_OUTPUT_COOKIE: u32 = 0x5746_4C31; // "WFL1"

// The header reservation holds the handle struct, whatever the kernel's `World` grows to.
const _: () = assert!(size_of::<WeftWorld>() <= WEFT_WORLD_HEADER_SIZE);
const _: () = assert!(align_of::<WeftWorld>() <= WEFT_WORLD_MEMORY_ALIGN);
const _: () = assert!(WEFT_WORLD_HEADER_SIZE.is_multiple_of(WEFT_WORLD_MEMORY_ALIGN));
const _: () = assert!(WEFT_BLOB_ALIGN == crate::blob::BASE_ALIGN);
const _: () = assert!(WEFT_BLOB_VERSION == crate::blob::VERSION);
const _: () = assert!(WEFT_EFFECT_ALL == crate::world::effects::ALL);
const _: () = assert!(WEFT_ORIGIN_GRID == crate::world::ORIGIN_GRID);
// Bindings and frames blocks are the kernel's formats, viewed in place in the caller's blocks.
const _: () = assert!(WEFT_BIND_HEADER_SIZE == blocks::BINDINGS_HEADER_SIZE);
const _: () = assert!(WEFT_BIND_VERTEX_SIZE == blocks::BINDING_SIZE);
const _: () = assert!(WEFT_BIND_MEMORY_ALIGN == blocks::BINDINGS_ALIGN);
const _: () = assert!(WEFT_LOCALIZE_FRAMES_HEADER_SIZE == blocks::FRAMES_HEADER_SIZE);
const _: () = assert!(WEFT_LOCALIZE_FRAME_SIZE == blocks::FRAME_SIZE);
const _: () = assert!(WEFT_LOCALIZE_FRAMES_ALIGN == blocks::FRAMES_ALIGN);

/// The library's version, `(major << 16) | (minor << 8) | patch`; equals `WEFT_VERSION` when
/// the header matches the library.
#[no_mangle]
pub extern "C" fn weft_version() -> u32 {
    WEFT_VERSION
}
