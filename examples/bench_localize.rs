//! Localization throughput on one core: the `three` cell (10×10 pixels, 1 cm, refine 1: 1 mm
//! micro squares) tiled over a 0.38 m cloth gives a 381×381-vertex, 288,800-triangle fine mesh
//! (the paper's Fig. 8 size) bound to a 21×21-vertex coarse cloth in a smooth, strained pose.
//!
//! Run with `cargo run --release --example bench_localize`. Prints the one-off costs (tiled
//! mesh, bind) and, per frame, the median over samples of `prepare` and of `localize` into a
//! 32-byte interleaved vertex buffer (position, normal, uv), positions only and with blended
//! normals, plus the exact normals recomputed from the fine mesh, in fine vertices per second;
//! then positions kept outside a sphere (`localize_colliding`) that the cloth lies on (the
//! demo's cloth over a sphere: a cap of the fine mesh cuts into it) and a floor below, against
//! the plain call.
//!
//! Times are the thread's CPU time (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)` on Linux, the wall
//! clock elsewhere), so that time spent preempted on a busy machine does not count; the
//! wall-clock median is printed alongside.

#[cfg(feature = "std")]
fn main() {
    use std::hint::black_box;
    use std::path::PathBuf;
    use std::time::Instant;

    use glam::{Mat3A, Vec3A};
    use weft::blob::{AlignedBytes, Blob};
    use weft::collide::{Collider, ColliderSet, Shape};
    use weft::localize::{
        bind, localize, localize_colliding, prepare, recompute_normals, tiled_mesh,
        tiled_mesh_counts, Binding, Coarse, NormalTarget, StrainMeasure, VertexFrame,
    };
    use weft::mesh;
    use weft::strided::{Strided, StridedMut};
    use weft::world::{Capacity, ClothDef, Materials, Settings, World};

    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // (cpu seconds, wall seconds) since an arbitrary origin
    let origin = Instant::now();
    let clock = move || {
        let wall = origin.elapsed().as_secs_f64();
        (thread_cpu_seconds().unwrap_or(wall), wall)
    };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("cells/three.toml");
    let bytes = weft::homogenize::build_blob(&[path], 1, &mut |_, _| {}).expect("blob");
    let bytes = AlignedBytes::copy_from(&bytes);
    let blob = Blob::parse(&bytes).expect("parse");

    // 21×21 coarse cloth, 0.38 m, in a bent, stretched and sheared pose.
    let (n, size) = (21usize, 0.38f32);
    let mut positions = vec![[0.0f32; 3]; n * n];
    let mut uvs = vec![[0.0f32; 2]; n * n];
    let mut triangles = vec![[0u32; 3]; 2 * (n - 1) * (n - 1)];
    mesh::grid(n, n, size, size, &mut positions, &mut uvs, &mut triangles).expect("grid");
    let materials = vec![0u32; triangles.len()];
    let rot = Mat3A::from_rotation_y(0.4) * Mat3A::from_rotation_z(-0.3);
    for (p, q) in positions.iter_mut().zip(&uvs) {
        let (u, v) = (q[0] / size, q[1] / size);
        let x = Vec3A::new(
            q[0] * (1.0 + 0.03 * (3.0 * v).sin()),
            q[1] * (1.0 + 0.02 * (2.0 * u).cos()) + 0.01 * size * u * v,
            0.2 * size * (2.5 * u).sin() * (1.5 * v).cos(),
        );
        *p = (rot * x).to_array();
    }
    let cap = Capacity::grid(n as u32);
    let mut mem = vec![0u8; cap.world_bytes()];
    let def = ClothDef {
        positions: &positions,
        uvs: &uvs,
        triangles: &triangles,
        materials: &materials,
    };
    let world = World::new(
        &mut mem,
        cap,
        &def,
        Materials::Blob(&blob),
        Settings::default(),
    )
    .expect("world");

    let t0 = Instant::now();
    let (nv, nt) = tiled_mesh_counts(&world, &blob, 0).expect("counts");
    let mut fine_uv = vec![[0.0f32; 2]; nv];
    let mut fine_tris = vec![[0u32; 3]; nt];
    tiled_mesh(&world, &blob, 0, &mut fine_uv, &mut fine_tris, None).expect("tiled");
    let t_tile = t0.elapsed().as_secs_f64();
    let mut bindings = vec![Binding::ZERO; nv];
    let t0 = Instant::now();
    bind(&world, &blob, &Strided::from_slice(&fine_uv), &mut bindings).expect("bind");
    let t_bind = t0.elapsed().as_secs_f64();
    println!(
        "coarse {} vertices / {} triangles; fine {} vertices / {} triangles",
        world.vertex_count(),
        world.triangle_count(),
        nv,
        nt
    );
    println!(
        "one-off: tiled mesh {:.1} ms, bind {:.1} ms ({:.2} M vertices/s)",
        t_tile * 1e3,
        t_bind * 1e3,
        nv as f64 / t_bind / 1e6
    );

    // Interleaved 32-byte vertices: position @0, normal @12, uv @24.
    let stride = 32;
    let mut vb = vec![0u8; nv * stride];
    {
        let mut rec = StridedMut::<2>::with_offset(&mut vb, stride, 24, nv).expect("layout");
        for (i, q) in fine_uv.iter().enumerate() {
            rec.set(i, *q);
        }
    }
    let mut frames = vec![VertexFrame::REST; world.vertex_count()];
    let samples = 15;
    let reps = 20;

    // Median over `samples` of the per-call (cpu, wall) time of `reps` calls of `f`.
    let time = |reps: usize, f: &mut dyn FnMut()| {
        let (mut cpu, mut wall) = (Vec::new(), Vec::new());
        for _ in 0..samples {
            let (c0, w0) = clock();
            for _ in 0..reps {
                f();
            }
            let (c1, w1) = clock();
            cpu.push((c1 - c0) / reps as f64);
            wall.push((w1 - w0) / reps as f64);
        }
        (median(&mut cpu), median(&mut wall))
    };
    let report = |label: &str, (cpu, wall): (f64, f64)| {
        println!(
            "{label:<52} {:>8.3} ms/frame {:>7.1} M vertices/s   (wall {:.3} ms)",
            cpu * 1e3,
            nv as f64 / cpu / 1e6,
            wall * 1e3
        );
    };

    let (cpu, wall) = time(200, &mut || {
        prepare(&world, StrainMeasure::Corotated, black_box(&mut frames)).expect("prepare");
    });
    println!(
        "prepare (Corotated, {} triangles): {:.1} µs (wall {:.1} µs)",
        world.triangle_count(),
        cpu * 1e6,
        wall * 1e6
    );

    for (label, normals) in [
        ("localize positions, 32-byte interleaved", false),
        ("localize positions + blended normals, interleaved", true),
    ] {
        let t = time(reps, &mut || {
            let mut pos = StridedMut::<3>::new(&mut vb, stride, nv).expect("layout");
            let nrm = normals.then_some(NormalTarget::Interleaved { offset: 12 });
            localize(
                &frames,
                world.triangles(),
                black_box(&bindings),
                0,
                &mut pos,
                nrm,
            )
            .expect("localize");
            black_box(&mut pos);
        });
        report(label, t);
    }

    // Tightly packed positions ([f32; 3] array) for comparison.
    let mut packed = vec![[0.0f32; 3]; nv];
    let t = time(reps, &mut || {
        let mut pos = StridedMut::from_slice(&mut packed);
        localize(
            &frames,
            world.triangles(),
            black_box(&bindings),
            0,
            &mut pos,
            None,
        )
        .expect("localize");
        black_box(&mut pos);
    });
    report("localize positions, packed [f32; 3]", t);

    let t = time(2, &mut || {
        let mut pos = StridedMut::<3>::new(&mut vb, stride, nv).expect("layout");
        recompute_normals(
            &fine_tris,
            &mut pos,
            NormalTarget::Interleaved { offset: 12 },
        )
        .expect("normals");
    });
    report("recompute_normals (exact, from the fine mesh)", t);

    // Colliders: a sphere under the middle of the cloth whose top cuts 1 cm through it, and a
    // floor 0.5 m below that no vertex reaches.
    let mid = (n / 2) * n + n / 2;
    let (top, up) = (frames[mid].p, frames[mid].normal);
    let radius = 0.1;
    let sphere = Shape::Sphere {
        center: top - up * (radius - 0.01),
        radius,
    };
    let floor = Shape::Plane {
        normal: Vec3A::Z,
        offset: top.z - 0.5,
    };
    let coarse = Coarse {
        frames: &frames,
        triangles: world.triangles(),
    };
    let plain = {
        let mut pos = StridedMut::from_slice(&mut packed);
        localize(&frames, world.triangles(), &bindings, 0, &mut pos, None).expect("localize");
        packed.clone()
    };
    for (label, colliders) in [
        ("localize positions, packed, no colliders", &[][..]),
        (
            "  outside a floor (none inside)",
            &[Collider::new(floor, 0.5, 0.003)][..],
        ),
        (
            "  outside a sphere (a cap inside)",
            &[Collider::new(sphere, 0.5, 0.003)][..],
        ),
        (
            "  outside the sphere and the floor",
            &[
                Collider::new(sphere, 0.5, 0.003),
                Collider::new(floor, 0.5, 0.003),
            ][..],
        ),
    ] {
        let t = time(reps, &mut || {
            let mut pos = StridedMut::from_slice(&mut packed);
            let set = ColliderSet::new(colliders);
            localize_colliding(coarse, black_box(&bindings), 0, &mut pos, None, set)
                .expect("localize");
            black_box(&mut pos);
        });
        let moved = packed.iter().zip(&plain).filter(|(a, b)| a != b).count();
        report(label, t);
        println!("{:<52} {moved} vertices pushed", "");
    }
}

/// CPU time of the calling thread (the bench's only platform call; the library has none).
#[cfg(all(feature = "std", target_os = "linux", target_pointer_width = "64"))]
fn thread_cpu_seconds() -> Option<f64> {
    #[repr(C)]
    struct Timespec {
        tv_sec: i64,
        tv_nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut ts = Timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec (two 64-bit fields on 64-bit Linux); the call
    // only writes it.
    let rc = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(all(
    feature = "std",
    not(all(target_os = "linux", target_pointer_width = "64"))
))]
fn thread_cpu_seconds() -> Option<f64> {
    None
}

#[cfg(not(feature = "std"))]
fn main() {}
