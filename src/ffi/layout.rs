//! The C structs' layouts, checked at compile time: every `#[repr(C)]` struct of the API is
//! its fields back to back, with no hidden padding (a C compiler, another language's binding
//! generator or a serializer sees exactly the listed fields), and no field is a `bool` (whose
//! size and valid values C does not fix): flags are `u32` 0/1. A new field or struct that breaks
//! this fails the build here; `tests/c_examples.rs` checks that C agrees with every offset.

use core::ffi::{c_char, c_void};
use core::mem::{offset_of, size_of};

use super::result::{WeftErrorDetail, WeftResult};
use super::types::*;

/// Asserts that the fields of `$t`, listed in order with their types, tile it exactly: each
/// starts where the previous one ends and the last ends at the struct's size.
macro_rules! no_padding {
    ($t:ty { $($f:ident : $ft:ty),* $(,)? }) => {
        const _: () = {
            let mut end = 0usize;
            $(
                assert!(
                    offset_of!($t, $f) == end,
                    concat!(stringify!($t), ".", stringify!($f), " follows hidden padding")
                );
                end += size_of::<$ft>();
            )*
            assert!(end == size_of::<$t>(), concat!(stringify!($t), " ends in hidden padding"));
        };
    };
}

no_padding!(WeftVec3 {
    x: f32,
    y: f32,
    z: f32
});
no_padding!(WeftVec2 { x: f32, y: f32 });
no_padding!(WeftQuat {
    x: f32,
    y: f32,
    z: f32,
    w: f32
});
no_padding!(WeftCapacity {
    max_vertices: u32,
    max_triangles: u32,
    max_edges: u32,
    max_colliders: u32,
    max_pins: u32,
});
no_padding!(WeftSettings {
    effects: u32,
    substeps: u32,
    gravity: WeftVec3,
    damping_mass: f32,
    damping_stiffness: f32,
    wind: WeftVec3,
    drag: f32,
    tolerance: f32,
    max_iterations: u32,
    rotation_iterations: u32,
    sleep_velocity: f32,
    sleep_frames: u32,
    max_depenetration_speed: f32,
});
no_padding!(WeftWorldDef {
    positions: *const c_void,
    position_stride: usize,
    uvs: *const c_void,
    uv_stride: usize,
    vertex_count: u32,
    triangle_count: u32,
    indices: *const u32,
    materials: *const u32,
    material: u32,
    capacity: WeftCapacity,
    settings: WeftSettings,
    internal_cookie: u32,
});
no_padding!(WeftBlob {
    data: *const c_void,
    size: usize,
    version: u32,
    cell_count: u32,
    internal_cookie: u32,
    reserved: u32,
});
no_padding!(WeftCellInfo {
    name: [c_char; 64],
    width: f64,
    height: f64,
    cols: u32,
    rows: u32,
    refine: u32,
    node_count: u32,
    stiffness: [[f64; 3]; 3],
    density: f64,
    bending: f64,
});
no_padding!(WeftShape {
    kind: u32,
    p0: WeftVec3,
    p1: WeftVec3,
    size: f32,
});
no_padding!(WeftColliderDef {
    shape: WeftShape,
    friction: f32,
    thickness: f32,
    internal_cookie: u32,
});
no_padding!(WeftStepStats {
    iterations: u32,
    residual: f32,
    converged: u32,
    substeps: u32,
    asleep: u32,
    contacts: u32,
    redone: u32,
    energy_removed: f32,
    stopped: u32,
    limited: u32,
});
no_padding!(WeftLocalizeOutput {
    positions: *mut c_void,
    position_stride: usize,
    normals: *mut c_void,
    normal_stride: usize,
    fine_indices: *const u32,
    normal_mode: u32,
    fine_triangle_count: u32,
    collider_mode: u32,
    internal_cookie: u32,
});
no_padding!(WeftErrorDetail {
    result: WeftResult,
    triangle: u32,
    vertex: u32,
    vertex_b: u32,
    material: u32,
    cell: u32,
    index: u32,
    needed: u32,
    capacity: u32,
    reserved: u32,
    what: *const c_char,
});
