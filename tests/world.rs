//! The runtime's specification (issue: the coarse cloth step): patch tests, rigid motion,
//! momentum, anisotropic stretch, settling, contact, determinism and every error path.

mod common;

use common::*;
use glam::{Quat, Vec3A};
use weft::collide::{Collider, Shape};
use weft::mesh::MeshError;
use weft::strided::Strided;
use weft::world::{
    effects, Capacity, ClothDef, InitError, Material, Materials, PinAxes, Settings, Solver,
    StepError, StridedClothDef, TriangleMaterials, World,
};

fn no_warp() -> Settings {
    Settings {
        effects: 0,
        ..Settings::default()
    }
}

/// Uniform strain of a homogenized sheet: interior nodes feel no force and the boundary
/// forces integrate the C^H stress exactly (linear FEM patch test).
#[test]
fn patch_test_uniform_strain_reproduces_stress() {
    let mat = [anisotropic()];
    let (e1, e2, g) = (0.01f32, -0.004f32, 0.003f32);
    let (w_, h_) = (1.0f32, 0.75f32);
    let mut sheet = Sheet::grid(9, 7, w_, h_);
    sheet.transform(|p| [p[0] * (1.0 + e1) + g * p[1], p[1] * (1.0 + e2), 0.0]);
    for settings in [no_warp(), settings_quiet()] {
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mat, settings);
        let mut f = vec![Vec3A::ZERO; w.vertex_count()];
        assert!(w.elastic_forces(&mut f));
        let c = mat[0].stiffness;
        let e = [e1 as f64, e2 as f64, g as f64];
        let s: [f64; 3] =
            core::array::from_fn(|i| c[i][0] * e[0] + c[i][1] * e[1] + c[i][2] * e[2]);
        let scale = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        // warping: boundary rings are not symmetric, so R is only close to I there
        let tol = if settings.effects & effects::WARPING != 0 {
            2e-2
        } else {
            1e-4
        };
        for j in 1..sheet.ny - 1 {
            for i in 1..sheet.nx - 1 {
                let fi = f[sheet.index(i, j) as usize];
                assert!(
                    (fi.length() as f64) < tol * scale * 0.2,
                    "interior force {fi}"
                );
            }
        }
        // the external force holding the right edge is -f; it integrates (s11, s12)·height
        let right: Vec3A = (0..sheet.ny)
            .map(|j| -f[sheet.index(sheet.nx - 1, j) as usize])
            .sum();
        let top: Vec3A = (0..sheet.nx)
            .map(|i| -f[sheet.index(i, sheet.ny - 1) as usize])
            .sum();
        let hh = h_ as f64 * (1.0 + e2 as f64);
        let ww = w_ as f64;
        assert!(
            ((right.x as f64) - s[0] * h_ as f64).abs() < tol * scale * hh,
            "{right} vs {s:?}"
        );
        assert!(
            ((right.y as f64) - s[2] * h_ as f64).abs() < tol * scale * hh,
            "{right} vs {s:?}"
        );
        assert!(
            ((top.y as f64) - s[1] * ww).abs() < tol * scale * ww,
            "{top} vs {s:?}"
        );
        assert!(
            ((top.x as f64) - s[2] * ww).abs() < tol * scale * ww,
            "{top} vs {s:?}"
        );
    }
}

/// Rigid rotation (including turning the sheet upside down) and translation: zero force.
#[test]
fn rigid_motion_gives_zero_elastic_force() {
    let mat = [anisotropic()];
    let rotations = [
        Quat::IDENTITY,
        Quat::from_axis_angle(glam::Vec3::new(1.0, 2.0, 3.0).normalize(), 1.1),
        Quat::from_rotation_x(core::f32::consts::PI),
        Quat::from_rotation_y(core::f32::consts::FRAC_PI_2),
        Quat::from_axis_angle(glam::Vec3::new(-0.3, 0.2, 1.0).normalize(), 2.9),
    ];
    // force scale: a 1% stretch of this sheet
    let mut stretched = Sheet::grid(11, 11, 1.0, 1.0);
    stretched.transform(|p| [p[0] * 1.01, p[1], p[2]]);
    let mut mem = memory(&stretched.capacity());
    let mut w = world(&mut mem, &stretched, &mat, settings_quiet());
    let mut f = vec![Vec3A::ZERO; w.vertex_count()];
    w.elastic_forces(&mut f);
    let scale = f.iter().map(|v| v.length()).fold(0.0, f32::max);
    assert!(scale > 0.0);
    for q in rotations {
        let mut sheet = Sheet::grid(11, 11, 1.0, 1.0);
        let t = Vec3A::new(3.0, -2.0, 7.5);
        sheet.transform(|p| (q * glam::Vec3::from(p) + glam::Vec3::from(t)).into());
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mat, settings_quiet());
        w.elastic_forces(&mut f);
        let worst = f.iter().map(|v| v.length()).fold(0.0, f32::max);
        // f32 positions 7.5 m from the origin resolve 0.5 µm: on 0.1 m edges that is a strain
        // noise of ~5e-6, i.e. ~5e-4 of the 1% stretch's force. Anything structural (a wrong
        // frame, a missing rotation) is orders of magnitude above this.
        assert!(
            worst < 1e-3 * scale,
            "rotation {q}: |f| = {worst} vs 1% stretch {scale}"
        );
    }
}

/// What a stiff anisotropic 21×21 cloth at rest shape, set moving as a whole at `v0` with no
/// input and no damping, did over 300 steps.
struct Coasting {
    /// The largest distance of a vertex's velocity from the mean (m/s).
    spread: f32,
    iterations_per_step: f64,
    /// The largest local coordinate of a vertex after a step (m).
    farthest_local: f32,
    /// The distance of vertex 0 from the caller's zero at the end (m).
    travelled: f64,
}

impl Coasting {
    /// Every vertex kept the common velocity (within 5 mm/s), at the cost of a cloth at rest.
    fn assert_whole(&self) {
        assert!(self.spread < 5e-3, "vertices {} m/s apart", self.spread);
        let per_step = self.iterations_per_step;
        assert!(per_step < 20.0, "{per_step} CG iterations per step");
    }
}

fn coast(v0: Vec3A) -> Coasting {
    coast_at(v0, Settings::DEFAULT_TOLERANCE)
}

/// [`coast`] with the CG at `tolerance`.
fn coast_at(v0: Vec3A, tolerance: f32) -> Coasting {
    let mats = [Material {
        stiffness: [[2e4, 3e3, 0.0], [3e3, 5e3, 0.0], [0.0, 0.0, 4e3]],
        density: 0.05,
        bending: 1e-3,
    }];
    let sheet = Sheet::grid(21, 21, 0.5, 0.5);
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::BENDING,
        tolerance,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    w.set_velocities(&vec![v0.to_array(); w.vertex_count()])
        .unwrap();
    let (mut spread, mut iterations, mut farthest_local) = (0.0f32, 0, 0.0f32);
    let steps = 300;
    for _ in 0..steps {
        iterations += w.step().unwrap().iterations;
        let v = w.velocities();
        let mean = v.iter().copied().sum::<Vec3A>() / v.len() as f32;
        spread = v
            .iter()
            .map(|vi| (*vi - mean).length())
            .fold(spread, f32::max);
        farthest_local = w
            .positions()
            .iter()
            .map(|x| x.abs().max_element())
            .fold(farthest_local, f32::max);
    }
    Coasting {
        spread,
        iterations_per_step: f64::from(iterations) / f64::from(steps),
        farthest_local,
        travelled: (w.origin() + w.positions()[0].as_dvec3()).length(),
    }
}

/// A stiff anisotropic cloth at rest shape moving as a whole at 9 m/s, no input and no
/// damping: it stays whole (every vertex keeps the common velocity) and costs what a cloth at
/// rest costs. The step's `K v` used to be formed as `K_ii v_i + Σ_j K_ij v_j`, whose f32
/// cancellation at 9 m/s made spurious elastic forces: vertices drifted 0.19 m/s apart and CG
/// took 58 iterations per step. From velocity differences (`BlockMatrix::mul_stiffness`):
/// 7e-4 m/s (the resolution of positions 45 m from the origin) and 11 iterations.
#[test]
fn a_cloth_moving_as_a_whole_stays_whole() {
    let c = coast(Vec3A::new(7.0, -3.0, 5.0));
    c.assert_whole();
}

/// The same cloth sent 2 km away at 400 m/s: the world's origin follows it (a step moves it
/// once the cloth is more than `ORIGIN_GRID`, 4 m, from local zero), so its positions keep the
/// resolution they have at home: 3e-5 m/s apart (1.5e-3 with the 64 m grid of before, where
/// the cloth could be 64 m from local zero). With the origin left where the cloth was created,
/// positions 2 km away resolve 1.2e-4 m, a 2.5 cm edge's strain 5e-3, and that noise became
/// elastic forces: 1.2e-2 m/s apart.
#[test]
fn a_cloth_that_travels_far_keeps_its_precision() {
    let c = coast(Vec3A::new(320.0, -120.0, 200.0));
    assert!(c.travelled > 1900.0, "{} m", c.travelled);
    // (the centre within the grid of local zero after each step, the cloth 0.5 m wide)
    assert!(
        c.farthest_local < weft::world::ORIGIN_GRID as f32 + 0.5,
        "{} m from local zero",
        c.farthest_local
    );
    c.assert_whole();
}

/// The same at tolerance 1e-2: the solves' error in the cloth's rigid rotations drove its
/// vertices apart (5.1e-3 m/s, against 1.5e-3 at the default) until each free solve was also
/// corrected on its rotations (`system::correct_rigid`).
#[test]
fn a_cloth_that_travels_far_at_a_loose_tolerance_stays_whole() {
    let c = coast_at(Vec3A::new(320.0, -120.0, 200.0), 1e-2);
    println!("{} m/s apart", c.spread);
    c.assert_whole();
}

/// A free anisotropic cloth tumbling and vibrating for 200 steps with no external force and no
/// damping, solved at `tolerance`: how far its linear momentum moved, and the scale it is
/// measured against (`Σ m |v|` at the start).
fn free_cloth_momentum_drift(tolerance: f32, max_iterations: u32, solver: Solver) -> (f64, f64) {
    let mat = [anisotropic()];
    let mut sheet = Sheet::grid(9, 9, 1.0, 1.0);
    // a deformed initial state
    sheet.transform(|p| {
        [
            p[0] * 1.05,
            p[1] * 0.97 + 0.02 * p[0],
            0.1 * (p[0] * 3.0).sin(),
        ]
    });
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::BENDING,
        tolerance,
        max_iterations,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mat, settings);
    w.set_solver(solver);
    // spin about z plus drift
    let v: Vec<[f32; 3]> = sheet
        .positions
        .iter()
        .map(|p| [0.3 - 0.8 * (p[1] - 0.5), 0.1 + 0.8 * (p[0] - 0.5), 0.2])
        .collect();
    w.set_velocities(&v).unwrap();
    let momentum = |w: &World<'_>| -> glam::DVec3 {
        w.velocities()
            .iter()
            .zip(w.masses())
            .map(|(v, &m)| glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64) * m as f64)
            .sum()
    };
    let scale: f64 = w
        .velocities()
        .iter()
        .zip(w.masses())
        .map(|(v, &m)| v.length() as f64 * m as f64)
        .sum();
    let p0 = momentum(&w);
    for _ in 0..200 {
        let s = w.step().unwrap();
        assert!(s.converged);
    }
    ((momentum(&w) - p0).length(), scale)
}

/// No external force, no damping: total linear momentum stays put while the cloth tumbles and
/// vibrates.
#[test]
fn free_cloth_conserves_momentum() {
    let (drift, scale) = free_cloth_momentum_drift(1e-6, 500, Solver::Multigrid);
    assert!(drift < 1e-3 * scale, "momentum drift {drift} of {scale}");
}

/// The same at the default and at a loose tolerance: a solve stopped early errs in the rigid
/// modes too, and nothing but air damping would take that drift out again; the step corrects
/// its solve on them (`step::system`), so the momentum holds to round-off whatever the
/// tolerance (before: 1.1e-3 and 4e-3 of the scale in 200 steps at 1e-3 and 1e-2).
#[test]
fn free_cloth_conserves_momentum_at_any_tolerance() {
    for solver in [
        Solver::Multigrid,
        Solver::MultigridLines,
        Solver::BlockJacobi,
    ] {
        for tolerance in [Settings::DEFAULT_TOLERANCE, 1e-2, 1e-1] {
            let (drift, scale) = free_cloth_momentum_drift(tolerance, 200, solver);
            assert!(
                drift < 2e-5 * scale,
                "{solver:?} at {tolerance}: momentum drift {drift} of {scale}"
            );
        }
    }
}

/// Hang a strip from its top edge under gravity: its elongation is ρ g L² / (2 C⁻¹₁₁-direction)
/// of the material, along u and along v, and the two differ as the stiffness says.
/// The elongation of a strip of length `l` hanging under its own weight `w` (N/m² of rest area)
/// with uniaxial compliance `s11` (m/N), for the Green-strain membrane: at distance `t` from the
/// free end the tension is `T = w t` (per rest width), the second Piola–Kirchhoff stress
/// `Σ = T / λ`, the Green strain `E = s11 Σ` and the stretch `λ = sqrt(1 + 2E)`; the elongation
/// is `∫ (λ − 1) dt` (Simpson). At small strain it is linear FEM's `w l² s11 / 2`.
fn hanging_strip_elongation(w: f64, l: f64, s11: f64) -> f64 {
    let stretch = |t: f64| {
        let mut lambda = 1.0f64;
        for _ in 0..100 {
            lambda = (1.0 + 2.0 * s11 * w * t / lambda).sqrt();
        }
        lambda
    };
    let k = 400;
    let h = l / k as f64;
    (0..=k)
        .map(|i| {
            let weight = if i == 0 || i == k {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            weight * (stretch(i as f64 * h) - 1.0)
        })
        .sum::<f64>()
        * h
        / 3.0
}

#[test]
fn anisotropic_static_stretch_matches_compliance() {
    let mat = anisotropic();
    let s = weft::membrane::inverse3(&mat.stiffness).unwrap();
    let (length, width) = (1.0f32, 0.1f32);
    let g = 50.0f32;
    let mut measured = [0.0f64; 2];
    for axis in 0..2 {
        // strip along u (axis 0) or along v (axis 1); gravity pulls along the strip
        let (nx, ny, wu, hv) = if axis == 0 {
            (41, 5, length, width)
        } else {
            (5, 41, width, length)
        };
        let sheet = Sheet::grid(nx, ny, wu, hv);
        let mats = [mat];
        let mut mem = memory(&sheet.capacity());
        let gravity = if axis == 0 {
            [-g, 0.0, 0.0]
        } else {
            [0.0, -g, 0.0]
        };
        let settings = Settings {
            effects: effects::GRAVITY | effects::PINS | effects::DAMPING | effects::WARPING,
            gravity,
            damping_mass: 2.0,
            damping_stiffness: 0.0,
            tolerance: 1e-6,
            max_iterations: 1000,
            ..Settings::default()
        };
        let mut w = world(&mut mem, &sheet, &mats, settings);
        // pin the far end (u = L or v = L): gravity pulls the strip away from it
        if axis == 0 {
            for j in 0..ny {
                let i = sheet.index(nx - 1, j);
                w.set_pin(i, sheet.positions[i as usize]).unwrap();
            }
        } else {
            for i in 0..nx {
                let k = sheet.index(i, ny - 1);
                w.set_pin(k, sheet.positions[k as usize]).unwrap();
            }
        }
        for _ in 0..1500 {
            w.step().unwrap();
        }
        // free-end displacement along the strip, averaged over its nodes
        let free: Vec<u32> = if axis == 0 {
            (0..ny).map(|j| sheet.index(0, j)).collect()
        } else {
            (0..nx).map(|i| sheet.index(i, 0)).collect()
        };
        let d: f64 = free
            .iter()
            .map(|&k| (sheet.positions[k as usize][axis] - w.positions()[k as usize][axis]) as f64)
            .sum::<f64>()
            / free.len() as f64;
        let compliance = s[axis][axis];
        let expected = hanging_strip_elongation(mat.density * g as f64, length as f64, compliance);
        measured[axis] = d;
        let err = (d - expected).abs() / expected;
        assert!(
            err < 0.02,
            "axis {axis}: elongation {d} vs the closed form {expected} ({:.2}%)",
            err * 100.0
        );
    }
    let ratio = measured[1] / measured[0];
    let weight = mat.density * g as f64;
    let expected_ratio = hanging_strip_elongation(weight, length as f64, s[1][1])
        / hanging_strip_elongation(weight, length as f64, s[0][0]);
    assert!(
        ratio > 1.5,
        "the soft axis must stretch more: ratio {ratio}"
    );
    assert!((ratio / expected_ratio - 1.0).abs() < 0.03);
}

fn hanging(nx: usize) -> (Sheet, Settings) {
    let mut sheet = Sheet::grid(nx, nx, 1.0, 1.0);
    // hang in the x–z plane: v becomes height
    sheet.transform(|p| [p[0], 0.0, p[1]]);
    (sheet, Settings::default())
}

#[test]
fn cloth_pinned_at_two_corners_settles() {
    let (sheet, settings) = hanging(15);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(
        &mut mem,
        &sheet,
        &mats,
        Settings {
            damping_mass: 0.5,
            ..settings
        },
    );
    let (a, b) = (sheet.index(0, 14), sheet.index(14, 14));
    w.set_pin(a, sheet.positions[a as usize]).unwrap();
    w.set_pin(b, sheet.positions[b as usize]).unwrap();
    let mut peak = 0.0f64;
    let mut last = 0.0;
    for step in 0..900 {
        let s = w.step().unwrap();
        assert!(s.converged, "step {step} did not converge: {s:?}");
        last = kinetic_energy(&w);
        peak = peak.max(last);
    }
    assert!(peak > 0.0);
    assert!(last < 1e-3 * peak, "kinetic energy {last} vs peak {peak}");
    // pinned corners stay exactly where they are
    assert_eq!(
        <[f32; 3]>::from(w.positions()[a as usize]),
        sheet.positions[a as usize]
    );
}

fn drop_on(shape: Shape) {
    let mut sheet = Sheet::grid(17, 17, 1.0, 1.0);
    sheet.transform(|p| [p[0] - 0.5, p[1] - 0.5, 0.6]);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    let thickness = 0.01;
    w.add_collider(Collider::new(shape, 0.3, thickness))
        .unwrap();
    for step in 0..240 {
        let s = w.step().unwrap();
        for (i, x) in w.positions().iter().enumerate() {
            let d = shape.proximity(*x).distance;
            assert!(
                d > -1e-5,
                "step {step}: vertex {i} penetrates {d} (thickness {thickness})"
            );
        }
        if step > 60 {
            assert!(s.contacts > 0);
        }
    }
}

#[test]
fn dropped_on_sphere_never_penetrates() {
    drop_on(Shape::Sphere {
        center: Vec3A::new(0.0, 0.0, 0.0),
        radius: 0.3,
    });
}

#[test]
fn dropped_on_plane_never_penetrates() {
    drop_on(Shape::Plane {
        normal: Vec3A::Z,
        offset: 0.0,
    });
}

#[test]
fn replay_is_bit_identical() {
    let run = || {
        let (sheet, settings) = hanging(12);
        let mats = [anisotropic()];
        let mut mem = memory(&sheet.capacity());
        let mut w = world(
            &mut mem,
            &sheet,
            &mats,
            Settings {
                effects: effects::ALL & !effects::SLEEP,
                drag: 0.5,
                wind: [1.0, 2.0, 0.0],
                ..settings
            },
        );
        w.set_pin(
            sheet.index(0, 11),
            sheet.positions[sheet.index(0, 11) as usize],
        )
        .unwrap();
        w.add_collider(Collider::new(
            Shape::Sphere {
                center: Vec3A::new(0.5, 0.2, 0.3),
                radius: 0.2,
            },
            0.4,
            0.005,
        ))
        .unwrap();
        for _ in 0..500 {
            w.step().unwrap();
        }
        w.positions()
            .iter()
            .flat_map(|p| p.to_array())
            .map(f32::to_bits)
            .collect::<Vec<u32>>()
    };
    assert_eq!(run(), run());
}

#[test]
fn init_errors_are_specific_and_memory_is_reusable() {
    let mats = [anisotropic()];
    let sheet = Sheet::grid(4, 4, 1.0, 1.0);
    let cap = sheet.capacity();
    let mut mem = memory(&cap);
    let try_init = |mem: &mut [u8], def: &ClothDef<'_>, cap: Capacity, s: Settings| {
        World::new(mem, cap, def, Materials::Table(&mats), s).map(|_| ())
    };
    let ok = Settings::default();
    // capacities
    let small = Capacity {
        vertices: 15,
        ..cap
    };
    assert_eq!(
        try_init(&mut mem, &sheet.def(), small, ok),
        Err(InitError::VertexCapacity {
            needed: 16,
            capacity: 15
        })
    );
    let small = Capacity {
        triangles: 17,
        ..cap
    };
    assert_eq!(
        try_init(&mut mem, &sheet.def(), small, ok),
        Err(InitError::TriangleCapacity {
            needed: 18,
            capacity: 17
        })
    );
    let small = Capacity { edges: 20, ..cap };
    assert!(matches!(
        try_init(&mut mem, &sheet.def(), small, ok),
        Err(InitError::EdgeCapacity { .. })
    ));
    assert_eq!(
        try_init(&mut mem[..100], &sheet.def(), cap, ok),
        Err(InitError::MemoryTooSmall)
    );
    // degenerate triangles
    let mut bad = Sheet::grid(4, 4, 1.0, 1.0);
    bad.positions[5] = bad.positions[0];
    assert!(matches!(
        try_init(&mut mem, &bad.def(), cap, ok),
        Err(InitError::Mesh(MeshError::Degenerate3d { .. }))
    ));
    let mut bad = Sheet::grid(4, 4, 1.0, 1.0);
    bad.uvs[5] = bad.uvs[0];
    assert!(matches!(
        try_init(&mut mem, &bad.def(), cap, ok),
        Err(InitError::Mesh(MeshError::DegenerateUv { .. }))
    ));
    // an edge shared by three triangles: the diagonal (0, 5) of the first square
    let mut bad = Sheet::grid(4, 4, 1.0, 1.0);
    bad.positions.push([0.2, 0.1, 0.5]);
    bad.uvs.push([0.9, 0.2]);
    bad.triangles.push([0, 5, 16]);
    bad.materials.push(0);
    let cap2 = Capacity {
        vertices: 17,
        triangles: 19,
        ..cap
    };
    let mut mem2 = memory(&cap2);
    assert_eq!(
        try_init(&mut mem2, &bad.def(), cap2, ok),
        Err(InitError::Mesh(MeshError::NonManifoldEdge { a: 0, b: 5 }))
    );
    // index out of range, material out of range, NaN
    let mut bad = Sheet::grid(4, 4, 1.0, 1.0);
    bad.triangles[3] = [0, 1, 99];
    assert_eq!(
        try_init(&mut mem, &bad.def(), cap, ok),
        Err(InitError::Mesh(MeshError::IndexOutOfRange { triangle: 3 }))
    );
    let mut bad = Sheet::grid(4, 4, 1.0, 1.0);
    bad.materials[7] = 3;
    assert_eq!(
        try_init(&mut mem, &bad.def(), cap, ok),
        Err(InitError::MaterialOutOfRange {
            triangle: 7,
            material: 3
        })
    );
    let mut bad = Sheet::grid(4, 4, 1.0, 1.0);
    bad.positions[2][1] = f32::NAN;
    assert_eq!(
        try_init(&mut mem, &bad.def(), cap, ok),
        Err(InitError::Mesh(MeshError::NonFinite { vertex: 2 }))
    );
    bad.positions[2][1] = f32::INFINITY;
    assert!(try_init(&mut mem, &bad.def(), cap, ok).is_err());
    // settings
    for time_step in [0.0, -1.0, f32::NAN] {
        assert_eq!(
            try_init(&mut mem, &sheet.def(), cap, Settings { time_step, ..ok }),
            Err(InitError::InvalidSetting { field: "time_step" })
        );
    }
    // iteration caps bound the cost of one step
    for max_iterations in [0, Settings::MAX_ITERATIONS + 1, u32::MAX] {
        assert_eq!(
            try_init(
                &mut mem,
                &sheet.def(),
                cap,
                Settings {
                    max_iterations,
                    ..ok
                }
            ),
            Err(InitError::InvalidSetting {
                field: "max_iterations"
            })
        );
    }
    assert_eq!(
        try_init(
            &mut mem,
            &sheet.def(),
            cap,
            Settings {
                rotation_iterations: Settings::MAX_ROTATION_ITERATIONS + 1,
                ..ok
            }
        ),
        Err(InitError::InvalidSetting {
            field: "rotation_iterations"
        })
    );
    let bad_mat = [Material {
        density: -1.0,
        ..anisotropic()
    }];
    assert_eq!(
        World::new(&mut mem, cap, &sheet.def(), Materials::Table(&bad_mat), ok).map(|_| ()),
        Err(InitError::InvalidMaterial { material: 0 })
    );
    // after all that, the same memory builds a good world
    let mut w = World::new(&mut mem, cap, &sheet.def(), Materials::Table(&mats), ok).unwrap();
    assert!(w.step().is_ok());
}

#[test]
fn nan_pin_target_is_refused_and_world_stays_usable() {
    let (sheet, settings) = hanging(6);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, settings);
    w.set_pin(0, [0.0, 0.0, 0.0]).unwrap();
    for _ in 0..10 {
        w.step().unwrap();
    }
    let before: Vec<Vec3A> = w.positions().to_vec();
    w.set_pin(0, [f32::NAN, 0.0, 0.0]).unwrap();
    assert_eq!(w.step(), Err(StepError::NonFinitePin { vertex: 0 }));
    assert_eq!(w.positions(), &before[..]);
    w.set_pin(0, [0.0, 0.0, 0.1]).unwrap();
    assert!(w.step().is_ok());
    assert!(w.positions().iter().all(|p| p.is_finite()));
    assert_eq!(w.step_dt(0.0), Err(StepError::InvalidTimeStep));
    assert_eq!(w.step_dt(f32::NAN), Err(StepError::InvalidTimeStep));
}

#[test]
fn effects_are_honoured() {
    let (sheet, settings) = hanging(8);
    let mats = [Material {
        bending: 1e-2,
        ..anisotropic()
    }];
    let run = |effects: u32| {
        let mut mem = memory(&sheet.capacity());
        let mut w = world(
            &mut mem,
            &sheet,
            &mats,
            Settings {
                effects,
                ..settings
            },
        );
        w.set_pin(
            sheet.index(0, 7),
            sheet.positions[sheet.index(0, 7) as usize],
        )
        .unwrap();
        for _ in 0..30 {
            w.step().unwrap();
        }
        w.positions().to_vec()
    };
    let base = effects::GRAVITY | effects::PINS | effects::WARPING;
    let still = run(effects::PINS | effects::WARPING);
    assert!(
        still
            .iter()
            .zip(&sheet.positions)
            .all(|(a, b)| (*a - Vec3A::from(*b)).length() < 1e-6),
        "no gravity: nothing moves"
    );
    let falls = run(base);
    let bends = run(base | effects::BENDING);
    let damped = run(base | effects::DAMPING);
    let diff = |a: &[Vec3A], b: &[Vec3A]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x - *y).length())
            .fold(0.0, f32::max)
    };
    assert!(diff(&falls, &still) > 0.1);
    assert!(diff(&falls, &bends) > 1e-4);
    assert!(diff(&falls, &damped) > 1e-4);
}

/// `settings` with sleep on and damping that lets a hanging cloth come to rest soon.
fn sleepy(settings: Settings) -> Settings {
    Settings {
        effects: settings.effects | effects::SLEEP,
        damping_mass: 2.0,
        ..settings
    }
}

#[test]
fn cloth_at_rest_sleeps_and_wakes() {
    let (sheet, settings) = hanging(8);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, sleepy(settings));
    let (a, b) = (sheet.index(0, 7), sheet.index(7, 7));
    w.set_pin(a, sheet.positions[a as usize]).unwrap();
    w.set_pin(b, sheet.positions[b as usize]).unwrap();
    let mut slept_at = None;
    for step in 0..3000 {
        let s = w.step().unwrap();
        if s.asleep {
            slept_at = Some(step);
            break;
        }
    }
    assert!(
        slept_at.is_some(),
        "a hanging cloth comes to rest and sleeps"
    );
    let frozen = w.positions().to_vec();
    assert!(w.step().unwrap().asleep);
    assert_eq!(w.positions(), &frozen[..]);
    // moving a pin wakes it
    let mut t = sheet.positions[b as usize];
    t[0] += 0.2;
    w.set_pin(b, t).unwrap();
    assert!(!w.is_asleep());
    assert!(!w.step().unwrap().asleep);
    assert_ne!(w.positions(), &frozen[..]);
}

/// A cloth whose only effect is its membrane, at rest in its rest shape: its energy is f32
/// round-off (1e-15..1e-12 J), and the balance must not read round-off changes of it as gains.
/// Found by an outside fuzzer: at spacings 0.011–0.083 m, 96–100 of 100 steps were refused
/// (never asleep); a nudged, damped cloth coming to rest likewise. The elastic energy's
/// round-off now has an absolute bound (`membrane::elastic_energy_with_noise`).
#[test]
fn a_membrane_only_cloth_at_rest_is_never_refused_and_sleeps() {
    // isotropic, and the anisotropic test fabric (C12 ≠ 0, C11 = 4 C22)
    for mats in [[isotropic(2000.0, 0.3, 0.2)], [anisotropic()]] {
        at_rest_and_nudged(&mats);
    }
}

fn at_rest_and_nudged(mats: &[Material]) {
    for (n, spacing) in [
        (2, 0.026f32),
        (2, 0.011),
        (21, 0.026),
        (21, 0.053),
        (21, 0.083),
    ] {
        let size = spacing * (n - 1) as f32;
        let sheet = Sheet::grid(n, n, size, size);
        let settings = Settings {
            effects: effects::WARPING | effects::SLEEP,
            ..Settings::default()
        };
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, mats, settings);
        for step in 0..100 {
            let s = w.step();
            assert!(s.is_ok(), "{n}×{n} at {spacing} m: step {step}: {s:?}");
        }
        assert!(w.is_asleep(), "{n}×{n} at {spacing} m never sleeps");
    }
    // nudged in its plane (1 cm/s), damped, coming to rest: no step refused on the way
    let sheet = Sheet::grid(10, 10, 1.0, 1.0);
    let settings = Settings {
        effects: effects::WARPING | effects::DAMPING,
        damping_mass: 1.0,
        ..Settings::default()
    };
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, mats, settings);
    let v: Vec<[f32; 3]> = (0..100)
        .map(|i| {
            let a = i as f32 * 2.4;
            [0.01 * a.cos(), 0.01 * a.sin(), 0.0]
        })
        .collect();
    w.set_velocities(&v).unwrap();
    for step in 0..600 {
        let s = w.step();
        assert!(s.is_ok(), "nudged cloth, step {step}: {s:?}");
    }
}

/// A free cloth at rest (no gravity, no pins, nothing touching) stays exactly where it is and
/// costs no CG iteration: its right-hand side is round-off, which neither the CG (its
/// absolute floor) nor the rigid correction after it (skipped where the residual is below
/// that floor) turns into motion. Corrected anyway, the round-off's net force moved
/// it (here from the 11th step; on weft-bench's 21×21 sheet 0.35 CG iterations a step and
/// strains of 1e-7).
#[test]
fn a_free_cloth_at_rest_stays_exactly_at_rest() {
    for mats in [[isotropic(2000.0, 0.3, 0.2)], [anisotropic()]] {
        // upright in the x–z plane, as weft-bench's sheet (a turn that rounds nothing)
        let sheet = hanging_sheet(21, 1.0);
        let settings = Settings {
            effects: effects::WARPING | effects::BENDING | effects::DAMPING,
            ..Settings::default()
        };
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, settings);
        let start = w.positions().to_vec();
        for step in 0..60 {
            let s = w.step().unwrap();
            assert_eq!(s.iterations, 0, "step {step}: {s:?}");
        }
        assert!(w.positions() == start.as_slice(), "the cloth moved");
    }
}

/// The memory aim: a 64×64-vertex world (and the default C capacity, which holds one) in
/// under 4 MB of caller memory, all of it inside the block.
#[test]
fn a_64x64_world_fits_in_4_mb() {
    let grid = Capacity::grid(64);
    assert!(
        grid.world_bytes() < 4_000_000,
        "{} bytes",
        grid.world_bytes()
    );
    let d = Capacity::DEFAULT;
    assert!(d.vertices >= grid.vertices && d.triangles >= grid.triangles && d.edges >= grid.edges);
    assert!(d.colliders >= 8);
    assert!(d.world_bytes() < 4_000_000, "{} bytes", d.world_bytes());
    // and a world really is built in exactly that many bytes
    let sheet = Sheet::grid(64, 64, 1.0, 1.0);
    let mats = [anisotropic()];
    let mut mem = vec![0u8; d.world_bytes()];
    let mut w = World::new(
        &mut mem,
        d,
        &sheet.def(),
        Materials::Table(&mats),
        Settings::default(),
    )
    .unwrap();
    assert!(w.step().is_ok());
}

/// A crumpled, stretched cloth of an anisotropic fabric (the test fabric, and one of contrast
/// 1e4 on turned axes): its elastic forces are the gradient of a rotation-invariant energy, so
/// they carry no net force and no net torque.
#[test]
fn anisotropic_elastic_forces_carry_no_net_torque() {
    let strong = Material {
        stiffness: [[1e4, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        density: 0.15,
        bending: 1e-4,
    };
    for mat in [anisotropic(), strong] {
        let mut sheet = Sheet::grid(9, 9, 0.5, 0.5);
        sheet.transform(|p| {
            [
                1.3 * p[0] + 0.25 * p[1] + 0.02 * (7.0 * p[1]).sin(),
                0.8 * p[1],
                0.1 * (9.0 * p[0]).sin() * (5.0 * p[1]).cos(),
            ]
        });
        let mats = [mat];
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, settings_quiet());
        let mut f = vec![Vec3A::ZERO; w.vertex_count()];
        assert!(w.elastic_forces(&mut f));
        let x = w.positions();
        let centre = x.iter().copied().sum::<Vec3A>() / x.len() as f32;
        let (mut net, mut torque, mut scale, mut fsum) = (Vec3A::ZERO, Vec3A::ZERO, 0.0, 0.0);
        for (p, fi) in x.iter().zip(&f) {
            net += *fi;
            torque += (*p - centre).cross(*fi);
            scale += (*p - centre).length() * fi.length();
            fsum += fi.length();
        }
        assert!(net.length() < 1e-5 * fsum, "net force {net} of {fsum}");
        assert!(
            torque.length() < 1e-5 * scale,
            "net torque {torque} N·m of {scale}"
        );
    }
}

/// A free, crumpled, strongly anisotropic cloth (C = diag(1000, 1, 1) N/m) released at rest,
/// no gravity: it unfolds, its damping takes the energy out, and it comes to rest.
#[test]
fn free_anisotropic_cloth_comes_to_rest() {
    free_anisotropic_cloth_rests(Settings::DEFAULT_TOLERANCE);
}

/// The same at tolerance 1e-2: the solves' error in its rigid rotations kept it spinning
/// (9.5e-6 J after 10 s, 1.7e-3 of its peak) until each free solve was also corrected on its
/// rotations (`system::correct_rigid`).
#[test]
fn a_free_cloth_rests_at_a_loose_tolerance() {
    free_anisotropic_cloth_rests(1e-2);
}

/// [`free_anisotropic_cloth_comes_to_rest`] with the CG at `tolerance`.
fn free_anisotropic_cloth_rests(tolerance: f32) {
    let mats = [Material {
        stiffness: [[1000.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        density: 0.15,
        bending: 1e-4,
    }];
    let mut sheet = Sheet::grid(9, 9, 0.4, 0.4);
    sheet.transform(|p| {
        [
            1.1 * p[0] + 0.1 * p[1],
            0.9 * p[1],
            0.05 * (9.0 * p[0]).sin() * (7.0 * p[1]).cos(),
        ]
    });
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::BENDING | effects::DAMPING,
        tolerance,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let mut peak = 0.0f64;
    for step in 0..600 {
        // with the rotation term missing, the elastic forces pumped energy in until the step's
        // energy check refused the state (or, before it, the cloth spun up forever)
        let s = w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        assert!(s.energy_removed <= 1e-3 * peak as f32, "step {step}: {s:?}");
        peak = peak.max(kinetic_energy(&w));
    }
    let ke = kinetic_energy(&w);
    assert!(peak > 0.0);
    assert!(
        ke < 1e-3 * peak,
        "kinetic energy {ke} J after 10 s (peak {peak} J)"
    );
}

/// No input at all (no gravity, damping or pins): every step's end state holds no more
/// energy than its start, for an anisotropic cloth released crumpled and stretched.
#[test]
fn steps_without_input_never_gain_energy() {
    let mats = [anisotropic()];
    let mut sheet = Sheet::grid(11, 11, 0.5, 0.5);
    sheet.transform(|p| {
        [
            1.2 * p[0],
            0.95 * p[1] + 0.1 * p[0],
            0.04 * (11.0 * p[0]).sin() * (6.0 * p[1]).cos(),
        ]
    });
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::BENDING,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let mut before = w.energy().total();
    let start = before;
    for step in 0..300 {
        w.step().unwrap();
        let now = w.energy().total();
        assert!(
            now <= before + 1e-6 * start,
            "step {step}: energy rose from {before} to {now} J"
        );
        before = now;
    }
}

/// The highest the energy of a stiff anisotropic cloth (90 kN/m) gets above the lowest it has
/// had, relative to that lowest, over 400 steps with no input: one corner on a still rail
/// (a line pin), the cloth spinning at 1 rad/s and sliding along the rail at 0.3 m/s, no
/// gravity, block Jacobi at `tolerance`, three substeps of 1/109 s.
fn spinning_on_a_rail_rise(tolerance: f32) -> f64 {
    let stiff = 9e4;
    let mats = [Material {
        stiffness: [
            [stiff, 0.05 * stiff, 0.0],
            [0.05 * stiff, 0.35 * stiff, 0.0],
            [0.0, 0.0, 0.15 * stiff],
        ],
        density: 0.1,
        bending: 1e-5,
    }];
    let sheet = Sheet::grid(15, 15, 0.3, 0.3);
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::DAMPING | effects::PINS,
        damping_mass: 0.0024,
        damping_stiffness: 0.00026,
        tolerance,
        substeps: 3,
        time_step: 0.00916,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    w.set_solver(Solver::BlockJacobi);
    let rail = Vec3A::new(-0.89, -0.45, 0.03).normalize();
    let corner = w.positions()[0];
    w.set_pin_axes(
        0,
        corner.into(),
        PinAxes::Line {
            direction: rail.into(),
        },
    )
    .unwrap();
    let spin = Vec3A::new(0.3, 0.2, 1.0).normalize();
    let v: Vec<[f32; 3]> = w
        .positions()
        .iter()
        .map(|&p| (spin.cross(p - corner) + 0.3 * rail).into())
        .collect();
    w.set_velocities(&v).unwrap();
    let mut lowest = w.energy().total();
    let mut rise = 0.0f64;
    for _ in 0..400 {
        w.step().unwrap();
        let now = w.energy().total();
        lowest = lowest.min(now);
        rise = rise.max((now - lowest) / lowest);
    }
    rise
}

/// Gains within each step's round-off do not add up. The balance forgives a step a gain up to
/// the round-off of its two states' energies (here ~2 % of the energy: the elastic energy's
/// resolution in `f32`, `tr(K) δ²`, on a stiff cloth that moves almost rigidly); a solve at a
/// loose tolerance (block Jacobi at 2.4e-3) that gains a little at every step went on gaining
/// step after step, to 7.8 % above its lowest level (13 % at 5e-3). The balance since the
/// lowest level reached (`monitor::Drift`) holds that sum to the round-off of the two states
/// too: 0.18 %.
#[test]
fn gains_within_each_steps_round_off_do_not_add_up() {
    let rise = spinning_on_a_rail_rise(2.4e-3);
    assert!(
        rise < 0.01,
        "the energy rose {:.2} % above its lowest level with no input",
        100.0 * rise
    );
}

/// Strong bending (0.1 and 0.01 N·m) on long thin triangles: a disc of 3 spokes and 12 rings
/// hanging from one rim vertex, gravity its only input. The energy the world reports (gravity's
/// potential included) never rises from one step to the next. Found by an outside fuzzer: the
/// bending energy, summed in f32 from terms far larger than it, jumped between 0 and 2e-3 J,
/// and its round-off bound (0.34 J) hid 207 of 600 steps that gained; it is now summed in f64.
#[test]
fn strong_bending_on_thin_triangles_never_gains_energy() {
    let (spokes, rings) = (3usize, 12usize);
    let mut uvs = vec![[0.0f32, 0.0]];
    for ring in 1..=rings {
        for s in 0..spokes {
            let r = 0.5 * ring as f32 / rings as f32;
            let a = std::f32::consts::TAU * s as f32 / spokes as f32;
            uvs.push([r * a.cos(), r * a.sin()]);
        }
    }
    let at = |ring: usize, s: usize| (1 + (ring - 1) * spokes + s % spokes) as u32;
    let mut triangles: Vec<[u32; 3]> = (0..spokes).map(|s| [0, at(1, s), at(1, s + 1)]).collect();
    for ring in 1..rings {
        for s in 0..spokes {
            triangles.push([at(ring, s), at(ring + 1, s), at(ring + 1, s + 1)]);
            triangles.push([at(ring, s), at(ring + 1, s + 1), at(ring, s + 1)]);
        }
    }
    let sheet = Sheet {
        positions: uvs.iter().map(|p| [p[0], p[1], 0.0]).collect(),
        materials: vec![0; triangles.len()],
        uvs,
        triangles,
        nx: 0,
        ny: 0,
    };
    for bending in [0.1, 0.01] {
        let mats = [Material {
            stiffness: weft::membrane::isotropic(3000.0, 0.3),
            density: 0.3,
            bending,
        }];
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, Settings::default());
        let rim = sheet.positions.len() - 1;
        w.set_pin(rim as u32, sheet.positions[rim]).unwrap();
        let mut before = w.energy().total();
        for step in 0..600 {
            w.step().unwrap();
            let now = w.energy().total();
            assert!(
                now <= before + 1e-6 * before.abs() + 1e-9,
                "bending {bending}: step {step}: energy rose from {before} to {now} J"
            );
            before = now;
        }
    }
}

/// Pins switched on (`set_settings`) after their vertices fell away with pins off: they take
/// the vertices back over a step as moving pins (their work counted), so no step is refused or
/// has energy taken out, and the vertices end on their targets. Found by an outside fuzzer:
/// from their old targets the pins yanked the vertices back in one substep (here: redone at 8×
/// and 27 J removed; there, 0.09 J became 75 J and every later step was refused).
#[test]
fn pins_switched_on_after_the_cloth_fell_take_it_back() {
    let sheet = hanging_sheet(11, 0.5);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let free = Settings {
        effects: Settings::default().effects & !effects::PINS,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, free);
    pin_top_corners(&mut w, &sheet);
    for _ in 0..20 {
        w.step().unwrap();
    }
    let (a, b) = (sheet.index(0, 10) as usize, sheet.index(10, 10) as usize);
    let fell = w.positions()[a].distance(Vec3A::from(sheet.positions[a]));
    assert!(
        fell > 0.3,
        "the pinned corner fell only {fell} m with pins off"
    );
    w.set_settings(Settings::default()).unwrap();
    for step in 0..120 {
        let s = w.step();
        assert!(
            s.is_ok_and(|s| s.energy_removed == 0.0),
            "step {step} after pins were switched on: {s:?}"
        );
    }
    for k in [a, b] {
        let off = w.positions()[k].distance(Vec3A::from(sheet.positions[k]));
        assert!(off < 1e-5, "pinned vertex {k} is {off} m off its target");
    }
}

/// A cloth read in place from an interleaved vertex buffer (position, uv, padding per 28-byte
/// record) with one material for every triangle builds the same world as the packed arrays,
/// and the strided setters equal the slice ones.
#[test]
fn strided_cloth_and_edits_match_the_packed_ones() {
    let mut sheet = Sheet::grid(6, 5, 0.5, 0.4);
    sheet.transform(|p| [p[0], p[1] + 0.1 * p[0], 0.2 * p[0] * p[1]]);
    let mats = [isotropic(800.0, 0.3, 0.2), anisotropic()];
    let cap = sheet.capacity();
    let zeros = vec![1u32; sheet.triangles.len()];
    let packed_def = ClothDef {
        materials: &zeros,
        ..sheet.def()
    };
    let mut mem_a = memory(&cap);
    let mut a = World::new(
        &mut mem_a,
        cap,
        &packed_def,
        Materials::Table(&mats),
        no_warp(),
    )
    .unwrap();
    let n = sheet.positions.len();
    let mut records = vec![0u8; 28 * n];
    for (i, (p, uv)) in sheet.positions.iter().zip(&sheet.uvs).enumerate() {
        let r = &mut records[28 * i..];
        for (k, c) in p.iter().chain(uv).enumerate() {
            r[4 * k..4 * k + 4].copy_from_slice(&c.to_le_bytes());
        }
    }
    let cloth = StridedClothDef {
        positions: Strided::new(&records, 28, n).unwrap(),
        uvs: Strided::with_offset(&records, 28, 12, n).unwrap(),
        triangles: &sheet.triangles,
        materials: TriangleMaterials::Uniform(1),
    };
    let mut mem_b = memory(&cap);
    let mut b =
        World::new_strided(&mut mem_b, cap, &cloth, Materials::Table(&mats), no_warp()).unwrap();
    assert_eq!(a.positions(), b.positions());
    assert_eq!(a.masses(), b.masses());
    assert_eq!(a.triangle_materials(), b.triangle_materials());
    // a uniform material that is not in the table is refused like a per-triangle one
    let bad = StridedClothDef {
        materials: TriangleMaterials::Uniform(2),
        ..cloth
    };
    let mut mem_c = memory(&cap);
    assert!(matches!(
        World::new_strided(&mut mem_c, cap, &bad, Materials::Table(&mats), no_warp()),
        Err(InitError::MaterialOutOfRange {
            triangle: 0,
            material: 2
        })
    ));
    // strided edits
    let moved: Vec<[f32; 3]> = sheet
        .positions
        .iter()
        .map(|p| [p[0], p[1], p[2] + 0.01])
        .collect();
    let mut rec = vec![0u8; 20 * n];
    for (i, p) in moved.iter().enumerate() {
        for (k, c) in p.iter().enumerate() {
            rec[20 * i + 4 + 4 * k..20 * i + 8 + 4 * k].copy_from_slice(&c.to_le_bytes());
        }
    }
    let view = Strided::<3>::with_offset(&rec, 20, 4, n).unwrap();
    a.set_positions(&moved).unwrap();
    b.set_positions_strided(&view).unwrap();
    a.set_velocities(&moved).unwrap();
    b.set_velocities_strided(&view).unwrap();
    assert_eq!(a.step(), b.step());
    assert_eq!(a.positions(), b.positions());
    rec[20 * 3 + 8..20 * 3 + 12].copy_from_slice(&f32::NAN.to_le_bytes());
    let view = Strided::<3>::with_offset(&rec, 20, 4, n).unwrap();
    assert_eq!(
        b.set_positions_strided(&view),
        Err(weft::world::EditError::NonFinite)
    );
    assert_eq!(a.positions(), b.positions());
}

/// Collision turned on with the cloth 14 cm inside a floor, and a sphere added 10 cm into a
/// resting cloth: the contacts push out no faster than `max_depenetration_speed` and correct
/// the rest by position, so nothing is launched (it left at 8.9 and 6 m/s before).
#[test]
fn depenetration_does_not_launch_the_cloth() {
    let mats = [anisotropic()];
    let limit = Settings::default().max_depenetration_speed;
    // the floor, 14 cm above a flat cloth
    let mut sheet = Sheet::grid(11, 11, 0.5, 0.5);
    sheet.transform(|p| [p[0], p[1], 0.0]);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    w.add_collider(Collider::new(
        Shape::Plane {
            normal: Vec3A::Z,
            offset: 0.14,
        },
        0.3,
        0.005,
    ))
    .unwrap();
    let mut fastest = 0.0f32;
    for _ in 0..60 {
        w.step().unwrap();
        fastest = fastest.max(w.velocities().iter().map(|v| v.z).fold(f32::MIN, f32::max));
    }
    assert!(
        fastest < 1.5 * limit,
        "left the floor at {fastest} m/s (limit {limit})"
    );
    assert!(w.positions().iter().all(|p| p.z > 0.14));
    // a sphere appearing 10 cm into a resting, hanging cloth
    let sheet = hanging_sheet(11, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    pin_top_corners(&mut w, &sheet);
    for _ in 0..120 {
        w.step().unwrap();
    }
    let centre = w.positions()[sheet.index(5, 5) as usize];
    w.add_collider(Collider::new(
        Shape::Sphere {
            center: centre + Vec3A::new(0.0, 0.1, 0.0),
            radius: 0.2,
        },
        0.3,
        0.005,
    ))
    .unwrap();
    let mut fastest = 0.0f32;
    for _ in 0..30 {
        w.step().unwrap();
        fastest = fastest.max(top_speed(&w));
    }
    // The contacts push out at the limit; the position correction then leaves the cloth
    // wrapped round 10 cm of sphere, stretched, and that stretch (input, counted by the
    // balance) springs back: converged, either solver gives 2.89 m/s at one substep and 3.40 at
    // four (tolerance 1e-3 and 1e-5 alike). A bound of twice the limit held only while this
    // 121-vertex cloth stepped with block Jacobi, whose first solve stopped at its cap with a
    // residual of 21 and lost the motion. The launch this guards against was 6 m/s.
    assert!(
        fastest < 4.0 * limit,
        "a sphere appearing inside threw the cloth at {fastest} m/s"
    );
}

/// A fast depenetration (`max_depenetration_speed` raised to 5 and 12.8 m/s) out of a still
/// sphere that the cloth starts cut by: the push is a surface moving out at that speed, and its
/// work is input to the energy balance. Found by an outside fuzzer: it was not counted, every
/// attempt (and every redo, which pushes again) gained, and every step was refused from the
/// first, the world frozen.
#[test]
fn a_fast_depenetration_out_of_a_still_sphere_is_input_not_a_gain() {
    let (iso, aniso) = ([isotropic(2000.0, 0.3, 0.2)], [anisotropic()]);
    let cases = [
        (3, 12.8f32, &iso),
        (5, 12.8, &iso),
        (15, 12.8, &iso),
        (3, 5.0, &iso),
        (5, 12.8, &aniso),
        (15, 5.0, &aniso),
    ];
    for (n, speed, mats) in cases {
        let sheet = Sheet::grid(n, n, 1.0, 1.0);
        // no gravity: pushed out, the cloth coasts (slowed by damping) at most as fast as
        // the push
        let settings = Settings {
            max_depenetration_speed: speed,
            effects: Settings::default().effects & !effects::GRAVITY,
            ..Settings::default()
        };
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, mats, settings);
        // the middle of the sheet 5 cm inside a 10 cm sphere below it
        let sphere = Shape::Sphere {
            center: Vec3A::new(0.51, 0.513, -0.05),
            radius: 0.1,
        };
        w.add_collider(Collider::new(sphere, 0.3, 0.005)).unwrap();
        for step in 0..100 {
            let s = w.step();
            assert!(s.is_ok(), "{n}×{n} at {speed} m/s: step {step}: {s:?}");
        }
        let fastest = top_speed(&w);
        assert!(
            fastest <= speed * 1.01,
            "{n}×{n}: moving at {fastest} m/s after a push at {speed} m/s"
        );
        assert!(
            w.positions()
                .iter()
                .all(|&p| sphere.proximity(p).distance > 0.005 - 1e-4),
            "{n}×{n}: a vertex stayed inside"
        );
    }
}

/// Air drag is implicit (`h·drag·area·n nᵀ` in the system): a light fabric (50 g/m²) with
/// strong drag (10 kg/(m²·s), drag·h/ρ = 3.3) hanging in still air comes to rest; explicit drag
/// fluttered at 10–20 m/s once drag·h/ρ > 2.
#[test]
fn strong_drag_on_light_fabric_is_stable() {
    let mats = [Material {
        density: 0.05,
        ..anisotropic()
    }];
    let sheet = hanging_sheet(11, 0.5);
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: Settings::default().effects | effects::WIND,
        wind: [0.0; 3],
        drag: 10.0,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    pin_top_corners(&mut w, &sheet);
    let (mut fastest, mut redone, mut removed) = (0.0f32, 0, 0.0f32);
    for step in 0..600 {
        let s = w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        redone += s.redone;
        removed += s.energy_removed;
        if step > 300 {
            fastest = fastest.max(top_speed(&w));
        }
    }
    assert!(
        fastest < 0.05,
        "still fluttering at {fastest} m/s after 5 s"
    );
    // stable by itself, not by the energy balance's redos
    assert!(
        redone <= 2 && removed == 0.0,
        "{redone} redos, {removed} J removed"
    );
}

/// A static drape: a cloth dropped on a sphere (default settings, sleep on) comes to rest on
/// it and sleeps, at 21×21 and 41×41, without sliding off.
#[test]
fn a_drape_on_a_sphere_rests_and_sleeps() {
    for n in [21usize, 41] {
        let mut sheet = Sheet::grid(n, n, 1.0, 1.0);
        sheet.transform(|p| [p[0] - 0.5, p[1] - 0.5, 0.45]);
        let mats = [anisotropic()];
        let mut mem = memory(&sheet.capacity());
        let settings = Settings {
            effects: Settings::default().effects | effects::SLEEP,
            ..Settings::default()
        };
        let mut w = world(&mut mem, &sheet, &mats, settings);
        let sphere = Shape::Sphere {
            center: Vec3A::ZERO,
            radius: 0.3,
        };
        w.add_collider(Collider::new(sphere, 0.5, 0.005)).unwrap();
        let mut slept = None;
        for step in 0..1500 {
            let s = w
                .step()
                .unwrap_or_else(|e| panic!("{n}×{n}, step {step}: {e:?}"));
            if s.asleep {
                slept = Some(step);
                break;
            }
        }
        let top = w.positions()[sheet.index(n / 2, n / 2) as usize];
        println!("{n}×{n}: asleep at {slept:?}, centre at {top}");
        assert!(slept.is_some(), "{n}×{n}: still moving after 25 s");
        assert!(
            (top - Vec3A::new(0.0, 0.0, 0.305)).length() < 0.02,
            "{n}×{n}: slid off the top (centre vertex at {top})"
        );
    }
}

/// A cloth let go from one corner falls into a pile on a floor and comes to rest there: the
/// resting pile costs a few CG iterations per step and its vertices stop. Before, a solve
/// warm-started from the last step's `Δv` kept, where the absolute floor stopped it, what of
/// that start lay below the floor: the light corner vertex (a sixth to a third of an inner
/// vertex's mass; the floor is a mass-weighted sum) went on oscillating at 1.5e-4 m/s, and every
/// step cost 6.4 CG iterations for ever, in every landing.
///
/// Whether one landing rests within the 600 steps is a lottery: some piles keep the friction
/// creep described in the README (Limits, "A cloth landing in a pile") at 0.9–5 mm/s and 17–30
/// CG iterations a step, and which ones changes with any change of round-off. So the test drops
/// forty landings (jitter seeds 1–40) and asks most of them to rest: 29 of 40 when this form
/// landed (2026-11-28), and 23–32 of 40 over the tolerances 1e-3 … 1e-2 and the frictions 0.1 …
/// 1 measured before (`cargo run --release --example rest_sweep -- pile`; README, "The default,
/// re-examined"). The bound, 22, leaves that spread room; a regression like the one above rests
/// none. One landing used to be the test (seed 7), and a change of summation order elsewhere
/// could fail it.
#[test]
fn a_cloth_fallen_into_a_pile_comes_to_rest() {
    let mut creeping = Vec::new();
    let seeds = 1..=40u64;
    for seed in seeds.clone() {
        let run = drop_pile(seed, Settings::default());
        let (top, fastest, per_step) = (run.top, run.fastest, run.tail_per_step());
        println!(
            "seed {seed}: last {PILE_TAIL} steps {per_step} CG iterations per step, \
             {fastest} m/s, top {top} m"
        );
        assert!(
            top < 0.5,
            "seed {seed}: the cloth did not fall (top at {top} m)"
        );
        if !run.at_rest() {
            creeping.push(seed);
        }
    }
    let rested = seeds.count() - creeping.len();
    println!("{rested} of 40 at rest; creeping: {creeping:?}");
    assert!(
        rested >= 22,
        "{rested} of 40 piles at rest (creeping: {creeping:?})"
    );
}

/// Random ±5 m/s velocities on a resting hanging cloth: with nothing else driving it, one step
/// must not raise its energy (the linearized step used to multiply it by 8.5, accepted).
#[test]
fn random_kicks_on_a_resting_cloth_do_not_create_energy() {
    let mats = [anisotropic()];
    let sheet = hanging_sheet(15, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    pin_top_corners(&mut w, &sheet);
    for _ in 0..200 {
        w.step().unwrap();
    }
    let mut random = uniform(12345);
    for speed in [5.0f32, 50.0] {
        let v: Vec<[f32; 3]> = (0..w.vertex_count())
            .map(|_| [speed * random(), speed * random(), speed * random()])
            .collect();
        w.set_velocities(&v).unwrap();
        let before = w.energy().total();
        w.step().unwrap();
        let after = w.energy().total();
        assert!(
            after <= before * (1.0 + 1e-6),
            "±{speed} m/s: energy {before} J → {after} J in one step"
        );
    }
}

/// An isotropic 1e4 N/m sheet released flat from two pinned corners (one substep, 41×41):
/// no step gains energy and none is refused (the cloth used to gain in its first steps and
/// then hang frozen while the monitor refused the identical state).
#[test]
fn a_stiff_sheet_released_from_two_corners_never_gains_energy() {
    let mats = [isotropic(1e4, 0.3, 0.1)];
    let mut sheet = Sheet::grid(41, 41, 1.0, 1.0);
    sheet.transform(|p| [p[0], p[1], 0.0]);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    pin_top_corners(&mut w, &sheet);
    let mut before = w.energy().total();
    for step in 0..40 {
        w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        let now = w.energy().total();
        assert!(
            now <= before + 1e-6 * before.abs().max(1e-3),
            "step {step}: energy {before} J → {now} J"
        );
        before = now;
    }
}

/// A step that gains energy is redone at a tenth of a loose CG tolerance (down to the default), not
/// only at twice the substeps: a gain from the solves' error does not shrink with the substep. A
/// small, stiff anisotropic sheet starts with its vertices 5 % of an edge off their rest places
/// (strain noise, as from coordinates rounded far from the origin), with no gravity and block
/// Jacobi at tolerance 0.1. Redone with more substeps alone, every attempt of most steps gained and
/// the cloth was held still at 27 of 30 steps, its noise never released (1.3e-1 of 4.4 J left); now
/// no step is held and the noise is gone (5e-5 J), with 19 redos instead of 85.
#[test]
fn a_step_that_gains_is_redone_with_a_tighter_solve() {
    let mut material = anisotropic();
    for row in material.stiffness.iter_mut() {
        for c in row.iter_mut() {
            *c *= 1e5 / 600.0;
        }
    }
    let mats = [material];
    let n = 21;
    let mut sheet = Sheet::grid(n, n, 0.2, 0.2);
    let edge = 0.2 / (n - 1) as f32;
    let mut rnd = uniform(11);
    for p in sheet.positions.iter_mut() {
        for c in p.iter_mut() {
            *c += 0.05 * edge * rnd();
        }
    }
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        tolerance: 0.1,
        gravity: [0.0; 3],
        effects: effects::WARPING,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    w.set_solver(Solver::BlockJacobi);
    let start = w.energy().total();
    let mut held = 0;
    for step in 0..30 {
        let stats = w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        held += u32::from(stats.stopped);
    }
    let end = w.energy().total();
    assert_eq!(held, 0, "steps held still");
    assert!(end < 1e-3 * start, "energy {start} J → {end} J");
}

/// A 10 cm sphere at 50 m/s that stops 0.3 m in front of a hanging cloth never touches it, so
/// it must not push it (the contact test used to look a substep ahead along the collider's
/// velocity and launched the cloth at 32 m/s).
#[test]
fn a_fast_collider_that_stops_short_pushes_nothing() {
    let mats = [anisotropic()];
    let sheet = hanging_sheet(11, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    pin_top_corners(&mut w, &sheet);
    for _ in 0..120 {
        w.step().unwrap();
    }
    let centre = w.positions()[sheet.index(5, 5) as usize];
    let at = |y: f32| Shape::Sphere {
        center: Vec3A::new(centre.x, y, centre.z),
        radius: 0.1,
    };
    let start = centre.y - 0.3 - 50.0 / 60.0;
    w.add_collider(Collider::new(at(start), 0.3, 0.005))
        .unwrap();
    w.step().unwrap();
    let calm = top_speed(&w);
    // one frame at 50 m/s, stopping 0.3 m in front of the cloth
    w.set_collider_shape(0, at(centre.y - 0.3)).unwrap();
    w.step().unwrap();
    w.step().unwrap();
    let fastest = top_speed(&w);
    assert!(
        fastest < calm + 0.05,
        "a collider that never touched the cloth moved it at {fastest} m/s (at rest: {calm})"
    );
}

/// Pins pulled far (two corners of a hanging cloth pulled apart to 4× its width, then a pin
/// teleported 1 m): the cloth must settle rather than flip its compressed elements every step
/// in a period-2 cycle.
#[test]
fn pins_moved_far_settle() {
    let mats = [anisotropic()];
    let sheet = hanging_sheet(15, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    let (a, b) = (sheet.index(0, 14), sheet.index(14, 14));
    let (pa, pb) = (sheet.positions[a as usize], sheet.positions[b as usize]);
    w.set_pin(a, pa).unwrap();
    w.set_pin(b, pb).unwrap();
    // pulled apart over one second to 4× the width
    for step in 0..60 {
        let s = (step + 1) as f32 / 60.0 * 0.75;
        w.set_pin(a, [pa[0] - s, pa[1], pa[2]]).unwrap();
        w.set_pin(b, [pb[0] + s, pb[1], pb[2]]).unwrap();
        w.step()
            .unwrap_or_else(|e| panic!("pull, step {step}: {e:?}"));
    }
    // one pin teleported 1 m
    w.set_pin(a, [pa[0] - 0.75, pa[1] + 1.0, pa[2]]).unwrap();
    let mut slowest_tail = 0.0f32;
    for step in 0..900 {
        w.step()
            .unwrap_or_else(|e| panic!("settle, step {step}: {e:?}"));
        if step >= 840 {
            let fastest = top_speed(&w);
            slowest_tail = slowest_tail.max(fastest);
        }
    }
    assert!(
        slowest_tail < 0.05,
        "still moving at {slowest_tail} m/s after 15 s"
    );
}

/// A very soft, heavy fabric (10 N/m, 1 kg/m²) hanging from two corners is stretched hard and
/// compressed sideways next to its pins; its elements must not flip back and forth every step
/// (a period-2 cycle at ~1 m/s kept the corotated cloth from ever resting).
#[test]
fn a_soft_heavy_cloth_hanging_from_two_corners_rests() {
    let mats = [Material {
        stiffness: weft::membrane::isotropic(10.0, 0.3),
        density: 1.0,
        bending: 1e-5,
    }];
    let sheet = hanging_sheet(15, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    pin_top_corners(&mut w, &sheet);
    let mut tail = 0.0f32;
    for step in 0..1200 {
        w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        if step >= 1140 {
            tail = tail.max(top_speed(&w));
        }
    }
    assert!(tail < 0.05, "still moving at {tail} m/s after 20 s");
}

// ----- far from the origin -----

/// A hanging anisotropic cloth (17×17, 1 m, its vertices exactly representable at 10 km)
/// pinned at its top corners, one pin swept along x for the first 32 frames, leaning under
/// tilted gravity on a sphere behind it, translated by `offset` (m): steps it until it sleeps
/// (at most 2000 frames). Returns its positions in local coordinates shifted back by
/// `offset - origin` (in f64: the cloth at the origin's coordinates), the frame it fell
/// asleep and its origin.
fn translated_hanging_cloth(offset: [f32; 3]) -> (Vec<glam::DVec3>, Option<usize>, glam::DVec3) {
    let n = 17;
    let at = |p: [f32; 3]| [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]];
    let (mut sheet, settings) = hanging(n);
    sheet.transform(at);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let tilted = Settings {
        gravity: [0.0, 4.0, -9.0],
        ..sleepy(settings)
    };
    let mut w = world(&mut mem, &sheet, &mats, tilted);
    let sphere = Shape::Sphere {
        center: Vec3A::from(at([0.5, 0.25, 0.5])),
        radius: 0.25,
    };
    w.add_collider(Collider::new(sphere, 0.5, 0.005)).unwrap();
    let (a, b) = (sheet.index(0, n - 1), sheet.index(n - 1, n - 1));
    w.set_pin(a, sheet.positions[a as usize]).unwrap();
    let mut asleep = None;
    for frame in 0..2000 {
        if frame <= 32 {
            let mut t = sheet.positions[b as usize];
            t[0] -= frame as f32 / 256.0;
            w.set_pin(b, t).unwrap();
        }
        if w.step().unwrap().asleep {
            asleep = Some(frame);
            break;
        }
    }
    let back = w.origin() - glam::DVec3::from(offset.map(f64::from));
    let local = w.positions().iter().map(|x| x.as_dvec3() + back).collect();
    (local, asleep, w.origin())
}

/// At 10 km a cloth behaves as at the origin, with its pins and its collider given in the far
/// coordinates: it comes to rest and sleeps, and it moves exactly as the same cloth at zero and
/// 16 m from zero, whose local coordinates are the same (each is given the origin of its own
/// place on the 4 m grid: 10,000 m, 16 m, zero). With the 64 m grid of before, the cloths at
/// 16 m and at 10 km (16 m past the origin 9,984 m) were simulated 16 m from local zero and
/// ended 1.6 mm from the cloth at zero: what `f32` rounding at 16 m instead of 1 m does to a
/// scene with sticking contacts. (Simulated in absolute `f32` the far cloth never slept: slow
/// vertices' moves were rounded away while their velocities stayed.)
#[test]
fn a_cloth_10_km_away_rests_and_sleeps_as_at_the_origin() {
    let (near, near_asleep, near_origin) = translated_hanging_cloth([0.0; 3]);
    let (near16, near16_asleep, near16_origin) = translated_hanging_cloth([16.0, 0.0, 0.0]);
    let (far, far_asleep, far_origin) = translated_hanging_cloth([10_000.0, 0.0, 0.0]);
    assert_eq!(near_origin, glam::DVec3::ZERO);
    assert_eq!(near16_origin, glam::DVec3::new(16.0, 0.0, 0.0));
    assert_eq!(far_origin, glam::DVec3::new(10_000.0, 0.0, 0.0));
    eprintln!("asleep at {near_asleep:?} / {near16_asleep:?} / {far_asleep:?}");
    assert!(near_asleep.is_some(), "the cloth at the origin never slept");
    assert!(far_asleep.is_some(), "the cloth 10 km away never slept");
    for (other, at) in [(&near16, "16 m"), (&far, "10 km")] {
        assert_eq!(
            *other, near,
            "the cloth {at} away moved otherwise than the one at zero"
        );
    }
    assert_eq!(far_asleep, near_asleep);
    assert_eq!(near16_asleep, near_asleep);
}

/// `set_origin` re-expresses the world around a new origin and `shift_origin` follows the
/// caller's recentering; neither moves anything in the caller's coordinates (but for one
/// rounding), and localization's frames are in the caller's coordinates.
#[test]
fn set_and_shift_origin_keep_the_cloth_where_the_caller_sees_it() {
    use glam::DVec3;
    use weft::localize::{prepare, StrainMeasure, VertexFrame};
    let (mut sheet, settings) = hanging(5);
    sheet.transform(|p| [p[0] + 10_000.0, p[1] - 3000.0, p[2] + 200.0]);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, settings);
    assert_eq!(w.origin(), DVec3::new(10_000.0, -3000.0, 200.0));
    let centre = [10_000.5, -2999.75, 200.5];
    let sphere = Shape::Sphere {
        center: Vec3A::from(centre),
        radius: 0.25,
    };
    w.add_collider(Collider::new(sphere, 0.5, 0.005)).unwrap();
    w.set_pin(0, sheet.positions[0]).unwrap();
    for _ in 0..10 {
        w.step().unwrap();
    }
    let ulp = 1.0 / 1024.0; // of 10 km in f32
    let close = |a: &[[f32; 3]], b: &[[f32; 3]], shift: f32| {
        a.iter().zip(b).all(|(p, q)| {
            (p[0] - shift - q[0]).abs() <= ulp
                && (p[1] - q[1]).abs() <= ulp
                && (p[2] - q[2]).abs() <= ulp
        })
    };
    let before = caller_positions(&w);
    let mut frames = vec![VertexFrame::REST; w.vertex_count()];
    prepare(&w, StrainMeasure::Corotated, &mut frames).unwrap();
    for (f, p) in frames.iter().zip(&before) {
        assert_eq!(f.p.to_array(), *p, "frames are in the caller's coordinates");
    }
    let local = w.to_local(centre);
    assert_eq!(local, Vec3A::new(0.5, 0.25, 0.5));
    assert!(
        matches!(w.collider(0).unwrap().shape, Shape::Sphere { center, .. } if center == local)
    );

    w.set_origin(DVec3::new(9984.0, -3008.0, 192.0)).unwrap();
    assert!(
        close(&before, &caller_positions(&w), 0.0),
        "set_origin moved the cloth"
    );
    let Shape::Sphere { center, .. } = w.collider(0).unwrap().shape else {
        panic!("not a sphere")
    };
    assert_eq!(center, Vec3A::new(16.5, 8.25, 8.5));
    let kept = w.positions().to_vec();
    w.shift_origin(DVec3::new(10_000.0, 0.0, 0.0)).unwrap();
    assert_eq!(w.positions(), &kept[..], "shift_origin moved the world");
    assert_eq!(w.origin(), DVec3::new(-16.0, -3008.0, 192.0));
    assert!(close(&before, &caller_positions(&w), 10_000.0));
    assert_eq!(
        w.set_origin(DVec3::NAN),
        Err(weft::world::EditError::NonFinite)
    );
    assert_eq!(
        w.shift_origin(DVec3::INFINITY),
        Err(weft::world::EditError::NonFinite)
    );
    assert_eq!(w.origin(), DVec3::new(-16.0, -3008.0, 192.0));
    w.step().unwrap();
}

/// A cloth resting on a sphere with the default settings (one substep) is not redone at every
/// step, and comes to rest. It used to be: the contacts' slop held the vertices just above the
/// sphere at the drape's rim and drew them toward it against the membrane that held them up,
/// which put energy in at nearly every step, and the energy balance redid those steps with two
/// substeps (3× the cost; 304 / 5 / 535 of 600 redone at 21 / 31 / 41 per side). A contact
/// now only pushes (`contacts::release`).
///
/// When the drape stops sliding is friction's stick and slip, a lottery at 41×41: the drop
/// turned to 8 orientations about the vertical (2026-11-28) is at rest (below 1 mm/s) after
/// 317–805 steps, and one of them (0.3 rad) still slides at 2.4e-2 m/s at step 600 (README,
/// "The default, re-examined"); at 21 and 31 per side every orientation rests after 213–360
/// steps. So the 41×41 drape is dropped in all 8 orientations and watched for 1,000 steps, and
/// the smaller ones in one for 600: one orientation used to be the test at every size, and a
/// change of round-off elsewhere could fail it.
#[test]
fn a_drape_resting_on_a_sphere_is_not_redone_at_every_step() {
    let runs = (0..8)
        .map(|k| (41usize, 0.1 * k as f32, 1000u32))
        .chain([(21, 0.0, 600), (31, 0.0, 600)]);
    for (n, angle, steps) in runs {
        let sheet = drape_sheet(n, angle);
        let mats = [anisotropic()];
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, Settings::default());
        w.add_collider(drape_sphere()).unwrap();
        let redone: u32 = (0..steps).map(|_| w.step().unwrap().redone.min(1)).sum();
        let fastest = top_speed(&w);
        println!(
            "{n}×{n}, {angle:.1} rad: {redone} of {steps} steps redone, fastest vertex \
             {fastest:.1e} m/s"
        );
        assert!(
            redone <= steps / 20,
            "{n}×{n}, {angle:.1} rad: {redone} of {steps} redone"
        );
        assert!(
            fastest < 1e-2,
            "{n}×{n}, {angle:.1} rad: still sliding at {fastest} m/s"
        );
    }
}

/// An `n × n` sheet over `size` metres, flat, two contact thicknesses (`thickness`) above the
/// top of a sphere of radius `0.3 size` at the origin (friction 0.5): the study's drape.
fn over_a_small_sphere(n: usize, size: f32, thickness: f32) -> (Sheet, Collider) {
    let radius = 0.3 * size;
    let mut sheet = Sheet::grid(n, n, size, size);
    sheet.transform(|p| {
        [
            p[0] - 0.5 * size,
            p[1] - 0.5 * size,
            radius + 2.0 * thickness,
        ]
    });
    let sphere = Shape::Sphere {
        center: Vec3A::ZERO,
        radius,
    };
    (sheet, Collider::new(sphere, 0.5, thickness))
}

/// A fine cloth on a sphere with a thin contact layer, at the default 60 Hz and one substep, is
/// not redone at every step. It was: the contact slop had a part for gravity's fall in a substep
/// (`g h²`, 2.7 mm here, against the slop's 0.1 mm tenth of the thickness), every vertex the
/// membrane held within it above the sphere was held by its own contact and drawn toward it,
/// and the contacts still pulling after the release rounds did work on the cloth: the energy
/// balance redid all 60 steps (7.5× the time the run takes now). Such a vertex is now held only
/// where the solve carries it in (`contacts::engage`).
#[test]
fn a_fine_cloth_on_a_sphere_at_60_hz_is_not_redone_at_every_step() {
    // 49 × 49 vertices over 16 cm (3.3 mm edges), 2 mm above a sphere of radius 4.8 cm with a
    // contact thickness of 1 mm, held by its central 2 × 2 vertices (a free one slides off)
    let n = 49usize;
    let (sheet, sphere) = over_a_small_sphere(n, 0.16, 0.001);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    let c = n / 2;
    for (i, j) in [(c, c), (c + 1, c), (c, c + 1), (c + 1, c + 1)] {
        let k = sheet.index(i, j);
        w.set_pin(k, sheet.positions[k as usize]).unwrap();
    }
    w.add_collider(sphere).unwrap();
    let steps = 60;
    let redone: u32 = (0..steps).map(|_| w.step().unwrap().redone.min(1)).sum();
    println!(
        "{redone} of {steps} steps redone, fastest vertex {:.1e} m/s",
        top_speed(&w)
    );
    assert!(redone <= steps / 20, "{redone} of {steps} steps redone");
}

/// Cloth lying on the floor peels off it when a corner is lifted: a contact only pushes. A
/// contact that held a vertex at the surface's velocity whatever its impulse glued the cloth
/// to the floor (measured: the lifted corner's edge stretched 25× in 1.5 s).
#[test]
fn cloth_lying_on_the_floor_peels_off_when_a_corner_is_lifted() {
    let n = 21usize;
    let mut sheet = Sheet::grid(n, n, 1.0, 1.0);
    sheet.transform(|p| [p[0], p[1], 0.0055]);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    let floor = Shape::Plane {
        normal: Vec3A::Z,
        offset: 0.0,
    };
    w.add_collider(Collider::new(floor, 0.5, 0.005)).unwrap();
    for _ in 0..60 {
        w.step().unwrap();
    }
    let corner = sheet.index(0, 0);
    let start = w.positions()[corner as usize];
    let rest = 1.0 / (n - 1) as f32;
    let mut worst = 0.0f32;
    let (mut resolved, mut resolve_iterations) = (0, 0);
    // lift the corner 1 m in 1 s
    for s in 1..=60 {
        let t = s as f32 / 60.0;
        w.set_pin(corner, (start + Vec3A::Z * t).to_array())
            .unwrap();
        let stats = w.step().unwrap();
        // `StepStats`: one solve per substep plus one per release round; the first solves'
        // iterations are part of all of them, and all of them when nothing was let go.
        assert!(stats.solves >= stats.substeps, "{stats:?}");
        assert!(stats.first_iterations <= stats.iterations, "{stats:?}");
        if stats.solves == stats.substeps {
            assert_eq!(stats.first_iterations, stats.iterations, "{stats:?}");
        } else {
            resolved += 1;
            resolve_iterations += stats.iterations - stats.first_iterations;
        }
        let x = w.positions();
        for (a, b) in [(0, 1), (0, n), (1, n + 1), (n, n + 1)] {
            worst = worst.max((x[a] - x[b]).length() / rest - 1.0);
        }
    }
    let x = w.positions();
    let neighbour = x[sheet.index(1, 1) as usize];
    println!(
        "worst strain near the corner {worst:.3}, its neighbour at {neighbour}, {resolved} steps let contacts go"
    );
    assert!(
        resolved > 0 && resolve_iterations > 0,
        "peeling off the floor lets contacts go, and solves again: {resolved}, {resolve_iterations}"
    );
    // (the jerk of starting at 1 m/s from rest stretches them ~26 %; glued, 2500 %)
    assert!(worst < 0.5, "the corner's edges stretched by {worst}");
    assert!(
        neighbour.z > 0.8,
        "the corner's neighbour stayed down: {neighbour}"
    );
}

/// A fine cloth (1.25 mm edges, 1 mm contact thickness) draped over a small sphere comes to
/// rest with one substep as with two, in the same place. Letting go of a pulling contact only
/// at the next substep made such a cloth churn: hundreds of vertices per step held, let go,
/// fallen in and projected out, still moving at 0.29 m/s after 1 s (129×129 vertices).
///
/// "The same place" is to within where friction lets each drape stop, which round-off decides:
/// over 16 runs whose solver tolerance was scaled by 0.99 … 1.01 (2026-11-28, a scratch build;
/// the unscaled one among them) the two rest states were 0.15–3.4 mm apart on average (median
/// 1.8 mm), and the one-substep drape's fastest vertex moved at 0.5–8.3 mm/s. The bound was 2 %
/// of the cloth's size (3.2 mm), inside that spread: one run in 16 failed it. It is 5 % (8 mm)
/// now, beyond the spread; the churn it guards against is the speed bound's to catch.
#[test]
fn a_fine_drape_rests_with_one_substep_as_with_two() {
    let (n, size) = (129usize, 0.16f32);
    let drape = |substeps: u32| {
        let d = fine_drape(n, size, substeps, Solver::Multigrid);
        (d.positions, d.fastest)
    };
    let (one, fastest_one) = drape(1);
    let (two, fastest_two) = drape(2);
    let apart = mean_distance(&one, &two);
    println!("one substep {fastest_one:.1e} m/s, two {fastest_two:.1e} m/s, {apart:.1e} m apart");
    assert!(
        fastest_one < 0.02,
        "one substep: still moving at {fastest_one} m/s"
    );
    assert!(apart < 0.05 * size, "{apart} m apart on a {size} m cloth");
}

/// The mean distance (m) between the vertices of two runs of the same mesh.
fn mean_distance(a: &[Vec3A], b: &[Vec3A]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (*p - *q).length())
        .sum::<f32>()
        / a.len() as f32
}

/// What [`fine_drape`] leaves.
struct Drape {
    positions: Vec<Vec3A>,
    fastest: f32,
    iterations: u32,
    unconverged: u32,
}

/// The study's drape over a small sphere ([`over_a_small_sphere`]): an `n × n` anisotropic
/// cloth `size` metres wide, pinned at its centre, stepped 120 times at 120 Hz with `substeps`
/// and `solver`.
fn fine_drape(n: usize, size: f32, substeps: u32, solver: Solver) -> Drape {
    let (sheet, sphere) = over_a_small_sphere(n, size, 0.001);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        substeps,
        time_step: 1.0 / 120.0,
        damping_mass: 5.0,
        damping_stiffness: 0.01,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    w.set_solver(solver);
    w.add_collider(sphere).unwrap();
    let centre = sheet.index(n / 2, n / 2);
    w.set_pin(centre, w.positions()[centre as usize].to_array())
        .unwrap();
    let (mut iterations, mut unconverged) = (0, 0);
    for _ in 0..120 {
        let s = w.step().unwrap();
        iterations += s.iterations;
        unconverged += u32::from(!s.converged);
    }
    Drape {
        positions: w.positions().to_vec(),
        fastest: top_speed(&w),
        iterations,
        unconverged,
    }
}

/// Coulomb friction on an incline steeper than the friction angle: the cloth slides down with
/// the acceleration of a block, `g (sin θ − μ cos θ)`, and one below it stays put
/// (`engine_api.rs`: sticking contacts).
#[test]
fn cloth_on_an_incline_steeper_than_its_friction_angle_slides_at_coulombs_rate() {
    let (theta, mu) = (0.54f32, 0.4f32); // tan θ = 0.6
    let normal = Vec3A::new(0.0, -theta.sin(), theta.cos());
    let down = Vec3A::new(0.0, -theta.cos(), -theta.sin());
    let mut sheet = Sheet::grid(11, 11, 0.3, 0.3);
    sheet.transform(|p| {
        let p = Vec3A::new(p[0], p[1] * theta.cos(), p[1] * theta.sin()) + normal * 0.0055;
        p.to_array()
    });
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::GRAVITY | effects::COLLISION,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let incline = Shape::Plane {
        normal,
        offset: 0.0,
    };
    w.add_collider(Collider::new(incline, mu, 0.005)).unwrap();
    let steps = 30;
    for _ in 0..steps {
        w.step().unwrap();
    }
    let mean = w.velocities().iter().sum::<Vec3A>() / w.velocities().len() as f32;
    let g = 9.81f32;
    let expected = g * (theta.sin() - mu * theta.cos()) * steps as f32 / 60.0;
    let along = mean.dot(down);
    println!("sliding at {along} m/s, a block would at {expected}");
    assert!(
        (along - expected).abs() < 0.05 * expected,
        "{along} m/s down the incline, a block {expected}"
    );
    assert!(mean.dot(normal).abs() < 1e-3, "off the incline: {mean}");
}

/// The bending force is the gradient of the bending energy, on the couplings of both patterns
/// (the edges' blocks and the scalars of the two vertices opposite each hinge, which share no
/// edge). A soft anisotropic sheet is bent round a cylinder (membrane energy ~1e-5 of the
/// bending energy), released at rest without gravity or damping; one step of 10 µs gives the
/// force, `f = M Δv / h` (the implicit part, `h² K / M ~ 1e-7`, is negligible), and central
/// differences of the world's own energy along random directions must match `−f · d`.
/// Without the hinge-only forces, `−f · d` was 0.083 J/m along the first direction, against
/// an energy slope of 0.003.
#[test]
fn bending_forces_are_the_gradient_of_the_bending_energy() {
    let mats = [Material {
        stiffness: [[1e-2, 2e-3, 0.0], [2e-3, 5e-3, 0.0], [0.0, 0.0, 3e-3]],
        density: 0.15,
        bending: 1e-4,
    }];
    let radius = 0.1f32;
    let mut sheet = Sheet::grid(11, 11, 0.3, 0.3);
    sheet.transform(|p| {
        let a = (p[0] - 0.15) / radius;
        [radius * a.sin(), p[1], radius * (1.0 - a.cos())]
    });
    let settings = Settings {
        effects: effects::WARPING | effects::BENDING,
        time_step: 1e-5,
        substeps: 1,
        gravity: [0.0; 3],
        tolerance: 1e-7,
        max_iterations: 500,
        ..Settings::default()
    };
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let e = w.energy();
    assert!(e.bending > 1e4 * e.elastic, "{e:?}");
    let x0: Vec<[f32; 3]> = w.positions().iter().map(|p| p.to_array()).collect();
    let masses = w.masses().to_vec();
    let stats = w.step().unwrap();
    assert!(stats.converged && stats.redone == 0, "{stats:?}");
    let f: Vec<Vec3A> = w
        .velocities()
        .iter()
        .zip(&masses)
        .map(|(v, &m)| *v * (m / settings.time_step))
        .collect();
    let mut uniform = uniform(0x2545_f491);
    let eps = 1e-4f32;
    for _ in 0..4 {
        let d: Vec<Vec3A> = (0..x0.len())
            .map(|_| Vec3A::new(uniform(), uniform(), uniform()))
            .collect();
        let mut potential = |s: f32| {
            let x: Vec<[f32; 3]> = x0
                .iter()
                .zip(&d)
                .map(|(p, di)| (Vec3A::from(*p) + s * *di).to_array())
                .collect();
            w.set_positions(&x).unwrap();
            let e = w.energy();
            e.elastic + e.bending
        };
        let slope = (potential(eps) - potential(-eps)) / (2.0 * f64::from(eps));
        let work: f64 = f.iter().zip(&d).map(|(f, d)| f64::from(f.dot(*d))).sum();
        // Measured: within 0.02–0.4 % of the slope. The floor covers the cancellation of a
        // sum of terms of both signs (`Σ |f_i| |d_i|` is ~300× the slope).
        let scale: f64 = f
            .iter()
            .zip(&d)
            .map(|(f, d)| f64::from(f.length() * d.length()))
            .sum();
        assert!(
            (slope + work).abs() <= 0.02 * work.abs() + 1e-4 * scale,
            "dE/ds {slope:e} against −f·d {:e} (scale {scale:e})",
            -work
        );
    }
}

/// An engine that moves a hanging cloth with `set_positions` (pinned vertices included, pins
/// left where they are) gets it carried back to its pins over the next step as by moving pins,
/// with no energy removed and no step refused.
#[test]
fn positions_set_away_from_their_pins_are_carried_back() {
    let sheet = hanging_sheet(11, 0.5);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, Settings::default());
    pin_top_corners(&mut w, &sheet);
    for _ in 0..30 {
        w.step().unwrap();
    }
    let moved: Vec<[f32; 3]> = w
        .positions()
        .iter()
        .map(|p| [p.x + 0.3, p.y - 0.2, p.z + 0.1])
        .collect();
    w.set_positions(&moved).unwrap();
    for step in 0..120 {
        let s = w.step();
        assert!(
            s.is_ok_and(|s| s.energy_removed == 0.0),
            "step {step} after the cloth was moved: {s:?}"
        );
    }
    let (a, b) = (sheet.index(0, 10) as usize, sheet.index(10, 10) as usize);
    for k in [a, b] {
        let off = w.positions()[k].distance(Vec3A::from(sheet.positions[k]));
        assert!(off < 1e-5, "pinned vertex {k} is {off} m off its target");
    }
}

/// An 11×11 anisotropic cloth hanging in a vertical plane from its four corners, its middle
/// pushed out 5.5 cm by a sphere with friction, no damping and no drag, its pins, sphere and
/// velocities all carried at `u`: after `steps`, its positions and velocities relative to the
/// carried frame.
fn carried(u: Vec3A, steps: usize) -> (Vec<Vec3A>, Vec<Vec3A>) {
    let mats = [anisotropic()];
    let sheet = hanging_sheet(11, 0.5);
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::GRAVITY
            | effects::BENDING
            | effects::PINS
            | effects::COLLISION
            | effects::WARPING,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mats, settings);
    let corners = [(0, 0), (10, 0), (0, 10), (10, 10)].map(|(i, j)| sheet.index(i, j));
    let pin_at = |c: u32, t: f32| (Vec3A::from(sheet.positions[c as usize]) + u * t).to_array();
    let sphere = |t: f32| Shape::Sphere {
        center: Vec3A::new(0.25, -0.1, 0.25) + u * t,
        radius: 0.15,
    };
    for &c in &corners {
        w.set_pin(c, pin_at(c, 0.0)).unwrap();
    }
    w.add_collider(Collider::new(sphere(0.0), 0.3, 0.005))
        .unwrap();
    w.set_velocities(&vec![u.to_array(); w.vertex_count()])
        .unwrap();
    let mut t = 0.0;
    for _ in 0..steps {
        t += settings.time_step;
        for &c in &corners {
            w.set_pin(c, pin_at(c, t)).unwrap();
        }
        w.set_collider_shape(0, sphere(t)).unwrap();
        w.step().unwrap();
    }
    (
        w.positions().iter().map(|&x| x - u * t).collect(),
        w.velocities().iter().map(|&v| v - u).collect(),
    )
}

/// Galilean invariance: the scene of [`carried`] moving as a whole at 2 m/s does what it does
/// at rest (to f32 round-off). A vertex held by its own contact and by nearly parallel edge
/// contacts beside it used to read the common motion along the edge normals' tilt as an
/// approach and be pushed off (at 1 m/s the vertex at the sphere's pole left it at 0.11 m/s in
/// step 7):
/// here the cloth ended 1.0 mm and 5.7e-4 m/s from the one at rest; now 3e-7 m and 1.4e-5
/// m/s.
#[test]
fn a_scene_carried_as_a_whole_moves_as_at_rest() {
    let steps = 90;
    let (x0, v0) = carried(Vec3A::ZERO, steps);
    let (x1, v1) = carried(Vec3A::new(1.5, 0.5, -1.0), steps);
    let apart = |a: &[Vec3A], b: &[Vec3A]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| (*p - *q).length())
            .fold(0.0f32, f32::max)
    };
    let pushed = x0.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(pushed > 0.05, "the sphere pushes the cloth out: {pushed} m");
    let (dx, dv) = (apart(&x0, &x1), apart(&v0, &v1));
    assert!(
        dx < 2e-5 && dv < 2e-4,
        "{dx} m and {dv} m/s from the cloth at rest"
    );
}

/// A 41 × 41 sheet of a ribbed material (23 times stiffer along `u` than along `v`, as the
/// `ribbed` bench cell) hanging from two corners, stepped with the multilevel solver and with
/// its line smoothing (`Solver::MultigridLines`): the lines take fewer CG iterations
/// (measured 2026-11-29: 262 against 454 over 30 steps; the coarse levels, aggregated alike
/// in every direction and smoothed by block Jacobi, keep the rest), and the cloth moves the
/// same to within what the tolerance leaves (0.13 mm apart on average after 30 steps).
#[test]
fn line_smoothing_solves_a_ribbed_cloth_in_fewer_iterations_to_the_same_motion() {
    let ribbed = Material {
        stiffness: [[2300.0, 30.0, 0.0], [30.0, 100.0, 0.0], [0.0, 0.0, 40.0]],
        density: 0.15,
        bending: 1e-4,
    };
    let n = 41;
    let run = |solver: Solver| {
        let sheet = Sheet::grid(n, n, 1.0, 1.0);
        let mats = [ribbed];
        let mut mem = memory(&sheet.capacity());
        let mut w = world(&mut mem, &sheet, &mats, Settings::default());
        w.set_solver(solver);
        for corner in [sheet.index(0, n - 1), sheet.index(n - 1, n - 1)] {
            let p = w.positions()[corner as usize].to_array();
            w.set_pin(corner, p).unwrap();
        }
        let mut iterations = 0;
        for step in 0..30 {
            let s = w
                .step()
                .unwrap_or_else(|e| panic!("{solver:?}, step {step}: {e:?}"));
            assert!(s.converged, "{solver:?}, step {step}: {s:?}");
            iterations += s.iterations;
        }
        (iterations, w.positions().to_vec())
    };
    let (plain, x_plain) = run(Solver::Multigrid);
    let (lines, x_lines) = run(Solver::MultigridLines);
    let apart = mean_distance(&x_plain, &x_lines);
    println!("CG iterations: {plain} plain, {lines} with lines; {apart:e} m apart");
    assert!(
        4 * lines <= 3 * plain,
        "{lines} CG iterations with lines, {plain} without"
    );
    assert!(apart < 1e-3, "{apart} m apart");
}

/// Where no coupling dominates its vertex's others (an isotropic material, or a weave's, as
/// stiff along `u` as along `v`) the line smoother makes no lines and is the multilevel solver
/// itself, bit for bit (linked wherever a vertex's two strongest couplings were mutual, the
/// weave's sheet of the `woven` bench cell took 225 CG iterations a step at 41 × 41 against
/// 37, and with only its borders linked 77); and on the fine, bending-
/// dominated drape of [`a_fine_drape_rests_with_one_substep_as_with_two`] at 33 × 33 (5 mm
/// edges: its anisotropic membrane makes lines along its stiff direction) every solve still
/// converges, in no more CG iterations than without lines. Smoothed along the lines of `A`
/// itself, whose bending part along a line (a plate's `[−8, 20, −8]`) leaves
/// `λ_max(T⁻¹A) ≈ 4`, that drape took 151 CG iterations a step and 53 of its 120 solves did
/// not converge (without lines: 28 and none); the lines of `Ã`, whose diagonal holds the
/// hinge couplings' weights, take 23.
#[test]
fn line_smoothing_is_the_plain_solver_without_lines_and_stays_convergent_on_a_plate() {
    let woven = Material {
        stiffness: [
            [3000.0, 300.0, 0.0],
            [300.0, 3000.0, 0.0],
            [0.0, 0.0, 320.0],
        ],
        density: 0.15,
        bending: 1e-4,
    };
    for material in [isotropic(1000.0, 0.3, 0.15), woven] {
        let sheet = Sheet::grid(41, 41, 1.0, 1.0);
        let mats = [material];
        let run = |solver: Solver| {
            let mut mem = memory(&sheet.capacity());
            let mut w = world(&mut mem, &sheet, &mats, Settings::default());
            w.set_solver(solver);
            for corner in [sheet.index(0, 40), sheet.index(40, 40)] {
                let p = w.positions()[corner as usize].to_array();
                w.set_pin(corner, p).unwrap();
            }
            for _ in 0..20 {
                w.step().unwrap();
            }
            w.positions().to_vec()
        };
        assert!(
            run(Solver::Multigrid) == run(Solver::MultigridLines),
            "{material:?}: lines made"
        );
    }

    let drape = |solver: Solver| {
        let d = fine_drape(33, 0.16, 1, solver);
        (d.iterations, d.unconverged)
    };
    let (plain, _) = drape(Solver::Multigrid);
    let (lines, unconverged) = drape(Solver::MultigridLines);
    println!("drape: {plain} CG iterations plain, {lines} with lines ({unconverged} unconverged)");
    assert_eq!(
        unconverged, 0,
        "{unconverged} of 120 steps unconverged with lines"
    );
    assert!(
        lines <= plain,
        "{lines} CG iterations with lines, {plain} without"
    );
}

/// A step that breaks down or overflows at every substep count holds the cloth still, and the
/// next step goes on from rest. Failing kept the start, velocities and all, and every later
/// call failed the same way (adversarial scene 16050: a stiff cloth an unconverged solve had
/// left with a vertex at 169 m/s failed at each of its last 25 calls). Here one vertex of a
/// hanging cloth is given 1e18 m/s: at any substep count its first substep throws it beyond
/// what `f32` energies hold.
#[test]
fn a_step_that_fails_at_every_substep_count_holds_the_cloth_still() {
    let (sheet, settings) = hanging(9);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, settings);
    pin_top_corners(&mut w, &sheet);
    for _ in 0..5 {
        w.step().unwrap();
    }
    let before: Vec<Vec3A> = w.positions().to_vec();
    let mut v: Vec<[f32; 3]> = w.velocities().iter().map(|&v| v.into()).collect();
    v[40] = [0.0, 1e18, 0.0];
    w.set_velocities(&v).unwrap();
    let held = w.step().expect("held still, not failed");
    assert!(held.stopped, "{held:?}");
    assert!(held.redone >= 3, "{held:?}");
    assert_eq!(w.positions(), &before[..], "held where it started");
    assert!(w.velocities().iter().all(|&v| v == Vec3A::ZERO));
    // and from rest it steps on
    for step in 0..10 {
        let s = w
            .step()
            .unwrap_or_else(|e| panic!("step {step} after the hold: {e:?}"));
        assert!(!s.stopped, "step {step} after the hold: {s:?}");
    }
    assert!(w.positions().iter().all(|p| p.is_finite()));
}
