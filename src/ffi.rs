//! The C ABI: `weft_*` functions, `Weft*` types and `WEFT_*` constants, declared in
//! `include/weft.h` (generated from this file by cbindgen 0.29.4 with `cbindgen.toml`;
//! `tests/header.rs` fails when the committed header is stale, `WEFT_BLESS=1` rewrites it).
//!
//! This layer only converts and checks: every pointer is tested for NULL (and alignment where
//! it is typed), every enum-like input arrives as `u32` and is validated, every count and
//! stride is checked with overflow-free arithmetic, and outputs are written only on success.
//! The physics is the safe slice-based kernel ([`crate::world`]); nothing here allocates and
//! nothing panics (the kernel is panic-free by construction; the shipped no_std build aborts
//! should it ever happen, so no unwind crosses the boundary).
//!
//! Memory is the caller's. A world lives entirely inside the block the engine hands to
//! [`weft_world_create`]: the [`WeftWorld`] header (at the block's start, which must be
//! [`WEFT_WORLD_MEMORY_ALIGN`]-aligned), then the kernel's arrays ([`Capacity::world_bytes`]),
//! then a scratch area for the strided input (used only during create). The blob is borrowed in
//! place, never copied.
//!
//! Comments starting with `///` become the header's documentation: they are written for a C
//! programmer who never reads the Rust.
#![deny(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::unreachable
)]

use core::ffi::{c_char, c_void, CStr};
use core::mem::{align_of, size_of};
use core::ptr;

use glam::Vec3A;

use crate::blob::{self, Blob, BlobError};
use crate::collide::{Collider, Shape};
use crate::localize::{self, BindError, Binding, NormalTarget, StrainMeasure, VertexFrame};
use crate::mesh::MeshError;
use crate::strided::{Strided, StridedMut};
use crate::world::{
    effects, Capacity, ClothDef, EditError, InitError, Materials, Settings, StepError, StepStats,
    World,
};

// ---------------------------------------------------------------------------------------------
// Constants
// ---------------------------------------------------------------------------------------------

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
/// Effect bit: warped (corotated) stiffness, needed for large rotations. Off: plain linear FEM.
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
pub const WEFT_DEFAULT_WORLD_MEMORY_SIZE: usize = 4_186_656;

/// `strain_measure` of `weft_localize_prepare`: each coarse triangle's deformation gradient is
/// split into rotation and stretch (F = R U, polar decomposition); the macro strain is U - I
/// (Biot) and R carries the micro displacement into 3D. The strain measure of the coarse step's
/// corotated elements, so the fine pattern matches the cell problem's linear solution; use this
/// one unless you want the paper verbatim.
pub const WEFT_STRAIN_COROTATED: u32 = 0;
/// `strain_measure` of `weft_localize_prepare`: the paper verbatim, Green strain (FᵀF - I)/2
/// (Eq. 19) carried into 3D by F itself. Agrees with `WEFT_STRAIN_COROTATED` to first order;
/// overshoots the micro fluctuation slightly under stretch.
pub const WEFT_STRAIN_GREEN: u32 = 1;

/// `WeftLocalizeOutput.normal_mode`: each fine normal is the barycentric blend of the coarse
/// vertex normals (smooth, cheap: about 1.3 × the cost of positions alone).
pub const WEFT_NORMALS_BLENDED: u32 = 0;
/// `WeftLocalizeOutput.normal_mode`: normals recomputed from the localized fine triangles
/// (`WeftLocalizeOutput.fine_indices`), so they show the micro pattern's relief; about 6 × the
/// cost of positions alone.
pub const WEFT_NORMALS_RECOMPUTED: u32 = 1;

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

/// Sizes of the scratch area the strided input is gathered into during create.
const STAGE_VERTEX_BYTES: usize = size_of::<[f32; 3]>() + size_of::<[f32; 2]>();
const STAGE_TRIANGLE_BYTES: usize = size_of::<[u32; 3]>() + size_of::<u32>();

const WORLD_DEF_COOKIE: u32 = 0x5746_4431; // "WFD1"
const COLLIDER_DEF_COOKIE: u32 = 0x5746_4331; // "WFC1"
const BLOB_COOKIE: u32 = 0x5746_4231; // "WFB1"
const WORLD_COOKIE: u64 = 0x5745_4654_574f_524c; // "WEFTWORL"
const LOCALIZE_OUTPUT_COOKIE: u32 = 0x5746_4C31; // "WFL1"
const BINDINGS_COOKIE: u32 = 0x5742_4E31; // "WBN1"
const FRAMES_COOKIE: u32 = 0x5746_5231; // "WFR1"

// The header reservation holds the handle struct, whatever the kernel's `World` grows to.
const _: () = assert!(size_of::<WeftWorld>() <= WEFT_WORLD_HEADER_SIZE);
const _: () = assert!(align_of::<WeftWorld>() <= WEFT_WORLD_MEMORY_ALIGN);
const _: () = assert!(WEFT_WORLD_HEADER_SIZE % WEFT_WORLD_MEMORY_ALIGN == 0);
const _: () = assert!(WEFT_BLOB_ALIGN == blob::BASE_ALIGN);
const _: () = assert!(WEFT_BLOB_VERSION == blob::VERSION);
const _: () = assert!(WEFT_EFFECT_ALL == effects::ALL);
// Bindings and frames are the kernel's own records, viewed in place in the caller's blocks.
const _: () = assert!(size_of::<Binding>() == WEFT_BIND_VERTEX_SIZE);
const _: () = assert!(align_of::<Binding>() <= WEFT_BIND_MEMORY_ALIGN);
const _: () = assert!(WEFT_BIND_HEADER_SIZE % align_of::<Binding>() == 0);
const _: () = assert!(WEFT_BIND_HEADER_SIZE == size_of::<[u32; 4]>());
const _: () = assert!(size_of::<VertexFrame>() == WEFT_LOCALIZE_FRAME_SIZE);
const _: () = assert!(align_of::<VertexFrame>() <= WEFT_LOCALIZE_FRAMES_ALIGN);
const _: () = assert!(size_of::<FramesHeader>() <= WEFT_LOCALIZE_FRAMES_HEADER_SIZE);
const _: () = assert!(align_of::<FramesHeader>() <= WEFT_LOCALIZE_FRAMES_ALIGN);
const _: () = assert!(WEFT_LOCALIZE_FRAMES_HEADER_SIZE % WEFT_LOCALIZE_FRAMES_ALIGN == 0);
const _: () = assert!(WEFT_LOCALIZE_FRAME_SIZE % WEFT_LOCALIZE_FRAMES_ALIGN == 0);

// ---------------------------------------------------------------------------------------------
// Types
// ---------------------------------------------------------------------------------------------

/// Result of every fallible call. `WEFT_RESULT_OK` (0) is success; `weft_result_string` names
/// any value. Calls that fail write none of their outputs (a `WeftErrorDetail` excepted, which
/// says where the problem is: see each value). Values are stable across versions; 80–99 are
/// reserved for localization.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeftResult {
    /// Success.
    Ok = 0,
    /// A required pointer argument is NULL. `detail.what` names the argument.
    NullPointer = 1,
    /// A def (`WeftWorldDef`, `WeftColliderDef`) was not made by its `weft_default_*` function,
    /// or a `WeftBlob` was not filled by `weft_blob_parse`: uninitialized memory, or a struct
    /// from another version of the header. `detail.what` names the argument.
    Uninitialized = 2,
    /// The `WeftWorld*` is not a live world: never created, destroyed, or its memory block was
    /// moved or overwritten.
    InvalidHandle = 3,
    /// An argument is out of its range: an unknown enum value, a stride smaller than the
    /// element, a flag that is not 0 or 1. `detail.what` names the argument or field.
    InvalidArgument = 4,
    /// A pointer is not aligned for its type, or the world memory block is not
    /// `WEFT_WORLD_MEMORY_ALIGN`-aligned. `detail.what` names the argument.
    Misaligned = 5,
    /// A vertex count argument does not match the world (`weft_world_set_positions` needs
    /// exactly `weft_world_vertex_count`, the getters at least that many).
    /// `detail.needed` is the count required.
    CountMismatch = 6,
    /// An internal consistency check failed (a bug in weft; please report it).
    Internal = 7,

    /// The memory block is smaller than `weft_world_memory_size` says. `detail.what` is
    /// "memory_size".
    MemoryTooSmall = 20,
    /// The capacity's memory size does not fit in `size_t` on this target.
    CapacityTooLarge = 21,
    /// The mesh has more vertices than `capacity.max_vertices`: `detail.needed` vertices,
    /// `detail.capacity` the capacity.
    VertexCapacity = 22,
    /// The mesh has more triangles than `capacity.max_triangles` (`detail.needed`,
    /// `detail.capacity`).
    TriangleCapacity = 23,
    /// The mesh has more unique edges (or interior edges) than `capacity.max_edges`
    /// (`detail.capacity`). Three times the triangle count is always enough.
    EdgeCapacity = 24,
    /// `capacity.max_pins` pins already exist (`detail.capacity`).
    PinCapacity = 25,
    /// `capacity.max_colliders` colliders already exist (`detail.capacity`).
    ColliderCapacity = 26,

    /// The mesh has no vertices or no triangles.
    MeshEmpty = 30,
    /// Triangle `detail.triangle` names a vertex ≥ `vertex_count`.
    MeshIndexOutOfRange = 31,
    /// Triangle `detail.triangle` uses one vertex twice.
    MeshRepeatedVertex = 32,
    /// Triangle `detail.triangle` has (near) zero area in material (u, v) space.
    MeshDegenerateUv = 33,
    /// Triangle `detail.triangle` has (near) zero area in its initial 3D placement.
    MeshDegenerate3d = 34,
    /// The edge from `detail.vertex` to `detail.vertex_b` is shared by more than two triangles.
    MeshNonManifoldEdge = 35,
    /// The two triangles on the edge `detail.vertex`–`detail.vertex_b` disagree on their
    /// orientation in (u, v): the sheet folds over itself in material space.
    MeshFoldedUv = 36,
    /// The position or (u, v) of vertex `detail.vertex` is NaN or infinite.
    MeshNonFinite = 37,
    /// Triangle `detail.triangle` names material `detail.material`, which is ≥ the blob's cell
    /// count.
    MaterialOutOfRange = 38,
    /// Cell `detail.material` has unusable numbers (cannot happen with a blob that parsed).
    InvalidMaterial = 39,
    /// A `WeftSettings` field is out of range: `detail.what` names it.
    InvalidSetting = 40,
    /// Vertex `detail.vertex` belongs to no triangle (it would have no mass).
    MeshUnusedVertex = 41,
    /// Triangle `detail.triangle` is so large or so small in (u, v) that its area or mass does
    /// not fit a 32-bit float.
    MeshUvOutOfRange = 42,

    /// The blob is shorter than its header, or than the size its header announces, or longer
    /// (`detail.what` says which): a truncated or padded file.
    BlobSize = 50,
    /// Not a weft cell blob (its first 8 bytes are not "WEFTCELL").
    BlobBadMagic = 51,
    /// A blob format version this library does not read: `detail.index` is the version found,
    /// `WEFT_BLOB_VERSION` the one it reads.
    BlobVersion = 52,
    /// The blob's first byte is not `WEFT_BLOB_ALIGN`-aligned.
    BlobMisaligned = 53,
    /// The blob's CRC-32 does not match: the file is corrupt.
    BlobChecksum = 54,
    /// The blob's structure is corrupt (header, section table, padding): `detail.what` names
    /// the check, `detail.index` the section (or `WEFT_NONE`).
    BlobCorrupt = 55,
    /// Cell `detail.cell` of the blob holds invalid data: `detail.what` names the check and
    /// `detail.index` the element (node, triangle, material) when there is one.
    BlobInvalidCell = 56,
    /// `weft_blob_cell_info` was asked for a cell ≥ the blob's cell count (`detail.cell`).
    BlobCellOutOfRange = 57,

    /// Vertex `detail.vertex` is ≥ the world's vertex count.
    VertexOutOfRange = 60,
    /// Collider `detail.index` does not exist.
    ColliderOutOfRange = 61,
    /// A collider's numbers are invalid: non-finite, radius ≤ 0, a plane normal that is not unit
    /// length (±0.001), friction or thickness < 0. `detail.what` names the field when known.
    InvalidCollider = 62,
    /// An input value is NaN or infinite: `detail.what` names it, `detail.vertex` the vertex
    /// when it is per vertex.
    NonFinite = 63,
    /// `dt` is not a finite number > 0.
    InvalidTimeStep = 64,
    /// The target of the pin on vertex `detail.vertex` is NaN or infinite; the step did nothing.
    NonFinitePin = 65,
    /// The linear solver broke down; the world kept the state it had before the step.
    SolverBreakdown = 66,
    /// The step produced NaN or infinite positions; the world kept the state it had before.
    /// Usually a time step far too large for the cloth's stiffness: try more substeps.
    NonFiniteState = 67,
    /// The cloth gained mechanical energy with nothing driving it (pins and colliders still, no
    /// wind, no contact) over the last few steps: numerically unstable, e.g. sliver triangles
    /// beyond f32 resolution. The world kept the state it had before the step.
    Unstable = 68,

    /// `weft_bind`: fine vertex `detail.vertex` lies outside the coarse cloth's (u, v) layout
    /// (beyond a relative tolerance of 1e-5), or its (u, v) is NaN or infinite.
    BindOutOfDomain = 80,
    /// `weft_bind`: the bindings block is smaller than `weft_bind_memory_size` says:
    /// `detail.needed` fine vertices, room for `detail.capacity`.
    BindMemoryTooSmall = 81,
    /// The bindings block was not written by `weft_bind` (or is truncated or overwritten: its
    /// size disagrees with its vertex count). `detail.what` names the check.
    BindingsInvalid = 82,
    /// The bindings were made for another cloth: a world with a different mesh, rest (u, v),
    /// materials or blob. Bind the render mesh to this world again.
    BindingsMismatch = 83,
    /// Binding `detail.index` names a coarse triangle the world does not have (corrupt binding
    /// data that kept a valid header). Nothing was written.
    BindingOutOfRange = 84,
    /// `first + count` is beyond the bindings: `detail.index` is `first`, `detail.needed`
    /// `first + count` and `detail.capacity` the number of bindings.
    LocalizeRange = 85,
    /// `weft_localize_prepare`: the frames block is smaller than `weft_localize_frames_size`
    /// says: `detail.needed` coarse vertices, room for `detail.capacity`.
    FramesTooSmall = 86,
    /// The frames block was not filled by `weft_localize_prepare`, or was moved or overwritten
    /// since (frames are used where they were prepared).
    FramesNotPrepared = 87,
    /// The frames were prepared for another world (or for a world since destroyed and created
    /// again with another cloth in the same memory).
    FramesMismatch = 88,
    /// `weft_localize`: the normals overlap the positions (interleaved normals need the same
    /// stride and bytes of their own in each record), or an interleaved normal does not fit in
    /// its record. `detail.what` is "output.normals".
    NormalLayout = 89,
    /// `weft_localize` with `WEFT_NORMALS_RECOMPUTED`: fine triangle `detail.triangle` names
    /// vertex `detail.vertex`, which is ≥ `count` (indices are relative to `first`).
    FineIndexOutOfRange = 90,
    /// `weft_tiled_mesh_counts` / `weft_tiled_mesh`: cell `detail.cell` tiled over the cloth
    /// would have more vertices or triangles than a `uint32_t` counts (a tiny cell on a huge
    /// cloth).
    TiledMeshTooLarge = 91,
    /// `weft_tiled_mesh`: an output holds fewer elements than `weft_tiled_mesh_counts` says:
    /// `detail.what` names it, `detail.needed` and `detail.capacity` are the counts.
    TiledMeshCapacity = 92,
}

/// A 3D vector (metres, or metres per second for velocities). 12 bytes, no padding, any
/// alignment of 4 (vertex buffers are read and written unaligned, so any byte address works).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WeftVec3 {
    /// x component.
    pub x: f32,
    /// y component.
    pub y: f32,
    /// z component.
    pub z: f32,
}

/// A 2D vector: material coordinates (u, v) in metres. 8 bytes, no padding.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WeftVec2 {
    /// u, metres.
    pub x: f32,
    /// v, metres.
    pub y: f32,
}

/// How much a world holds, fixed at create; `weft_world_memory_size` turns it into bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WeftCapacity {
    /// Most vertices the cloth may have. Default `WEFT_DEFAULT_MAX_VERTICES`.
    pub max_vertices: u32,
    /// Most triangles. Default `WEFT_DEFAULT_MAX_TRIANGLES`.
    pub max_triangles: u32,
    /// Most unique edges. A connected sheet with h holes has `vertices + triangles - 1 + h`
    /// (a grid of n × n vertices: 3(n-1)² + 2(n-1)); 3 × `max_triangles` is always enough.
    /// Default `WEFT_DEFAULT_MAX_EDGES`.
    pub max_edges: u32,
    /// Most colliders at once. Default `WEFT_DEFAULT_MAX_COLLIDERS`.
    pub max_colliders: u32,
    /// Most pinned vertices at once. Default `WEFT_DEFAULT_MAX_PINS`.
    pub max_pins: u32,
}

/// Scene parameters. Start from `weft_default_settings()` (or `def.settings`); they can change
/// between steps (`weft_world_set_settings`, `weft_world_set_effects`). Every field is checked
/// (`WEFT_RESULT_INVALID_SETTING` names the first bad one).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeftSettings {
    /// Bit set of `WEFT_EFFECT_*`. Default: gravity, bending, damping, pins, collision, warping.
    pub effects: u32,
    /// Substeps per `weft_world_step`, 1..=1000. More substeps: stiffer or faster cloth stays
    /// stable, at proportional cost. Default 1.
    pub substeps: u32,
    /// Gravity, m/s². Default (0, 0, -9.81): weft itself has no "up", this is z-up.
    pub gravity: WeftVec3,
    /// Rayleigh damping mass factor α, 1/s, ≥ 0. Default 0.1.
    pub damping_mass: f32,
    /// Rayleigh damping stiffness factor β, s, ≥ 0. Default 0.001.
    pub damping_stiffness: f32,
    /// Wind velocity, m/s (needs `WEFT_EFFECT_WIND`). Default 0.
    pub wind: WeftVec3,
    /// Air drag coefficient, kg/(m²·s), ≥ 0: the force on a vertex is
    /// `drag · area · ((wind - v)·n) n`. Default 0.
    pub drag: f32,
    /// Linear solver relative residual, > 0. Default 1e-4.
    pub tolerance: f32,
    /// Linear solver iteration cap per substep, 1..=10000. Default 200.
    pub max_iterations: u32,
    /// 1: warp with per-node rotations (the paper's Eq. 14–17, for comparison only: unstable
    /// for cloth hanging in 3D); 0: per-element rotations. Any other value is
    /// `WEFT_RESULT_INVALID_SETTING`. Default 0.
    pub per_node_warping: u32,
    /// Rotation iterations per node per substep (per-node warping only), 0..=100. Default 4.
    pub rotation_iterations: u32,
    /// Sleep threshold, m/s, ≥ 0: the cloth sleeps when every vertex is slower than this for
    /// `sleep_frames` steps (needs `WEFT_EFFECT_SLEEP`). Default 0.001.
    pub sleep_velocity: f32,
    /// Calm steps before sleeping. Default 30.
    pub sleep_frames: u32,
}

/// Everything `weft_world_create` needs to build a cloth. Get one from
/// `weft_default_world_def()` and edit it: a def that did not come from there is refused
/// (`WEFT_RESULT_UNINITIALIZED`), so an uninitialized def is an error, not undefined behaviour.
/// The def and every buffer it points to are only read during `weft_world_create`; nothing is
/// kept, so they may be freed right after.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct WeftWorldDef {
    /// Initial vertex positions (metres): `vertex_count` groups of 3 floats (x, y, z), vertex
    /// i at byte `i * position_stride`. Read unaligned, so a position inside an interleaved
    /// vertex struct works in place. NULL only when `vertex_count` is 0.
    pub positions: *const c_void,
    /// Bytes from one position to the next, ≥ 12 (`sizeof(WeftVec3)`). Default 12.
    pub position_stride: usize,
    /// Material coordinates (u, v) of each vertex, in metres of fabric: the rest shape. 2
    /// floats per vertex at `uv_stride`, read unaligned. A cell blob's pattern repeats every
    /// cell width along u. NULL only when `vertex_count` is 0.
    pub uvs: *const c_void,
    /// Bytes from one (u, v) to the next, ≥ 8 (`sizeof(WeftVec2)`). Default 8.
    pub uv_stride: usize,
    /// Number of vertices, ≤ `capacity.max_vertices`. Default 0 (must be set).
    pub vertex_count: u32,
    /// Number of triangles, ≤ `capacity.max_triangles`. Default 0 (must be set).
    pub triangle_count: u32,
    /// Triangle vertex indices, 3 × `triangle_count` tightly packed `uint32_t` (4-aligned).
    /// Orientation is free but must be consistent across the sheet. NULL only when
    /// `triangle_count` is 0.
    pub indices: *const u32,
    /// Per-triangle material: the index of a cell in the blob, `triangle_count` tightly packed
    /// `uint32_t` (4-aligned). NULL: every triangle uses `material`. Default NULL.
    pub materials: *const u32,
    /// The cell index used by every triangle when `materials` is NULL. Default 0.
    pub material: u32,
    /// Fixed storage limits; also decides the memory size. Default `WEFT_DEFAULT_MAX_*`.
    pub capacity: WeftCapacity,
    /// Initial scene parameters. Default `weft_default_settings()`.
    pub settings: WeftSettings,
    /// Set by `weft_default_world_def`; do not touch.
    pub internal_cookie: u32,
}

/// A validated cell blob, borrowed in place: filled by `weft_blob_parse`, read-only
/// afterwards. The blob's bytes are not copied, so they must stay valid and unchanged as long as
/// this struct or any world made with it is used. Copying the struct is fine.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct WeftBlob {
    /// First byte of the blob (the caller's memory).
    pub data: *const c_void,
    /// Size of the blob in bytes.
    pub size: usize,
    /// Format version (`WEFT_BLOB_VERSION`).
    pub version: u32,
    /// Number of cells; a triangle's material is a cell index below it.
    pub cell_count: u32,
    /// Set by `weft_blob_parse`; do not touch.
    pub internal_cookie: u32,
}

/// What a blob cell is, for tools and logs (`weft_blob_cell_info`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct WeftCellInfo {
    /// The cell's name, NUL-terminated UTF-8 (at most 63 bytes before the NUL).
    pub name: [c_char; 64],
    /// Width of one period of the pattern along u, metres.
    pub width: f64,
    /// Height of one period along v, metres.
    pub height: f64,
    /// Pattern pixels along u.
    pub cols: u32,
    /// Pattern pixels along v.
    pub rows: u32,
    /// Mesh refinement of the homogenization (pixel edge / mesh edge).
    pub refine: u32,
    /// Nodes of the cell's periodic mesh (for localization).
    pub node_count: u32,
    /// Homogenized membrane stiffness C^H, N/m, Voigt order [11, 22, 12] with engineering
    /// shear, row-major.
    pub stiffness: [[f64; 3]; 3],
    /// Areal density, kg/m².
    pub density: f64,
    /// Bending stiffness, N·m.
    pub bending: f64,
}

/// A collider's geometry, world space, metres. Make one with `weft_shape_plane`,
/// `weft_shape_sphere`, `weft_shape_capsule` or `weft_shape_shell`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeftShape {
    /// `WEFT_SHAPE_PLANE`, `WEFT_SHAPE_SPHERE`, `WEFT_SHAPE_CAPSULE` or `WEFT_SHAPE_SHELL`; anything else is
    /// `WEFT_RESULT_INVALID_ARGUMENT`.
    pub kind: u32,
    /// Plane: unit outward normal. Sphere: centre. Capsule: first end of the segment.
    pub p0: WeftVec3,
    /// Capsule: second end of the segment. Ignored otherwise.
    pub p1: WeftVec3,
    /// Plane: offset (the plane is `dot(normal, x) = offset`, solid below). Sphere, capsule:
    /// radius, > 0.
    pub size: f32,
}

/// A kinematic collider to add to a world (`weft_world_add_collider`). Get one from
/// `weft_default_collider_def()` and edit it.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeftColliderDef {
    /// Where the collider is. Default: the ground plane z = 0.
    pub shape: WeftShape,
    /// Coulomb friction coefficient, ≥ 0. Default 0.5.
    pub friction: f32,
    /// Distance the cloth keeps from the surface, metres, ≥ 0 (half the cloth's thickness plus
    /// a skin). Default 0.005.
    pub thickness: f32,
    /// Set by `weft_default_collider_def`; do not touch.
    pub internal_cookie: u32,
}

/// What one `weft_world_step` did.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WeftStepStats {
    /// Linear-solver iterations, summed over substeps.
    pub iterations: u32,
    /// Largest final relative residual over substeps.
    pub residual: f32,
    /// Every substep's solve reached `settings.tolerance` (false: it stopped at
    /// `max_iterations`; the step is still valid, only less accurate).
    pub converged: bool,
    /// Substeps taken (0 when asleep).
    pub substeps: u32,
    /// The world was asleep and did nothing.
    pub asleep: bool,
    /// Vertices in contact with a collider at the end of the step.
    pub contacts: u32,
}

/// Where a failure is: filled by `weft_world_create` and `weft_blob_parse` (when their
/// `out_detail` is not NULL) and by `weft_world_last_error_detail`. Which fields apply is said
/// by each `WeftResult` value; the others are `WEFT_NONE` (indices) or "" (`what`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeftErrorDetail {
    /// The result this detail is about (`WEFT_RESULT_OK` when the call succeeded).
    pub result: WeftResult,
    /// The triangle at fault.
    pub triangle: u32,
    /// The vertex at fault (the first end of an edge at fault).
    pub vertex: u32,
    /// The second end of an edge at fault.
    pub vertex_b: u32,
    /// The material (blob cell index) at fault.
    pub material: u32,
    /// The blob cell at fault.
    pub cell: u32,
    /// Another index: a blob section or element, a collider, a version found.
    pub index: u32,
    /// How many were needed (capacity and count errors).
    pub needed: u32,
    /// The capacity that was too small.
    pub capacity: u32,
    /// A static, NUL-terminated string naming the argument, field or check; never NULL, owned
    /// by the library.
    pub what: *const c_char,
}

/// A world: an opaque handle that points to the start of the memory block given to
/// `weft_world_create`. Not thread-safe: one thread at a time per world (distinct worlds may
/// step on different threads at once). The exception: calls that take a `const WeftWorld *`
/// only read it, so several threads may make them at once (e.g. `weft_localize` on disjoint
/// ranges), as long as no call taking a non-const `WeftWorld *` runs meanwhile.
pub struct WeftWorld {
    /// `WORLD_COOKIE` while alive; zeroed by `weft_world_destroy`.
    cookie: u64,
    /// The address of this header, so a moved or copied block is refused.
    home: *const WeftWorld,
    world: World<'static>,
    /// The parsed blob, borrowed for the world's life: localization reads its cells.
    blob: Blob<'static>,
    /// Key of the cloth (mesh, rest (u, v), materials, blob) that bindings and frames carry.
    mesh_key: u64,
    /// The last failure of a call that took this world mutably.
    last_error: WeftErrorDetail,
    /// The block's scratch area: `capacity.max_vertices` entries that gather the strided input
    /// of create and of `weft_world_set_positions` / `weft_world_set_velocities`.
    scratch: *mut [f32; 3],
    scratch_len: usize,
}

// ---------------------------------------------------------------------------------------------
// Internal helpers: error details, pointer checks, conversions
// ---------------------------------------------------------------------------------------------

impl WeftErrorDetail {
    const fn of(result: WeftResult) -> WeftErrorDetail {
        WeftErrorDetail {
            result,
            triangle: WEFT_NONE,
            vertex: WEFT_NONE,
            vertex_b: WEFT_NONE,
            material: WEFT_NONE,
            cell: WEFT_NONE,
            index: WEFT_NONE,
            needed: WEFT_NONE,
            capacity: WEFT_NONE,
            what: EMPTY.as_ptr(),
        }
    }
    const fn what(mut self, what: &'static CStr) -> Self {
        self.what = what.as_ptr();
        self
    }
    const fn triangle(mut self, t: u32) -> Self {
        self.triangle = t;
        self
    }
    const fn vertex(mut self, v: u32) -> Self {
        self.vertex = v;
        self
    }
    const fn edge(mut self, a: u32, b: u32) -> Self {
        self.vertex = a;
        self.vertex_b = b;
        self
    }
    const fn cell(mut self, c: u32) -> Self {
        self.cell = c;
        self
    }
    const fn index(mut self, i: u32) -> Self {
        self.index = i;
        self
    }
    const fn needed(mut self, n: u32, capacity: u32) -> Self {
        self.needed = n;
        self.capacity = capacity;
        self
    }
}

const EMPTY: &CStr = c"";

type Fault = WeftErrorDetail;
type FfiResult<T> = Result<T, Fault>;

fn fault(result: WeftResult) -> Fault {
    WeftErrorDetail::of(result)
}

fn null(what: &'static CStr) -> Fault {
    fault(WeftResult::NullPointer).what(what)
}

fn invalid(what: &'static CStr) -> Fault {
    fault(WeftResult::InvalidArgument).what(what)
}

/// Writes `value` to an optional out-pointer (NULL: nothing).
///
/// # Safety
/// `out` is NULL or valid for a write of `T`.
unsafe fn write_opt<T>(out: *mut T, value: T) {
    if !out.is_null() && out.is_aligned() {
        // SAFETY: non-null and aligned; validity for writes is the caller's contract.
        unsafe { out.write(value) };
    }
}

/// A shared reference from a C pointer: checks NULL and alignment.
///
/// # Safety
/// A non-null, aligned `p` points to a readable `T` for `'a`.
unsafe fn read_ref<'a, T>(p: *const T, what: &'static CStr) -> FfiResult<&'a T> {
    if p.is_null() {
        return Err(null(what));
    }
    if !p.is_aligned() {
        return Err(fault(WeftResult::Misaligned).what(what));
    }
    // SAFETY: checked non-null and aligned; readability for 'a is the caller's contract. Every
    // T used here is plain data (integers, floats, raw pointers) valid for any bit pattern.
    Ok(unsafe { &*p })
}

/// Checks an out-pointer before anything is computed, so a NULL one fails early.
fn out_ptr<T>(p: *mut T, what: &'static CStr) -> FfiResult<*mut T> {
    if p.is_null() {
        return Err(null(what));
    }
    if !p.is_aligned() {
        return Err(fault(WeftResult::Misaligned).what(what));
    }
    Ok(p)
}

/// Byte extent of `count` elements of `elem` bytes at `stride`, if it fits in `isize`.
fn strided_extent(count: usize, stride: usize, elem: usize) -> Option<usize> {
    if count == 0 {
        return Some(0);
    }
    let e = (count - 1).checked_mul(stride)?.checked_add(elem)?;
    (e <= isize::MAX as usize).then_some(e)
}

/// Validates a strided buffer's pointer and stride for `count` elements of `elem` bytes.
fn check_strided(
    p: *const c_void,
    count: usize,
    stride: usize,
    elem: usize,
    what: &'static CStr,
    stride_what: &'static CStr,
) -> FfiResult<()> {
    if count == 0 {
        return Ok(());
    }
    if p.is_null() {
        return Err(null(what));
    }
    if stride < elem {
        return Err(invalid(stride_what));
    }
    strided_extent(count, stride, elem).ok_or(invalid(stride_what))?;
    Ok(())
}

/// Reads `N` floats at element `i` of a strided buffer, unaligned.
///
/// # Safety
/// `check_strided` passed for `p`, `stride` and a count > `i`, and the buffer is readable.
unsafe fn read_floats<const N: usize>(p: *const c_void, stride: usize, i: usize) -> [f32; N] {
    // SAFETY: i * stride + size_of::<[f32; N]>() is within the checked extent.
    unsafe {
        p.cast::<u8>()
            .add(i * stride)
            .cast::<[f32; N]>()
            .read_unaligned()
    }
}

/// Writes vectors to a strided buffer, unaligned, after the caller's checks.
///
/// # Safety
/// `check_strided` passed for `out`, `stride` and `src.len()`, and the buffer is writable.
unsafe fn write_vec3s(out: *mut c_void, stride: usize, src: &[Vec3A]) {
    for (i, v) in src.iter().enumerate() {
        // SAFETY: within the checked extent.
        unsafe {
            out.cast::<u8>()
                .add(i * stride)
                .cast::<[f32; 3]>()
                .write_unaligned([v.x, v.y, v.z]);
        }
    }
}

fn setting_name(field: &str) -> &'static CStr {
    match field {
        "time_step" => c"time_step",
        "substeps" => c"substeps",
        "gravity" => c"gravity",
        "damping_mass" => c"damping_mass",
        "damping_stiffness" => c"damping_stiffness",
        "wind" => c"wind",
        "drag" => c"drag",
        "tolerance" => c"tolerance",
        "max_iterations" => c"max_iterations",
        "rotation_iterations" => c"rotation_iterations",
        "sleep_velocity" => c"sleep_velocity",
        "effects" => c"effects",
        _ => c"settings",
    }
}

fn mesh_fault(e: MeshError) -> Fault {
    use WeftResult as R;
    match e {
        MeshError::Empty => fault(R::MeshEmpty),
        MeshError::VertexCapacity { needed, capacity } => {
            fault(R::VertexCapacity).needed(needed, capacity)
        }
        MeshError::TriangleCapacity { needed, capacity } => {
            fault(R::TriangleCapacity).needed(needed, capacity)
        }
        MeshError::EdgeCapacity { capacity } => fault(R::EdgeCapacity).needed(WEFT_NONE, capacity),
        MeshError::IndexOutOfRange { triangle } => fault(R::MeshIndexOutOfRange).triangle(triangle),
        MeshError::RepeatedVertex { triangle } => fault(R::MeshRepeatedVertex).triangle(triangle),
        MeshError::DegenerateUv { triangle } => fault(R::MeshDegenerateUv).triangle(triangle),
        MeshError::Degenerate3d { triangle } => fault(R::MeshDegenerate3d).triangle(triangle),
        MeshError::NonManifoldEdge { a, b } => fault(R::MeshNonManifoldEdge).edge(a, b),
        MeshError::FoldedUv { a, b } => fault(R::MeshFoldedUv).edge(a, b),
        MeshError::NonFinite { vertex } => fault(R::MeshNonFinite).vertex(vertex),
        MeshError::UnusedVertex { vertex } => fault(R::MeshUnusedVertex).vertex(vertex),
        MeshError::UvOutOfRange { triangle } => fault(R::MeshUvOutOfRange).triangle(triangle),
        // The FFI always hands the kernel buffers of matching length.
        MeshError::BufferTooSmall => fault(R::Internal).what(c"mesh buffer"),
    }
}

fn init_fault(e: InitError) -> Fault {
    use WeftResult as R;
    match e {
        InitError::MemoryTooSmall => fault(R::MemoryTooSmall).what(c"memory_size"),
        InitError::CapacityTooLarge => fault(R::CapacityTooLarge),
        InitError::VertexCapacity { needed, capacity } => {
            fault(R::VertexCapacity).needed(needed, capacity)
        }
        InitError::TriangleCapacity { needed, capacity } => {
            fault(R::TriangleCapacity).needed(needed, capacity)
        }
        InitError::EdgeCapacity { capacity } => fault(R::EdgeCapacity).needed(WEFT_NONE, capacity),
        InitError::Mesh(m) => mesh_fault(m),
        InitError::MaterialCount => fault(R::Internal).what(c"material count"),
        InitError::MaterialOutOfRange { triangle, material } => {
            let mut f = fault(R::MaterialOutOfRange).triangle(triangle);
            f.material = material;
            f
        }
        InitError::InvalidMaterial { material } => {
            let mut f = fault(R::InvalidMaterial);
            f.material = material;
            f
        }
        InitError::InvalidSetting { field } => fault(R::InvalidSetting).what(setting_name(field)),
        InitError::Internal => fault(R::Internal),
    }
}

fn step_fault(e: StepError) -> Fault {
    use WeftResult as R;
    match e {
        StepError::InvalidTimeStep => fault(R::InvalidTimeStep).what(c"dt"),
        StepError::NonFinitePin { vertex } => fault(R::NonFinitePin).vertex(vertex),
        StepError::SolverBreakdown => fault(R::SolverBreakdown),
        StepError::NonFiniteState => fault(R::NonFiniteState),
        StepError::Unstable => fault(R::Unstable),
    }
}

fn edit_fault(e: EditError, w: &World<'_>) -> Fault {
    use WeftResult as R;
    let cap = w.capacity();
    match e {
        EditError::VertexOutOfRange => fault(R::VertexOutOfRange),
        EditError::NonFinite => fault(R::NonFinite),
        EditError::PinCapacity => fault(R::PinCapacity).needed(cap.pins + 1, cap.pins),
        EditError::ColliderCapacity => {
            fault(R::ColliderCapacity).needed(cap.colliders + 1, cap.colliders)
        }
        EditError::ColliderOutOfRange => fault(R::ColliderOutOfRange),
        EditError::InvalidCollider => fault(R::InvalidCollider),
    }
}

fn blob_fault(e: BlobError) -> Fault {
    use WeftResult as R;
    let corrupt = |what: &'static CStr| fault(R::BlobCorrupt).what(what);
    let cell = |cell: u32, what: &'static CStr| fault(R::BlobInvalidCell).cell(cell).what(what);
    match e {
        BlobError::TooShort => fault(R::BlobSize).what(c"truncated"),
        BlobError::TrailingBytes { .. } => fault(R::BlobSize).what(c"trailing bytes"),
        BlobError::BadMagic => fault(R::BlobBadMagic),
        BlobError::UnsupportedVersion { found } => fault(R::BlobVersion).index(found),
        BlobError::BadHeader => corrupt(c"header"),
        BlobError::Misaligned => fault(R::BlobMisaligned).what(c"data"),
        BlobError::ChecksumMismatch { .. } => fault(R::BlobChecksum),
        BlobError::BadSectionTable => corrupt(c"section table"),
        BlobError::UnexpectedSection { section, .. } => corrupt(c"section order").index(section),
        BlobError::SectionOutOfRange { section } => corrupt(c"section range").index(section),
        BlobError::SectionMisaligned { section } => corrupt(c"section alignment").index(section),
        BlobError::SectionOverlap { section } => corrupt(c"section overlap").index(section),
        BlobError::SectionGap { section } => corrupt(c"section gap").index(section),
        BlobError::SectionSizeMismatch { section } => corrupt(c"section size").index(section),
        BlobError::NonZeroPadding { .. } => corrupt(c"padding"),
        BlobError::BadName { cell: c } => cell(c, c"name"),
        BlobError::DuplicateName { cell: c } => cell(c, c"duplicate name"),
        BlobError::BadDimensions { cell: c } => cell(c, c"dimensions"),
        BlobError::CountMismatch { cell: c, .. } => cell(c, c"section count"),
        BlobError::NonFinite { cell: c, index, .. } => cell(c, c"non-finite value").index(index),
        BlobError::BadValue { cell: c, index, .. } => cell(c, c"value out of range").index(index),
        BlobError::NotSpd { cell: c } => cell(c, c"stiffness not SPD"),
        BlobError::BoundNotSpd { cell: c } => cell(c, c"bound not SPD"),
        BlobError::MaterialNotSpd { cell: c, material } => {
            cell(c, c"material stiffness not SPD").index(material)
        }
        BlobError::NodeOffGrid { cell: c, node } => cell(c, c"node off grid").index(node),
        BlobError::IndexOutOfRange { cell: c, triangle } => {
            cell(c, c"node index out of range").index(triangle)
        }
        BlobError::TopologyMismatch { cell: c, triangle } => cell(c, c"topology").index(triangle),
        BlobError::MaterialIndexOutOfRange { cell: c, triangle } => {
            cell(c, c"material index out of range").index(triangle)
        }
        BlobError::PixelMaterialMismatch { cell: c, triangle } => {
            cell(c, c"pixel material").index(triangle)
        }
        BlobError::TooLarge => corrupt(c"too large"),
    }
}

fn vec3(v: WeftVec3) -> [f32; 3] {
    [v.x, v.y, v.z]
}

fn to_vec3(v: [f32; 3]) -> WeftVec3 {
    WeftVec3 {
        x: v[0],
        y: v[1],
        z: v[2],
    }
}

fn capacity_of(c: &WeftCapacity) -> Capacity {
    Capacity {
        vertices: c.max_vertices,
        triangles: c.max_triangles,
        edges: c.max_edges,
        colliders: c.max_colliders,
        pins: c.max_pins,
    }
}

fn settings_to_c(s: &Settings) -> WeftSettings {
    WeftSettings {
        effects: s.effects,
        substeps: s.substeps,
        gravity: to_vec3(s.gravity),
        damping_mass: s.damping_mass,
        damping_stiffness: s.damping_stiffness,
        wind: to_vec3(s.wind),
        drag: s.drag,
        tolerance: s.tolerance,
        max_iterations: s.max_iterations,
        per_node_warping: s.per_node_warping as u32,
        rotation_iterations: s.rotation_iterations,
        sleep_velocity: s.sleep_velocity,
        sleep_frames: s.sleep_frames,
    }
}

/// The kernel's settings from the C ones; `base` supplies what C does not set (the frame time
/// step, unused: C passes `dt` to every step). Range checks are `Settings::validate`'s.
fn settings_from_c(c: &WeftSettings, base: &Settings) -> FfiResult<Settings> {
    let per_node_warping = match c.per_node_warping {
        0 => false,
        1 => true,
        _ => return Err(fault(WeftResult::InvalidSetting).what(c"per_node_warping")),
    };
    let s = Settings {
        effects: c.effects,
        time_step: base.time_step,
        substeps: c.substeps,
        gravity: vec3(c.gravity),
        damping_mass: c.damping_mass,
        damping_stiffness: c.damping_stiffness,
        wind: vec3(c.wind),
        drag: c.drag,
        tolerance: c.tolerance,
        max_iterations: c.max_iterations,
        per_node_warping,
        rotation_iterations: c.rotation_iterations,
        sleep_velocity: c.sleep_velocity,
        sleep_frames: c.sleep_frames,
    };
    s.validate().map_err(init_fault)?;
    Ok(s)
}

fn shape_from_c(s: &WeftShape) -> FfiResult<Shape> {
    let v = |p: WeftVec3| Vec3A::new(p.x, p.y, p.z);
    let shape = match s.kind {
        WEFT_SHAPE_PLANE => Shape::Plane {
            normal: v(s.p0),
            offset: s.size,
        },
        WEFT_SHAPE_SPHERE => Shape::Sphere {
            center: v(s.p0),
            radius: s.size,
        },
        WEFT_SHAPE_CAPSULE => Shape::Capsule {
            a: v(s.p0),
            b: v(s.p1),
            radius: s.size,
        },
        WEFT_SHAPE_SHELL => Shape::Shell {
            center: v(s.p0),
            radius: s.size,
        },
        _ => return Err(invalid(c"shape.kind")),
    };
    if !shape.is_valid() {
        return Err(fault(WeftResult::InvalidCollider).what(c"shape"));
    }
    Ok(shape)
}

fn stats_to_c(s: &StepStats) -> WeftStepStats {
    WeftStepStats {
        iterations: s.iterations,
        residual: s.residual,
        converged: s.converged,
        substeps: s.substeps,
        asleep: s.asleep,
        contacts: s.contacts,
    }
}

/// Where the parts of a world's block are (byte offsets from its start).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct BlockLayout {
    /// The kernel's arrays: `[WEFT_WORLD_HEADER_SIZE, + world_bytes)`.
    world_bytes: usize,
    /// The create-time scratch area (4-aligned offset).
    stage_at: usize,
    /// Total bytes, a multiple of `WEFT_WORLD_MEMORY_ALIGN`.
    total: usize,
}

/// `Capacity::world_bytes` with overflow checks: it is affine in the five counts (each array
/// is a count times an element size plus alignment slack), so it is evaluated from its value
/// at zero and at each unit capacity in `u64`. `tests` check it against `world_bytes`.
fn world_bytes_checked(c: &Capacity) -> Option<usize> {
    let at = |v, t, e, cl, p| {
        Capacity {
            vertices: v,
            triangles: t,
            edges: e,
            colliders: cl,
            pins: p,
        }
        .world_bytes() as u64
    };
    let base = at(0, 0, 0, 0, 0);
    let terms = [
        (at(1, 0, 0, 0, 0), c.vertices),
        (at(0, 1, 0, 0, 0), c.triangles),
        (at(0, 0, 1, 0, 0), c.edges),
        (at(0, 0, 0, 1, 0), c.colliders),
        (at(0, 0, 0, 0, 1), c.pins),
    ];
    let mut total = base;
    for (unit, n) in terms {
        let per = unit.checked_sub(base)?;
        total = total.checked_add(per.checked_mul(n as u64)?)?;
    }
    let total = usize::try_from(total).ok()?;
    (total <= isize::MAX as usize / 2).then_some(total)
}

fn block_layout(c: &Capacity) -> Option<BlockLayout> {
    let world_bytes = world_bytes_checked(c)?;
    let end = WEFT_WORLD_HEADER_SIZE.checked_add(world_bytes)?;
    let stage_at = end.checked_add(3)? & !3;
    let stage = (c.vertices as usize)
        .checked_mul(STAGE_VERTEX_BYTES)?
        .checked_add((c.triangles as usize).checked_mul(STAGE_TRIANGLE_BYTES)?)?;
    let align = WEFT_WORLD_MEMORY_ALIGN - 1;
    let total = stage_at.checked_add(stage)?.checked_add(align)? & !align;
    (total <= isize::MAX as usize).then_some(BlockLayout {
        world_bytes,
        stage_at,
        total,
    })
}

/// The live world behind a handle, or why not.
///
/// # Safety
/// A non-null, aligned `w` points to readable memory of at least `WEFT_WORLD_HEADER_SIZE`
/// bytes (a block given to `weft_world_create`, or any memory the caller owns).
unsafe fn world_at<'a>(w: *const WeftWorld) -> FfiResult<&'a WeftWorld> {
    if w.is_null() {
        return Err(null(c"world"));
    }
    if !w.is_aligned() {
        return Err(fault(WeftResult::InvalidHandle));
    }
    // SAFETY: readable per the contract; u64 and raw pointers are valid for any bytes.
    let (cookie, home) = unsafe {
        (
            ptr::addr_of!((*w).cookie).read(),
            ptr::addr_of!((*w).home).read(),
        )
    };
    if cookie != WORLD_COOKIE || home != w {
        return Err(fault(WeftResult::InvalidHandle));
    }
    // SAFETY: the cookie and self-address say weft_world_create wrote a WeftWorld here and
    // weft_world_destroy has not run; the caller keeps the block alive and unmoved.
    Ok(unsafe { &*w })
}

/// # Safety
/// As [`world_at`], and no other reference to the world is alive (one thread at a time).
unsafe fn world_mut<'a>(w: *mut WeftWorld) -> FfiResult<&'a mut WeftWorld> {
    // SAFETY: forwarded contract.
    unsafe { world_at(w)? };
    // SAFETY: validated above; exclusive per the contract.
    Ok(unsafe { &mut *w })
}

/// Runs `f` on a live world, recording a failure as its last error.
///
/// # Safety
/// As [`world_mut`].
unsafe fn with_world(
    w: *mut WeftWorld,
    f: impl FnOnce(&mut WeftWorld) -> FfiResult<()>,
) -> WeftResult {
    // SAFETY: forwarded contract.
    match unsafe { world_mut(w) } {
        Ok(ww) => match f(ww) {
            Ok(()) => WeftResult::Ok,
            Err(d) => {
                ww.last_error = d;
                d.result
            }
        },
        Err(d) => d.result,
    }
}

fn done(r: FfiResult<()>) -> WeftResult {
    match r {
        Ok(()) => WeftResult::Ok,
        Err(d) => d.result,
    }
}

/// Parses a C blob descriptor again (a `WeftBlob` is only a view; the bytes are re-validated
/// wherever they are used, so a stale or forged struct is an error, never a misread).
///
/// # Safety
/// `b.data` is readable for `b.size` bytes for `'static` (the caller's lifetime contract).
unsafe fn reparse(b: &WeftBlob) -> FfiResult<Blob<'static>> {
    if b.internal_cookie != BLOB_COOKIE {
        return Err(fault(WeftResult::Uninitialized).what(c"blob"));
    }
    if b.data.is_null() {
        return Err(null(c"blob.data"));
    }
    if b.size > isize::MAX as usize {
        return Err(invalid(c"blob.size"));
    }
    // SAFETY: non-null, size ≤ isize::MAX, readable per the contract; u8 has no invalid values.
    let bytes = unsafe { core::slice::from_raw_parts(b.data.cast::<u8>(), b.size) };
    Blob::parse(bytes).map_err(blob_fault)
}

// ---------------------------------------------------------------------------------------------
// Library
// ---------------------------------------------------------------------------------------------

/// The library's version, `(major << 16) | (minor << 8) | patch`; equals `WEFT_VERSION` when
/// the header matches the library.
#[no_mangle]
pub extern "C" fn weft_version() -> u32 {
    WEFT_VERSION
}

/// A short English description of a `WeftResult` value (any `uint32_t` is accepted; unknown
/// values give "unknown result"). The string is static, NUL-terminated and owned by the
/// library: never free it.
#[no_mangle]
pub extern "C" fn weft_result_string(result: u32) -> *const c_char {
    use WeftResult as R;
    let all = [
        (R::Ok, c"ok"),
        (R::NullPointer, c"a required pointer argument is NULL"),
        (
            R::Uninitialized,
            c"def or blob not initialized by weft_default_*_def / weft_blob_parse",
        ),
        (R::InvalidHandle, c"not a live world handle"),
        (R::InvalidArgument, c"argument out of range"),
        (R::Misaligned, c"pointer or memory block misaligned"),
        (R::CountMismatch, c"vertex count does not match the world"),
        (R::Internal, c"internal error (a bug in weft)"),
        (
            R::MemoryTooSmall,
            c"memory block smaller than weft_world_memory_size",
        ),
        (R::CapacityTooLarge, c"capacity too large for this target"),
        (
            R::VertexCapacity,
            c"more vertices than capacity.max_vertices",
        ),
        (
            R::TriangleCapacity,
            c"more triangles than capacity.max_triangles",
        ),
        (R::EdgeCapacity, c"more edges than capacity.max_edges"),
        (R::PinCapacity, c"pin capacity exhausted"),
        (R::ColliderCapacity, c"collider capacity exhausted"),
        (R::MeshEmpty, c"mesh has no vertices or no triangles"),
        (
            R::MeshIndexOutOfRange,
            c"triangle vertex index out of range",
        ),
        (R::MeshRepeatedVertex, c"triangle repeats a vertex"),
        (R::MeshDegenerateUv, c"triangle degenerate in (u, v)"),
        (R::MeshDegenerate3d, c"triangle degenerate in 3D"),
        (
            R::MeshNonManifoldEdge,
            c"edge shared by more than two triangles",
        ),
        (R::MeshFoldedUv, c"mesh folds over itself in (u, v)"),
        (R::MeshNonFinite, c"vertex position or (u, v) not finite"),
        (
            R::MaterialOutOfRange,
            c"triangle material is not a cell of the blob",
        ),
        (R::InvalidMaterial, c"material has invalid numbers"),
        (R::InvalidSetting, c"setting out of range"),
        (R::BlobSize, c"blob size does not match its header"),
        (R::BlobBadMagic, c"not a weft cell blob"),
        (R::BlobVersion, c"unsupported blob version"),
        (R::BlobMisaligned, c"blob data not 8-byte aligned"),
        (R::BlobChecksum, c"blob checksum mismatch"),
        (R::BlobCorrupt, c"blob structure corrupt"),
        (R::BlobInvalidCell, c"blob cell holds invalid data"),
        (R::BlobCellOutOfRange, c"blob cell index out of range"),
        (R::VertexOutOfRange, c"vertex index out of range"),
        (R::ColliderOutOfRange, c"collider index out of range"),
        (R::InvalidCollider, c"invalid collider"),
        (R::NonFinite, c"value not finite"),
        (R::InvalidTimeStep, c"time step not finite and positive"),
        (R::NonFinitePin, c"pin target not finite"),
        (R::SolverBreakdown, c"linear solver broke down"),
        (R::NonFiniteState, c"step produced non-finite state"),
        (
            R::Unstable,
            c"the cloth gains energy with nothing driving it (unstable)",
        ),
        (R::MeshUnusedVertex, c"a vertex belongs to no triangle"),
        (
            R::MeshUvOutOfRange,
            c"a triangle's (u, v) size does not fit a 32-bit float",
        ),
        (
            R::BindOutOfDomain,
            c"fine vertex outside the coarse cloth's (u, v)",
        ),
        (
            R::BindMemoryTooSmall,
            c"bindings block smaller than weft_bind_memory_size",
        ),
        (
            R::BindingsInvalid,
            c"not a bindings block written by weft_bind",
        ),
        (R::BindingsMismatch, c"bindings were made for another cloth"),
        (
            R::BindingOutOfRange,
            c"binding names a coarse triangle that does not exist",
        ),
        (R::LocalizeRange, c"first + count beyond the bindings"),
        (
            R::FramesTooSmall,
            c"frames block smaller than weft_localize_frames_size",
        ),
        (
            R::FramesNotPrepared,
            c"frames not prepared by weft_localize_prepare (or moved since)",
        ),
        (R::FramesMismatch, c"frames were prepared for another world"),
        (
            R::NormalLayout,
            c"normals overlap the positions or leave their record",
        ),
        (
            R::FineIndexOutOfRange,
            c"fine triangle vertex index out of range",
        ),
        (
            R::TiledMeshTooLarge,
            c"tiled mesh too large for 32-bit indices",
        ),
        (
            R::TiledMeshCapacity,
            c"output smaller than weft_tiled_mesh_counts",
        ),
    ];
    all.iter()
        .find(|(r, _)| *r as u32 == result)
        .map_or(c"unknown result", |(_, s)| *s)
        .as_ptr()
}

// ---------------------------------------------------------------------------------------------
// Blobs
// ---------------------------------------------------------------------------------------------

/// Validates a cell blob in place (structure, checksum, every number; O(size)) and describes it
/// in `*out_blob`. Nothing is copied: `data` must stay valid and unchanged while the blob or
/// any world made with it is used.
///
/// - `data`: the blob's bytes (e.g. a file read into memory), `WEFT_BLOB_ALIGN`-aligned.
/// - `size`: bytes at `data`.
/// - `out_blob`: written on success.
/// - `out_detail`: NULL, or filled on every call with where a failure is (`BLOB_*` results).
///
/// # Safety
/// `data` is readable for `size` bytes; `out_blob` and a non-NULL `out_detail` are writable.
#[no_mangle]
pub unsafe extern "C" fn weft_blob_parse(
    data: *const c_void,
    size: usize,
    out_blob: *mut WeftBlob,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let run = || -> FfiResult<()> {
        let out = out_ptr(out_blob, c"out_blob")?;
        let mut b = WeftBlob {
            data,
            size,
            version: 0,
            cell_count: 0,
            internal_cookie: BLOB_COOKIE,
        };
        // SAFETY: readability of data[..size] is the caller's contract.
        let blob = unsafe { reparse(&b) }?;
        b.version = blob.version();
        b.cell_count = u32::try_from(blob.cell_count()).map_err(|_| invalid(c"cell count"))?;
        // SAFETY: checked non-null and aligned; writable per the contract.
        unsafe { out.write(b) };
        Ok(())
    };
    let r = run();
    let detail = match r {
        Ok(()) => WeftErrorDetail::of(WeftResult::Ok),
        Err(d) => d,
    };
    // SAFETY: NULL or writable per the contract.
    unsafe { write_opt(out_detail, detail) };
    detail.result
}

/// Describes cell `cell` of a parsed blob in `*out_info` (validates the blob again: O(size)).
///
/// # Safety
/// `blob` points to a `WeftBlob` filled by `weft_blob_parse` whose bytes are still valid;
/// `out_info` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_blob_cell_info(
    blob: *const WeftBlob,
    cell: u32,
    out_info: *mut WeftCellInfo,
) -> WeftResult {
    done((|| {
        // SAFETY: readable per the contract.
        let b = unsafe { read_ref(blob, c"blob") }?;
        let out = out_ptr(out_info, c"out_info")?;
        // SAFETY: the bytes are valid per the contract.
        let parsed = unsafe { reparse(b) }?;
        let c = parsed
            .cell(cell as usize)
            .ok_or(fault(WeftResult::BlobCellOutOfRange).cell(cell))?;
        let mut name = [0 as c_char; 64];
        for (d, s) in name.iter_mut().zip(c.name.bytes().take(63)) {
            *d = s as c_char;
        }
        let info = WeftCellInfo {
            name,
            width: c.width(),
            height: c.height(),
            cols: c.cols,
            rows: c.rows,
            refine: c.refine,
            node_count: u32::try_from(c.nodes.len()).unwrap_or(u32::MAX),
            stiffness: c.stiffness,
            density: c.density,
            bending: c.bending,
        };
        // SAFETY: checked non-null and aligned; writable per the contract.
        unsafe { out.write(info) };
        Ok(())
    })())
}

// ---------------------------------------------------------------------------------------------
// Defaults
// ---------------------------------------------------------------------------------------------

/// The default capacity: `WEFT_DEFAULT_MAX_*`.
#[no_mangle]
pub extern "C" fn weft_default_capacity() -> WeftCapacity {
    WeftCapacity {
        max_vertices: WEFT_DEFAULT_MAX_VERTICES,
        max_triangles: WEFT_DEFAULT_MAX_TRIANGLES,
        max_edges: WEFT_DEFAULT_MAX_EDGES,
        max_colliders: WEFT_DEFAULT_MAX_COLLIDERS,
        max_pins: WEFT_DEFAULT_MAX_PINS,
    }
}

/// The default scene parameters (see each `WeftSettings` field).
#[no_mangle]
pub extern "C" fn weft_default_settings() -> WeftSettings {
    settings_to_c(&Settings::default())
}

/// A world def with every field at its default (no mesh yet: set `positions`, `uvs`,
/// `vertex_count`, `indices`, `triangle_count`, and usually `material(s)`).
#[no_mangle]
pub extern "C" fn weft_default_world_def() -> WeftWorldDef {
    WeftWorldDef {
        positions: ptr::null(),
        position_stride: size_of::<WeftVec3>(),
        uvs: ptr::null(),
        uv_stride: size_of::<WeftVec2>(),
        vertex_count: 0,
        triangle_count: 0,
        indices: ptr::null(),
        materials: ptr::null(),
        material: 0,
        capacity: weft_default_capacity(),
        settings: weft_default_settings(),
        internal_cookie: WORLD_DEF_COOKIE,
    }
}

/// A collider def: the ground plane z = 0, friction 0.5, thickness 0.005 m.
#[no_mangle]
pub extern "C" fn weft_default_collider_def() -> WeftColliderDef {
    WeftColliderDef {
        shape: weft_shape_plane(
            WeftVec3 {
                x: 0.0,
                y: 0.0,
                z: 1.0,
            },
            0.0,
        ),
        friction: 0.5,
        thickness: 0.005,
        internal_cookie: COLLIDER_DEF_COOKIE,
    }
}

/// The plane `dot(normal, x) = offset` (metres), solid on the side `dot(normal, x) < offset`.
/// `normal` must be unit length (±0.001; checked when the shape is used).
#[no_mangle]
pub extern "C" fn weft_shape_plane(normal: WeftVec3, offset: f32) -> WeftShape {
    WeftShape {
        kind: WEFT_SHAPE_PLANE,
        p0: normal,
        p1: WeftVec3::default(),
        size: offset,
    }
}

/// A sphere of `radius` metres (> 0) around `center` (metres).
#[no_mangle]
pub extern "C" fn weft_shape_sphere(center: WeftVec3, radius: f32) -> WeftShape {
    WeftShape {
        kind: WEFT_SHAPE_SPHERE,
        p0: center,
        p1: WeftVec3::default(),
        size: radius,
    }
}

/// A capsule: the segment `a`–`b` (metres) swept by a sphere of `radius` metres (> 0).
#[no_mangle]
pub extern "C" fn weft_shape_capsule(a: WeftVec3, b: WeftVec3, radius: f32) -> WeftShape {
    WeftShape {
        kind: WEFT_SHAPE_CAPSULE,
        p0: a,
        p1: b,
        size: radius,
    }
}

/// A hollow sphere of `radius` metres (> 0) around `center`: the cloth is kept inside it (a
/// container, or a shrinking sphere that crumples the cloth).
#[no_mangle]
pub extern "C" fn weft_shape_shell(center: WeftVec3, radius: f32) -> WeftShape {
    WeftShape {
        kind: WEFT_SHAPE_SHELL,
        p0: center,
        p1: WeftVec3::default(),
        size: radius,
    }
}

// ---------------------------------------------------------------------------------------------
// World memory and life cycle
// ---------------------------------------------------------------------------------------------

/// Bytes a world of `*capacity` needs (header, arrays and create-time scratch), a multiple of
/// `WEFT_WORLD_MEMORY_ALIGN`, in `*out_size`.
///
/// # Safety
/// `capacity` is readable, `out_size` writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_memory_size(
    capacity: *const WeftCapacity,
    out_size: *mut usize,
) -> WeftResult {
    done((|| {
        // SAFETY: readable per the contract.
        let c = unsafe { read_ref(capacity, c"capacity") }?;
        let out = out_ptr(out_size, c"out_size")?;
        let layout = block_layout(&capacity_of(c)).ok_or(fault(WeftResult::CapacityTooLarge))?;
        // SAFETY: checked; writable per the contract.
        unsafe { out.write(layout.total) };
        Ok(())
    })())
}

/// Required alignment (bytes) of a world's memory block: `WEFT_WORLD_MEMORY_ALIGN`.
#[no_mangle]
pub extern "C" fn weft_world_memory_align() -> usize {
    WEFT_WORLD_MEMORY_ALIGN
}

/// Builds a world for the cloth `*def` with the cells of `*blob`, inside `memory`, and writes
/// its handle to `*out_world` (which points to `memory`).
///
/// - `memory`: `memory_size` bytes, `WEFT_WORLD_MEMORY_ALIGN`-aligned, at least
///   `weft_world_memory_size(&def->capacity)`; contents need not be initialized. Owned by the
///   caller: it must stay allocated, and must not be moved, copied over or reused, until
///   `weft_world_destroy` (the world lives in it; nothing else is allocated). On failure
///   nothing refers to it.
/// - `blob`: from `weft_blob_parse` (validated again here, O(blob size)); its bytes must stay
///   valid and unchanged until `weft_world_destroy`.
/// - `out_detail`: NULL, or filled on every call with where a failure is (which triangle,
///   vertex, capacity, setting ...).
///
/// # Safety
/// `def`, `blob` and every buffer `def` points to are readable for the sizes they announce;
/// `memory` is writable for `memory_size` bytes; `out_world` and a non-NULL `out_detail` are
/// writable; the lifetimes above are kept.
#[no_mangle]
pub unsafe extern "C" fn weft_world_create(
    def: *const WeftWorldDef,
    blob: *const WeftBlob,
    memory: *mut c_void,
    memory_size: usize,
    out_world: *mut *mut WeftWorld,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract.
    let r = unsafe { create(def, blob, memory, memory_size, out_world) };
    let detail = match r {
        Ok(()) => WeftErrorDetail::of(WeftResult::Ok),
        Err(d) => d,
    };
    // SAFETY: NULL or writable per the contract.
    unsafe { write_opt(out_detail, detail) };
    detail.result
}

/// # Safety
/// As [`weft_world_create`].
unsafe fn create(
    def: *const WeftWorldDef,
    blob: *const WeftBlob,
    memory: *mut c_void,
    memory_size: usize,
    out_world: *mut *mut WeftWorld,
) -> FfiResult<()> {
    use WeftResult as R;
    // SAFETY: readable per the contract.
    let d = unsafe { read_ref(def, c"def") }?;
    if d.internal_cookie != WORLD_DEF_COOKIE {
        return Err(fault(R::Uninitialized).what(c"def"));
    }
    // SAFETY: readable per the contract.
    let b = unsafe { read_ref(blob, c"blob") }?;
    if b.internal_cookie != BLOB_COOKIE {
        return Err(fault(R::Uninitialized).what(c"blob"));
    }
    let out = out_ptr(out_world, c"out_world")?;
    if memory.is_null() {
        return Err(null(c"memory"));
    }
    if (memory as usize) % WEFT_WORLD_MEMORY_ALIGN != 0 {
        return Err(fault(R::Misaligned).what(c"memory"));
    }
    let capacity = capacity_of(&d.capacity);
    let layout = block_layout(&capacity).ok_or(fault(R::CapacityTooLarge))?;
    if memory_size < layout.total {
        return Err(fault(R::MemoryTooSmall).what(c"memory_size"));
    }
    let (nv, nt) = (d.vertex_count, d.triangle_count);
    if nv > capacity.vertices {
        return Err(fault(R::VertexCapacity).needed(nv, capacity.vertices));
    }
    if nt > capacity.triangles {
        return Err(fault(R::TriangleCapacity).needed(nt, capacity.triangles));
    }
    let (nv, nt) = (nv as usize, nt as usize);
    let v3 = size_of::<[f32; 3]>();
    let v2 = size_of::<[f32; 2]>();
    check_strided(
        d.positions,
        nv,
        d.position_stride,
        v3,
        c"def.positions",
        c"def.position_stride",
    )?;
    check_strided(d.uvs, nv, d.uv_stride, v2, c"def.uvs", c"def.uv_stride")?;
    if nt > 0 && d.indices.is_null() {
        return Err(null(c"def.indices"));
    }
    if nt > 0 && !d.indices.is_aligned() {
        return Err(fault(R::Misaligned).what(c"def.indices"));
    }
    if !d.materials.is_aligned() {
        return Err(fault(R::Misaligned).what(c"def.materials"));
    }
    let settings = settings_from_c(&d.settings, &Settings::default())?;
    // SAFETY: the blob's bytes are readable and outlive the world per the contract.
    let parsed = unsafe { reparse(b) }?;

    let base = memory.cast::<u8>();
    // SAFETY: `memory` is writable for memory_size ≥ layout.total bytes. Zeroing makes every
    // byte initialized before any of it is viewed as a slice.
    unsafe { ptr::write_bytes(base, 0, layout.total) };

    // Gather the strided input into the scratch area (4-aligned, after the world's arrays).
    // SAFETY: offsets are within layout.total; the areas are disjoint; [f32; N] and u32 need
    // 4-byte alignment, which stage_at (a multiple of 4) on a 16-aligned base gives.
    let (positions, uvs, triangles, materials) = unsafe {
        let p = base.add(layout.stage_at).cast::<[f32; 3]>();
        let u = p.add(nv).cast::<[f32; 2]>();
        let t = u.add(nv).cast::<[u32; 3]>();
        let m = t.add(nt).cast::<u32>();
        for i in 0..nv {
            p.add(i)
                .write(read_floats::<3>(d.positions, d.position_stride, i));
            u.add(i).write(read_floats::<2>(d.uvs, d.uv_stride, i));
        }
        for i in 0..nt {
            let at = d.indices.add(3 * i);
            t.add(i)
                .write([at.read(), at.add(1).read(), at.add(2).read()]);
            let mat = if d.materials.is_null() {
                d.material
            } else {
                d.materials.add(i).read()
            };
            m.add(i).write(mat);
        }
        (
            core::slice::from_raw_parts(p, nv),
            core::slice::from_raw_parts(u, nv),
            core::slice::from_raw_parts(t, nt),
            core::slice::from_raw_parts(m, nt),
        )
    };
    let cloth = ClothDef {
        positions,
        uvs,
        triangles,
        materials,
    };
    // SAFETY: the arrays' region [HEADER, HEADER + world_bytes) lies within the block, is
    // disjoint from the header and the scratch area, initialized (zeroed) and, per the
    // contract, stays valid and unaliased until weft_world_destroy: hence 'static.
    let arrays: &'static mut [u8] = unsafe {
        core::slice::from_raw_parts_mut(base.add(WEFT_WORLD_HEADER_SIZE), layout.world_bytes)
    };
    let world = World::new(arrays, capacity, &cloth, Materials::Blob(&parsed), settings)
        .map_err(init_fault)?;
    let mesh_key = mesh_key(&world, &parsed);
    let handle = base.cast::<WeftWorld>();
    // SAFETY: the header area is WEFT_WORLD_HEADER_SIZE ≥ size_of::<WeftWorld>() bytes at a
    // WEFT_WORLD_MEMORY_ALIGN ≥ align_of::<WeftWorld>() aligned address, disjoint from the
    // arrays; `out` was checked.
    unsafe {
        handle.write(WeftWorld {
            cookie: WORLD_COOKIE,
            home: handle,
            world,
            blob: parsed,
            mesh_key,
            last_error: WeftErrorDetail::of(R::Ok),
            scratch: base.add(layout.stage_at).cast::<[f32; 3]>(),
            scratch_len: capacity.vertices as usize,
        });
        out.write(handle);
    }
    Ok(())
}

/// Ends a world: afterwards the memory block and the blob may be freed or reused; nothing else
/// needs releasing. While the block stays allocated and untouched, calls with the old handle
/// are refused (`WEFT_RESULT_INVALID_HANDLE`); once it is freed, the handle must not be used.
///
/// # Safety
/// `world` is NULL or points to readable, writable memory of at least `WEFT_WORLD_HEADER_SIZE`
/// bytes.
#[no_mangle]
pub unsafe extern "C" fn weft_world_destroy(world: *mut WeftWorld) -> WeftResult {
    done((|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_mut(world) }?;
        w.cookie = 0;
        Ok(())
    })())
}

/// The detail of the last failed call on `world` (calls taking a non-const `WeftWorld*`),
/// or `WEFT_RESULT_OK` with every index `WEFT_NONE` when none has failed.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_last_error_detail(
    world: *const WeftWorld,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    done((|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let out = out_ptr(out_detail, c"out_detail")?;
        // SAFETY: checked; writable per the contract.
        unsafe { out.write(w.last_error) };
        Ok(())
    })())
}

// ---------------------------------------------------------------------------------------------
// Stepping and settings
// ---------------------------------------------------------------------------------------------

/// Advances the cloth by `dt` seconds (finite, > 0) in `settings.substeps` substeps, moving
/// pins and colliders linearly from where they were at the last step to where they were set
/// since. `out_stats`: NULL, or written on success. On failure the world keeps the state it had
/// before the call.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); a non-NULL `out_stats` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_step(
    world: *mut WeftWorld,
    dt: f32,
    out_stats: *mut WeftStepStats,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            if !out_stats.is_null() && !out_stats.is_aligned() {
                return Err(fault(WeftResult::Misaligned).what(c"out_stats"));
            }
            let stats = w.world.step_dt(dt).map_err(step_fault)?;
            write_opt(out_stats, stats_to_c(&stats));
            Ok(())
        })
    }
}

/// The world's current settings, in `*out_settings`.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out_settings` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_settings(
    world: *const WeftWorld,
    out_settings: *mut WeftSettings,
) -> WeftResult {
    done((|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let out = out_ptr(out_settings, c"out_settings")?;
        // SAFETY: checked; writable per the contract.
        unsafe { out.write(settings_to_c(w.world.settings())) };
        Ok(())
    })())
}

/// Replaces the world's settings (all fields checked; nothing changes on failure). Wakes the
/// world when anything changed.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `settings` is readable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_settings(
    world: *mut WeftWorld,
    settings: *const WeftSettings,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let s = read_ref(settings, c"settings")?;
            let s = settings_from_c(s, w.world.settings())?;
            w.world.set_settings(s).map_err(init_fault)
        })
    }
}

/// Replaces the effect bit set (`WEFT_EFFECT_*`; other bits are `WEFT_RESULT_INVALID_SETTING`).
/// Effects can change between any two steps. Wakes the world when it changed.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_effects(world: *mut WeftWorld, effects: u32) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let s = Settings {
                effects,
                ..*w.world.settings()
            };
            w.world.set_settings(s).map_err(init_fault)
        })
    }
}

/// Whether the world is asleep (false for an invalid handle).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_is_asleep(world: *const WeftWorld) -> bool {
    // SAFETY: forwarded contract.
    unsafe { world_at(world) }.is_ok_and(|w| w.world.is_asleep())
}

/// Wakes a sleeping world (edits wake it too).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_wake(world: *mut WeftWorld) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            w.world.wake();
            Ok(())
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Vertices
// ---------------------------------------------------------------------------------------------

/// Number of vertices of the world's cloth (0 for an invalid handle).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_vertex_count(world: *const WeftWorld) -> u32 {
    // SAFETY: forwarded contract.
    unsafe { world_at(world) }.map_or(0, |w| w.world.vertex_count() as u32)
}

/// Number of triangles of the world's cloth (0 for an invalid handle).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_triangle_count(world: *const WeftWorld) -> u32 {
    // SAFETY: forwarded contract.
    unsafe { world_at(world) }.map_or(0, |w| w.world.triangle_count() as u32)
}

/// # Safety
/// `out` writable for the strided extent; `world` as [`world_at`].
unsafe fn get_vec3s(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
    which: for<'w> fn(&'w World<'static>) -> &'w [Vec3A],
) -> WeftResult {
    done((|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let src = which(&w.world);
        let n = src.len();
        if (count as usize) < n {
            let mut f = fault(WeftResult::CountMismatch).what(c"count");
            f.needed = n as u32;
            return Err(f);
        }
        check_strided(out, n, stride, 12, c"out", c"stride")?;
        // SAFETY: checked extent; writable per the contract.
        unsafe { write_vec3s(out, stride, src) };
        Ok(())
    })())
}

/// Copies the world's vertex positions (metres) out: vertex i's 3 floats to byte
/// `i * stride` of `out`, written unaligned (so straight into an interleaved vertex buffer).
/// `count` is the capacity of `out` in vertices, ≥ `weft_world_vertex_count`; exactly that
/// many are written. `stride` ≥ 12.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out` is writable for
/// `(vertex_count - 1) * stride + 12` bytes and does not overlap the world's memory block.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_positions(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe { get_vec3s(world, out, count, stride, |w| w.positions()) }
}

/// Copies the world's vertex velocities (m/s) out, like `weft_world_get_positions`.
///
/// # Safety
/// As `weft_world_get_positions`.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_velocities(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe { get_vec3s(world, out, count, stride, |w| w.velocities()) }
}

/// # Safety
/// `src` readable for the strided extent; `world` as [`world_mut`].
unsafe fn set_vec3s(
    world: *mut WeftWorld,
    src: *const c_void,
    count: u32,
    stride: usize,
    velocities: bool,
) -> WeftResult {
    let what = if velocities {
        c"velocities"
    } else {
        c"positions"
    };
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let n = w.world.vertex_count();
            if count as usize != n {
                let mut f = fault(WeftResult::CountMismatch).what(c"count");
                f.needed = n as u32;
                return Err(f);
            }
            check_strided(src, n, stride, 12, what, c"stride")?;
            if n > w.scratch_len {
                return Err(fault(WeftResult::Internal).what(c"scratch"));
            }
            // Gather into the block's scratch area (capacity.max_vertices entries, used by
            // nothing else after create), checking every value, then hand the kernel a slice.
            for i in 0..n {
                let p = read_floats::<3>(src, stride, i);
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(fault(WeftResult::NonFinite).what(what).vertex(i as u32));
                }
                w.scratch.add(i).write(p);
            }
            let gathered = core::slice::from_raw_parts(w.scratch, n);
            let r = if velocities {
                w.world.set_velocities(gathered)
            } else {
                w.world.set_positions(gathered)
            };
            r.map_err(|e| edit_fault(e, &w.world))
        })
    }
}

/// Overwrites every vertex position (metres) from `src`: vertex i's 3 floats at byte
/// `i * stride`, read unaligned. `count` must equal `weft_world_vertex_count`; `stride` ≥ 12.
/// Velocities are kept. Checks every value first (`WEFT_RESULT_NON_FINITE` names the vertex);
/// nothing changes on failure. Wakes the world. For teleports: the next step starts from here.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `src` is readable for
/// `(count - 1) * stride + 12` bytes.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_positions(
    world: *mut WeftWorld,
    src: *const c_void,
    count: u32,
    stride: usize,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe { set_vec3s(world, src, count, stride, false) }
}

/// Overwrites every vertex velocity (m/s), like `weft_world_set_positions`.
///
/// # Safety
/// As `weft_world_set_positions`.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_velocities(
    world: *mut WeftWorld,
    src: *const c_void,
    count: u32,
    stride: usize,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe { set_vec3s(world, src, count, stride, true) }
}

// ---------------------------------------------------------------------------------------------
// Pins
// ---------------------------------------------------------------------------------------------

/// Pins vertex `vertex` to `target` (metres), or moves its pin there. The vertex travels to the
/// target over the next step (linearly across substeps), so animate a pin by setting its
/// target every frame. A new pin starts where the vertex is. Wakes the world when the target
/// changed. Pins hold only while `WEFT_EFFECT_PINS` is on.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_pin(
    world: *mut WeftWorld,
    vertex: u32,
    target: WeftVec3,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            if !vec3(target).iter().all(|c| c.is_finite()) {
                return Err(fault(WeftResult::NonFinite).what(c"target").vertex(vertex));
            }
            w.world
                .set_pin(vertex, vec3(target))
                .map_err(|e| edit_fault(e, &w.world).vertex(vertex))
        })
    }
}

/// Releases the pin of vertex `vertex` (no error when it had none). Wakes the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_remove_pin(world: *mut WeftWorld, vertex: u32) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            w.world
                .remove_pin(vertex)
                .map_err(|e| edit_fault(e, &w.world).vertex(vertex))
        })
    }
}

/// Number of pinned vertices (0 for an invalid handle).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_pin_count(world: *const WeftWorld) -> u32 {
    // SAFETY: forwarded contract.
    unsafe { world_at(world) }.map_or(0, |w| w.world.pin_count() as u32)
}

// ---------------------------------------------------------------------------------------------
// Colliders
// ---------------------------------------------------------------------------------------------

/// Adds a kinematic collider (the engine moves it; the cloth does not push back) and writes
/// its index (0, 1, 2 ... in order of addition) to `*out_index` when that is not NULL.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `def` is readable; a non-NULL
/// `out_index` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_add_collider(
    world: *mut WeftWorld,
    def: *const WeftColliderDef,
    out_index: *mut u32,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let d = read_ref(def, c"def")?;
            if d.internal_cookie != COLLIDER_DEF_COOKIE {
                return Err(fault(WeftResult::Uninitialized).what(c"def"));
            }
            if !out_index.is_null() && !out_index.is_aligned() {
                return Err(fault(WeftResult::Misaligned).what(c"out_index"));
            }
            let shape = shape_from_c(&d.shape)?;
            if !(d.friction.is_finite() && d.friction >= 0.0) {
                return Err(fault(WeftResult::InvalidCollider).what(c"friction"));
            }
            if !(d.thickness.is_finite() && d.thickness >= 0.0) {
                return Err(fault(WeftResult::InvalidCollider).what(c"thickness"));
            }
            let index = w
                .world
                .add_collider(Collider::new(shape, d.friction, d.thickness))
                .map_err(|e| edit_fault(e, &w.world))?;
            write_opt(out_index, index);
            Ok(())
        })
    }
}

/// Moves collider `index` to `*shape` (same or another kind). The next step sweeps it linearly
/// from where it was at the last step (a change of kind teleports). Wakes the world when it
/// moved.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `shape` is readable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_collider(
    world: *mut WeftWorld,
    index: u32,
    shape: *const WeftShape,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let s = shape_from_c(read_ref(shape, c"shape")?)?;
            w.world
                .set_collider_shape(index, s)
                .map_err(|e| edit_fault(e, &w.world).index(index))
        })
    }
}

/// Removes every collider. Wakes the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_clear_colliders(world: *mut WeftWorld) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            w.world.clear_colliders();
            Ok(())
        })
    }
}

/// Number of colliders (0 for an invalid handle).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_collider_count(world: *const WeftWorld) -> u32 {
    // SAFETY: forwarded contract.
    unsafe { world_at(world) }.map_or(0, |w| w.world.collider_count() as u32)
}

// ---------------------------------------------------------------------------------------------
// Localization
// ---------------------------------------------------------------------------------------------

/// Where `weft_localize` writes a range of the fine render mesh. Get one from
/// `weft_default_localize_output()` and edit it (a struct that did not come from there is
/// `WEFT_RESULT_UNINITIALIZED`). Only read during the call.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct WeftLocalizeOutput {
    /// Fine vertex positions, metres: element k of the call (binding `first + k`) gets 3 floats
    /// at byte `k * position_stride`, written unaligned, so straight into an interleaved
    /// vertex buffer; the bytes between are left alone. NULL only when `count` is 0.
    pub positions: *mut c_void,
    /// Bytes from one position to the next, ≥ 12. Default 12.
    pub position_stride: usize,
    /// Unit normals, like `positions` (element k at byte `k * normal_stride`); NULL (the
    /// default): no normals. Either a buffer of its own that does not overlap the positions,
    /// or the same records (interleaved: `normal_stride` equal to `position_stride`, the
    /// normal's 12 bytes disjoint from the position's inside each record).
    pub normals: *mut c_void,
    /// Bytes from one normal to the next, ≥ 12. Default 12.
    pub normal_stride: usize,
    /// `WEFT_NORMALS_BLENDED` (default) or `WEFT_NORMALS_RECOMPUTED`; anything else is
    /// `WEFT_RESULT_INVALID_ARGUMENT`. Ignored when `normals` is NULL.
    pub normal_mode: u32,
    /// `WEFT_NORMALS_RECOMPUTED` only: the fine triangles, 3 × `fine_triangle_count` tightly
    /// packed `uint32_t` (4-aligned) indices *relative to this call's range* (index k is
    /// binding `first + k`, so every index is < `count`). Counter-clockwise in (u, v), as
    /// `weft_tiled_mesh` makes them, gives normals on the same side as the blended ones. A
    /// vertex whose triangles all collapsed keeps the normal the buffer held (so the normals
    /// must hold initialized values: zeros, or the last frame's). Recomputed normals need
    /// every triangle around a vertex: localize the whole mesh in one call, or give each range
    /// the triangles of its vertices. Default NULL.
    pub fine_indices: *const u32,
    /// Number of triangles at `fine_indices`. Default 0.
    pub fine_triangle_count: u32,
    /// Set by `weft_default_localize_output`; do not touch.
    pub internal_cookie: u32,
}

/// The start of a frames block (private to the library).
#[repr(C)]
#[derive(Clone, Copy)]
struct FramesHeader {
    cookie: u32,
    vertex_count: u32,
    mesh_key: u64,
    /// The world they were prepared from.
    world: *const WeftWorld,
    /// The block's own address: a moved or copied block is refused.
    home: *const c_void,
}

/// FNV-1a, 64 bits: the cloth key of bindings and frames (a check, not a security measure).
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
}

/// What bindings depend on: the coarse mesh, its rest (u, v), its materials and the blob (its
/// header holds the checksum of everything else in it). Stable across runs, so bindings stored
/// with a mesh asset still match the same cloth later.
fn mesh_key(world: &World<'_>, blob: &Blob<'_>) -> u64 {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    h.u32(world.vertex_count() as u32);
    h.u32(world.triangle_count() as u32);
    for r in world.rest_positions() {
        h.u32(r.x.to_bits());
        h.u32(r.y.to_bits());
    }
    for t in world.triangles() {
        for &v in t {
            h.u32(v);
        }
    }
    for &m in world.triangle_materials() {
        h.u32(m);
    }
    h.bytes(blob.as_bytes().get(..blob::HEADER_SIZE).unwrap_or(&[]));
    h.0
}

/// Bytes of a caller-owned block of `header` bytes and `n` records of `record` bytes, if it can
/// be one Rust slice (at most `isize::MAX` bytes).
fn block_bytes(header: usize, record: usize, n: usize) -> Option<usize> {
    let b = n.checked_mul(record)?.checked_add(header)?;
    (b <= isize::MAX as usize).then_some(b)
}

/// Bytes of a bindings block for `n` fine vertices.
fn bind_bytes(n: usize) -> Option<usize> {
    block_bytes(WEFT_BIND_HEADER_SIZE, WEFT_BIND_VERTEX_SIZE, n)
}

/// Bytes of a frames block for `n` coarse vertices.
fn frames_bytes(n: usize) -> Option<usize> {
    block_bytes(
        WEFT_LOCALIZE_FRAMES_HEADER_SIZE,
        WEFT_LOCALIZE_FRAME_SIZE,
        n,
    )
}

/// A count as `u32` for an error detail (saturating).
fn count32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Writes the detail of a call that reports through an `out_detail` argument.
///
/// # Safety
/// `out_detail` is NULL or writable.
unsafe fn detailed(out_detail: *mut WeftErrorDetail, r: FfiResult<()>) -> WeftResult {
    let detail = match r {
        Ok(()) => WeftErrorDetail::of(WeftResult::Ok),
        Err(d) => d,
    };
    // SAFETY: NULL or writable per the contract.
    unsafe { write_opt(out_detail, detail) };
    detail.result
}

/// A bindings block's count, key and records, after checking its header against its size.
///
/// # Safety
/// A non-null `p` is readable for `size` bytes for `'a`.
unsafe fn bindings_block<'a>(p: *const c_void, size: usize) -> FfiResult<(u64, &'a [Binding])> {
    use WeftResult as R;
    if p.is_null() {
        return Err(null(c"bindings"));
    }
    if (p as usize) % WEFT_BIND_MEMORY_ALIGN != 0 {
        return Err(fault(R::Misaligned).what(c"bindings"));
    }
    if size < WEFT_BIND_HEADER_SIZE {
        return Err(fault(R::BindingsInvalid).what(c"bindings_size"));
    }
    // SAFETY: 16 readable bytes (size checked), 4-aligned; u32 is valid for any bytes.
    let [cookie, count, lo, hi] = unsafe { p.cast::<[u32; 4]>().read() };
    if cookie != BINDINGS_COOKIE {
        return Err(fault(R::BindingsInvalid).what(c"bindings"));
    }
    let n = count as usize;
    if bind_bytes(n).is_none_or(|b| b > size) {
        return Err(fault(R::BindingsInvalid).what(c"bindings_size"));
    }
    // SAFETY: the records lie within the `size` readable bytes (checked), 4-aligned (the block
    // is, and the header is 16 bytes); Binding is plain data (u32 and f32), valid for any bytes.
    let records = unsafe {
        core::slice::from_raw_parts(
            p.cast::<u8>().add(WEFT_BIND_HEADER_SIZE).cast::<Binding>(),
            n,
        )
    };
    Ok((u64::from(lo) | (u64::from(hi) << 32), records))
}

/// The frames prepared in `p` for the world `w` (at `handle`).
///
/// # Safety
/// A non-null `p` is readable for `WEFT_LOCALIZE_FRAMES_HEADER_SIZE` bytes and, when its
/// header says it was prepared here, for the frames it announces, for `'a`.
unsafe fn frames_at<'a>(
    p: *const c_void,
    handle: *const WeftWorld,
    w: &WeftWorld,
) -> FfiResult<&'a [VertexFrame]> {
    use WeftResult as R;
    if p.is_null() {
        return Err(null(c"frames"));
    }
    if (p as usize) % WEFT_LOCALIZE_FRAMES_ALIGN != 0 {
        return Err(fault(R::Misaligned).what(c"frames"));
    }
    // SAFETY: readable and aligned per the contract; integers and raw pointers are valid for
    // any bytes.
    let h = unsafe { p.cast::<FramesHeader>().read() };
    if h.cookie != FRAMES_COOKIE || h.home != p {
        return Err(fault(R::FramesNotPrepared).what(c"frames"));
    }
    let n = w.world.vertex_count();
    if h.world != handle || h.vertex_count as usize != n || h.mesh_key != w.mesh_key {
        return Err(fault(R::FramesMismatch).what(c"frames"));
    }
    // SAFETY: weft_localize_prepare checked the block holds n frames after the header and
    // wrote them (the cookie and home say so); 16-aligned.
    Ok(unsafe {
        core::slice::from_raw_parts(
            p.cast::<u8>()
                .add(WEFT_LOCALIZE_FRAMES_HEADER_SIZE)
                .cast::<VertexFrame>(),
            n,
        )
    })
}

fn tiled_fault(e: BindError, cell: u32) -> Fault {
    use WeftResult as R;
    match e {
        BindError::NoSuchCell { .. } => fault(R::BlobCellOutOfRange).cell(cell),
        BindError::TooLarge => fault(R::TiledMeshTooLarge).cell(cell),
        BindError::BufferTooSmall { needed, len } => {
            fault(R::TiledMeshCapacity).needed(count32(needed), count32(len))
        }
        _ => fault(R::Internal).what(c"tiled mesh"),
    }
}

/// A `WeftLocalizeOutput` with every field at its default: no buffers yet (set `positions`,
/// and `normals` if wanted), strides 12, blended normals.
#[no_mangle]
pub extern "C" fn weft_default_localize_output() -> WeftLocalizeOutput {
    WeftLocalizeOutput {
        positions: ptr::null_mut(),
        position_stride: size_of::<WeftVec3>(),
        normals: ptr::null_mut(),
        normal_stride: size_of::<WeftVec3>(),
        normal_mode: WEFT_NORMALS_BLENDED,
        fine_indices: ptr::null(),
        fine_triangle_count: 0,
        internal_cookie: LOCALIZE_OUTPUT_COOKIE,
    }
}

/// Bytes of a bindings block for `fine_vertex_count` fine vertices, in `*out_size`:
/// `WEFT_BIND_HEADER_SIZE + WEFT_BIND_VERTEX_SIZE * fine_vertex_count`.
/// `WEFT_RESULT_CAPACITY_TOO_LARGE` when that does not fit in `size_t`.
///
/// # Safety
/// `out_size` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_bind_memory_size(
    fine_vertex_count: u32,
    out_size: *mut usize,
) -> WeftResult {
    done((|| {
        let out = out_ptr(out_size, c"out_size")?;
        let size =
            bind_bytes(fine_vertex_count as usize).ok_or(fault(WeftResult::CapacityTooLarge))?;
        // SAFETY: checked; writable per the contract.
        unsafe { out.write(size) };
        Ok(())
    })())
}

/// Binds a fine render mesh to the world's coarse cloth, once per mesh: for each fine vertex,
/// its coarse triangle, its barycentric place there and the cells' characteristic
/// displacements at its (u, v), written to the caller's bindings block. The block is plain,
/// position-independent data: it can be stored with the mesh asset and used with any world
/// made from the same cloth (mesh, rest (u, v), materials and blob bytes); `weft_localize`
/// refuses it for any other (`WEFT_RESULT_BINDINGS_MISMATCH`).
///
/// - `fine_uvs`: material coordinates (u, v) in metres, in the same layout as the coarse
///   `WeftWorldDef.uvs` (the cell pattern repeats every cell width from u = v = 0): 2 floats
///   per fine vertex, vertex i at byte `i * uv_stride`, read unaligned. NULL only when
///   `fine_vertex_count` is 0. Points on a coarse edge or vertex get the same binding
///   whichever copy of the vertex they are (seams stay closed).
/// - `uv_stride`: ≥ 8.
/// - `out_bindings`: `bindings_size` bytes, `WEFT_BIND_MEMORY_ALIGN`-aligned, at least
///   `weft_bind_memory_size(fine_vertex_count)`; written only on success. Owned by the caller.
/// - `out_detail`: NULL, or filled on every call (`WEFT_RESULT_BIND_OUT_OF_DOMAIN` names the
///   vertex).
///
/// Cost: a point location per vertex, walking from the previous vertex's triangle (fast for
/// coherent vertex orders such as a tiled mesh's), plus an interpolation in the cell: about
/// 0.25–0.6 µs per vertex on a desktop core. Reads the world only (see `WeftWorld` on
/// threads).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `fine_uvs` is readable for
/// `(fine_vertex_count - 1) * uv_stride + 8` bytes; `out_bindings` is writable for
/// `bindings_size` bytes and overlaps neither `fine_uvs` nor the world's memory; a non-NULL
/// `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_bind(
    world: *const WeftWorld,
    fine_uvs: *const c_void,
    fine_vertex_count: u32,
    uv_stride: usize,
    out_bindings: *mut c_void,
    bindings_size: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let run = || -> FfiResult<()> {
        use WeftResult as R;
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        if out_bindings.is_null() {
            return Err(null(c"out_bindings"));
        }
        if (out_bindings as usize) % WEFT_BIND_MEMORY_ALIGN != 0 {
            return Err(fault(R::Misaligned).what(c"out_bindings"));
        }
        let n = fine_vertex_count as usize;
        let needed = bind_bytes(n).ok_or(fault(R::CapacityTooLarge))?;
        if bindings_size < needed {
            let room = bindings_size.saturating_sub(WEFT_BIND_HEADER_SIZE) / WEFT_BIND_VERTEX_SIZE;
            return Err(fault(R::BindMemoryTooSmall)
                .what(c"bindings_size")
                .needed(fine_vertex_count, count32(room)));
        }
        check_strided(fine_uvs, n, uv_stride, 8, c"fine_uvs", c"uv_stride")?;
        let uv = if n == 0 {
            Strided::from_slice(&[])
        } else {
            let extent = strided_extent(n, uv_stride, 8).ok_or(invalid(c"uv_stride"))?;
            // SAFETY: non-null (checked), readable for the extent per the contract.
            let bytes = unsafe { core::slice::from_raw_parts(fine_uvs.cast::<u8>(), extent) };
            Strided::<2>::new(bytes, uv_stride, n).map_err(|_| invalid(c"uv_stride"))?
        };
        let base = out_bindings.cast::<u8>();
        // SAFETY: the records lie within the writable block (size checked), 4-aligned, disjoint
        // from the inputs per the contract; Binding is plain data valid for any bytes.
        let records = unsafe {
            core::slice::from_raw_parts_mut(base.add(WEFT_BIND_HEADER_SIZE).cast::<Binding>(), n)
        };
        localize::bind(&w.world, &w.blob, &uv, records).map_err(|e| match e {
            BindError::OutOfDomain { vertex } => fault(R::BindOutOfDomain).vertex(vertex),
            _ => fault(R::Internal).what(c"bind"),
        })?;
        let key = w.mesh_key;
        // SAFETY: the header's 16 bytes are within the block, 4-aligned.
        unsafe {
            base.cast::<[u32; 4]>().write([
                BINDINGS_COOKIE,
                fine_vertex_count,
                key as u32,
                (key >> 32) as u32,
            ])
        };
        Ok(())
    };
    // SAFETY: forwarded contract.
    unsafe { detailed(out_detail, run()) }
}

/// The number of fine vertices a bindings block holds (written by `weft_bind`), in
/// `*out_count`: e.g. for a block loaded from a file. Checks the block's header against
/// `bindings_size` (`WEFT_RESULT_BINDINGS_INVALID`), not against a world.
///
/// # Safety
/// `bindings` is readable for `bindings_size` bytes; `out_count` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_bind_vertex_count(
    bindings: *const c_void,
    bindings_size: usize,
    out_count: *mut u32,
) -> WeftResult {
    done((|| {
        let out = out_ptr(out_count, c"out_count")?;
        // SAFETY: forwarded contract.
        let (_, records) = unsafe { bindings_block(bindings, bindings_size) }?;
        // SAFETY: checked; writable per the contract.
        unsafe { out.write(count32(records.len())) };
        Ok(())
    })())
}

/// Bytes of a frames block for this world, in `*out_size`: `WEFT_LOCALIZE_FRAMES_HEADER_SIZE +
/// WEFT_LOCALIZE_FRAME_SIZE * weft_world_vertex_count(world)`, a multiple of
/// `WEFT_LOCALIZE_FRAMES_ALIGN` (as C11 `aligned_alloc` wants).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out_size` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_localize_frames_size(
    world: *const WeftWorld,
    out_size: *mut usize,
) -> WeftResult {
    done((|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let out = out_ptr(out_size, c"out_size")?;
        let size = frames_bytes(w.world.vertex_count()).ok_or(fault(WeftResult::Internal))?;
        // SAFETY: checked; writable per the contract.
        unsafe { out.write(size) };
        Ok(())
    })())
}

/// Once per frame, after the step and before `weft_localize`: measures the coarse cloth's
/// current deformation (per coarse triangle, area-averaged to its vertices, so the fine mesh
/// has no cracks) into the caller's frames block. O(coarse triangles).
///
/// - `strain_measure`: `WEFT_STRAIN_COROTATED` or `WEFT_STRAIN_GREEN`; anything else is
///   `WEFT_RESULT_INVALID_ARGUMENT`.
/// - `frames`: `frames_size` bytes, `WEFT_LOCALIZE_FRAMES_ALIGN`-aligned, at least
///   `weft_localize_frames_size(world)`; written only on success. Owned by the caller; used
///   where it was prepared (a moved or copied block is `WEFT_RESULT_FRAMES_NOT_PREPARED`), and
///   it describes the world as it was at this call until prepared again.
/// - `out_detail`: NULL, or filled on every call.
///
/// Reads the world only (see `WeftWorld` on threads).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `frames` is writable for
/// `frames_size` bytes and does not overlap the world's memory; a non-NULL `out_detail` is
/// writable.
#[no_mangle]
pub unsafe extern "C" fn weft_localize_prepare(
    world: *const WeftWorld,
    strain_measure: u32,
    frames: *mut c_void,
    frames_size: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let run = || -> FfiResult<()> {
        use WeftResult as R;
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let measure = match strain_measure {
            WEFT_STRAIN_COROTATED => StrainMeasure::Corotated,
            WEFT_STRAIN_GREEN => StrainMeasure::Green,
            _ => return Err(invalid(c"strain_measure")),
        };
        if frames.is_null() {
            return Err(null(c"frames"));
        }
        if (frames as usize) % WEFT_LOCALIZE_FRAMES_ALIGN != 0 {
            return Err(fault(R::Misaligned).what(c"frames"));
        }
        let n = w.world.vertex_count();
        let needed = frames_bytes(n).ok_or(fault(R::Internal))?;
        if frames_size < needed {
            let room = frames_size.saturating_sub(WEFT_LOCALIZE_FRAMES_HEADER_SIZE)
                / WEFT_LOCALIZE_FRAME_SIZE;
            return Err(fault(R::FramesTooSmall)
                .what(c"frames_size")
                .needed(count32(n), count32(room)));
        }
        let base = frames.cast::<u8>();
        // SAFETY: within the writable block (size checked), 16-aligned, disjoint from the world
        // per the contract; VertexFrame is plain f32 data valid for any bytes (and `prepare`
        // overwrites every one before reading).
        let slots = unsafe {
            core::slice::from_raw_parts_mut(
                base.add(WEFT_LOCALIZE_FRAMES_HEADER_SIZE)
                    .cast::<VertexFrame>(),
                n,
            )
        };
        localize::prepare(&w.world, measure, slots)
            .map_err(|_| fault(R::Internal).what(c"prepare"))?;
        // SAFETY: the header lies at the block's 16-aligned start, within it.
        unsafe {
            base.cast::<FramesHeader>().write(FramesHeader {
                cookie: FRAMES_COOKIE,
                vertex_count: count32(n),
                mesh_key: w.mesh_key,
                world,
                home: frames,
            })
        };
        Ok(())
    };
    // SAFETY: forwarded contract.
    unsafe { detailed(out_detail, run()) }
}

/// Puts the fine pattern back on the coarse cloth (the paper's Eq. 20–23): writes fine vertices
/// `first .. first + count` of a bound render mesh (positions, and normals if asked) to the
/// buffers of `*output`; element k of the output is binding `first + k`. Each fine vertex lands
/// at its barycentric place on the current coarse triangle plus the cell's micro displacement
/// under the blended macro strain, so the fine mesh shows the pattern's own deformation (soft
/// layers stretching more than hard ones) without cracks across coarse edges or cells.
///
/// - `frames`: prepared by `weft_localize_prepare` from this world.
/// - `bindings`, `bindings_size`: a block written by `weft_bind` for this world's cloth.
/// - `first`, `count`: the range of fine vertices; `first + count` ≤ the bindings' vertex
///   count. Disjoint ranges can go to different threads at once (the call reads the world,
///   frames and bindings only), e.g. `first = k * n / jobs` with `output.positions` pointing at
///   that range's first record.
/// - `output`: from `weft_default_localize_output()`, with the buffers set.
/// - `out_detail`: NULL, or filled on every call.
///
/// Everything is checked before anything is written: on failure no output byte changed.
/// Cost per fine vertex: a few ns for positions (about 150 M vertices/s on one desktop
/// core), about 1.3 × that with blended normals, about 6 × with recomputed normals.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `frames` a block given to
/// `weft_localize_prepare` (or any readable memory of `WEFT_LOCALIZE_FRAMES_HEADER_SIZE`
/// bytes); `bindings` is readable for `bindings_size` bytes; `output` is readable, and the
/// buffers it names are writable for their strided extents (`fine_indices` readable) and
/// overlap neither each other (interleaved normals aside, as `WeftLocalizeOutput.normals`
/// describes) nor the world's memory, the frames or the bindings; a non-NULL `out_detail` is
/// writable. No other thread writes any of them during the call.
#[no_mangle]
pub unsafe extern "C" fn weft_localize(
    world: *const WeftWorld,
    frames: *const c_void,
    bindings: *const c_void,
    bindings_size: usize,
    first: u32,
    count: u32,
    output: *const WeftLocalizeOutput,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract.
    let r =
        unsafe { localize_checked(world, frames, bindings, bindings_size, first, count, output) };
    // SAFETY: forwarded contract.
    unsafe { detailed(out_detail, r) }
}

/// # Safety
/// As [`weft_localize`].
unsafe fn localize_checked(
    world: *const WeftWorld,
    frames: *const c_void,
    bindings: *const c_void,
    bindings_size: usize,
    first: u32,
    count: u32,
    output: *const WeftLocalizeOutput,
) -> FfiResult<()> {
    use WeftResult as R;
    // SAFETY: forwarded contract.
    let w = unsafe { world_at(world) }?;
    // SAFETY: readable per the contract.
    let o = unsafe { read_ref(output, c"output") }?;
    if o.internal_cookie != LOCALIZE_OUTPUT_COOKIE {
        return Err(fault(R::Uninitialized).what(c"output"));
    }
    let recompute = match o.normal_mode {
        WEFT_NORMALS_BLENDED => false,
        WEFT_NORMALS_RECOMPUTED => true,
        _ => return Err(invalid(c"output.normal_mode")),
    };
    // SAFETY: forwarded contract.
    let frames = unsafe { frames_at(frames, world, w) }?;
    // SAFETY: forwarded contract.
    let (key, all) = unsafe { bindings_block(bindings, bindings_size) }?;
    if key != w.mesh_key {
        return Err(fault(R::BindingsMismatch).what(c"bindings"));
    }
    let n = count as usize;
    let range_fault = || {
        let mut f = fault(R::LocalizeRange).index(first);
        f.needed = first.saturating_add(count);
        f.capacity = count32(all.len());
        f
    };
    let end = (first as usize).checked_add(n).ok_or_else(range_fault)?;
    let range = all.get(first as usize..end).ok_or_else(range_fault)?;

    let (pp, ps) = (o.positions, o.position_stride);
    check_strided(
        pp,
        n,
        ps,
        12,
        c"output.positions",
        c"output.position_stride",
    )?;
    let normals = !o.normals.is_null();
    let (np, ns) = (o.normals, o.normal_stride);
    if normals {
        check_strided(np, n, ns, 12, c"output.normals", c"output.normal_stride")?;
    }
    let fine: &[[u32; 3]] = if normals && recompute && o.fine_triangle_count > 0 {
        let t = o.fine_indices;
        if t.is_null() {
            return Err(null(c"output.fine_indices"));
        }
        if !t.is_aligned() {
            return Err(fault(R::Misaligned).what(c"output.fine_indices"));
        }
        let nt = o.fine_triangle_count as usize;
        if nt.checked_mul(12).is_none_or(|b| b > isize::MAX as usize) {
            return Err(invalid(c"output.fine_triangle_count"));
        }
        // SAFETY: non-null, 4-aligned, readable for nt triangles per the contract.
        let tris = unsafe { core::slice::from_raw_parts(t.cast::<[u32; 3]>(), nt) };
        for (ti, tri) in tris.iter().enumerate() {
            if let Some(&v) = tri.iter().find(|&&v| v >= count) {
                return Err(fault(R::FineIndexOutOfRange)
                    .triangle(count32(ti))
                    .vertex(v)
                    .what(c"output.fine_indices"));
            }
        }
        tris
    } else {
        &[]
    };
    // Bindings from a matching block name existing triangles unless the data was damaged:
    // checked here so that the kernel cannot stop half-way.
    let nt = w.world.triangle_count();
    if let Some(i) = range.iter().position(|b| b.triangle as usize >= nt) {
        return Err(fault(R::BindingOutOfRange)
            .index(first.saturating_add(count32(i)))
            .what(c"bindings"));
    }
    if n == 0 {
        return Ok(());
    }
    fn layout<E>(_: E) -> Fault {
        fault(WeftResult::NormalLayout).what(c"output.normals")
    }
    fn internal<E>(_: E) -> Fault {
        fault(WeftResult::Internal).what(c"localize")
    }
    let pe = strided_extent(n, ps, 12).ok_or(invalid(c"output.position_stride"))?;
    let p_end = (pp as usize)
        .checked_add(pe)
        .ok_or(invalid(c"output.positions"))?;
    let tris = w.world.triangles();
    if !normals {
        // SAFETY: non-null, writable for the extent per the contract, disjoint from the inputs.
        let bytes = unsafe { core::slice::from_raw_parts_mut(pp.cast::<u8>(), pe) };
        let mut pos = StridedMut::<3>::new(bytes, ps, n).map_err(internal)?;
        return localize::localize(frames, tris, range, 0, &mut pos, None).map_err(internal);
    }
    let ne = strided_extent(n, ns, 12).ok_or(invalid(c"output.normal_stride"))?;
    let n_end = (np as usize)
        .checked_add(ne)
        .ok_or(invalid(c"output.normals"))?;
    let overlap = (pp as usize) < n_end && (np as usize) < p_end;
    if !overlap {
        // SAFETY: both non-null, writable for their extents per the contract, and disjoint
        // (checked) from each other and (per the contract) from the inputs.
        let (pb, nb) = unsafe {
            (
                core::slice::from_raw_parts_mut(pp.cast::<u8>(), pe),
                core::slice::from_raw_parts_mut(np.cast::<u8>(), ne),
            )
        };
        let mut pos = StridedMut::<3>::new(pb, ps, n).map_err(internal)?;
        let mut nrm = StridedMut::<3>::new(nb, ns, n).map_err(internal)?;
        return if recompute {
            localize::localize(frames, tris, range, 0, &mut pos, None).map_err(internal)?;
            localize::recompute_normals(fine, &mut pos, NormalTarget::Buffer(&mut nrm))
                .map_err(internal)
        } else {
            localize::localize(
                frames,
                tris,
                range,
                0,
                &mut pos,
                Some(NormalTarget::Buffer(&mut nrm)),
            )
            .map_err(internal)
        };
    }
    // Interleaved: one view of the records, the normal at its own offset in each.
    let lo = (pp as usize).min(np as usize);
    let (po, no) = (pp as usize - lo, np as usize - lo);
    let disjoint = po + 12 <= no || no + 12 <= po;
    if ps != ns || po + 12 > ps || no + 12 > ps || !disjoint {
        return Err(layout(()));
    }
    let len = p_end.max(n_end) - lo;
    let start = if po == 0 { pp } else { np };
    // SAFETY: [lo, lo + len) is the union of the two writable extents, which overlap (so the
    // union is one range); disjoint from the inputs per the contract.
    let bytes = unsafe { core::slice::from_raw_parts_mut(start.cast::<u8>(), len) };
    let mut pos = StridedMut::<3>::with_offset(bytes, ps, po, n).map_err(layout)?;
    let target = NormalTarget::Interleaved { offset: no };
    if recompute {
        localize::localize(frames, tris, range, 0, &mut pos, None).map_err(internal)?;
        localize::recompute_normals(fine, &mut pos, target).map_err(internal)
    } else {
        localize::localize(frames, tris, range, 0, &mut pos, Some(target)).map_err(internal)
    }
}

/// The size of cell `cell`'s micro mesh tiled over the cloth (`weft_tiled_mesh`): vertices in
/// `*out_vertex_count`, triangles in `*out_triangle_count`.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); the outputs are writable; a
/// non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_tiled_mesh_counts(
    world: *const WeftWorld,
    cell: u32,
    out_vertex_count: *mut u32,
    out_triangle_count: *mut u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let run = || -> FfiResult<()> {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let ov = out_ptr(out_vertex_count, c"out_vertex_count")?;
        let ot = out_ptr(out_triangle_count, c"out_triangle_count")?;
        let (nv, nt) = tiled_counts(w, cell)?;
        // SAFETY: checked; writable per the contract.
        unsafe {
            ov.write(nv);
            ot.write(nt);
        }
        Ok(())
    };
    // SAFETY: forwarded contract.
    unsafe { detailed(out_detail, run()) }
}

fn tiled_counts(w: &WeftWorld, cell: u32) -> FfiResult<(u32, u32)> {
    let (nv, nt) =
        localize::tiled_mesh_counts(&w.world, &w.blob, cell).map_err(|e| tiled_fault(e, cell))?;
    match (u32::try_from(nv), u32::try_from(nt)) {
        (Ok(v), Ok(t)) if nt.checked_mul(3).is_some_and(|i| u32::try_from(i).is_ok()) => Ok((v, t)),
        _ => Err(fault(WeftResult::TiledMeshTooLarge).cell(cell)),
    }
}

/// Cell `cell`'s micro mesh (any cell of the world's blob) tiled over the (u, v) bounding box
/// of the cloth: a fine render mesh that shows the pattern, ready for `weft_bind`. A grid on
/// the cell's own lattice (square side `WeftCellInfo.width / (cols * refine)`, anchored at
/// u = v = 0 like the cells), the outer rows and columns clamped to the box. Vertices go row
/// by row (a row along u, rows from the lowest v up); each square is split into two
/// counter-clockwise triangles. For a cloth that is
/// not a rectangle in (u, v), drop the vertices outside it before binding
/// (`WEFT_RESULT_BIND_OUT_OF_DOMAIN` names them).
///
/// - `out_uvs`: `uv_capacity` ≥ the vertex count of `weft_tiled_mesh_counts`; receives each
///   vertex's (u, v), metres (tightly packed; 4-aligned).
/// - `out_indices`: 3 × `triangle_capacity` `uint32_t`, `triangle_capacity` ≥ the triangle
///   count; receives 3 vertex indices per triangle.
/// - `out_materials`: NULL, or `triangle_capacity` `uint32_t` that receive each triangle's
///   pattern material: its index among the cell's materials, which `weft-cell` numbers in the
///   sorted order of the cell file's material keys.
/// - `out_detail`: NULL, or filled on every call.
///
/// Of each output, only the first (vertex or triangle count) elements are written, and only on
/// success.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); the outputs are writable for their
/// capacities and do not overlap each other or the world's memory; a non-NULL `out_detail`
/// is writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn weft_tiled_mesh(
    world: *const WeftWorld,
    cell: u32,
    out_uvs: *mut WeftVec2,
    uv_capacity: u32,
    out_indices: *mut u32,
    triangle_capacity: u32,
    out_materials: *mut u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let run = || -> FfiResult<()> {
        use WeftResult as R;
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let uvs = out_ptr(out_uvs, c"out_uvs")?;
        let idx = out_ptr(out_indices, c"out_indices")?;
        if !out_materials.is_aligned() {
            return Err(fault(R::Misaligned).what(c"out_materials"));
        }
        let (nv, nt) = tiled_counts(w, cell)?;
        if uv_capacity < nv {
            return Err(fault(R::TiledMeshCapacity)
                .what(c"uv_capacity")
                .needed(nv, uv_capacity));
        }
        if triangle_capacity < nt {
            return Err(fault(R::TiledMeshCapacity)
                .what(c"triangle_capacity")
                .needed(nt, triangle_capacity));
        }
        // SAFETY: non-null and aligned (checked), writable for the capacities ≥ the counts per
        // the contract, disjoint; WeftVec2 is [f32; 2] in layout and every type is plain data.
        let (uv_out, tri_out, mat_out) = unsafe {
            (
                core::slice::from_raw_parts_mut(uvs.cast::<[f32; 2]>(), nv as usize),
                core::slice::from_raw_parts_mut(idx.cast::<[u32; 3]>(), nt as usize),
                (!out_materials.is_null())
                    .then(|| core::slice::from_raw_parts_mut(out_materials, nt as usize)),
            )
        };
        localize::tiled_mesh(&w.world, &w.blob, cell, uv_out, tri_out, mat_out)
            .map_err(|e| tiled_fault(e, cell))?;
        Ok(())
    };
    // SAFETY: forwarded contract.
    unsafe { detailed(out_detail, run()) }
}
