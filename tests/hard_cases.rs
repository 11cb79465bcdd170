//! The named hard-case suite: each case runs thousands of steps and asserts no NaN/inf,
//! bounded energy, no penetration beyond the collider thickness, and that the cloth settles
//! when it should. A step that fails must report it and keep the last good state; the harness
//! then retries that frame with more substeps (what an engine would do) and counts it.

mod common;

use common::*;
use glam::Vec3A;
use weft::blob::{AlignedBytes, Blob};
use weft::collide::{Collider, Shape};
use weft::strided::Strided;
use weft::world::{effects, Capacity, ClothDef, Material, Materials, Settings, Solver, World};

/// Homogenizes a cell description given as TOML text; returns the blob bytes.
fn blob_of(name: &str, toml: &str) -> AlignedBytes {
    let dir = std::env::temp_dir().join(format!("weft-hard-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, toml).unwrap();
    let bytes = weft::homogenize::build_blob(&[path], 1, &mut |_, _| {}).unwrap();
    AlignedBytes::copy_from(&bytes)
}

/// `sheet` of the blob's first cell at default settings, pinned at its top corners.
fn hanging_from_blob<'m>(mem: &'m mut [u8], sheet: &Sheet, blob: &Blob) -> World<'m> {
    let mut w = World::new(
        mem,
        sheet.capacity(),
        &sheet.def(),
        Materials::Blob(blob),
        Settings::default(),
    )
    .unwrap();
    pin_top_corners(&mut w, sheet);
    w
}

/// What a run saw.
#[derive(Default, Debug)]
struct Run {
    steps: usize,
    failed_steps: usize,
    /// Frames that failed even with 8× substeps (reported, state kept).
    refused_frames: usize,
    peak_kinetic: f64,
    last_kinetic: f64,
}

/// Steps `frames` times, calling `frame(w, i)` before each step; checks every state is
/// finite and that a failed step left the state untouched.
fn run(w: &mut World<'_>, frames: usize, mut frame: impl FnMut(&mut World<'_>, usize)) -> Run {
    let mut r = Run::default();
    for i in 0..frames {
        frame(w, i);
        let before: Vec<Vec3A> = w.positions().to_vec();
        match w.step() {
            Ok(_) => {}
            Err(_) => {
                r.failed_steps += 1;
                assert_eq!(
                    w.positions(),
                    &before[..],
                    "a failed step must keep the last good state"
                );
                // what an engine does: retry the frame with more substeps
                let s = *w.settings();
                w.set_settings(Settings {
                    substeps: s.substeps * 8,
                    ..s
                })
                .unwrap();
                let retried = w.step();
                w.set_settings(s).unwrap();
                if retried.is_err() {
                    assert_eq!(w.positions(), &before[..], "a refused step keeps the state");
                    r.refused_frames += 1;
                }
            }
        }
        assert!(
            w.positions()
                .iter()
                .chain(w.velocities())
                .all(|p| p.is_finite()),
            "non-finite state at frame {i}"
        );
        let ke = kinetic_energy(w);
        r.peak_kinetic = r.peak_kinetic.max(ke);
        r.last_kinetic = ke;
        r.steps += 1;
    }
    r
}

/// At rest: every vertex slower than a millimetre per second per metre of cloth.
fn assert_settled(w: &World<'_>, size: f32, what: &str) {
    // (or slower than 10 µm/s: at rest to any eye, and the f32 noise floor of a 1 mm cloth)
    let fastest = top_speed(w);
    let limit = (1e-3 * size).max(1e-5);
    assert!(
        fastest < limit,
        "{what} does not settle: fastest vertex {fastest} m/s"
    );
}

/// Kinetic energy must stay below the potential energy the cloth can release falling its own
/// size, times a margin: anything above is energy the integrator created.
fn energy_bound(w: &World<'_>, drop: f64) -> f64 {
    10.0 * w.total_mass() * 9.81 * drop
}

#[test]
fn contrast_1e4_inside_one_cell_and_a_near_zero_material() {
    // hard threads in both directions around soft pockets: with a near-zero pocket the cell
    // keeps its stretch stiffness but nearly loses its shear stiffness (a mechanism)
    for (name, soft) in [("contrast", 1.0), ("nearzero", 1e-4)] {
        let toml = format!(
            r#"size = 0.01
pattern = ["HHHH", "H...", "H...", "H..."]
[materials."H"]
stiffness = 1.0e4
poisson = 0.3
density = 0.2
[materials."."]
stiffness = {soft}
poisson = 0.3
density = 0.1
"#
        );
        let bytes = blob_of(name, &toml);
        let blob = Blob::parse(&bytes).unwrap();
        let c = blob.cell(0).unwrap().stiffness;
        assert!(weft::membrane::is_spd(&c), "{name}: C^H {c:?}");
        let sheet = hanging_sheet(15, 1.0);
        let mut mem = memory(&sheet.capacity());
        let mut w = hanging_from_blob(&mut mem, &sheet, &blob);
        let bound = energy_bound(&w, 1.0);
        let r = run(&mut w, 3000, |_, _| {});
        assert!(r.peak_kinetic < bound, "{name}: {r:?}");
        assert_settled(&w, 1.0, name);
    }
}

#[test]
fn very_stiff_fabric_at_30_hz_one_substep() {
    let sheet = hanging_sheet(15, 1.0);
    let mats = [Material {
        stiffness: weft::membrane::isotropic(1e6, 0.3),
        density: 0.2,
        bending: 1e-3,
    }];
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        time_step: 1.0 / 30.0,
        substeps: 1,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    pin_top_corners(&mut w, &sheet);
    let bound = energy_bound(&w, 1.0);
    let r = run(&mut w, 2000, |_, _| {});
    assert!(r.peak_kinetic < bound, "{r:?}");
    assert_settled(&w, 1.0, "cloth");
}

/// The same very stiff fabric hanging at 60 Hz, struck at its centre out of its plane (2, 3,
/// 5 and 10 m/s), and dropped into a bowl (a static shell): no step may be refused from then
/// on. Found by an outside fuzzer: with the step redone at 2× and 4× its substeps only, both
/// still gained energy at 4× and every later call was refused, the state frozen for good;
/// 8× holds them.
#[test]
fn a_very_stiff_fabric_struck_or_dropped_into_a_bowl_is_never_frozen() {
    let mats = [Material {
        stiffness: weft::membrane::isotropic(1e6, 0.3),
        density: 0.2,
        bending: 1e-3,
    }];
    for speed in [2.0f32, 3.0, 5.0, 10.0] {
        let sheet = hanging_sheet(15, 1.0);
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, Settings::default());
        pin_top_corners(&mut w, &sheet);
        for _ in 0..120 {
            w.step().unwrap();
        }
        let centre = sheet.positions.len() / 2;
        let m = w.masses()[centre];
        let kick = [[0.0, m * speed, 0.0]];
        w.add_impulses(centre, &Strided::from_slice(&kick)).unwrap();
        let bound = energy_bound(&w, 1.0) + 0.5 * f64::from(m * speed * speed);
        let r = run(&mut w, 300, |_, _| {});
        assert!(
            r.failed_steps == 0 && r.peak_kinetic < bound,
            "struck at {speed} m/s: {r:?}"
        );
    }
    for n in [4, 10] {
        let sheet = Sheet::grid(n, n, 1.0, 1.0);
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, Settings::default());
        let bowl = Shape::Shell {
            center: Vec3A::new(0.5, 0.5, 0.0),
            radius: 0.8,
        };
        w.add_collider(Collider::new(bowl, 0.3, 0.005)).unwrap();
        let bound = energy_bound(&w, 1.0);
        let r = run(&mut w, 300, |_, _| {});
        assert!(
            r.failed_steps == 0 && r.peak_kinetic < bound,
            "{n}×{n} in a bowl: {r:?}"
        );
    }
}

#[test]
fn a_pinned_strip_twisted_360_degrees() {
    // 2 m × 0.2 m strip along x, both short ends pinned; the right end turns once about x
    let (nx, ny) = (31, 5);
    let mut sheet = Sheet::grid(nx, ny, 2.0, 0.2);
    sheet.transform(|p| [p[0], p[1] - 0.1, 0.0]);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::ALL & !effects::SLEEP,
        damping_mass: 1.0,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let right: Vec<u32> = (0..ny).map(|j| sheet.index(nx - 1, j)).collect();
    for j in 0..ny {
        let l = sheet.index(0, j);
        w.set_pin(l, sheet.positions[l as usize]).unwrap();
    }
    let turn_frames = 240;
    let bound = energy_bound(&w, 2.0);
    let r = run(&mut w, 2000, |w, i| {
        let angle = core::f32::consts::TAU * (i.min(turn_frames) as f32 / turn_frames as f32);
        let q = glam::Quat::from_rotation_x(angle);
        for &k in &right {
            let p = glam::Vec3::from(sheet.positions[k as usize]);
            let t = q * glam::Vec3::new(0.0, p.y, p.z) + glam::Vec3::new(p.x, 0.0, 0.0);
            w.set_pin(k, t.into()).unwrap();
        }
    });
    assert!(r.peak_kinetic < bound, "{r:?}");
    assert_settled(&w, 2.0, "cloth");
}

#[test]
fn a_cloth_crumpled_into_a_ball_by_a_shrinking_sphere() {
    let mut sheet = Sheet::grid(15, 15, 1.0, 1.0);
    sheet.transform(|p| [p[0] - 0.5, p[1] - 0.5, 0.0]);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    let thickness = 0.005;
    let shell = |r: f32| Shape::Shell {
        center: Vec3A::ZERO,
        radius: r,
    };
    w.add_collider(Collider::new(shell(0.75), 0.3, thickness))
        .unwrap();
    let shrink = 300;
    let radius = |i: usize| 0.75 - 0.6 * (i.min(shrink) as f32 / shrink as f32);
    let r = run(&mut w, 1500, |w, i| {
        w.set_collider_shape(0, shell(radius(i))).unwrap()
    });
    // everything ends inside the final ball, no deeper into the shell than its thickness
    let final_r = radius(1500);
    for (k, p) in w.positions().iter().enumerate() {
        assert!(
            p.length() <= final_r - thickness + 1e-5,
            "vertex {k} at {} outside {}",
            p.length(),
            final_r
        );
    }
    assert!(r.peak_kinetic < energy_bound(&w, 1.0), "{r:?}");
}

#[test]
fn a_pin_teleported_10_m_in_one_frame() {
    let sheet = hanging_sheet(15, 1.0);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let damped = Settings {
        damping_mass: 1.0,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, damped);
    let (a, b) = pin_top_corners(&mut w, &sheet);
    run(&mut w, 300, |_, _| {});
    let jump = Vec3A::new(10.0, 0.0, 0.0);
    let r = run(&mut w, 2500, |w, i| {
        if i == 0 {
            for k in [a, b] {
                let t = Vec3A::from(sheet.positions[k as usize]) + jump;
                w.set_pin(k, t.into()).unwrap();
            }
        }
    });
    // the cloth follows and comes to rest again; nothing was refused
    assert_eq!(r.refused_frames, 0, "{r:?}");
    assert_settled(&w, 1.0, "cloth");
    let com: Vec3A = caller_positions(&w)
        .into_iter()
        .map(Vec3A::from)
        .sum::<Vec3A>()
        / w.vertex_count() as f32;
    assert!((com.x - 10.5).abs() < 0.2, "centre of mass {com}");
}

#[test]
fn a_collider_moving_at_50_m_per_s_through_the_cloth() {
    let sheet = hanging_sheet(15, 1.0);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let damped = Settings {
        damping_mass: 1.0,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, damped);
    pin_top_corners(&mut w, &sheet);
    let thickness = 0.005;
    let at = |y: f32| Shape::Sphere {
        center: Vec3A::new(0.5, y, 0.5),
        radius: 0.2,
    };
    w.add_collider(Collider::new(at(-3.0), 0.2, thickness))
        .unwrap();
    let speed = 50.0 / 60.0; // metres per frame
    let r = run(&mut w, 1500, |w, i| {
        // one pass through the cloth, then park far away
        let y = (-3.0 + speed * i as f32).min(6.0);
        w.set_collider_shape(0, at(y)).unwrap();
    });
    for (k, p) in w.positions().iter().enumerate() {
        assert!(
            at(6.0).proximity(*p).distance > thickness - 1e-5,
            "vertex {k} inside"
        );
    }
    // A kinematic surface at speed V gives what it strikes at most 2V (an elastic bounce):
    // kinetic energy below ½ M (2V)². The sphere can catch the cloth and carry it until it
    // parks, stretching it (work the balance counts as input), and the cloth snaps back: that
    // is where the peak is (352 J, 101 m/s at most, when this was written; 170 J of a bound of
    // 750 J on 2026-11-27). Since the step is redone up to 8× its substeps, the first contact
    // resolves at 8× (the sphere moves 10 cm per substep); at 4× it tunnelled half through and
    // the balance took all the cloth's kinetic energy away (peak 58 J). The earlier bound, 20×
    // a one-metre drop's, was set from that. Holding every vertex the solve carries into the
    // sphere (`contacts::engage` without its limit) kept the cloth on it a frame longer: 976 J.
    let v = 50.0;
    let bounce = 0.5 * w.total_mass() * (2.0 * v) * (2.0 * v);
    assert!(r.failed_steps == 0 && r.peak_kinetic < bounce, "{r:?}");
    assert_settled(&w, 1.0, "cloth");
}

#[test]
fn a_free_falling_cloth_without_pins() {
    // no pins: the stiffness alone is singular (rigid modes); only the mass keeps A definite
    let mut sheet = Sheet::grid(12, 12, 1.0, 1.0);
    sheet.transform(|p| [p[0], p[1], 100.0]);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::GRAVITY | effects::BENDING | effects::WARPING,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let frames = 1000;
    run(&mut w, frames, |_, _| {});
    // implicit Euler on free fall: z(n) = z0 - g h² n(n+1)/2, exactly (no damping)
    let h = 1.0 / 60.0f64;
    let n = frames as f64;
    let expected = 100.0 - 9.81 * h * h * n * (n + 1.0) / 2.0;
    // (positions are relative to the world's origin: z = 128 for a cloth created at z = 100)
    let local_z = w.positions().iter().map(|p| p.z as f64).sum::<f64>() / w.vertex_count() as f64;
    let com_z = w.origin().z + local_z;
    assert!(
        (com_z - expected).abs() < 1e-3 * (100.0 - expected),
        "z {com_z} vs {expected}"
    );
    // and the sheet is still flat and unstretched
    let span =
        w.positions()[sheet.index(11, 0) as usize] - w.positions()[sheet.index(0, 0) as usize];
    assert!((span.length() - 1.0).abs() < 1e-3, "span {span}");
}

#[test]
fn sliver_triangles_and_a_single_triangle() {
    // a hanging cloth with a seam of sliver triangles (a CAD export that welded two panels
    // badly): at 1:100 and at 1:1000 it stays bounded
    for aspect in [100.0f32, 1000.0] {
        let mut sheet = hanging_sheet(15, 1.0);
        let h = 1.0 / 14.0;
        for j in 0..sheet.ny {
            let k = sheet.index(7, j) as usize;
            let x = 6.0 * h + h / aspect;
            sheet.positions[k][0] = x;
            sheet.uvs[k][0] = x;
        }
        let mats = [anisotropic()];
        let mut mem = memory(&sheet.capacity());
        let damped = Settings {
            damping_mass: 1.0,
            ..Settings::default()
        };
        let mut w = world(&mut mem, &sheet, &mats, damped);
        pin_top_corners(&mut w, &sheet);
        let r = run(&mut w, 2000, |_, _| {});
        // Both stay bounded: at 1:1000 the seam's short side is ~1000 f32 ulps of the
        // coordinates and its strain is noise, but the step's energy balance redoes or damps
        // every step that would gain energy (it used to be refused as Unstable, a documented
        // limit; the balance checked at the end of each step lifted it).
        assert!(
            r.peak_kinetic < energy_bound(&w, 1.0),
            "aspect {aspect}: {r:?}"
        );
        assert_eq!(r.failed_steps, 0, "aspect {aspect}: {r:?}");
        if aspect <= 100.0 {
            assert_settled(&w, 1.0, "cloth with a 1:100 sliver seam");
        } else {
            println!("aspect 1:{aspect}: {r:?}");
        }
    }

    // a single triangle, one corner pinned: it swings and comes to rest hanging
    let positions = [[0.0f32, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]];
    let uvs = [[0.0f32, 0.0], [0.1, 0.0], [0.0, 0.1]];
    let triangles = [[0u32, 1, 2]];
    let cap = Capacity {
        vertices: 3,
        triangles: 1,
        edges: 3,
        colliders: 1,
        pins: 1,
    };
    let mut mem = memory(&cap);
    let def = ClothDef {
        positions: &positions,
        uvs: &uvs,
        triangles: &triangles,
        materials: &[0],
    };
    let mats = [anisotropic()];
    let damped = Settings {
        damping_mass: 1.0,
        ..Settings::default()
    };
    let mut w = World::new(&mut mem, cap, &def, Materials::Table(&mats), damped).unwrap();
    w.set_pin(0, positions[0]).unwrap();
    run(&mut w, 3000, |_, _| {});
    assert_settled(&w, 0.1, "single triangle");
    let c = (w.positions()[1] + w.positions()[2]) * 0.5;
    assert!(c.z < -0.05, "hangs below its pin: {c}");
}

#[test]
fn a_hundred_thousand_steps_of_a_hanging_cloth() {
    let sheet = hanging_sheet(8, 0.5);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    pin_top_corners(&mut w, &sheet);
    let first = run(&mut w, 10_000, |_, _| {});
    let settled: Vec<Vec3A> = w.positions().to_vec();
    let rest = run(&mut w, 90_000, |_, _| {});
    assert!(
        rest.peak_kinetic <= first.peak_kinetic,
        "energy grew: {first:?} then {rest:?}"
    );
    let drift = w
        .positions()
        .iter()
        .zip(&settled)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f32::max);
    assert!(
        drift < 1e-4,
        "rest shape drifted {drift} m over 90,000 steps"
    );
}

#[test]
fn extreme_scales_1_mm_and_100_m() {
    for scale in [1e-3f32, 100.0] {
        let toml = format!(
            r#"size = {}
pattern = ["HH..", "....", "HH..", "...."]
[materials."H"]
stiffness = 2000.0
poisson = 0.3
density = 0.2
[materials."."]
stiffness = 200.0
poisson = 0.3
density = 0.1
"#,
            0.01 * scale
        );
        let bytes = blob_of(&format!("scale{scale}"), &toml);
        let blob = Blob::parse(&bytes).unwrap();
        let sheet = hanging_sheet(13, scale);
        let mut mem = memory(&sheet.capacity());
        let settings = Settings {
            damping_mass: 1.0,
            ..Settings::default()
        };
        let mut w = World::new(
            &mut mem,
            sheet.capacity(),
            &sheet.def(),
            Materials::Blob(&blob),
            settings,
        )
        .unwrap();
        pin_top_corners(&mut w, &sheet);
        let r = run(&mut w, 3000, |_, _| {});
        assert!(
            r.peak_kinetic < energy_bound(&w, scale as f64),
            "scale {scale}: {r:?}"
        );
        assert_settled(&w, scale, &format!("scale {scale}"));
    }
}

/// Regression (found through the C examples): a sphere pushed head-on into a flat, vertically
/// hanging cloth. The first contact step's solve bottomed out at the f32 noise floor and the
/// PCG residual then diverged, throwing the cloth to ~1e7 m/s. The divergence guard stops it.
#[test]
fn a_sphere_pushed_into_a_flat_hanging_cloth() {
    let bytes = blob_of(
        "pushed",
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/cells/stripes.toml"))
            .unwrap(),
    );
    let blob = Blob::parse(&bytes).unwrap();
    let (cols, rows, width) = (10usize, 8usize, 0.45f32);
    let h = width / (cols - 1) as f32;
    let mut sheet = Sheet::grid(cols, rows, width, h * (rows - 1) as f32);
    sheet.transform(|p| [p[0], 0.0, 2.0 - (h * (rows - 1) as f32 - p[1])]);
    for substeps in [1, 2] {
        let mut mem = memory(&sheet.capacity());
        let settings = Settings {
            substeps,
            ..Settings::default()
        };
        let mut w = World::new(
            &mut mem,
            sheet.capacity(),
            &sheet.def(),
            Materials::Blob(&blob),
            settings,
        )
        .unwrap();
        for i in 0..cols {
            let k = sheet.index(i, rows - 1);
            w.set_pin(k, sheet.positions[k as usize]).unwrap();
        }
        let sphere = |y: f32| Shape::Sphere {
            center: Vec3A::new(0.2, y, 1.8),
            radius: 0.1,
        };
        w.add_collider(Collider::new(sphere(0.3), 0.4, 0.005))
            .unwrap();
        let r = run(&mut w, 120, |w, f| {
            let s = (f + 1) as f32 / 120.0;
            w.set_collider_shape(0, sphere(0.3 - 0.5 * s)).unwrap();
        });
        let fastest = top_speed(&w);
        // the sphere moves at 0.25 m/s; the cloth may be flicked, not launched
        assert!(
            fastest < 5.0,
            "substeps {substeps}: fastest {fastest} m/s, {r:?}"
        );
        for (k, p) in w.positions().iter().enumerate() {
            assert!(
                sphere(0.3 - 0.5).proximity(*p).distance > 0.005 - 1e-5,
                "vertex {k} inside the sphere"
            );
        }
    }
}

/// A laminate of contrast 1e6 (hard and soft layers, the paper's unit cell 1 at an extreme):
/// its C^H is anisotropic by ~5e5, the worst conditioning a bundled-style cell gives. In f32
/// the CG residual stalls at 1e-3..1e-2 of the right-hand side and then drifts (the attainable
/// accuracy, not the cap); the solve then restarts from the true residual (residual
/// replacement), which took the multigrid solves that converge from 151 to 934 of 1500 and
/// the cloth's fastest vertex after 1500 steps from 0.019 to 0.007 m/s. The creep itself came
/// mostly from the right-hand side: `K v` formed as `K_ii v_i + Σ_j K_ij v_j` left forces of
/// the stiff layers' f32 cancellation on a cloth at rest; from velocity differences
/// (`BlockMatrix::mul_stiffness`) the fastest vertex moves at 0.7 mm/s, not 7.3 (measured
/// 2026-11-27: 956 of 1500 converged, 118.8 iterations per step; block Jacobi 375, 165.4,
/// 1.6 mm/s, not 2.7). At this noise floor the order of the sums alone moves the creep ~4×
/// (0.17 / 1.3 mm/s with the scalar terms summed into the row's register). The rest is a
/// measured limit (README, "Limits"): at tolerance 1e-3, 227 of the multigrid's 1500 solves
/// and 690 of block Jacobi's end "not converged" (2026-11-28: 67.6 and 123.9 iterations per
/// step, 0.12 and 0.44 mm/s).
#[test]
fn a_laminate_of_contrast_1e6_keeps_converging() {
    let toml = r#"size = 0.01
pattern = ["HHHH", "....", "HHHH", "...."]
[materials."H"]
stiffness = 1.0e6
poisson = 0.3
density = 0.2
[materials."."]
stiffness = 1.0
poisson = 0.3
density = 0.2
"#;
    let bytes = blob_of("laminate1e6", toml);
    let blob = Blob::parse(&bytes).unwrap();
    let c = blob.cell(0).unwrap().stiffness;
    let ratio = c[0][0].max(c[1][1]) / c[0][0].min(c[1][1]);
    assert!(ratio > 1e5, "C^H {c:?}: anisotropy {ratio:e}");
    // 21×21: above the size where the world falls back from multigrid to block Jacobi.
    let sheet = hanging_sheet(21, 1.0);
    for solver in [
        weft::world::Solver::Multigrid,
        weft::world::Solver::BlockJacobi,
    ] {
        let mut mem = memory(&sheet.capacity());
        let mut w = hanging_from_blob(&mut mem, &sheet, &blob);
        w.set_solver(solver);
        let (mut solves, mut converged, mut iterations) = (0u32, 0u32, 0u64);
        for _ in 0..1500 {
            let s = w.step().unwrap();
            solves += 1;
            converged += s.converged as u32;
            iterations += u64::from(s.iterations);
        }
        let fastest = top_speed(&w);
        println!(
            "{solver:?}: {converged}/{solves} converged, {:.1} iterations per step, fastest \
             vertex {fastest} m/s",
            iterations as f64 / f64::from(solves)
        );
        assert!(fastest < 3e-3, "{solver:?}: fastest vertex {fastest} m/s");
        if solver == weft::world::Solver::Multigrid {
            assert!(2 * converged > solves, "{converged}/{solves} converged");
        }
    }
}

/// A step that gains energy at every substep count the balance tries is energy-limited, not
/// refused and not held still: a 1.6 cm cloth of 0.5 mm edges (a stiff fabric) kicked out of
/// its plane at up to 2 m/s moves ~20 edge lengths per step, which one linearized substep
/// turns into stretch (an unstressed flat membrane has no out-of-plane stiffness) and 8
/// substeps only shrink as h⁴ (an outside fuzzer's seed: 351 J from 6.6 µJ). Refusing kept
/// the kicked state, and every later step failed the same way; held still, the cloth went on
/// from rest, its kick lost. Energy-limited (`StepStats::limited`: each substep's free
/// velocity scaled until the substep ends with no more energy than it began with), the first
/// step keeps what of the kick goes downhill, and no step is held still. (Its solves' error
/// at the default tolerance adds to the gain: redone at 1e-4 and 1e-5, tighter than the redos
/// go, its last attempt gained 2.7e-4 J, which its kinetic energy covered. Since a free
/// cloth's solve is corrected on the translations (`step::system`), the fuzzer's kick of up
/// to 1 m/s balances after four redos, and smoothed along lines (`Solver::MultigridLines`)
/// its kick of 2 m/s at 4.8 ms balances too: the gain that remains is the solves' as much as
/// the membrane's. Kicked at up to 10 m/s in steps of 9.6 ms, ~100 edge lengths a step, it
/// cannot balance with either smoother, and that is the step tested.)
#[test]
fn a_step_that_cannot_balance_is_energy_limited_and_the_cloth_goes_on() {
    let sheet = Sheet::grid(34, 37, 0.0157, 0.0172);
    // a stiff anisotropic fabric (C12 ≠ 0, C11 = 4 C22)
    let k = 20000.0;
    let stiff = Material {
        stiffness: [
            [k, 0.1 * k, 0.0],
            [0.1 * k, 0.25 * k, 0.0],
            [0.0, 0.0, k / 12.0],
        ],
        density: 0.15,
        bending: 1e-4,
    };
    let mats = [stiff];
    for solver in [Solver::Multigrid, Solver::MultigridLines] {
        let mut mem = memory(&sheet.capacity());
        let settings = Settings {
            time_step: 0.0096,
            damping_stiffness: 0.03,
            ..Settings::default()
        };
        let mut w = world(&mut mem, &sheet, &mats, settings);
        w.set_solver(solver);
        let mut kick = uniform(5041);
        let v: Vec<[f32; 3]> = (0..sheet.positions.len())
            .map(|_| [10.0 * kick(), 10.0 * kick(), 10.0 * kick()])
            .collect();
        w.set_velocities(&v).unwrap();
        let (mut limited, mut stopped) = (0, 0);
        let start = w.energy().total();
        for step in 0..60 {
            let s = w
                .step()
                .unwrap_or_else(|e| panic!("{solver:?}, step {step}: {e:?}"));
            limited += usize::from(s.limited);
            stopped += usize::from(s.stopped);
            assert!(!s.limited || s.energy_removed > 0.0, "step {step}: {s:?}");
            // (gravity's potential included: only the balance's round-off above the start)
            let e = w.energy().total();
            assert!(e <= 1.01 * start, "step {step}: {start} J -> {e} J ({s:?})");
        }
        assert!(limited >= 1, "{solver:?}: no step had to be energy-limited");
        assert_eq!(stopped, 0, "{solver:?}: a step was held still");
        assert!(
            top_speed(&w) > 0.01,
            "{solver:?}: the cloth does not go on after its limited step"
        );
    }
}

/// A small cloth gets the multilevel solver too. Its pools borrow the world's own arrays,
/// which below a few hundred vertices used to be too short for a hierarchy's fixed part, so
/// such meshes fell back to block Jacobi; on a stiff strip of 45:1 triangles (what an outside
/// fuzzer drew: 4 × 33 vertices over 0.68 × 0.16 m, C^H up to 32 kN/m) that stopped at the
/// iteration cap in most steps (here, hanging: in 7 of 120 steps).
#[test]
fn a_small_stiff_strip_of_slivers_gets_a_hierarchy_and_converges() {
    for (nx, ny) in [(3, 3), (5, 5), (4, 33), (11, 11)] {
        let sheet = Sheet::grid(nx, ny, 0.2, 0.2);
        let mats = [anisotropic()];
        let mut mem = memory(&sheet.capacity());
        let w = world(&mut mem, &sheet, &mats, Settings::default());
        let levels = w.multigrid_info().map_or(0, |i| i.levels);
        assert!(levels >= 2, "{nx}x{ny}: {levels} levels");
    }
    let mut sheet = Sheet::grid(4, 33, 0.68, 0.16);
    sheet.transform(|p| [p[0], 0.0, p[1]]);
    let stiff = Material {
        stiffness: [
            [31960.0, 3498.0, 0.0],
            [3498.0, 8300.0, 0.0],
            [0.0, 0.0, 2401.0],
        ],
        density: 0.2,
        bending: 1e-4,
    };
    let mats = [stiff];
    // (iterations, unconverged steps) of 120 steps hanging from two corners
    let hang = |solver: Solver| {
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, Settings::default());
        w.set_solver(solver);
        pin_top_corners(&mut w, &sheet);
        let (mut iterations, mut unconverged) = (0, 0);
        for _ in 0..120 {
            let s = w.step().unwrap();
            iterations += s.iterations;
            unconverged += u32::from(!s.converged);
        }
        (iterations, unconverged)
    };
    let (multigrid, jacobi) = (hang(Solver::Multigrid), hang(Solver::BlockJacobi));
    // measured: 6,596 iterations and 1 capped step against 14,406 and 7
    assert!(
        3 * multigrid.0 < 2 * jacobi.0 && multigrid.1 < jacobi.1,
        "multigrid {multigrid:?}, block Jacobi {jacobi:?} (iterations, capped steps)"
    );
}

/// A step whose block-Jacobi solves did not converge and that gained energy is redone with
/// the multilevel preconditioner. A very stiff fabric (C^H₁₁ = 7.4e5 N/m) on a crumpled strip
/// of 11:1 slivers, kicked at 0.5 m/s into a bowl: block Jacobi breaks down in `f32` long
/// before its cap (the residual grows), and every redo at more substeps gained again. An
/// outside fuzzer's cloth like this was held still for 138 steps in a row, and moved again
/// only when the scene switched to the multilevel solver.
#[test]
fn block_jacobi_that_cannot_converge_does_not_freeze_the_cloth() {
    let (stopped, worst, unconverged) = stiff_strip_in_a_bowl(5203);
    // measured: 7 steps held still, never two in a row (the multilevel solver alone: 4);
    // before, 90 in a row from step 30 on
    assert!(
        worst <= 2 && stopped <= 15,
        "held still {stopped} steps, {worst} in a row ({unconverged} unconverged)"
    );
    assert!(
        unconverged > 0,
        "block Jacobi converged: the case is not exercised"
    );
}

/// A step that gains energy at 8× its substeps, but less at every doubling, is redone with
/// more (up to 32×) instead of holding the cloth still. The stiff strip of
/// [`stiff_strip_in_a_bowl`], kicked by other random velocities: at rest in the bowl, a step
/// from rest gained 8.9e-4 J at 4× and 7.8e-5 J at 8×, held the cloth still, and the next step
/// started from the same state, at every later call. Measured over kick seeds 1–30: 7 froze so
/// (held 26–52 steps in a row); with the further redos 3 (see `monitor::converging`).
#[test]
fn a_step_whose_gain_shrinks_is_redone_until_it_balances() {
    // measured: 0 / 0 held; before, 51 (48 in a row) and 54 (51)
    assert_held_at_most(&[9, 14], 15, 2);
}

/// A free vertex that the solve itself drives a little way into a still collider is held in
/// that substep, not left to the projection. The stiff strip of [`stiff_strip_in_a_bowl`] at
/// rest in its bowl: contacts were predicted from the velocity at the substep's start, so a
/// vertex beside the bowl that the membrane pushed into it ended inside, and the projection
/// moved it back against its neighbours, making stretch (up to 2.5e-2 J in a substep) that
/// more substeps did not shrink; the cloth was held still at its start and the next step
/// started from the same state. Measured over kick seeds 1–30: 170 steps held still and one
/// seed frozen (seed 20, 50 in a row); with the engaged contacts 9, none more than one in a
/// row (see `contacts::engage`).
#[test]
fn a_vertex_the_solve_drives_into_the_bowl_is_held_not_projected() {
    // measured: 0 / 0 held; before, 52 (50 in a row) and 12 (1)
    assert_held_at_most(&[20, 24], 2, 1);
}

/// [`stiff_strip_in_a_bowl`] for each kick seed holds the cloth still at most `steps` steps,
/// at most `in_a_row` of them in a row.
fn assert_held_at_most(seeds: &[u64], steps: u32, in_a_row: u32) {
    for &seed in seeds {
        let (stopped, worst, unconverged) = stiff_strip_in_a_bowl(seed);
        assert!(
            worst <= in_a_row && stopped <= steps,
            "seed {seed}: held still {stopped} steps, {worst} in a row ({unconverged} unconverged)"
        );
    }
}

/// A very stiff fabric on a crumpled strip of slivers, kicked (random velocities from `seed`)
/// into a bowl with block Jacobi, 120 steps: returns the steps held still, the most in a row
/// and the steps whose solves did not converge.
fn stiff_strip_in_a_bowl(seed: u64) -> (u32, u32, u32) {
    let mut sheet = Sheet::grid(27, 4, 0.34, 0.44);
    sheet.transform(|p| {
        let z = 0.044 * (7.0 * p[0] / 0.44).sin() * (5.0 * p[1] / 0.44).cos();
        [p[0], p[1], z]
    });
    let stiff = Material {
        stiffness: [
            [735_876.0, 2800.0, 0.0],
            [2800.0, 83_765.0, 0.0],
            [0.0, 0.0, 40_482.0],
        ],
        density: 0.13,
        bending: 2e-6,
    };
    let mats = [stiff];
    let settings = Settings {
        time_step: 0.0333,
        substeps: 3,
        tolerance: 2e-4,
        max_iterations: 1000,
        ..Settings::default()
    };
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, settings);
    w.set_solver(Solver::BlockJacobi);
    let bowl = Shape::Shell {
        center: Vec3A::new(0.124, 0.219, -0.065),
        radius: 0.301,
    };
    w.add_collider(Collider::new(bowl, 0.3, 8e-5)).unwrap();
    w.set_pin(27, sheet.positions[27]).unwrap();
    let mut kick = uniform(seed);
    let v: Vec<[f32; 3]> = (0..sheet.positions.len())
        .map(|_| [0.5 * kick(), 0.5 * kick(), 0.5 * kick()])
        .collect();
    w.set_velocities(&v).unwrap();
    let (mut stopped, mut in_a_row, mut unconverged, mut worst) = (0, 0, 0, 0);
    for step in 0..120 {
        if step == 29 {
            w.remove_pin(27).unwrap();
        }
        let s = w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        stopped += u32::from(s.stopped);
        unconverged += u32::from(!s.converged);
        in_a_row = if s.stopped { in_a_row + 1 } else { 0 };
        worst = worst.max(in_a_row);
    }
    (stopped, worst, unconverged)
}

/// A vertex resting on a collider's surface is a contact, also where the contact slop has
/// nothing to add: a thickness of zero and no gravity. The projection puts a vertex on the
/// surface only to within rounding, and the slop was zero there, so a resting vertex a
/// rounding above it (or exactly on it: the test was `≥`) was not held; when a pin pulled the
/// cloth through the surface (an engine's hand through the table), the next solve drew the
/// pin's neighbours into the collider and the projection put them back by position against
/// the stretched edges to the pin: energy that no substep count shrinks. Measured before the
/// rounding was in the slop: a floor 13 steps held still (8 in a row), a shell 38 (30 in a
/// row); now none. (Adversarial scene 5202, a line pin running out through a shell: 119
/// steps held still, 73 in a row; now none.)
#[test]
fn a_vertex_on_a_surface_of_zero_thickness_without_gravity_is_a_contact() {
    for shell in [false, true] {
        let mut sheet = Sheet::grid(15, 15, 0.5, 0.5);
        let radius = 10.0f32;
        let centre = Vec3A::new(0.25, 0.25, radius);
        let shape = if shell {
            // the sheet lies on the inside of the shell's bottom
            sheet.transform(|[x, y, _]| {
                let r2 = (x - centre.x).powi(2) + (y - centre.y).powi(2);
                [x, y, radius - (radius * radius - r2).sqrt()]
            });
            Shape::Shell {
                center: centre,
                radius,
            }
        } else {
            Shape::Plane {
                normal: Vec3A::Z,
                offset: 0.0,
            }
        };
        let mats = [anisotropic()];
        let mut mem = memory(&sheet.capacity());
        let settings = Settings {
            effects: effects::ALL & !effects::GRAVITY,
            ..Settings::default()
        };
        let mut w = world(&mut mem, &sheet, &mats, settings);
        w.add_collider(Collider::new(shape, 0.3, 0.0)).unwrap();
        let corner = sheet.index(0, 0);
        let start = Vec3A::from(sheet.positions[corner as usize]);
        let (mut held, mut in_a_row, mut worst) = (0, 0, 0);
        for frame in 0..60 {
            // down through the surface at 1 m/s for 10 frames, then still
            let depth = frame.min(10) as f32 / 60.0;
            w.set_pin(corner, (start - Vec3A::Z * depth).into())
                .unwrap();
            let s = w.step().unwrap();
            held += u32::from(s.stopped);
            in_a_row = if s.stopped { in_a_row + 1 } else { 0 };
            worst = worst.max(in_a_row);
        }
        assert!(
            held <= 1,
            "shell {shell}: held still {held} steps, {worst} in a row"
        );
    }
}

/// A contact that pushes a vertex out of a collider against the cloth's tension puts in the
/// whole work of that push. A 15×15 sheet stretched 10 % and pinned along its rim, gravity off,
/// pitched like a tent 3 cm high at its centre (its tension pulls the centre down): a still
/// sphere appears under the centre, its top 6 cm up, so the vertices inside it are pushed out
/// from rest at `max_depenetration_speed` against that pull. The balance credited such a push
/// at the vertices' mean velocity over the substep, half its work from rest, and the step
/// gained the other half (adversarial seed 5161: a cloth crammed into a moving shell).
#[test]
fn a_push_against_the_cloths_tension_is_credited_in_full() {
    let n = 15;
    let mut sheet = Sheet::grid(n, n, 1.0, 1.0);
    let centre = Vec3A::new(0.55, 0.55, 0.0);
    sheet.transform(|p| {
        let q = Vec3A::new(p[0] * 1.1, p[1] * 1.1, 0.0);
        let r = (q - centre).length();
        [q.x, q.y, 0.03 * (1.0 - r / 0.4).max(0.0)]
    });
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: Settings::default().effects & !effects::GRAVITY,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    for j in 0..n {
        for i in 0..n {
            if i == 0 || j == 0 || i == n - 1 || j == n - 1 {
                let k = sheet.index(i, j);
                w.set_pin(k, sheet.positions[k as usize]).unwrap();
            }
        }
    }
    let sphere = Shape::Sphere {
        center: centre - Vec3A::new(0.0, 0.0, 0.24),
        radius: 0.3,
    };
    w.add_collider(Collider::new(sphere, 0.0, 0.002)).unwrap();
    let before = w.energy();
    let s = w.step().unwrap();
    let after = w.energy();
    println!(
        "elastic {} -> {} J, gain {} J, redone {}",
        before.elastic, after.elastic, s.energy_gain, s.redone
    );
    assert!(
        after.elastic > before.elastic + 1e-4,
        "the push did no work against the tension: elastic {} -> {} J",
        before.elastic,
        after.elastic
    );
    assert!(
        s.energy_gain <= 0.0 && s.redone == 0,
        "the push's work was not all credited: gain {} J, redone {}",
        s.energy_gain,
        s.redone
    );
}

/// A push in the cloth's own plane is credited what the implicit step puts in, no less. For
/// linear forces implicit Euler keeps `E₁ − E₀ = J·v₁ − ½ Δvᵀ M Δv − ½ Δxᵀ K Δx`: the
/// constraint impulse at the end velocity, less the step's dissipation. A flat 15×15 sheet
/// at rest (gravity and damping off), its edge column cut by a still plane that appears
/// 4 or 12 mm into it: those vertices are pushed out from rest within one substep, in the
/// plane (no out-of-plane stretch the linearized step cannot see: there it is close to
/// linear, within 1.4 % at 17 % strain). The balance's gain must then be the free motion's
/// dissipation, which from rest is what the step leaves: `−(KE_free + elastic + bending)`,
/// with `KE_free` all kinetic energy but the pushed vertices' along the plane's normal. The
/// push's load was credited by the trapezoid rule between the start's (none here) and the
/// end's: half the load's part, and the balance read −2e-6 J where the step had −3.2e-3 J in
/// hand, so any harder push was a gain to redo. Across the stiff axis and the soft one.
#[test]
fn a_push_in_the_plane_is_credited_what_the_implicit_step_puts_in() {
    for normal in [Vec3A::X, Vec3A::Y] {
        for depth in [0.004f32, 0.012] {
            let sheet = Sheet::grid(15, 15, 1.0, 1.0);
            let mats = [anisotropic()];
            let mut mem = memory(&sheet.capacity());
            let settings = Settings {
                effects: effects::WARPING | effects::COLLISION | effects::BENDING,
                ..Settings::default()
            };
            let mut w = world(&mut mem, &sheet, &mats, settings);
            let plane = Shape::Plane {
                normal,
                offset: depth,
            };
            w.add_collider(Collider::new(plane, 0.0, 0.0)).unwrap();
            let inside: Vec<usize> = (0..sheet.positions.len())
                .filter(|&i| Vec3A::from(sheet.positions[i]).dot(normal) < depth)
                .collect();
            let s = w.step().unwrap();
            let after = w.energy();
            let (m, v) = (w.masses(), w.velocities());
            let held: f64 = inside
                .iter()
                .map(|&i| 0.5 * f64::from(m[i]) * f64::from(v[i].dot(normal)).powi(2))
                .sum();
            let dissipated = after.kinetic - held + after.elastic + after.bending;
            let gain = f64::from(s.energy_gain);
            println!(
                "normal {normal}, {depth} m: {} vertices pushed, gain {gain:e} J, dissipation \
                 {dissipated:e} J",
                inside.len()
            );
            assert!(
                inside.len() == 15 && held > 0.0,
                "the plane did not push the edge"
            );
            assert!(
                (gain + dissipated).abs() <= 0.02 * dissipated,
                "normal {normal}, depth {depth}: the balance read {gain:e} J where the step \
                 dissipated {dissipated:e} J"
            );
        }
    }
}

/// A step held still leaves its cloth out of the colliders, as every accepted substep does,
/// so the next step does not start from the state that failed. A stiff anisotropic strip
/// (120 kN/m along it), gravity off, at rest through a still sphere the engine put under it,
/// pinned at one end and at a vertex 7 cm inside the sphere (the pin wins: the sphere pushes
/// that vertex's neighbours out around it at up to 40 m/s): the linearized step cannot take
/// that stretch at any substep count it tries, and the balance holds the strip still. The
/// hold kept the vertices inside, from where the next step gained the same and was held
/// again: 60 of 60 steps (adversarial scene 16049: all 300 of its steps). Put out, the strip
/// goes on from there, its energy falling from what the hold left, and comes to rest. (At
/// rest, before `contacts::engage` held the vertices that only the contacts of the edges to
/// the pin held, the solve carried them into the sphere and the projection put them back,
/// +9 J in a step, and the strip was held still at every step from the 17th on.)
#[test]
fn a_cloth_held_still_inside_a_collider_is_put_out_of_it_and_goes_on() {
    let center = Vec3A::new(0.25, 0.05, -0.1);
    let sphere = Shape::Sphere {
        center,
        radius: 0.2,
    };
    let (held, worst) = strip_pinned_inside(8, 2, sphere, 0.3, 0.0);
    assert!(held <= 1, "held still {held} steps, {worst} in a row");
}

/// A vertex held by the contacts of the edges around it and caught by its own contact
/// (`contacts::engage`) is held along its own normal, and the edges' contacts ride on it: the
/// other way round its own contact rode on an edge's axis a few degrees off its normal, the
/// solve slid it along that axis's plane into the sphere, and the projection put it back
/// against the whole tension, a gain at every substep count. The strip of the test above,
/// pinned at its border 4 cm inside a 10 cm sphere of friction 1: the pin's neighbour on the
/// border (index (5, 0)) had its own contact ride 5–8° off at every attempt, and the strip was
/// held still at every step from the 8th on (adversarial scene 16049 froze so after a move of
/// its origin: 211 steps in a row).
#[test]
fn a_strip_resting_on_a_sphere_beside_a_pin_inside_it_is_not_held_still() {
    let sheet = Sheet::grid(24, 6, 0.5, 0.1);
    let pinned = Vec3A::from(sheet.positions[sheet.index(4, 0) as usize]);
    let radius = 0.1;
    let sphere = Shape::Sphere {
        center: pinned - Vec3A::new(0.0, 0.0, radius - 0.04),
        radius,
    };
    let (held, worst) = strip_pinned_inside(4, 0, sphere, 1.0, 1e-4);
    assert!(
        held <= 2 && worst <= 1,
        "held still {held} steps, {worst} in a row"
    );
}

/// A stiff anisotropic strip (24 × 6 vertices, 0.5 m × 0.1 m, 120 kN/m along it), gravity
/// off, at rest through a still `sphere` the engine put under it, pinned at one end and at
/// vertex `(i, j)` inside the sphere (the pin wins: the sphere pushes that vertex's neighbours
/// out around it at up to 40 m/s). Steps it 60 times, asserting that no free vertex is inside
/// the sphere after any step and that the energy never rises after the first (whose start
/// inside the sphere is input). Returns the steps held still, and the most in a row.
fn strip_pinned_inside(
    i: usize,
    j: usize,
    sphere: Shape,
    friction: f32,
    thickness: f32,
) -> (u32, u32) {
    let sheet = Sheet::grid(24, 6, 0.5, 0.1);
    let stiff = Material {
        stiffness: [[1.2e5, 2e4, 0.0], [2e4, 3e4, 0.0], [0.0, 0.0, 2e4]],
        density: 0.8,
        bending: 0.0,
    };
    let mats = [stiff];
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::ALL & !(effects::GRAVITY | effects::SLEEP),
        time_step: 0.0668,
        max_depenetration_speed: 40.0,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let (a, b) = (sheet.index(0, 2), sheet.index(i, j));
    w.set_pin(a, sheet.positions[a as usize]).unwrap();
    w.set_pin(b, sheet.positions[b as usize]).unwrap();
    w.add_collider(Collider::new(sphere, friction, thickness))
        .unwrap();
    let (mut held, mut in_a_row, mut worst) = (0, 0, 0);
    let mut previous = f64::INFINITY;
    for step in 0..60 {
        let s = w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        let e = w.energy().total();
        assert!(
            e <= previous * 1.0001,
            "step {step}: {previous} J -> {e} J ({s:?})"
        );
        previous = e;
        held += u32::from(s.stopped);
        in_a_row = if s.stopped { in_a_row + 1 } else { 0 };
        worst = worst.max(in_a_row);
        let deepest = w
            .positions()
            .iter()
            .enumerate()
            .filter(|&(k, _)| k != b as usize)
            .map(|(_, &x)| sphere.proximity(x).distance - thickness)
            .fold(f32::INFINITY, f32::min);
        assert!(
            deepest > -1e-5,
            "step {step}: a vertex {deepest} m inside ({s:?})"
        );
    }
    (held, worst)
}

/// Where the linearized step overshoots at every substep count, the step goes on energy-
/// limited instead of holding the cloth still (`StepStats::limited`). The strip of the tests
/// above, pinned 2–7 cm inside a 10 cm sphere: the sphere pushes the pin's neighbours out
/// around it, the elements there are squeezed and stretched to Green strains of 2–3, and on
/// that non-convex energy the one Newton step of a substep raised the energy from rest at 1
/// to 8 substeps alike, so the balance held the strip still at most steps while it crept
/// toward rest: 41 of 60 steps (38 in a row) pinned at (3, 3) on a sphere of friction 1, 44
/// (35) at (16, 0) and 42 (31) at (6, 5) on frictionless ones. Each held step also cost all
/// its redos, ~10× a step.
#[test]
fn a_strip_squeezed_around_a_pin_inside_a_sphere_is_not_held_still() {
    let sheet = Sheet::grid(24, 6, 0.5, 0.1);
    for (i, j, depth, friction) in [(3, 3, 0.02, 1.0), (16, 0, 0.07, 0.0), (6, 5, 0.07, 0.0)] {
        let pinned = Vec3A::from(sheet.positions[sheet.index(i, j) as usize]);
        let sphere = Shape::Sphere {
            center: pinned - Vec3A::new(0.0, 0.0, 0.1 - depth),
            radius: 0.1,
        };
        let (held, worst) = strip_pinned_inside(i, j, sphere, friction, 1e-4);
        // (the first step starts with the pin's neighbours inside: it may be held)
        assert!(
            held <= 2 && worst <= 1,
            "pinned at ({i}, {j}), {depth} m deep, friction {friction}: held still {held} \
             steps, {worst} in a row"
        );
    }
}
