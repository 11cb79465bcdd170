//! The runtime never touches the heap: a counting global allocator watches `World::new` and
//! 1,000 steps with every effect on. Only the test's own thread is counted: libtest's main
//! thread may allocate while the test runs (seen: 4 allocations, now and then, under load).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use common::*;
use glam::Vec3A;
use weft::collide::{Collider, Shape};
use weft::world::{effects, Capacity, Materials, Settings, World};

struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Set on the thread under watch. A `const` thread-local of a `Cell<bool>` needs neither
    /// lazy initialization nor a destructor, so the allocator may read it.
    static WATCHED: Cell<bool> = const { Cell::new(false) };
}

fn counted() -> bool {
    COUNTING.load(Ordering::SeqCst) && WATCHED.try_with(Cell::get).unwrap_or(false)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if counted() {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if counted() {
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

    WATCHED.with(|w| w.set(true));
    COUNTING.store(true, Ordering::SeqCst);
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
    COUNTING.store(false, Ordering::SeqCst);

    assert_eq!(steps, 1000);
    assert_eq!(
        ALLOCATIONS.load(Ordering::SeqCst),
        0,
        "heap allocations during init and stepping"
    );
    // and the counter works: a Vec allocates
    COUNTING.store(true, Ordering::SeqCst);
    let v = std::hint::black_box(vec![1u8; 10]);
    COUNTING.store(false, Ordering::SeqCst);
    drop(v);
    assert!(ALLOCATIONS.load(Ordering::SeqCst) > 0);
}
