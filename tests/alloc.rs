//! The runtime never touches the heap: a counting global allocator watches `World::new` and
//! 1,000 steps with every effect on (the only test in this binary, so nothing else allocates
//! concurrently).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use common::*;
use glam::Vec3A;
use weft::collide::{Collider, Shape};
use weft::world::{effects, Capacity, Materials, Settings, World};

struct Counting;

// Only the test's own thread is watched: the harness allocates on its threads meanwhile.
thread_local! {
    static WATCHED: Cell<bool> = const { Cell::new(false) };
}
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

fn watching() -> bool {
    WATCHED.try_with(Cell::get).unwrap_or(false)
}

fn watch(on: bool) {
    WATCHED.with(|w| w.set(on));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if watching() {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if watching() {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn init_and_a_thousand_steps_allocate_nothing() {
    let mut sheet = Sheet::grid(16, 16, 1.0, 1.0);
    sheet.transform(|p| [p[0], 0.0, p[1]]);
    let mats = [anisotropic()];
    let cap = Capacity::grid(16);
    let mut mem = vec![0u8; cap.world_bytes()];
    let settings = Settings {
        effects: effects::ALL,
        wind: [0.0, 2.0, 0.0],
        drag: 0.3,
        substeps: 2,
        ..Settings::default()
    };
    let def = sheet.def();
    let corner = sheet.index(0, 15);
    let target = sheet.positions[corner as usize];

    watch(true);
    let mut w = World::new(&mut mem, cap, &def, Materials::Table(&mats), settings).unwrap();
    w.set_pin(corner, target).unwrap();
    w.add_collider(Collider::new(
        Shape::Capsule {
            a: Vec3A::new(0.0, 0.2, 0.3),
            b: Vec3A::new(1.0, 0.2, 0.3),
            radius: 0.1,
        },
        0.3,
        0.005,
    ))
    .unwrap();
    let mut steps = 0;
    for frame in 0..1000 {
        // an animated pin keeps the cloth awake
        let t = frame as f32 / 60.0;
        w.set_pin(corner, [target[0] + 0.1 * t.sin(), target[1], target[2]])
            .unwrap();
        w.step().unwrap();
        steps += 1;
    }
    watch(false);

    assert_eq!(steps, 1000);
    assert_eq!(
        ALLOCATIONS.load(Ordering::SeqCst),
        0,
        "heap allocations during init and stepping"
    );
    // and the counter works: a Vec allocates
    watch(true);
    let v = std::hint::black_box(vec![1u8; 10]);
    watch(false);
    drop(v);
    assert!(ALLOCATIONS.load(Ordering::SeqCst) > 0);
}
