//! Localization never touches the heap: a counting global allocator watches binding, the
//! tiled mesh, prepare, localize (interleaved, with normals, in ranges) and the exact normals.
//! Every buffer is made before counting starts, and only this thread's allocations count
//! (threads left behind by the offline homogenization may still be winding down).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use common::*;
use weft::blob::{AlignedBytes, Blob};
use weft::localize::{
    bind, localize, prepare, recompute_normals, tiled_mesh, tiled_mesh_counts, Binding,
    NormalTarget, StrainMeasure, VertexFrame,
};
use weft::strided::{Strided, StridedMut};
use weft::world::{Materials, World};

struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

fn counting() -> bool {
    COUNTING.try_with(Cell::get).unwrap_or(false)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if counting() {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if counting() {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn bind_prepare_localize_allocate_nothing() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("cells");
    let paths = [dir.join("stripes.toml"), dir.join("three.toml")];
    let bytes = weft::homogenize::build_blob(&paths, 1, &mut |_, _| {}).unwrap();
    let bytes = AlignedBytes::copy_from(&bytes);
    let blob = Blob::parse(&bytes).unwrap();
    let mut sheet = Sheet::grid(6, 6, 0.05, 0.05);
    for (t, m) in sheet.materials.iter_mut().enumerate() {
        *m = (t % 2) as u32;
    }
    sheet.transform(|p| [p[0] * 1.02, p[1], 0.01 * (p[0] * 40.0).sin()]);
    let mut mem = memory(&sheet.capacity());
    let w = World::new(
        &mut mem,
        sheet.capacity(),
        &sheet.def(),
        Materials::Blob(&blob),
        settings_quiet(),
    )
    .unwrap();
    let (nv, nt) = tiled_mesh_counts(&w, &blob, 1).unwrap();
    let mut uv = vec![[0.0f32; 2]; nv];
    let mut tris = vec![[0u32; 3]; nt];
    let mut mats = vec![0u32; nt];
    let mut bindings = vec![Binding::ZERO; nv];
    let mut frames = vec![VertexFrame::REST; w.vertex_count()];
    let stride = 32;
    let mut vb = vec![0u8; nv * stride];

    // the counter sees this thread's allocations
    COUNTING.with(|c| c.set(true));
    std::hint::black_box(vec![1u8; 3]);
    COUNTING.with(|c| c.set(false));
    assert_eq!(ALLOCATIONS.swap(0, Ordering::SeqCst), 1);

    COUNTING.with(|c| c.set(true));
    tiled_mesh(&w, &blob, 1, &mut uv, &mut tris, Some(&mut mats)).unwrap();
    bind(&w, &blob, &Strided::from_slice(&uv), &mut bindings).unwrap();
    for _ in 0..3 {
        prepare(&w, StrainMeasure::Corotated, &mut frames).unwrap();
        let all = StridedMut::<3>::new(&mut vb, stride, nv).unwrap();
        let (mut a, mut b) = all.split_at(nv / 2);
        let n = Some(NormalTarget::Interleaved { offset: 12 });
        localize(&frames, w.triangles(), &bindings, 0, &mut a, n).unwrap();
        let n = Some(NormalTarget::Interleaved { offset: 12 });
        localize(&frames, w.triangles(), &bindings, nv / 2, &mut b, n).unwrap();
        let mut all = StridedMut::<3>::new(&mut vb, stride, nv).unwrap();
        recompute_normals(&tris, &mut all, NormalTarget::Interleaved { offset: 12 }).unwrap();
    }
    COUNTING.with(|c| c.set(false));
    assert_eq!(ALLOCATIONS.load(Ordering::SeqCst), 0);
}
