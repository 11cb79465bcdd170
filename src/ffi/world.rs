//! A world's life: defaults, memory size, create and destroy, the step, settings, sleep and
//! counts.

use core::ffi::c_void;
use core::mem::size_of;
use core::ptr;

use super::convert::*;
use super::result::{fault, init_fault, invalid, mesh_fault, null, step_fault, FfiResult};
use super::types::*;
use super::*;
use crate::localize::blocks;
use crate::world::{
    Capacity, Materials, Settings, Solver, StridedClothDef, TriangleMaterials, World,
};

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

/// Where the parts of a world's block are: the handle at the start, the kernel's arrays in
/// `[WEFT_WORLD_HEADER_SIZE, + world_bytes)`, `total` bytes in all (a multiple of
/// `WEFT_WORLD_MEMORY_ALIGN`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct BlockLayout {
    world_bytes: usize,
    total: usize,
}

/// The kernel's own overflow-checked byte count, bounded so that the block layout's sums
/// below cannot overflow either.
fn world_bytes_checked(c: &Capacity) -> Option<usize> {
    let total = c.checked_world_bytes()?;
    (total <= isize::MAX as usize / 2).then_some(total)
}

fn block_layout(c: &Capacity) -> Option<BlockLayout> {
    let world_bytes = world_bytes_checked(c)?;
    let align = WEFT_WORLD_MEMORY_ALIGN - 1;
    let total = WEFT_WORLD_HEADER_SIZE
        .checked_add(world_bytes)?
        .checked_add(align)?
        & !align;
    (total <= isize::MAX as usize).then_some(BlockLayout { world_bytes, total })
}

/// Fills caller buffers with a regular grid cloth, the quickest way to a first cloth:
/// `columns × rows` vertices (both ≥ 2) spanning `width × height` metres (finite, > 0), vertex
/// `j * columns + i` at `(u, v) = (width * i / (columns - 1), height * j / (rows - 1))`,
/// written both as its position `(u, v, 0)` (flat at z = 0; move or rotate it as you like)
/// and as its (u, v); each square split into two triangles along its lower-left to
/// upper-right diagonal, `6 * (columns - 1) * (rows - 1)` indices in all. Hand the buffers to
/// a `WeftWorldDef` with `vertex_count = columns * rows` and
/// `triangle_count = 2 * (columns - 1) * (rows - 1)`.
///
/// # Safety
/// `positions` is writable for `columns * rows` `WeftVec3`, `uvs` for as many `WeftVec2`,
/// `indices` for `6 * (columns - 1) * (rows - 1)` `uint32_t`; none overlap.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_grid(
    columns: u32,
    rows: u32,
    width: f32,
    height: f32,
    positions: *mut WeftVec3,
    uvs: *mut WeftVec2,
    indices: *mut u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r = (|| {
        if columns < 2 {
            return Err(invalid(c"columns"));
        }
        if rows < 2 {
            return Err(invalid(c"rows"));
        }
        if !(width.is_finite() && width > 0.0) {
            return Err(invalid(c"width"));
        }
        if !(height.is_finite() && height > 0.0) {
            return Err(invalid(c"height"));
        }
        let (nx, ny) = (columns as usize, rows as usize);
        // (every vertex index must fit a uint32_t, and every count an isize)
        let nv = columns
            .checked_mul(rows)
            .ok_or(invalid(c"columns * rows"))? as usize;
        let nt = (nx - 1)
            .checked_mul(ny - 1)
            .and_then(|s| s.checked_mul(2))
            .filter(|&nt| nt.checked_mul(12).is_some_and(|b| b <= isize::MAX as usize))
            .ok_or(invalid(c"columns * rows"))?;
        let positions = out_ptr(positions, c"positions")?;
        let uvs = out_ptr(uvs, c"uvs")?;
        let indices = out_ptr(indices, c"indices")?;
        // SAFETY: non-NULL and aligned (checked), writable for these counts and disjoint per
        // the contract; WeftVec3 / WeftVec2 are 3 / 2 f32 with no padding, as [f32; 3] / [f32; 2]
        // (src/ffi/layout.rs), and a triangle is 3 packed u32.
        let (positions, uvs, triangles) = unsafe {
            (
                core::slice::from_raw_parts_mut(positions.cast::<[f32; 3]>(), nv),
                core::slice::from_raw_parts_mut(uvs.cast::<[f32; 2]>(), nv),
                core::slice::from_raw_parts_mut(indices.cast::<[u32; 3]>(), nt),
            )
        };
        crate::mesh::grid(nx, ny, width, height, positions, uvs, triangles).map_err(mesh_fault)?;
        Ok(())
    })();
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Bytes a world of `*capacity` needs (header and arrays), a multiple of
/// `WEFT_WORLD_MEMORY_ALIGN`, in `*out_size`.
///
/// # Safety
/// `capacity` is readable, `out_size` writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_memory_size(
    capacity: *const WeftCapacity,
    out_size: *mut usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        (|| {
            // SAFETY: readable per the contract.
            let c = unsafe { read_ref(capacity, c"capacity") }?;
            let out = out_ptr(out_size, c"out_size")?;
            let layout =
                block_layout(&capacity_of(c)).ok_or(fault(WeftResult::CapacityTooLarge))?;
            // SAFETY: checked; writable per the contract.
            unsafe { out.write(layout.total) };
            Ok(())
        })()
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
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
    if !(memory as usize).is_multiple_of(WEFT_WORLD_MEMORY_ALIGN) {
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
    // SAFETY: readable for the strided extents per the contract, for the call.
    let positions = unsafe {
        strided_in::<3>(
            d.positions,
            nv,
            d.position_stride,
            c"def.positions",
            c"def.position_stride",
        )
    }?;
    // SAFETY: as above.
    let uvs = unsafe { strided_in::<2>(d.uvs, nv, d.uv_stride, c"def.uvs", c"def.uv_stride") }?;
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
    // nt ≤ capacity.triangles, whose arrays fit the block: 3 × nt u32 are far below isize::MAX.
    let triangles: &[[u32; 3]] = if nt == 0 {
        &[]
    } else {
        // SAFETY: non-null and 4-aligned (checked), readable for 3 × nt u32 per the contract;
        // [u32; 3] has the alignment of u32 and no invalid values.
        unsafe { core::slice::from_raw_parts(d.indices.cast::<[u32; 3]>(), nt) }
    };
    let materials = if d.materials.is_null() {
        TriangleMaterials::Uniform(d.material)
    } else {
        // SAFETY: non-null and 4-aligned (checked), readable for nt u32 per the contract.
        TriangleMaterials::PerTriangle(unsafe { core::slice::from_raw_parts(d.materials, nt) })
    };
    let cloth = StridedClothDef {
        positions,
        uvs,
        triangles,
        materials,
    };

    let base = memory.cast::<u8>();
    // SAFETY: `memory` is writable for memory_size ≥ layout.total bytes. Zeroing makes every
    // byte initialized before any of it is viewed as a slice.
    unsafe { ptr::write_bytes(base, 0, layout.total) };
    // SAFETY: the arrays' region [HEADER, HEADER + world_bytes) lies within the block, is
    // disjoint from the header, initialized (zeroed) and, per the contract, stays valid and
    // unaliased until weft_world_destroy: hence 'static. The def's buffers are not in it: the
    // block is handed over with contents that "need not be initialized", so it holds no input.
    let arrays: &'static mut [u8] = unsafe {
        core::slice::from_raw_parts_mut(base.add(WEFT_WORLD_HEADER_SIZE), layout.world_bytes)
    };
    let world = World::new_strided(arrays, capacity, &cloth, Materials::Blob(&parsed), settings)
        .map_err(init_fault)?;
    let cloth_key = blocks::cloth_key(&world, &parsed);
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
            cloth_key,
            user_data: core::ptr::null_mut(),
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
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_destroy(
    world: *mut WeftWorld,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        (|| {
            // SAFETY: forwarded contract.
            let w = unsafe { world_mut(world) }?;
            w.cookie = 0;
            Ok(())
        })()
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Advances the cloth by `dt` seconds (finite, > 0) in `settings.substeps` substeps, moving
/// pins and colliders linearly from where they were at the last step to where they were set
/// since. `out_stats`: NULL, or written on success. On failure the world keeps the state it had
/// before the call.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); a non-NULL `out_stats` is writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_step(
    world: *mut WeftWorld,
    dt: f32,
    out_stats: *mut WeftStepStats,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                if !out_stats.is_null() && !out_stats.is_aligned() {
                    return Err(fault(WeftResult::Misaligned).what(c"out_stats"));
                }
                let stats = w.world.step_dt(dt).map_err(step_fault)?;
                write_opt(out_stats, stats_to_c(&stats));
                Ok(())
            }),
        )
    }
}

/// The world's current settings, in `*out_settings`.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out_settings` is writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_settings(
    world: *const WeftWorld,
    out_settings: *mut WeftSettings,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        (|| {
            // SAFETY: forwarded contract.
            let w = unsafe { world_at(world) }?;
            let out = out_ptr(out_settings, c"out_settings")?;
            // SAFETY: checked; writable per the contract.
            unsafe { out.write(settings_to_c(w.world.settings())) };
            Ok(())
        })()
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Replaces the world's settings (all fields checked; nothing changes on failure). Wakes the
/// world when anything changed.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `settings` is readable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_settings(
    world: *mut WeftWorld,
    settings: *const WeftSettings,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                let s = read_ref(settings, c"settings")?;
                let s = settings_from_c(s, w.world.settings())?;
                w.world.set_settings(s).map_err(init_fault)
            }),
        )
    }
}

/// Replaces the effect bit set (`WEFT_EFFECT_*`; other bits are `WEFT_RESULT_INVALID_SETTING`).
/// Effects can change between any two steps. Wakes the world when it changed.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_effects(
    world: *mut WeftWorld,
    effects: u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                let s = Settings {
                    effects,
                    ..*w.world.settings()
                };
                w.world.set_settings(s).map_err(init_fault)
            }),
        )
    }
}

/// Chooses the preconditioner of the step's linear solver: `WEFT_SOLVER_MULTIGRID` (the
/// default: CG iterations that do not grow with the mesh), `WEFT_SOLVER_MULTIGRID_LINES` (the
/// same, smoothed along lines of dominant couplings: fewer iterations on strongly anisotropic
/// materials, the same elsewhere) or `WEFT_SOLVER_BLOCK_JACOBI` (the cheaper cycle whose
/// iteration count grows with the mesh; a step whose block-Jacobi solves did not converge and
/// that gained energy is redone with the multilevel one); any other value
/// is `WEFT_RESULT_INVALID_ARGUMENT` (`detail.what` = "solver"). Takes effect at the next step.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_solver(
    world: *mut WeftWorld,
    solver: u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                let solver = match solver {
                    WEFT_SOLVER_MULTIGRID => Solver::Multigrid,
                    WEFT_SOLVER_BLOCK_JACOBI => Solver::BlockJacobi,
                    WEFT_SOLVER_MULTIGRID_LINES => Solver::MultigridLines,
                    _ => return Err(invalid(c"solver")),
                };
                w.world.set_solver(solver);
                Ok(())
            }),
        )
    }
}

/// Stores the engine's pointer `user_data` with the world (e.g. the game object that owns
/// it), for `weft_world_user_data` to give back; weft never reads it. NULL at create.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_user_data(
    world: *mut WeftWorld,
    user_data: *mut c_void,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                w.user_data = user_data;
                Ok(())
            }),
        )
    }
}

/// The pointer last given to `weft_world_set_user_data` (NULL before, and for an invalid
/// handle).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_user_data(world: *const WeftWorld) -> *mut c_void {
    // SAFETY: forwarded contract.
    unsafe { world_at(world) }.map_or(core::ptr::null_mut(), |w| w.user_data)
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
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_wake(
    world: *mut WeftWorld,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                w.world.wake();
                Ok(())
            }),
        )
    }
}

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
