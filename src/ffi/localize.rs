//! Localization from C: binding render meshes (bindings blocks), preparing frames (frames
//! blocks), localizing ranges of fine vertices, and the cells' tiled micro meshes. The blocks'
//! formats and checks are the kernel's (`crate::localize::blocks`); this file turns the C
//! pointers into slices and the kernel's errors into details.

use core::ffi::c_void;
use core::mem::size_of;
use core::ptr;

use super::convert::*;
use super::result::{fault, invalid, null, Fault, FfiResult};
use super::types::*;
use super::*;
use crate::collide::ColliderSet;
use crate::localize::blocks::{self, BlockError, FramesHeader};
use crate::localize::VertexFrame;
use crate::localize::{
    self, BindError, Binding, Coarse, LocalizeError, NormalTarget, StrainMeasure,
};
use crate::strided::StridedMut;

/// A kernel block error as a detail, for the bindings block `weft_bind` writes.
fn bind_block_fault(e: BlockError) -> Fault {
    use WeftResult as R;
    match e {
        BlockError::Misaligned => fault(R::Misaligned).what(c"out_bindings"),
        BlockError::TooLarge => fault(R::CapacityTooLarge),
        BlockError::TooSmall { needed, room } => fault(R::BindMemoryTooSmall)
            .what(c"bindings_size")
            .needed(count32(needed), count32(room)),
        BlockError::Bind(BindError::OutOfDomain { vertex }) => {
            fault(R::BindOutOfDomain).vertex(vertex)
        }
        _ => fault(R::Internal).what(c"bind"),
    }
}

/// A bindings block's cloth key and records, after the kernel checked its header against its
/// size.
///
/// # Safety
/// A non-null `p` is readable for `size` bytes for `'a`.
unsafe fn bindings_block<'a>(p: *const c_void, size: usize) -> FfiResult<(u64, &'a [Binding])> {
    use WeftResult as R;
    if p.is_null() {
        return Err(null(c"bindings"));
    }
    if !(p as usize).is_multiple_of(WEFT_BIND_MEMORY_ALIGN) {
        return Err(fault(R::Misaligned).what(c"bindings"));
    }
    // A block never needs more than isize::MAX bytes (the kernel refuses larger counts).
    let size = size.min(isize::MAX as usize);
    // SAFETY: non-null, readable for size bytes per the contract; u8 has no invalid values.
    let bytes = unsafe { core::slice::from_raw_parts(p.cast::<u8>(), size) };
    blocks::read_bindings(bytes).map_err(|e| match e {
        BlockError::NotBindings => fault(R::BindingsInvalid).what(c"bindings"),
        BlockError::Misaligned => fault(R::Misaligned).what(c"bindings"),
        _ => fault(R::BindingsInvalid).what(c"bindings_size"),
    })
}

/// The frames prepared in `p` for the world `w`.
///
/// # Safety
/// A non-null `p` is readable for `WEFT_LOCALIZE_FRAMES_HEADER_SIZE` bytes and, when its
/// header says it was prepared here, for the frames it announces, for `'a`.
unsafe fn frames_at<'a>(p: *const c_void, w: &WeftWorld) -> FfiResult<&'a [VertexFrame]> {
    use WeftResult as R;
    if p.is_null() {
        return Err(null(c"frames"));
    }
    if !(p as usize).is_multiple_of(WEFT_LOCALIZE_FRAMES_ALIGN) {
        return Err(fault(R::Misaligned).what(c"frames"));
    }
    // SAFETY: readable and aligned per the contract; FramesHeader is plain integers, valid for
    // any bytes.
    let header = unsafe { &*p.cast::<FramesHeader>() };
    header.check(&w.world, w.cloth_key).map_err(|e| match e {
        BlockError::OtherWorld => fault(R::FramesMismatch).what(c"frames"),
        _ => fault(R::FramesNotPrepared).what(c"frames"),
    })?;
    // SAFETY: the header says weft_localize_prepare wrote the world's vertex count of frames
    // right after it, in this very block (its home address), which it checked to hold them;
    // 16-aligned; VertexFrame is plain f32 data.
    Ok(unsafe {
        core::slice::from_raw_parts(
            p.cast::<u8>()
                .add(WEFT_LOCALIZE_FRAMES_HEADER_SIZE)
                .cast::<VertexFrame>(),
            w.world.vertex_count(),
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
        collider_mode: WEFT_COLLIDERS_IGNORED,
        internal_cookie: LOCALIZE_OUTPUT_COOKIE,
    }
}

/// Bytes of a bindings block for `fine_vertex_count` fine vertices, in `*out_size`:
/// `WEFT_BIND_HEADER_SIZE + WEFT_BIND_VERTEX_SIZE * fine_vertex_count`.
/// `WEFT_RESULT_CAPACITY_TOO_LARGE` when that does not fit in `size_t`.
///
/// # Safety
/// `out_size` is writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_bind_memory_size(
    fine_vertex_count: u32,
    out_size: *mut usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        (|| {
            let out = out_ptr(out_size, c"out_size")?;
            let size = blocks::bindings_bytes(fine_vertex_count as usize)
                .ok_or(fault(WeftResult::CapacityTooLarge))?;
            // SAFETY: checked; writable per the contract.
            unsafe { out.write(size) };
            Ok(())
        })()
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
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
        if !(out_bindings as usize).is_multiple_of(WEFT_BIND_MEMORY_ALIGN) {
            return Err(fault(R::Misaligned).what(c"out_bindings"));
        }
        let n = fine_vertex_count as usize;
        let size = blocks::bindings_room(n, bindings_size).map_err(bind_block_fault)?;
        // SAFETY: readable for the strided extent per the contract.
        let uv = unsafe { strided_in::<2>(fine_uvs, n, uv_stride, c"fine_uvs", c"uv_stride") }?;
        // SAFETY: non-null, 4-aligned (checked), writable for bindings_size ≥ size bytes, and
        // disjoint from the inputs per the contract; u8 has no invalid values.
        let block = unsafe { core::slice::from_raw_parts_mut(out_bindings.cast::<u8>(), size) };
        blocks::bind_block(&w.world, &w.blob, w.cloth_key, &uv, block).map_err(bind_block_fault)
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
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_bind_vertex_count(
    bindings: *const c_void,
    bindings_size: usize,
    out_count: *mut u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        (|| {
            let out = out_ptr(out_count, c"out_count")?;
            // SAFETY: forwarded contract.
            let (_, records) = unsafe { bindings_block(bindings, bindings_size) }?;
            // SAFETY: checked; writable per the contract.
            unsafe { out.write(count32(records.len())) };
            Ok(())
        })()
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Bytes of a frames block for this world, in `*out_size`: `WEFT_LOCALIZE_FRAMES_HEADER_SIZE +
/// WEFT_LOCALIZE_FRAME_SIZE * weft_world_vertex_count(world)`, a multiple of
/// `WEFT_LOCALIZE_FRAMES_ALIGN` (as C11 `aligned_alloc` wants).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out_size` is writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_localize_frames_size(
    world: *const WeftWorld,
    out_size: *mut usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        (|| {
            // SAFETY: forwarded contract.
            let w = unsafe { world_at(world) }?;
            let out = out_ptr(out_size, c"out_size")?;
            let size =
                blocks::frames_bytes(w.world.vertex_count()).ok_or(fault(WeftResult::Internal))?;
            // SAFETY: checked; writable per the contract.
            unsafe { out.write(size) };
            Ok(())
        })()
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
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
        if !(frames as usize).is_multiple_of(WEFT_LOCALIZE_FRAMES_ALIGN) {
            return Err(fault(R::Misaligned).what(c"frames"));
        }
        let n = w.world.vertex_count();
        blocks::frames_room(n, frames_size).map_err(|e| match e {
            BlockError::TooSmall { needed, room } => fault(R::FramesTooSmall)
                .what(c"frames_size")
                .needed(count32(needed), count32(room)),
            _ => fault(R::Internal),
        })?;
        let base = frames.cast::<u8>();
        // SAFETY: the header and the n frames after it lie within the writable block (size
        // checked), 16-aligned, disjoint from each other and from the world per the contract;
        // FramesHeader (integers) and VertexFrame (f32) are plain data valid for any bytes, and
        // the kernel overwrites every frame before reading it.
        let (header, slots) = unsafe {
            (
                &mut *base.cast::<FramesHeader>(),
                core::slice::from_raw_parts_mut(
                    base.add(WEFT_LOCALIZE_FRAMES_HEADER_SIZE)
                        .cast::<VertexFrame>(),
                    n,
                ),
            )
        };
        blocks::prepare_block(&w.world, w.cloth_key, measure, header, slots)
            .map_err(|_| fault(R::Internal).what(c"prepare"))?;
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
/// Cost per fine vertex: a few ns for positions (about 110 M vertices/s on one core of a
/// 2-core cloud machine, `examples/bench_localize.rs`), about 1.8 × that with blended normals
/// (1.72 × measured there, 1.84 × by an outside client), about 6 × with recomputed normals;
/// with `WEFT_COLLIDERS_OUTSIDE` each collider adds a distance query per vertex (README,
/// "Measured").
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
    let colliders = match o.collider_mode {
        WEFT_COLLIDERS_IGNORED => ColliderSet::new(&[]),
        WEFT_COLLIDERS_OUTSIDE => w.world.collider_set(),
        _ => return Err(invalid(c"output.collider_mode")),
    };
    // SAFETY: forwarded contract.
    let frames = unsafe { frames_at(frames, w) }?;
    // SAFETY: forwarded contract.
    let (key, all) = unsafe { bindings_block(bindings, bindings_size) }?;
    if key != w.cloth_key {
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
    if end > all.len() {
        return Err(range_fault());
    }

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
        unsafe { core::slice::from_raw_parts(t.cast::<[u32; 3]>(), nt) }
    } else {
        &[]
    };
    // The kernel checks everything (bindings against the world, fine indices against the
    // range, the normals' layout) before it writes anything; these are its faults as details.
    let kernel_fault = |e: LocalizeError| match e {
        LocalizeError::BadBinding { index } => fault(R::BindingOutOfRange)
            .index(count32(index))
            .what(c"bindings"),
        LocalizeError::BadTriangle { triangle } => {
            let vertex = fine
                .get(triangle)
                .and_then(|t| t.iter().copied().find(|&v| v >= count))
                .unwrap_or(WEFT_NONE);
            fault(R::FineIndexOutOfRange)
                .triangle(count32(triangle))
                .vertex(vertex)
                .what(c"output.fine_indices")
        }
        LocalizeError::Range { .. } => range_fault(),
        LocalizeError::NormalLayout => layout(()),
        _ => internal(()),
    };
    fn layout<E>(_: E) -> Fault {
        fault(WeftResult::NormalLayout).what(c"output.normals")
    }
    fn internal<E>(_: E) -> Fault {
        fault(WeftResult::Internal).what(c"localize")
    }
    let coarse = Coarse {
        frames,
        triangles: w.world.triangles(),
    };
    let first = first as usize;
    if n == 0 {
        // Nothing to write, and the buffers may be NULL; the kernel still checks the range and
        // any fine triangles (which cannot name a vertex of an empty range).
        let (mut pos, mut nrm) = (
            StridedMut::from_slice(&mut []),
            StridedMut::from_slice(&mut []),
        );
        return if normals && recompute {
            let target = NormalTarget::Buffer(&mut nrm);
            localize::localize_recomputed_colliding(
                coarse, all, first, &mut pos, fine, target, colliders,
            )
        } else {
            localize::localize_colliding(coarse, all, first, &mut pos, None, colliders)
        }
        .map_err(kernel_fault);
    }
    let pe = strided_extent(n, ps, 12).ok_or(invalid(c"output.position_stride"))?;
    let p_end = (pp as usize)
        .checked_add(pe)
        .ok_or(invalid(c"output.positions"))?;
    if !normals {
        // SAFETY: writable for the extent per the contract, disjoint from the inputs.
        let mut pos =
            unsafe { strided_out::<3>(pp, n, ps, c"output.positions", c"output.position_stride") }?;
        return localize::localize_colliding(coarse, all, first, &mut pos, None, colliders)
            .map_err(kernel_fault);
    }
    let ne = strided_extent(n, ns, 12).ok_or(invalid(c"output.normal_stride"))?;
    let n_end = (np as usize)
        .checked_add(ne)
        .ok_or(invalid(c"output.normals"))?;
    let overlap = (pp as usize) < n_end && (np as usize) < p_end;
    if !overlap {
        // SAFETY: both writable for their extents per the contract, and disjoint (checked) from
        // each other and (per the contract) from the inputs.
        let (mut pos, mut nrm) = unsafe {
            (
                strided_out::<3>(pp, n, ps, c"output.positions", c"output.position_stride")?,
                strided_out::<3>(np, n, ns, c"output.normals", c"output.normal_stride")?,
            )
        };
        let target = NormalTarget::Buffer(&mut nrm);
        return if recompute {
            localize::localize_recomputed_colliding(
                coarse, all, first, &mut pos, fine, target, colliders,
            )
        } else {
            localize::localize_colliding(coarse, all, first, &mut pos, Some(target), colliders)
        }
        .map_err(kernel_fault);
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
        localize::localize_recomputed_colliding(
            coarse, all, first, &mut pos, fine, target, colliders,
        )
    } else {
        localize::localize_colliding(coarse, all, first, &mut pos, Some(target), colliders)
    }
    .map_err(kernel_fault)
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
