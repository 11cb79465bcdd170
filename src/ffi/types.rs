//! The `#[repr(C)]` structs of the C API and the opaque world handle.

use core::ffi::{c_char, c_void};

use crate::blob::Blob;
use crate::world::World;

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

/// A rotation as a unit quaternion `w + x i + y j + z k` (a non-unit one is normalized).
/// 16 bytes, no padding.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeftQuat {
    /// i component.
    pub x: f32,
    /// j component.
    pub y: f32,
    /// k component.
    pub z: f32,
    /// Real component (1 for no rotation).
    pub w: f32,
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
    /// Linear solver relative residual, > 0. Default 1e-3 (the step's energy balance redoes a
    /// step that an inexact solve made gain energy). 1e-2 is as accurate in motion at about
    /// half the CG iterations, but the energy balance forgives a step a gain of up to its input
    /// energy times the solve's residual (1 % at 1e-2), and a cloth near rest creeps longer:
    /// for cloth that never rests.
    pub tolerance: f32,
    /// Linear solver iteration cap per substep, 1..=10000. Default 200.
    pub max_iterations: u32,
    /// Rotation iterations per node per substep (per-node warping only), 0..=100. Default 4.
    pub rotation_iterations: u32,
    /// Sleep threshold, m/s, ≥ 0: the cloth sleeps when every vertex is slower than this for
    /// `sleep_frames` steps (needs `WEFT_EFFECT_SLEEP`). Default 0.001.
    pub sleep_velocity: f32,
    /// Calm steps before sleeping. Default 30.
    pub sleep_frames: u32,
    /// Largest speed, m/s, ≥ 0, at which a contact pushes a vertex out of a collider it is
    /// inside (relative to the collider); deeper penetration is corrected by position only, so
    /// a cloth found inside a collider is put back, not launched. Default 1.
    pub max_depenetration_speed: f32,
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
    /// Orientation (index order) is free, triangle by triangle: weft orients every triangle by
    /// its (u, v) layout, so a triangle listed in either order simulates identically. What must
    /// hold is that the (u, v) layout does not fold over itself
    /// (`WEFT_RESULT_MESH_FOLDED_UV`). NULL only when `triangle_count` is 0.
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
    /// Zero; reserved (it makes the struct's 64-bit layout free of hidden padding).
    pub reserved: u32,
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
    /// Largest final relative residual over substeps, `sqrt(rᵀ P r / δ₀)` (`P` the
    /// preconditioner, `δ₀` the same measure of the substep's first right-hand side). A solve
    /// also stops at an absolute floor (a cloth near rest, whose right-hand side is tiny): there
    /// it is converged with a relative residual above the tolerance, even above 1.
    pub residual: f32,
    /// 1 when every substep's solve reached `settings.tolerance` (0: it stopped at
    /// `max_iterations`; the step is still valid, only less accurate).
    pub converged: u32,
    /// Substeps taken (0 when asleep).
    pub substeps: u32,
    /// 1 when the world was asleep and did nothing, else 0.
    pub asleep: u32,
    /// Vertices in contact with a collider at the end of the step.
    pub contacts: u32,
    /// Times the step was redone with twice the substeps (and, when it gained after
    /// converged solves at a tolerance looser than the default, a tenth of it) because its end
    /// state held energy that nothing supplied (0 to 3, and up to 5 while each redo at least
    /// halved the gain; `substeps` is the count finally used), and once more when it was then
    /// energy-limited (`limited`).
    pub redone: u32,
    /// Energy (J) the step then still took out: of the kinetic energy at the end, or by the
    /// energy-limited substeps (`limited`); or, with no redo, of the kinetic energy of a step
    /// within its own round-off whose gains since the lowest level the cloth has been at add
    /// up to more than the round-off; 0 for a sound step.
    pub energy_removed: f32,
    /// 1 when even the energy-limited attempt (`limited`) gained more energy than the kinetic
    /// energy could give back, or every attempt's solve broke down or overflowed, so the world
    /// held the cloth still for this step instead: positions as at its start, but the pinned
    /// vertices on their targets and every other vertex put out of the colliders (as they are
    /// at the end of the step), velocities zero (`energy_removed` is the kinetic energy it
    /// had); else 0. The next step starts from rest.
    pub stopped: u32,
    /// 1 when the redos gained more energy than the kinetic energy could give back, so the
    /// step was done once more with each substep's end energy-limited: the velocity of the
    /// vertices no pin holds scaled by the first of 1, ½, …, 1/64 (else 0) that ends the
    /// substep with no more energy than it began with and the wind gave it (a Newton step that
    /// overshoots on a membrane squeezed to a fraction of its size still goes partly
    /// downhill); else 0.
    pub limited: u32,
}

/// A point or vector in double precision: the world's origin (`weft_world_set_origin`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WeftDVec3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

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
    /// `WEFT_NORMALS_RECOMPUTED` only: the fine triangles, 3 × `fine_triangle_count` tightly
    /// packed `uint32_t` (4-aligned) indices *relative to this call's range* (index k is
    /// binding `first + k`, so every index is < `count`). Counter-clockwise in (u, v), as
    /// `weft_tiled_mesh` makes them, gives normals on the same side as the blended ones. A
    /// vertex whose triangles all collapsed keeps the normal the buffer held (so the normals
    /// must hold initialized values: zeros, or the last frame's). Recomputed normals need
    /// every triangle around a vertex: localize the whole mesh in one call, or give each range
    /// the triangles of its vertices. Default NULL.
    pub fine_indices: *const u32,
    /// `WEFT_NORMALS_BLENDED` (default) or `WEFT_NORMALS_RECOMPUTED`; anything else is
    /// `WEFT_RESULT_INVALID_ARGUMENT`. Ignored when `normals` is NULL.
    pub normal_mode: u32,
    /// Number of triangles at `fine_indices`. Default 0.
    pub fine_triangle_count: u32,
    /// `WEFT_COLLIDERS_IGNORED` (default) or `WEFT_COLLIDERS_OUTSIDE` (fine vertices pushed
    /// out of the world's colliders); anything else is `WEFT_RESULT_INVALID_ARGUMENT`.
    pub collider_mode: u32,
    /// Set by `weft_default_localize_output`; do not touch. (With `collider_mode` it ends the
    /// struct on an 8-byte boundary: no hidden padding.)
    pub internal_cookie: u32,
}

/// A world: an opaque handle that points to the start of the memory block given to
/// `weft_world_create`. Not thread-safe: one thread at a time per world (distinct worlds may
/// step on different threads at once). The exception: calls that take a `const WeftWorld *`
/// only read it, so several threads may make them at once (e.g. `weft_localize` on disjoint
/// ranges), as long as no call taking a non-const `WeftWorld *` runs meanwhile.
pub struct WeftWorld {
    /// `WORLD_COOKIE` while alive; zeroed by `weft_world_destroy`.
    pub(super) cookie: u64,
    /// The address of this header, so a moved or copied block is refused.
    pub(super) home: *const WeftWorld,
    pub(super) world: World<'static>,
    /// The parsed blob, borrowed for the world's life: localization reads its cells.
    pub(super) blob: Blob<'static>,
    /// Key of the cloth (mesh, rest (u, v), materials, blob) that bindings and frames carry
    /// (`localize::blocks::cloth_key`, computed once at create).
    pub(super) cloth_key: u64,
    /// The engine's pointer (`weft_world_set_user_data`); never read by weft.
    pub(super) user_data: *mut c_void,
}
