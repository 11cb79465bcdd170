//! Converting and checking at the boundary: out-pointers, references from C pointers, strided
//! views of C vertex buffers, handle lookup, and the C <-> kernel conversions of plain values.

use core::ffi::{c_void, CStr};
use core::ptr;

use glam::Vec3A;

use super::result::{blob_fault, fault, init_fault, invalid, null, FfiResult};
use super::types::*;
use super::{WeftErrorDetail, WeftResult};
use super::{BLOB_COOKIE, WEFT_SHAPE_CAPSULE, WEFT_SHAPE_PLANE, WEFT_SHAPE_SHELL};
use super::{WEFT_SHAPE_SPHERE, WORLD_COOKIE};
use crate::blob::Blob;
use crate::collide::Shape;
use crate::strided::{Strided, StridedMut};
use crate::world::{Capacity, Settings, StepStats};

/// Writes `value` to an optional out-pointer (NULL: nothing).
///
/// # Safety
/// `out` is NULL or valid for a write of `T`.
pub(super) unsafe fn write_opt<T>(out: *mut T, value: T) {
    if !out.is_null() && out.is_aligned() {
        // SAFETY: non-null and aligned; validity for writes is the caller's contract.
        unsafe { out.write(value) };
    }
}

/// A shared reference from a C pointer: checks NULL and alignment.
///
/// # Safety
/// A non-null, aligned `p` points to a readable `T` for `'a`.
pub(super) unsafe fn read_ref<'a, T>(p: *const T, what: &'static CStr) -> FfiResult<&'a T> {
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
pub(super) fn out_ptr<T>(p: *mut T, what: &'static CStr) -> FfiResult<*mut T> {
    if p.is_null() {
        return Err(null(what));
    }
    if !p.is_aligned() {
        return Err(fault(WeftResult::Misaligned).what(what));
    }
    Ok(p)
}

/// Byte extent of `count` elements of `elem` bytes at `stride`, if it fits in `isize`.
pub(super) fn strided_extent(count: usize, stride: usize, elem: usize) -> Option<usize> {
    if count == 0 {
        return Some(0);
    }
    let e = (count - 1).checked_mul(stride)?.checked_add(elem)?;
    (e <= isize::MAX as usize).then_some(e)
}

/// Validates a strided buffer's pointer and stride for `count` elements of `elem` bytes.
pub(super) fn check_strided(
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

/// A read-only view of `count` groups of `N` floats at `p`, `stride` bytes apart (unaligned):
/// `check_strided`, then the kernel's [`Strided`] over the bytes they span. Empty for 0.
///
/// # Safety
/// `p` is readable for `(count - 1) * stride + 4 * N` bytes for `'a` (when `count` > 0).
pub(super) unsafe fn strided_in<'a, const N: usize>(
    p: *const c_void,
    count: usize,
    stride: usize,
    what: &'static CStr,
    stride_what: &'static CStr,
) -> FfiResult<Strided<'a, N>> {
    let elem = Strided::<N>::ELEMENT;
    check_strided(p, count, stride, elem, what, stride_what)?;
    if count == 0 {
        return Ok(Strided::from_slice(&[]));
    }
    let extent = strided_extent(count, stride, elem).ok_or(invalid(stride_what))?;
    // SAFETY: non-null (checked), extent ≤ isize::MAX (checked), readable per the contract; u8
    // has no invalid values.
    let bytes = unsafe { core::slice::from_raw_parts(p.cast::<u8>(), extent) };
    Strided::new(bytes, stride, count).map_err(|_| invalid(stride_what))
}

/// A writable view of `count` groups of `N` floats at `p`, `stride` bytes apart, like
/// [`strided_in`].
///
/// # Safety
/// `p` is writable for `(count - 1) * stride + 4 * N` bytes for `'a` (when `count` > 0) and no
/// other reference to those bytes is used meanwhile.
pub(super) unsafe fn strided_out<'a, const N: usize>(
    p: *mut c_void,
    count: usize,
    stride: usize,
    what: &'static CStr,
    stride_what: &'static CStr,
) -> FfiResult<StridedMut<'a, N>> {
    let elem = StridedMut::<N>::ELEMENT;
    check_strided(p, count, stride, elem, what, stride_what)?;
    if count == 0 {
        return Ok(StridedMut::from_slice(&mut []));
    }
    let extent = strided_extent(count, stride, elem).ok_or(invalid(stride_what))?;
    // SAFETY: non-null (checked), extent ≤ isize::MAX (checked), writable and unaliased per the
    // contract; u8 has no invalid values.
    let bytes = unsafe { core::slice::from_raw_parts_mut(p.cast::<u8>(), extent) };
    StridedMut::new(bytes, stride, count).map_err(|_| invalid(stride_what))
}

pub(super) fn vec3(v: WeftVec3) -> [f32; 3] {
    [v.x, v.y, v.z]
}

pub(super) fn to_vec3(v: [f32; 3]) -> WeftVec3 {
    WeftVec3 {
        x: v[0],
        y: v[1],
        z: v[2],
    }
}

pub(super) fn capacity_of(c: &WeftCapacity) -> Capacity {
    Capacity {
        vertices: c.max_vertices,
        triangles: c.max_triangles,
        edges: c.max_edges,
        colliders: c.max_colliders,
        pins: c.max_pins,
    }
}

pub(super) fn settings_to_c(s: &Settings) -> WeftSettings {
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
        rotation_iterations: s.rotation_iterations,
        sleep_velocity: s.sleep_velocity,
        sleep_frames: s.sleep_frames,
        max_depenetration_speed: s.max_depenetration_speed,
    }
}

/// The kernel's settings from the C ones; `base` supplies the frame time step, which C does
/// not set (it passes `dt` to every step), and per-node warping is off. Range checks are
/// `Settings::validate`'s.
pub(super) fn settings_from_c(c: &WeftSettings, base: &Settings) -> FfiResult<Settings> {
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
        // Per-node warping is a research mode (the paper's Eq. 14–17, unstable for cloth
        // hanging in 3D): C does not reach it.
        per_node_warping: false,
        rotation_iterations: c.rotation_iterations,
        sleep_velocity: c.sleep_velocity,
        sleep_frames: c.sleep_frames,
        max_depenetration_speed: c.max_depenetration_speed,
    };
    s.validate().map_err(init_fault)?;
    Ok(s)
}

pub(super) fn shape_from_c(s: &WeftShape) -> FfiResult<Shape> {
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

pub(super) fn stats_to_c(s: &StepStats) -> WeftStepStats {
    WeftStepStats {
        iterations: s.iterations,
        residual: s.residual,
        converged: s.converged.into(),
        substeps: s.substeps,
        asleep: s.asleep.into(),
        contacts: s.contacts,
        redone: s.redone,
        energy_removed: s.energy_removed,
        stopped: s.stopped.into(),
        limited: s.limited.into(),
    }
}

/// The live world behind a handle, or why not.
///
/// # Safety
/// A non-null, aligned `w` points to readable memory of at least `WEFT_WORLD_HEADER_SIZE`
/// bytes (a block given to `weft_world_create`, or any memory the caller owns).
pub(super) unsafe fn world_at<'a>(w: *const WeftWorld) -> FfiResult<&'a WeftWorld> {
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
pub(super) unsafe fn world_mut<'a>(w: *mut WeftWorld) -> FfiResult<&'a mut WeftWorld> {
    // SAFETY: forwarded contract.
    unsafe { world_at(w)? };
    // SAFETY: validated above; exclusive per the contract.
    Ok(unsafe { &mut *w })
}

/// Runs `f` on a live world.
///
/// # Safety
/// As [`world_mut`].
pub(super) unsafe fn with_world(
    w: *mut WeftWorld,
    f: impl FnOnce(&mut WeftWorld) -> FfiResult<()>,
) -> FfiResult<()> {
    // SAFETY: forwarded contract.
    f(unsafe { world_mut(w) }?)
}

/// Parses a C blob descriptor again (a `WeftBlob` is only a view; the bytes are re-validated
/// wherever they are used, so a stale or forged struct is an error, never a misread).
///
/// # Safety
/// `b.data` is readable for `b.size` bytes for `'static` (the caller's lifetime contract).
pub(super) unsafe fn reparse(b: &WeftBlob) -> FfiResult<Blob<'static>> {
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

/// A count as `u32` for an error detail (saturating).
pub(super) fn count32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// The one error channel: every call returning a `WeftResult` writes its detail (`OK` with
/// no index on success) to its last argument, `out_detail`, unless that is NULL.
///
/// # Safety
/// `out_detail` is NULL or writable.
pub(super) unsafe fn detailed(out_detail: *mut WeftErrorDetail, r: FfiResult<()>) -> WeftResult {
    let detail = match r {
        Ok(()) => WeftErrorDetail::of(WeftResult::Ok),
        Err(d) => d,
    };
    // SAFETY: NULL or writable per the contract.
    unsafe { write_opt(out_detail, detail) };
    detail.result
}
