//! Editing a live world: vertex positions and velocities in and out, pins, colliders.

use core::ffi::c_void;

use glam::DVec3;

use super::convert::*;
use super::result::{edit_fault, fault};
use super::types::*;
use super::*;
use crate::collide::Collider;
use crate::world::{EditError, World};

/// Vertex `i`'s position in the caller's coordinates (the kernel's conversion).
fn position_out(w: &World<'static>, i: usize) -> Option<[f32; 3]> {
    w.positions().get(i).map(|&x| w.to_world(x))
}

fn velocity_out(w: &World<'static>, i: usize) -> Option<[f32; 3]> {
    w.velocities().get(i).map(|v| v.to_array())
}

/// Writes `element(world, i)` for every vertex.
///
/// # Safety
/// `out` writable for the strided extent; `world` as [`world_at`].
unsafe fn get_vec3s(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
    element: fn(&World<'static>, usize) -> Option<[f32; 3]>,
) -> WeftResult {
    done((|| {
        // SAFETY: forwarded contract.
        let w = unsafe { world_at(world) }?;
        let n = w.world.vertex_count();
        if (count as usize) < n {
            let mut f = fault(WeftResult::CountMismatch).what(c"count");
            f.needed = n as u32;
            return Err(f);
        }
        // SAFETY: writable for the extent per the contract, disjoint from the world.
        let mut out = unsafe { strided_out::<3>(out, n, stride, c"out", c"stride") }?;
        for i in 0..n {
            out.set(i, element(&w.world, i).unwrap_or_default());
        }
        Ok(())
    })())
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
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_positions(
    world: *const WeftWorld,
    out: *mut c_void,
    count: u32,
    stride: usize,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe { get_vec3s(world, out, count, stride, position_out) }
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
    unsafe { get_vec3s(world, out, count, stride, velocity_out) }
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
            let src = strided_in::<3>(src, n, stride, what, c"stride")?;
            let r = if velocities {
                w.world.set_velocities_strided(&src)
            } else {
                w.world.set_positions_strided(&src)
            };
            // The kernel checks every value first; the detail names the first bad vertex.
            r.map_err(|e| match e {
                EditError::NonFinite => {
                    let finite = |i| src.get(i).is_some_and(|p| p.iter().all(|c| c.is_finite()));
                    let vertex = (0..n).find(|&i| !finite(i)).map_or(WEFT_NONE, count32);
                    fault(WeftResult::NonFinite).what(what).vertex(vertex)
                }
                e => edit_fault(e, &w.world),
            })
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

/// The world's origin, in `*out_origin`: the point of your coordinates that the world keeps at
/// zero of its own single-precision coordinates. A step moves vertices by `x += v * h` in
/// `float`; at 10 km from zero a `float` resolves only ~1 mm, so slow motion would be rounded
/// away and a cloth there would never rest. The world therefore simulates relative to an
/// origin near the cloth, and every position you give or get (the def's positions,
/// `weft_world_set_positions` / `weft_world_get_positions`, pin targets, collider shapes, and
/// `weft_localize`'s output) is in your coordinates, converted through double precision, one
/// rounding each way. At create the origin is the centre of the cloth's bounding box rounded
/// to a multiple of `WEFT_ORIGIN_GRID` metres: zero for any cloth within 32 m of zero, where
/// nothing is converted. Velocities do not depend on it; the gravitational energy is measured
/// from its height.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL); `out_origin` is writable.
#[no_mangle]
pub unsafe extern "C" fn weft_world_get_origin(
    world: *const WeftWorld,
    out_origin: *mut WeftDVec3,
) -> WeftResult {
    done((|| {
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
    })())
}

/// Moves the world's origin (`weft_world_get_origin`) to `origin`, in your coordinates: e.g.
/// when the cloth has travelled kilometres from where it was created. Nothing moves in your
/// coordinates (positions, pins and colliders are re-expressed relative to the new origin, one
/// rounding each). `WEFT_RESULT_NON_FINITE` (nothing changed) for a non-finite origin or one so
/// far from the cloth that its coordinates would overflow. Does not wake the world.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_set_origin(
    world: *mut WeftWorld,
    origin: WeftDVec3,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe { edit_origin(world, origin, c"origin", World::set_origin) }
}

/// For an engine that recenters its own coordinates (as Jolt's and PhysX's "shift origin"):
/// what was at `shift` in your old coordinates is at zero in the new ones, and every later
/// position you give or get is in the new ones. Nothing in the world moves or is rounded (its
/// origin changes by `-shift`). `WEFT_RESULT_NON_FINITE` (nothing changed) when the new
/// origin would not be finite.
///
/// # Safety
/// `world` is a handle from `weft_world_create` (or NULL).
#[no_mangle]
pub unsafe extern "C" fn weft_world_shift_origin(
    world: *mut WeftWorld,
    shift: WeftDVec3,
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe { edit_origin(world, shift, c"shift", World::shift_origin) }
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
) -> WeftResult {
    // SAFETY: forwarded contract.
    unsafe {
        with_world(world, |w| {
            let p = DVec3::new(point.x, point.y, point.z);
            edit(&mut w.world, p).map_err(|e| edit_fault(e, &w.world).what(what))
        })
    }
}
