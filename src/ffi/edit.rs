//! Editing a live world: vertex positions and velocities in and out, pins, colliders.

use core::ffi::{c_void, CStr};

use glam::{DVec3, Quat};

use super::convert::*;
use super::result::{edit_fault, fault, invalid};
use super::types::*;
use super::*;
use crate::collide::Collider;
use crate::strided::Strided;
use crate::world::{EditError, PinAxes, World};

/// Vertex `i`'s position in the caller's coordinates (the kernel's conversion).
fn position_out(w: &World<'static>, i: usize) -> Option<[f32; 3]> {
    w.positions().get(i).map(|&x| w.to_world(x))
}

fn velocity_out(w: &World<'static>, i: usize) -> Option<[f32; 3]> {
    w.velocities().get(i).map(|v| v.to_array())
}

/// The vertex count for a whole-cloth call: `count` must be at least it (outputs) or equal to
/// it (`exact`, inputs); `COUNT_MISMATCH` otherwise, `detail.needed` the vertex count.
///
/// # Safety
/// `world` as [`world_at`].
unsafe fn whole_cloth(world: *const WeftWorld, count: u32, exact: bool) -> FfiResult<u32> {
    // SAFETY: forwarded contract.
    let n = count32(unsafe { world_at(world) }?.world.vertex_count());
    if count < n || (exact && count != n) {
        let mut f = fault(WeftResult::CountMismatch).what(c"count");
        f.needed = n;
        return Err(f);
    }
    Ok(n)
}

/// Every vertex's 3 floats out (see [`whole_cloth`]).
///
/// # Safety
/// `out` writable for the strided extent; `world` as [`world_at`].
unsafe fn get_vec3s(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
    value: fn(&World<'static>, usize) -> Option<[f32; 3]>,
) -> FfiResult<()> {
    // SAFETY: forwarded contract.
    unsafe {
        let n = whole_cloth(world, count, false)?;
        get_range(world, 0, n, out, stride, value)
    }
}

/// Copies `count` per-vertex values of vertices `first..first + count` out: vertex
/// `first + k`'s `N` floats (`value(world, first + k)`) to byte `k * stride` of `out`. The
/// range is checked first (`VERTEX_OUT_OF_RANGE`, `detail.needed` the vertex count).
///
/// # Safety
/// `out` writable for the strided extent; `world` as [`world_at`].
unsafe fn get_range<const N: usize>(
    world: *const WeftWorld,
    first: u32,
    count: u32,
    out: *mut c_void,
    stride: usize,
    value: fn(&World<'static>, usize) -> Option<[f32; N]>,
) -> FfiResult<()> {
    (|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let n = w.world.vertex_count();
        let (first, count) = (first as usize, count as usize);
        if first.checked_add(count).is_none_or(|end| end > n) {
            let mut f = fault(WeftResult::VertexOutOfRange).what(c"first + count");
            f.needed = n as u32;
            return Err(f.vertex(count32(first.saturating_add(count).saturating_sub(1))));
        }
        // SAFETY: writable for the extent per the contract, disjoint from the world.
        let mut out = unsafe { strided_out::<N>(out, count, stride, c"out", c"stride") }?;
        for k in 0..count {
            out.set(k, value(&w.world, first + k).unwrap_or([0.0; N]));
        }
        Ok(())
    })()
}

/// Copies the masses (kg) of vertices `first .. first + count - 1` out: vertex `first + k`'s
/// mass to byte `k * stride` of `out` (written unaligned, `stride` ≥ 4). The masses are the
/// lumped masses of the triangles' densities times the mass scales
/// (`weft_world_set_mass_scales`).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out` is writable for
/// `(count - 1) * stride + 4` bytes and does not overlap the world's memory block.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_masses(
    world: *const WeftWorld,
    first: u32,
    count: u32,
    out: *mut c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            get_range(world, first, count, out, stride, |w, i| {
                w.masses().get(i).map(|&m| [m])
            }),
        )
    }
}

/// Copies the Green strain of triangles `first .. first + count - 1` out, for tearing or
/// shading: triangle `first + k`'s 3 floats `[E11, E22, 2 E12]` to byte `k * stride` of `out`
/// (written unaligned, `stride` ≥ 12). `E = (FᵀF - I) / 2`, `F` the map from the triangle's
/// rest (u, v) to its current positions, so the axes are the cloth's u and v (Voigt order
/// [11, 22, 12], engineering shear) and a rigid motion gives 0. The stretch ratio along u is
/// `sqrt(1 + 2 E11)`, along v `sqrt(1 + 2 E22)`. A range past the last triangle is
/// `WEFT_RESULT_TRIANGLE_OUT_OF_RANGE` (`detail.needed` the triangle count) and writes nothing.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out` is writable for
/// `(count - 1) * stride + 12` bytes and does not overlap the world's memory block.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_triangle_strains(
    world: *const WeftWorld,
    first: u32,
    count: u32,
    out: *mut c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r = (|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let nt = w.world.triangle_count();
        if (first as usize).saturating_add(count as usize) > nt {
            let mut f = fault(WeftResult::TriangleOutOfRange).what(c"first + count");
            f.needed = count32(nt);
            return Err(f);
        }
        // SAFETY: writable for the extent per the contract, disjoint from the world.
        let mut out = unsafe { strided_out::<3>(out, count as usize, stride, c"out", c"stride") }?;
        w.world
            .triangle_strains(first as usize, &mut out)
            .map_err(|e| edit_fault(e, &w.world))
    })();
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Copies the world's vertex positions (metres, in the caller's coordinates: see
/// `weft_world_set_origin`) out: vertex i's 3 floats to byte
/// `i * stride` of `out`, written unaligned (so straight into an interleaved vertex buffer).
/// `count` is the capacity of `out` in vertices, ≥ `weft_world_vertex_count`; exactly that
/// many are written. `stride` ≥ 12.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out` is writable for
/// `(vertex_count - 1) * stride + 12` bytes and does not overlap the world's memory block.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_positions(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            get_vec3s(world, out, count, stride, position_out),
        )
    }
}

/// Copies the world's vertex velocities (m/s) out, like `weft_world_get_positions`.
///
/// # Safety
/// As `weft_world_get_positions`.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_velocities(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            get_vec3s(world, out, count, stride, velocity_out),
        )
    }
}

/// An edit of the world from `count` groups of `N` floats at `src` (`stride` bytes apart) for
/// the vertices `first..first + count`: the range is checked against the vertex count
/// (`VERTEX_OUT_OF_RANGE`, `detail.needed` the vertex count), then the kernel checks every
/// value before it changes anything; a non-finite value is named by its vertex.
///
/// # Safety
/// `src` readable for the strided extent; `world` as [`world_mut`].
unsafe fn edit_range<const N: usize>(
    world: *mut WeftWorld,
    first: u32,
    count: u32,
    src: *const c_void,
    stride: usize,
    what: &'static CStr,
    edit: for<'w> fn(&mut World<'static>, usize, &Strided<'w, N>) -> Result<(), EditError>,
) -> FfiResult<()> {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let n = w.world.vertex_count();
            let (first, count) = (first as usize, count as usize);
            if first.checked_add(count).is_none_or(|end| end > n) {
                let mut f = fault(WeftResult::VertexOutOfRange).what(c"first + count");
                f.needed = n as u32;
                return Err(f.vertex(count32(first.saturating_add(count).saturating_sub(1))));
            }
            let src = strided_in::<N>(src, count, stride, what, c"stride")?;
            edit(&mut w.world, first, &src).map_err(|e| match e {
                EditError::NonFinite => {
                    let finite = |i| src.get(i).is_some_and(|p| p.iter().all(|c| c.is_finite()));
                    let vertex = (0..count)
                        .find(|&i| !finite(i))
                        .map_or(WEFT_NONE, |i| count32(first + i));
                    fault(WeftResult::NonFinite).what(what).vertex(vertex)
                }
                e => edit_fault(e, &w.world),
            })
        })
    }
}

/// # Safety
/// `src` readable for the strided extent; `world` as [`world_mut`].
unsafe fn set_vec3s(
    world: *mut WeftWorld,
    src: *const c_void,
    count: u32,
    stride: usize,
    velocities: bool,
) -> FfiResult<()> {
    // SAFETY: forwarded contract.
    unsafe { whole_cloth(world, count, true) }?;
    // SAFETY: forwarded contract.
    unsafe {
        if velocities {
            edit_range(
                world,
                0,
                count,
                src,
                stride,
                c"velocities",
                |w, first, s| w.set_velocities_range(first, s),
            )
        } else {
            edit_range(world, 0, count, src, stride, c"positions", |w, first, s| {
                w.set_positions_range(first, s)
            })
        }
    }
}

/// Overwrites every vertex position (metres) from `src`: vertex i's 3 floats at byte
/// `i * stride`, read unaligned. `count` must equal `weft_world_vertex_count`; `stride` ≥ 12.
/// Velocities are kept. Checks every value first (`WEFT_RESULT_NON_FINITE` names the vertex);
/// nothing changes on failure. Wakes the world. For teleports: the next step starts from here.
/// A pinned vertex keeps its pin: set away from the pin's target, it is carried back over the
/// next step (move the pin with `weft_world_set_pin`).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `src` is readable for
/// `(count - 1) * stride + 12` bytes.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_positions(
    world: *mut WeftWorld,
    src: *const c_void,
    count: u32,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe { detailed(out_detail, set_vec3s(world, src, count, stride, false)) }
}

/// Overwrites every vertex velocity (m/s), like `weft_world_set_positions`.
///
/// # Safety
/// As `weft_world_set_positions`.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_velocities(
    world: *mut WeftWorld,
    src: *const c_void,
    count: u32,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe { detailed(out_detail, set_vec3s(world, src, count, stride, true)) }
}

/// Copies the positions (metres, in your coordinates) of vertices `first .. first + count - 1`
/// out: vertex
/// `first + k`'s 3 floats to byte `k * stride` of `out` (written unaligned, `stride` ≥ 12).
/// A range past the last vertex is `WEFT_RESULT_VERTEX_OUT_OF_RANGE` (`detail.needed` is the
/// vertex count) and writes nothing.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out` is writable for
/// `(count - 1) * stride + 12` bytes and does not overlap the world's memory block.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_positions_range(
    world: *const WeftWorld,
    first: u32,
    count: u32,
    out: *mut c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            get_range(world, first, count, out, stride, position_out),
        )
    }
}

/// Copies the velocities (m/s) of vertices `first .. first + count - 1` out, like
/// `weft_world_get_positions_range`.
///
/// # Safety
/// As `weft_world_get_positions_range`.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_velocities_range(
    world: *const WeftWorld,
    first: u32,
    count: u32,
    out: *mut c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            get_range(world, first, count, out, stride, velocity_out),
        )
    }
}

/// Overwrites the positions (metres, in your coordinates) of vertices
/// `first .. first + count - 1` from `src`
/// (vertex `first + k` at byte `k * stride`, read unaligned, `stride` ≥ 12); the others keep
/// theirs. Checks the range and every value first (`WEFT_RESULT_NON_FINITE` names the
/// vertex); nothing changes on failure. Wakes the world. Pinned vertices as in
/// `weft_world_set_positions`.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `src` is readable for
/// `(count - 1) * stride + 12` bytes.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_positions_range(
    world: *mut WeftWorld,
    first: u32,
    count: u32,
    src: *const c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            edit_range(
                world,
                first,
                count,
                src,
                stride,
                c"positions",
                World::set_positions_range,
            ),
        )
    }
}

/// Overwrites the velocities (m/s) of vertices `first .. first + count - 1`, like
/// `weft_world_set_positions_range`, and forgets the solver's warm start.
///
/// # Safety
/// As `weft_world_set_positions_range`.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_velocities_range(
    world: *mut WeftWorld,
    first: u32,
    count: u32,
    src: *const c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            edit_range(
                world,
                first,
                count,
                src,
                stride,
                c"velocities",
                World::set_velocities_range,
            ),
        )
    }
}

/// Moves the whole cloth rigidly: every position `x` becomes `R x + translation` (metres, in
/// your coordinates, so `R` turns about your zero: to turn about a point `p`, pass
/// `translation = p - R p`), `R` the rotation of `rotation` (normalized; it must be finite and
/// not zero), so the cloth's shape and elastic energy are kept (a teleport with a character).
/// It is computed in double precision and the world's origin (`weft_world_get_origin`) is
/// chosen again for where the cloth lands, so a teleport kilometres from zero keeps the edge
/// lengths to the micrometre. `keep_velocity`
/// 1: the velocities turn with it (`v ← R v`) and the motion goes on in the new frame; 0: the
/// cloth is left at rest; anything else is `WEFT_RESULT_INVALID_ARGUMENT`. Pin targets move
/// with the cloth (set them again if they should not); contacts are forgotten, colliders stay
/// where they are. Wakes the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_transform(
    world: *mut WeftWorld,
    rotation: WeftQuat,
    translation: WeftVec3,
    keep_velocity: u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                let keep = match keep_velocity {
                    0 => false,
                    1 => true,
                    _ => return Err(invalid(c"keep_velocity")),
                };
                let q = Quat::from_xyzw(rotation.x, rotation.y, rotation.z, rotation.w);
                w.world
                    .transform(q, vec3(translation), keep)
                    .map_err(|e| match e {
                        EditError::NonFinite => fault(WeftResult::NonFinite).what(c"transform"),
                        e => edit_fault(e, &w.world),
                    })
            }),
        )
    }
}

/// Adds forces (newtons) to vertices `first .. first + count - 1` for the next
/// `weft_world_step`: vertex `first + k` gets the 3 floats at byte `k * stride` of `src`
/// (read unaligned, `stride` ≥ 12), added to what was applied since the last step. They act
/// constantly over that step and are then cleared: apply a lasting force every frame. Their
/// work enters the step's energy balance as input, like gravity's. Checks every value first
/// (`WEFT_RESULT_NON_FINITE` names the vertex); nothing changes on failure. Wakes the world
/// when any force is non-zero.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `src` is readable for
/// `(count - 1) * stride + 12` bytes.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_add_forces(
    world: *mut WeftWorld,
    first: u32,
    count: u32,
    src: *const c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            edit_range(
                world,
                first,
                count,
                src,
                stride,
                c"forces",
                World::add_forces,
            ),
        )
    }
}

/// Applies impulses (newton-seconds) to vertices `first .. first + count - 1`, laid out as in
/// `weft_world_add_forces`: each vertex's velocity changes by `impulse / mass` at once, so the
/// next step starts from it (a pinned vertex stays held). Checks every value first; nothing
/// changes on failure. Wakes the world when any impulse is non-zero.
///
/// # Safety
/// As `weft_world_add_forces`.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_add_impulses(
    world: *mut WeftWorld,
    first: u32,
    count: u32,
    src: *const c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            edit_range(
                world,
                first,
                count,
                src,
                stride,
                c"impulses",
                World::add_impulses,
            ),
        )
    }
}

/// Sets the mass scale of vertices `first .. first + count - 1`: vertex `first + k`'s mass
/// becomes the lumped mass its triangles' density gives it times the float at byte
/// `k * stride` of `src` (`stride` ≥ 4), e.g. 3 along a hem for a heavier edge. The step uses
/// these masses for inertia, gravity and damping; scales replace earlier ones (1 restores the
/// material's mass). A scale must be finite and > 0 and the mass it gives a normal `float`
/// (`WEFT_RESULT_INVALID_ARGUMENT`, `detail.what` "scales", `detail.vertex` the vertex).
/// Checks every value first; nothing changes on failure. Wakes the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `src` is readable for
/// `(count - 1) * stride + 4` bytes.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_mass_scales(
    world: *mut WeftWorld,
    first: u32,
    count: u32,
    src: *const c_void,
    stride: usize,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            edit_range(
                world,
                first,
                count,
                src,
                stride,
                c"scales",
                World::set_mass_scales,
            ),
        )
    }
}

/// Pins vertex `vertex` to `target` (metres, in your coordinates) in every direction, or moves
/// its pin there. The vertex travels to the target over the next step (linearly across
/// substeps), so animate a pin by setting its target every frame. A new pin starts where the vertex is. Wakes the world when the target
/// changed. Pins hold only while `WEFT_EFFECT_PINS` is on.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_pin(
    world: *mut WeftWorld,
    vertex: u32,
    target: WeftVec3,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                if !vec3(target).iter().all(|c| c.is_finite()) {
                    return Err(fault(WeftResult::NonFinite).what(c"target").vertex(vertex));
                }
                w.world
                    .set_pin(vertex, vec3(target))
                    .map_err(|e| edit_fault(e, &w.world).vertex(vertex))
            }),
        )
    }
}

/// # Safety
/// `world` as [`world_mut`].
unsafe fn set_pin_axes(
    world: *mut WeftWorld,
    vertex: u32,
    target: WeftVec3,
    axes: PinAxes,
    axis: WeftVec3,
) -> FfiResult<()> {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            if !vec3(target).iter().all(|c| c.is_finite()) {
                return Err(fault(WeftResult::NonFinite).what(c"target").vertex(vertex));
            }
            if !vec3(axis).iter().all(|c| c.is_finite()) {
                return Err(fault(WeftResult::NonFinite).what(c"axis").vertex(vertex));
            }
            w.world
                .set_pin_axes(vertex, vec3(target), axes)
                .map_err(|e| edit_fault(e, &w.world).vertex(vertex))
        })
    }
}

/// Pins vertex `vertex` in one direction only: it stays in the plane through `target`
/// (metres, in your coordinates) normal to `normal` (any length but zero; normalized) and moves freely, without
/// friction, within it. Otherwise as `weft_world_set_pin` (it replaces any pin the vertex had;
/// moving the target moves the plane; another target in the same plane is the same pin, and
/// does not wake the world). A pinned vertex ignores colliders. A zero normal is
/// `WEFT_RESULT_INVALID_ARGUMENT` (`detail.what` "axis").
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_pin_plane(
    world: *mut WeftWorld,
    vertex: u32,
    target: WeftVec3,
    normal: WeftVec3,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        let axes = PinAxes::Plane {
            normal: vec3(normal),
        };
        // SAFETY: forwarded contract.
        unsafe { set_pin_axes(world, vertex, target, axes, normal) }
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Pins vertex `vertex` in the two directions normal to `direction`: it stays on the line
/// through `target` (metres, in your coordinates) along `direction` (any length but zero; normalized) and slides
/// freely along it, like a curtain ring on a rail. Otherwise as `weft_world_set_pin_plane`.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_pin_line(
    world: *mut WeftWorld,
    vertex: u32,
    target: WeftVec3,
    direction: WeftVec3,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r: FfiResult<()> = {
        let axes = PinAxes::Line {
            direction: vec3(direction),
        };
        // SAFETY: forwarded contract.
        unsafe { set_pin_axes(world, vertex, target, axes, direction) }
    };
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Releases the pin of vertex `vertex` (no error when it had none). Wakes the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_remove_pin(
    world: *mut WeftWorld,
    vertex: u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                w.world
                    .remove_pin(vertex)
                    .map_err(|e| edit_fault(e, &w.world).vertex(vertex))
            }),
        )
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

/// Adds a kinematic collider (its shape in your coordinates; the engine moves it, the cloth
/// does not push back) and writes
/// its id to `*out_index` when that is not NULL. The id names the collider until it is removed,
/// whatever else is added or removed (0, 1, 2 ... in order of addition; a removed collider's
/// id is not given again).
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `def` is readable; a non-NULL
/// `out_index` is writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_add_collider(
    world: *mut WeftWorld,
    def: *const WeftColliderDef,
    out_index: *mut u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
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
            }),
        )
    }
}

/// Moves collider `index` (an id from `weft_world_add_collider`) to `*shape` (in your
/// coordinates; same or another kind); an id of no collider is `WEFT_RESULT_UNKNOWN_COLLIDER`.
/// The next step sweeps it linearly from where it was at the last step (a change of kind
/// teleports): its centre, axis, plane offset and radius, so a sphere, capsule or shell that
/// grows pushes the cloth at the speed its surface moves. Wakes the world when it moved.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `shape` is readable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_collider(
    world: *mut WeftWorld,
    index: u32,
    shape: *const WeftShape,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                let s = shape_from_c(read_ref(shape, c"shape")?)?;
                w.world
                    .set_collider_shape(index, s)
                    .map_err(|e| edit_fault(e, &w.world).index(index))
            }),
        )
    }
}

/// Removes collider `id` (from `weft_world_add_collider`); the others keep their ids. An id
/// that names no collider (never added, or removed already) is `WEFT_RESULT_UNKNOWN_COLLIDER`
/// (`detail.index` the id). Wakes the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_remove_collider(
    world: *mut WeftWorld,
    id: u32,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                w.world
                    .remove_collider(id)
                    .map_err(|e| edit_fault(e, &w.world).index(id))
            }),
        )
    }
}

/// Removes every collider (their ids are not given again). Wakes the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_clear_colliders(
    world: *mut WeftWorld,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            with_world(world, |w| {
                w.world.clear_colliders();
                Ok(())
            }),
        )
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

/// The world's origin, in `*out_origin`: the point of your coordinates that the world keeps at
/// zero of its own single-precision coordinates. A step moves vertices by `x += v * h` in
/// `float`; at 10 km from zero a `float` resolves only ~1 mm, so slow motion would be rounded
/// away and a cloth there would never rest. The world therefore simulates relative to an
/// origin near the cloth, and every position you give or get (the def's positions,
/// `weft_world_set_positions` / `weft_world_get_positions` and their ranges,
/// `weft_world_transform`, pin targets of every kind, collider shapes, and `weft_localize`'s
/// output) is in your coordinates, converted through double precision, one
/// rounding each way. At create the origin is the centre of the cloth's bounding box rounded
/// to a multiple of `WEFT_ORIGIN_GRID` metres: zero for any cloth within 2 m of zero, where
/// nothing is converted. A step after which the cloth's centre is more than
/// `WEFT_ORIGIN_GRID` metres from the origin (along any axis) moves it by the same rule, so
/// the origin follows a cloth that travels. Velocities do not depend on it; the gravitational
/// energy is measured from its height.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out_origin` is writable.
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_origin(
    world: *const WeftWorld,
    out_origin: *mut WeftDVec3,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    let r = (|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let out = out_ptr(out_origin, c"out_origin")?;
        let o = w.world.origin();
        // SAFETY: checked; writable per the contract.
        unsafe {
            out.write(WeftDVec3 {
                x: o.x,
                y: o.y,
                z: o.z,
            })
        };
        Ok(())
    })();
    // SAFETY: a non-NULL `out_detail` is writable (the contract).
    unsafe { detailed(out_detail, r) }
}

/// Moves the world's origin (`weft_world_get_origin`) to `origin`, in your coordinates: e.g.
/// when the cloth has travelled kilometres from where it was created. Nothing moves in your
/// coordinates (positions, pins and colliders are re-expressed relative to the new origin, one
/// rounding each). `WEFT_RESULT_NON_FINITE` (nothing changed) for a non-finite origin or one so
/// far from the cloth that its coordinates would overflow. Does not wake the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_origin(
    world: *mut WeftWorld,
    origin: WeftDVec3,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            edit_origin(world, origin, c"origin", World::set_origin),
        )
    }
}

/// For an engine that recenters its own coordinates (as Jolt's and PhysX's "shift origin"):
/// what was at `shift` in your old coordinates is at zero in the new ones, and every later
/// position you give or get is in the new ones. Nothing in the world moves or is rounded (its
/// origin changes by `-shift`). `WEFT_RESULT_NON_FINITE` (nothing changed) when the new
/// origin would not be finite.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
/// A non-NULL `out_detail` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_shift_origin(
    world: *mut WeftWorld,
    shift: WeftDVec3,
    out_detail: *mut WeftErrorDetail,
) -> WeftResult {
    // SAFETY: forwarded contract; a non-NULL `out_detail` is writable.
    unsafe {
        detailed(
            out_detail,
            edit_origin(world, shift, c"shift", World::shift_origin),
        )
    }
}

/// `edit(world, point)`, its fault naming `what`.
///
/// # Safety
/// `world` as [`with_world`].
unsafe fn edit_origin(
    world: *mut WeftWorld,
    point: WeftDVec3,
    what: &'static core::ffi::CStr,
    edit: fn(&mut World<'static>, DVec3) -> Result<(), EditError>,
) -> FfiResult<()> {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let p = DVec3::new(point.x, point.y, point.z);
            edit(&mut w.world, p).map_err(|e| edit_fault(e, &w.world).what(what))
        })
    }
}
