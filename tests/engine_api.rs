//! What an engine programmer reaches for (issue 14, "Engine API"): forces, impulses and mass
//! scales; per-axis pins; vertex ranges and rigid teleports; collider ids; strain read-back.
//! Each against a closed form or an invariant.

mod common;

use common::*;
use glam::{DMat3, DVec3, Quat, Vec3A};
use weft::strided::Strided;
use weft::world::{effects, EditError, PinAxes, Settings, World};

/// Σ m v (kg·m/s), in f64.
fn momentum(w: &World<'_>) -> DVec3 {
    w.velocities()
        .iter()
        .zip(w.masses())
        .map(|(v, &m)| v.as_dvec3() * m as f64)
        .sum()
}

/// Only warped (Green-strain) elasticity: no gravity, damping, bending, pins or contact.
fn free_settings() -> Settings {
    Settings {
        effects: effects::WARPING,
        tolerance: 1e-6,
        max_iterations: 500,
        ..Settings::default()
    }
}

/// A slightly deformed, anisotropic 7×7 sheet: its internal forces are not zero.
fn deformed_sheet() -> common::Sheet {
    let mut sheet = Sheet::grid(7, 7, 1.0, 1.0);
    sheet.transform(|p| {
        [
            p[0] * 1.03,
            p[1] * 0.98 + 0.02 * p[0],
            0.05 * (p[0] * 3.0).sin(),
        ]
    });
    sheet
}

/// A different force on every vertex, some of them zero.
fn forces(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| {
            let t = i as f32;
            [
                0.01 * (t * 0.7).sin(),
                -0.02 * (t * 1.3).cos(),
                0.015 * (i % 3) as f32,
            ]
        })
        .collect()
}

/// Applied forces act for one step: the momentum grows by exactly Σ F·dt per step (internal
/// forces sum to zero), the forces are cleared after the step, and the energy balance counts
/// their work as input (no step is redone or loses energy for it).
#[test]
fn applied_forces_change_momentum_by_their_impulse_and_are_cleared() {
    let mat = [anisotropic()];
    let sheet = deformed_sheet();
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, free_settings());
    let n = w.vertex_count();
    let f = forces(n);
    let total: DVec3 = f.iter().map(|f| Vec3A::from(*f).as_dvec3()).sum();
    let dt = w.settings().time_step as f64;
    let p0 = momentum(&w);
    for step in 1..=20 {
        w.add_forces(0, &Strided::from_slice(&f)).unwrap();
        assert_eq!(w.applied_forces()[n - 1], f[n - 1]);
        let s = w.step().unwrap();
        assert!(w.applied_forces().iter().all(|&f| f == [0.0; 3]));
        assert_eq!((s.redone, s.energy_removed), (0, 0.0), "step {step}: {s:?}");
        let expected = p0 + total * dt * step as f64;
        let drift = (momentum(&w) - expected).length();
        assert!(
            drift < 1e-4 * expected.length(),
            "step {step}: drift {drift}"
        );
    }
    // not applied again: the momentum stays
    let p = momentum(&w);
    w.step().unwrap();
    assert!((momentum(&w) - p).length() < 1e-4 * p.length());
}

/// A uniform force on a free cloth moves it rigidly: implicit Euler's step from `v₀` is
/// `v₁ = v₀ + h F/m`, `Δx = h v₁`, so the balance `ΔE_kin − F·Δx` is exactly its numerical
/// dissipation `−Σ ½ m (h a)²` for `F = m a`. Without the force's work counted it would be `+ΔE_kin`, a gain
/// that redoes every step.
#[test]
fn the_work_of_applied_forces_enters_the_energy_balance() {
    let mat = [isotropic(500.0, 0.3, 0.2)];
    let sheet = Sheet::grid(5, 5, 0.5, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, free_settings());
    // (proportional to mass, so that it accelerates every vertex alike)
    let a = 0.5f32;
    let push: Vec<[f32; 3]> = w.masses().iter().map(|&m| [0.0, 0.0, m * a]).collect();
    let h = w.settings().time_step as f64;
    let dissipation = 0.5 * w.total_mass() * (h * a as f64).powi(2);
    for _ in 0..30 {
        w.add_forces(0, &Strided::from_slice(&push)).unwrap();
        let s = w.step().unwrap();
        assert_eq!(s.redone, 0, "{s:?}");
        let error = (s.energy_gain as f64 + dissipation).abs();
        assert!(error < 1e-3 * dissipation, "{s:?}, expected −{dissipation}");
    }
}

/// Forces on a range add to what was applied; a range past the end, or a NaN, changes nothing.
#[test]
fn forces_on_a_range_add_up_and_bad_input_changes_nothing() {
    let mat = [anisotropic()];
    let sheet = deformed_sheet();
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, free_settings());
    let n = w.vertex_count();
    // every 2nd float of an interleaved buffer: [fx fy fz pad]
    let interleaved: Vec<[f32; 4]> = (0..3).map(|k| [k as f32, 1.0, 2.0, 99.0]).collect();
    let bytes: &[u8] = bytemuck::cast_slice(&interleaved);
    let src = Strided::<3>::new(bytes, 16, 3).unwrap();
    w.add_forces(10, &src).unwrap();
    w.add_forces(10, &src).unwrap();
    assert_eq!(w.applied_forces()[12], [4.0, 2.0, 4.0]);
    assert_eq!(w.applied_forces()[9], [0.0; 3]);
    let before: Vec<[f32; 3]> = w.applied_forces().to_vec();
    assert_eq!(w.add_forces(n - 2, &src), Err(EditError::VertexOutOfRange));
    let bad = [[0.0, f32::NAN, 0.0]];
    assert_eq!(
        w.add_forces(0, &Strided::from_slice(&bad)),
        Err(EditError::NonFinite)
    );
    assert_eq!(w.applied_forces(), &before[..]);
}

/// An impulse changes a free vertex's velocity by J/m at once.
#[test]
fn impulses_change_velocity_by_impulse_over_mass() {
    let mat = [anisotropic()];
    let sheet = deformed_sheet();
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, free_settings());
    let j = [[0.0f32, 0.0, 0.002], [0.001, 0.0, 0.0]];
    let p0 = momentum(&w);
    w.add_impulses(5, &Strided::from_slice(&j)).unwrap();
    let m = w.masses()[5];
    assert!((w.velocities()[5].z - 0.002 / m).abs() < 1e-6 * (0.002 / m));
    let dp = momentum(&w) - p0;
    assert!((dp - DVec3::new(0.001, 0.0, 0.002)).length() < 1e-9);
    // the next step conserves it (no forces, no gravity)
    w.step().unwrap();
    let drift = (momentum(&w) - p0 - dp).length();
    assert!(drift < 1e-3 * dp.length(), "{drift}");
}

/// A mass scale multiplies the material's lumped mass (it does not compound), and the step's
/// inertia uses it: forces proportional to the material masses accelerate a cloth whose
/// masses are doubled at half the rate, uniformly (a rigid translation, closed form `v = a t`).
#[test]
fn mass_scales_set_the_masses_the_step_uses() {
    let mat = [anisotropic()];
    let sheet = Sheet::grid(6, 6, 0.5, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, free_settings());
    let n = w.vertex_count();
    let rest: Vec<f32> = w.masses().to_vec();
    let total = w.total_mass();
    let twice = vec![[2.0f32]; n];
    w.set_mass_scales(0, &Strided::from_slice(&twice)).unwrap();
    w.set_mass_scales(0, &Strided::from_slice(&twice)).unwrap();
    for (m, r) in w.masses().iter().zip(&rest) {
        assert_eq!(*m, 2.0 * r);
    }
    assert!((w.total_mass() - 2.0 * total).abs() < 1e-6 * total);
    let a = 0.3f32;
    let f: Vec<[f32; 3]> = rest.iter().map(|&m| [m * a, 0.0, 0.0]).collect();
    let steps = 12;
    for _ in 0..steps {
        w.add_forces(0, &Strided::from_slice(&f)).unwrap();
        w.step().unwrap();
    }
    let t = steps as f32 * w.settings().time_step;
    for v in w.velocities() {
        assert!((v.x - 0.5 * a * t).abs() < 1e-3 * a * t, "{v}");
    }
    // a heavier hem: the bottom row at 3×, then back to 1×
    w.set_mass_scales(0, &Strided::from_slice(&[[3.0f32]; 6]))
        .unwrap();
    assert_eq!(w.masses()[0], 3.0 * rest[0]);
    assert_eq!(w.masses()[6], 2.0 * rest[6]);
    w.set_mass_scales(0, &Strided::from_slice(&vec![[1.0f32]; n]))
        .unwrap();
    assert_eq!(w.masses(), &rest[..]);
}

#[test]
fn invalid_mass_scales_are_refused_by_vertex_and_change_nothing() {
    let mat = [anisotropic()];
    let sheet = Sheet::grid(4, 4, 0.5, 0.5);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, free_settings());
    let before = w.masses().to_vec();
    for (bad, err) in [
        (0.0, EditError::InvalidMassScale { vertex: 3 }),
        (-1.0, EditError::InvalidMassScale { vertex: 3 }),
        (1e-40, EditError::InvalidMassScale { vertex: 3 }),
        (f32::NAN, EditError::NonFinite),
    ] {
        let scales = [[1.5f32], [1.5], [bad]];
        assert_eq!(
            w.set_mass_scales(1, &Strided::from_slice(&scales)),
            Err(err)
        );
        assert_eq!(w.masses(), &before[..]);
    }
    assert_eq!(
        w.set_mass_scales(15, &Strided::from_slice(&[[1.0f32], [1.0]])),
        Err(EditError::VertexOutOfRange)
    );
}

/// Gravity, no damping: a cloth free to fall but held by per-axis pins.
fn rail_settings() -> Settings {
    Settings {
        effects: effects::WARPING | effects::GRAVITY | effects::PINS | effects::BENDING,
        tolerance: 1e-6,
        max_iterations: 1000,
        ..Settings::default()
    }
}

/// A rail inclined by θ in the x–z plane.
fn rail(theta: f32) -> Vec3A {
    Vec3A::new(theta.cos(), 0.0, -theta.sin())
}

/// Every vertex on a frictionless line along the same inclined rail: the cloth slides as one
/// body, and each vertex accelerates at g·sinθ along the rail. Implicit Euler is exact for the
/// velocity under a constant force, so `v = g sinθ t` to round-off, and nothing moves across
/// the rail.
#[test]
fn a_cloth_on_an_inclined_rail_accelerates_at_g_sin_theta() {
    let mat = [anisotropic()];
    let sheet = hanging_sheet(5, 0.3);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, rail_settings());
    let theta = 0.4f32;
    let d = rail(theta);
    for (i, p) in sheet.positions.iter().enumerate() {
        w.set_pin_axes(
            i as u32,
            *p,
            PinAxes::Line {
                direction: d.to_array(),
            },
        )
        .unwrap();
    }
    let steps = 30;
    for _ in 0..steps {
        let s = w.step().unwrap();
        assert_eq!((s.redone, s.energy_removed), (0, 0.0), "{s:?}");
    }
    let t = steps as f32 * w.settings().time_step;
    let expected = 9.81 * theta.sin() * t;
    for (v, (x, x0)) in w
        .velocities()
        .iter()
        .zip(w.positions().iter().zip(&sheet.positions))
    {
        assert!(
            (v.dot(d) - expected).abs() < 1e-4 * expected,
            "{v} vs {expected}"
        );
        assert!((*v - d * v.dot(d)).length() < 1e-5 * expected, "{v}");
        let moved = *x - Vec3A::from(*x0);
        assert!((moved - d * moved.dot(d)).length() < 1e-5, "{moved}");
    }
}

/// A curtain whose top row hangs from rings on an inclined rail: the rail only pushes across
/// itself and every other force is internal, so the momentum along the rail grows at exactly
/// `M g sinθ`, however the curtain swings: the rings slide freely.
#[test]
fn a_curtain_on_rings_slides_freely_along_its_rail() {
    let mat = [anisotropic()];
    let sheet = hanging_sheet(7, 0.4);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, rail_settings());
    let theta = 0.3f32;
    let d = rail(theta);
    for i in 0..sheet.nx {
        let v = sheet.index(i, sheet.ny - 1);
        let line = PinAxes::Line {
            direction: d.to_array(),
        };
        w.set_pin_axes(v, sheet.positions[v as usize], line)
            .unwrap();
    }
    let mass = w.total_mass();
    let h = w.settings().time_step as f64;
    for step in 1..=60 {
        let s = w.step().unwrap();
        assert_eq!(s.energy_removed, 0.0, "{s:?}");
        let along = momentum(&w).dot(d.as_dvec3());
        let expected = mass * 9.81 * (theta as f64).sin() * h * step as f64;
        assert!(
            (along - expected).abs() < 1e-3 * expected,
            "step {step}: {along} vs {expected}"
        );
    }
    // the rings stayed on the rail
    for i in 0..sheet.nx {
        let v = sheet.index(i, sheet.ny - 1) as usize;
        let moved = w.positions()[v] - Vec3A::from(sheet.positions[v]);
        assert!((moved - d * moved.dot(d)).length() < 1e-5, "{moved}");
    }
}

/// A ring pinned to a rail whose target lies 3 km along it (the cloth slid there, or the rail
/// is given by its far end) is held as exactly as one whose target is at the ring: `f32`'s
/// projection of `target − x` onto the held directions lost ~1e-7 of those 3 km at every
/// projection, and kicked the ring sideways by a fraction of a millimetre at every substep
/// (adversarial scene 18004: a stiff cloth 2.4 km along its rail, held still at every other
/// step). A cloth at rest, no input: it stays at rest, and setting the same rail again each
/// frame does not wake it once it sleeps.
#[test]
fn a_ring_far_along_its_rail_is_held_to_round_off() {
    let mat = [anisotropic()];
    let sheet = hanging_sheet(5, 0.3);
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::PINS | effects::BENDING | effects::SLEEP,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mat, settings);
    let d = Vec3A::new(0.3, 0.5, 0.81).normalize();
    let top = sheet.index(2, sheet.ny - 1);
    let ring = Vec3A::from(sheet.positions[top as usize]);
    let rail = PinAxes::Line {
        direction: d.to_array(),
    };
    // (`f32` rounds this target by up to 1.2e-4 m across the rail: the first step puts the
    // ring on the rail through it; from then on it must stay)
    let far = (ring + d * 3000.0).to_array();
    w.set_pin_axes(top, far, rail).unwrap();
    w.step().unwrap();
    let ring = w.positions()[top as usize];
    let mut slept = false;
    for step in 1..120 {
        let s = w.step().unwrap();
        assert!(
            !s.stopped && s.redone == 0 && s.energy_removed == 0.0,
            "step {step}: {s:?}"
        );
        let moved = w.positions()[top as usize] - ring;
        let across = moved - d * moved.dot(d);
        assert!(
            across.length() < 1e-6,
            "step {step}: the ring moved {across} off its rail"
        );
        if s.asleep {
            slept = true;
            // the engine sets its rail again, as each frame
            w.set_pin_axes(top, far, rail).unwrap();
            assert!(w.is_asleep(), "step {step}: the same rail woke it");
        }
    }
    assert!(slept, "a cloth at rest fell asleep");
}

/// A pin in a plane holds the normal direction only: the vertex stays in the plane through its
/// target and moves in it; a moving plane target does work that the energy balance counts.
#[test]
fn a_pin_in_a_plane_holds_only_its_normal() {
    let mat = [anisotropic()];
    let sheet = hanging_sheet(5, 0.3);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, rail_settings());
    let n = Vec3A::new(0.0, 1.0, 1.0).normalize();
    let top = sheet.index(2, sheet.ny - 1);
    let target = Vec3A::from(sheet.positions[top as usize]);
    w.set_pin_axes(
        top,
        target.to_array(),
        PinAxes::Plane {
            normal: n.to_array(),
        },
    )
    .unwrap();
    for k in 0..60 {
        // the plane moves along its normal; the vertex follows it
        let offset = n * (0.002 * k as f32);
        w.set_pin_axes(
            top,
            (target + offset).to_array(),
            PinAxes::Plane {
                normal: n.to_array(),
            },
        )
        .unwrap();
        let s = w.step().unwrap();
        assert_eq!(s.energy_removed, 0.0, "{s:?}");
        let x = w.positions()[top as usize];
        assert!((x - target - offset).dot(n).abs() < 1e-5, "{x}");
    }
    // it fell within the plane
    let x = w.positions()[top as usize];
    assert!((x - target).z < -0.01, "{x}");
    for bad in [[0.0; 3], [f32::NAN, 0.0, 1.0]] {
        assert_eq!(
            w.set_pin_axes(top, target.to_array(), PinAxes::Line { direction: bad }),
            Err(EditError::InvalidAxis)
        );
    }
}

/// Edge lengths of the current positions.
fn edge_lengths(w: &World<'_>) -> Vec<f32> {
    let x = w.positions();
    w.triangles()
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (x[a as usize] - x[b as usize]).length())
        .collect()
}

/// A sub-range of positions and velocities in and out of an interleaved buffer: only that
/// range changes, and a range past the end changes nothing.
#[test]
fn ranges_of_positions_and_velocities_round_trip() {
    let mat = [anisotropic()];
    let sheet = deformed_sheet();
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, free_settings());
    let n = w.vertex_count();
    let before: Vec<Vec3A> = w.positions().to_vec();
    // [x y z vx vy vz] records
    let records: Vec<[f32; 6]> = (0..4)
        .map(|k| [k as f32, 1.0, 2.0, -1.0, 0.5, k as f32])
        .collect();
    let bytes: &[u8] = bytemuck::cast_slice(&records);
    let positions = Strided::<3>::new(bytes, 24, 4).unwrap();
    let velocities = Strided::<3>::with_offset(bytes, 24, 12, 4).unwrap();
    w.set_positions_range(20, &positions).unwrap();
    w.set_velocities_range(20, &velocities).unwrap();
    assert_eq!(w.positions()[22], Vec3A::new(2.0, 1.0, 2.0));
    assert_eq!(w.velocities()[23], Vec3A::new(-1.0, 0.5, 3.0));
    assert_eq!(w.positions()[19], before[19]);
    assert_eq!(w.positions()[24], before[24]);
    assert_eq!(w.velocities()[24], Vec3A::ZERO);
    let now: Vec<Vec3A> = w.positions().to_vec();
    assert_eq!(
        w.set_positions_range(n - 3, &positions),
        Err(EditError::VertexOutOfRange)
    );
    assert_eq!(
        w.set_positions_range(usize::MAX, &positions),
        Err(EditError::VertexOutOfRange)
    );
    assert_eq!(w.positions(), &now[..]);
}

/// A rigid teleport keeps the shape (edge lengths), the elastic energy and, with the velocity
/// kept, the kinetic energy; and stepping commutes with it: on a free cloth (no gravity) the
/// teleported cloth's next steps are the original's, teleported.
#[test]
fn a_rigid_teleport_keeps_shape_energy_and_motion() {
    let mat = [anisotropic()];
    let sheet = deformed_sheet();
    let (mut mem_a, mut mem_b) = (memory(&sheet.capacity()), memory(&sheet.capacity()));
    let mut a = world(&mut mem_a, &sheet, &mat, free_settings());
    let mut b = world(&mut mem_b, &sheet, &mat, free_settings());
    let spin: Vec<[f32; 3]> = sheet
        .positions
        .iter()
        .map(|p| [0.2 - 0.5 * (p[1] - 0.5), 0.1 + 0.5 * (p[0] - 0.5), 0.3])
        .collect();
    a.set_velocities(&spin).unwrap();
    b.set_velocities(&spin).unwrap();
    let q = glam::Quat::from_axis_angle(glam::Vec3::new(1.0, 2.0, -0.5).normalize(), 2.1);
    let t = [3.0f32, -1.0, 0.5];
    let (lengths, energy) = (edge_lengths(&b), b.energy());
    b.transform(q, t, true).unwrap();
    let moved = b.energy();
    for (l0, l1) in lengths.iter().zip(edge_lengths(&b)) {
        assert!((l1 - l0).abs() < 2e-6 * l0 + 1e-6, "{l0} -> {l1}");
    }
    assert!((moved.elastic - energy.elastic).abs() < 1e-4 * energy.elastic);
    assert!((moved.kinetic - energy.kinetic).abs() < 1e-5 * energy.kinetic);
    for _ in 0..10 {
        a.step().unwrap();
        b.step().unwrap();
    }
    let r = glam::Mat3A::from_quat(q);
    // in the caller's coordinates: the teleport chose b an origin near where it landed
    for ((xa, xb), (va, vb)) in caller_positions(&a)
        .into_iter()
        .map(Vec3A::from)
        .zip(caller_positions(&b).into_iter().map(Vec3A::from))
        .zip(a.velocities().iter().zip(b.velocities()))
    {
        assert!((r * xa + Vec3A::from(t) - xb).length() < 1e-4, "{xa} {xb}");
        assert!(
            (r * *va - *vb).length() < 1e-3 * va.length() + 1e-4,
            "{va} {vb}"
        );
    }
    // without the velocity: at rest, same shape
    b.transform(glam::Quat::IDENTITY, [0.0, 0.0, 1.0], false)
        .unwrap();
    assert_eq!(b.energy().kinetic, 0.0);
    assert_eq!(
        b.transform(glam::Quat::from_xyzw(0.0, 0.0, 0.0, 0.0), t, true),
        Err(EditError::InvalidRotation)
    );
    assert_eq!(
        b.transform(glam::Quat::IDENTITY, [f32::NAN, 0.0, 0.0], true),
        Err(EditError::NonFinite)
    );
}

/// Pins move with a teleport: a cloth hanging from two corners, moved and turned, keeps
/// hanging from them (the pins do not yank it back).
#[test]
fn pins_move_with_a_teleport() {
    let mat = [anisotropic()];
    let sheet = hanging_sheet(6, 0.3);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, rail_settings());
    let (pa, _) = pin_top_corners(&mut w, &sheet);
    for _ in 0..20 {
        w.step().unwrap();
    }
    let q = glam::Quat::from_rotation_z(1.0);
    w.transform(q, [5.0, 0.0, 0.0], true).unwrap();
    let s = w.step().unwrap();
    assert_eq!(s.energy_removed, 0.0, "{s:?}");
    let expected = glam::Mat3A::from_quat(q) * Vec3A::from(sheet.positions[pa as usize])
        + Vec3A::new(5.0, 0.0, 0.0);
    let at = Vec3A::from(w.to_world(w.positions()[pa as usize]));
    assert!((at - expected).length() < 1e-5, "{at} {expected}");
}

/// The engine calls 10 km from the caller's zero, where a world simulates relative to an
/// origin near its cloth: a range of positions goes in and comes out in the caller's
/// coordinates, bit for bit; a rigid teleport (a turn about the caller's zero, not the world's
/// origin, and a move of kilometres) lands where `R x + t` says in the caller's coordinates
/// and keeps the edge lengths to the `f32` of a local coordinate (an `f32` at 10 km resolves
/// only 1 mm); and a pin in a plane given in the caller's coordinates holds that plane while
/// the cloth slides down it.
#[test]
fn engine_calls_work_10_km_from_zero() {
    let far = [10_000.0f32, 5_000.0, 0.0];
    let mat = [anisotropic()];
    let mut sheet = hanging_sheet(5, 0.3);
    sheet.transform(|p| [p[0] + far[0], p[1] + far[1], p[2] + far[2]]);
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mat, rail_settings());
    assert!(w.origin().length() > 11_000.0, "{}", w.origin());
    let f64s = |p: [f32; 3]| DVec3::from(p.map(f64::from));

    // a range in and out
    let moved: Vec<[f32; 3]> = sheet.positions[5..9]
        .iter()
        .map(|p| [p[0] + 0.0625, p[1], p[2] - 0.125])
        .collect();
    w.set_positions_range(5, &Strided::from_slice(&moved))
        .unwrap();
    let now = caller_positions(&w);
    assert_eq!(now[5..9], moved[..]);
    assert_eq!(now[..5], sheet.positions[..5]);
    assert_eq!(now[9..], sheet.positions[9..]);
    w.set_positions(&sheet.positions).unwrap();

    // a teleport: 0.4 rad about the caller's z axis, then kilometres away
    let (q, t) = (Quat::from_rotation_z(0.4), [-2_500.0f32, 1_000.0, 3.0]);
    let r = DMat3::from_quat(q.as_dquat());
    let expected: Vec<DVec3> = caller_positions(&w)
        .into_iter()
        .map(|p| r * f64s(p) + f64s(t))
        .collect();
    let lengths = edge_lengths(&w);
    w.transform(q, t, false).unwrap();
    for (l0, l1) in lengths.iter().zip(edge_lengths(&w)) {
        assert!((l1 - l0).abs() < 1e-5, "{l0} -> {l1}");
    }
    for (p, e) in caller_positions(&w).into_iter().zip(&expected) {
        // (one rounding to the caller's f32: half an ulp at 11 km is 4.9e-4 m)
        assert!((f64s(p) - *e).length() < 1e-3, "{p:?} {e}");
    }
    let centre = expected.iter().sum::<DVec3>() / expected.len() as f64;
    assert!(centre.length() > 10_000.0, "{centre}");
    assert!(
        (w.origin() - centre).length() < weft::world::ORIGIN_GRID,
        "{} {centre}",
        w.origin()
    );

    // a pin in the plane through a top vertex, normal (0, 1, 1): the cloth slides in it
    let n = Vec3A::new(0.0, 1.0, 1.0).normalize();
    let top = sheet.index(2, sheet.ny - 1);
    let target = caller_positions(&w)[top as usize];
    let axes = PinAxes::Plane {
        normal: n.to_array(),
    };
    w.set_pin_axes(top, target, axes).unwrap();
    for _ in 0..60 {
        let s = w.step().unwrap();
        assert_eq!(s.energy_removed, 0.0, "{s:?}");
        let x = w.positions()[top as usize];
        assert!((x - w.to_local(target)).dot(n).abs() < 1e-5, "{x}");
    }
    let slid = f64s(caller_positions(&w)[top as usize]) - f64s(target);
    assert!(slid.z < -0.01, "{slid}");
    assert!(slid.dot(n.as_dvec3()).abs() < 1e-3, "{slid}");
}

/// Collider ids name their collider across removals: removing one leaves the others' ids,
/// shapes and contacts alone, and a removed id is refused. A cloth resting on the floor stays
/// on it when a sphere beside it is removed, and falls when the floor is.
#[test]
fn collider_ids_survive_the_removal_of_others() {
    use weft::collide::{Collider, Shape};
    let mat = [anisotropic()];
    let mut sheet = Sheet::grid(6, 6, 0.3, 0.3);
    sheet.transform(|p| [p[0], p[1], 0.006]);
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::GRAVITY | effects::COLLISION | effects::DAMPING,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mat, settings);
    let sphere = |x: f32| Shape::Sphere {
        center: Vec3A::new(x, 5.0, 0.0),
        radius: 0.1,
    };
    let floor = Shape::Plane {
        normal: Vec3A::Z,
        offset: 0.0,
    };
    let a = w
        .add_collider(Collider::new(sphere(0.0), 0.5, 0.005))
        .unwrap();
    let b = w
        .add_collider(Collider::new(sphere(1.0), 0.5, 0.005))
        .unwrap();
    let f = w.add_collider(Collider::new(floor, 0.5, 0.005)).unwrap();
    assert_eq!((a, b, f), (0, 1, 2));
    for _ in 0..20 {
        w.step().unwrap();
    }
    assert!(w.last_step().contacts > 0);
    w.remove_collider(a).unwrap();
    assert_eq!(w.collider_count(), 2);
    assert_eq!(w.collider(f).unwrap().shape, floor);
    assert_eq!(w.collider(b).unwrap().shape, sphere(1.0));
    assert_eq!(w.remove_collider(a), Err(EditError::UnknownCollider));
    assert_eq!(
        w.set_collider_shape(a, sphere(2.0)),
        Err(EditError::UnknownCollider)
    );
    assert!(w.collider(a).is_none());
    // the floor (moved into the removed one's slot, its contacts with it) still holds the
    // cloth
    for _ in 0..20 {
        w.step().unwrap();
    }
    assert!(w.positions().iter().all(|p| p.z > 0.004), "on the floor");
    assert_eq!(w.last_step().contacts, w.vertex_count() as u32);
    // a new collider gets a new id
    let c = w
        .add_collider(Collider::new(sphere(3.0), 0.5, 0.005))
        .unwrap();
    assert_eq!(c, 3);
    w.set_collider_shape(b, sphere(4.0)).unwrap();
    assert_eq!(w.collider(c).unwrap().shape, sphere(3.0));
    w.remove_collider(f).unwrap();
    for _ in 0..10 {
        w.step().unwrap();
    }
    assert!(
        w.positions().iter().all(|p| p.z < -0.01),
        "falls without the floor"
    );
    assert_eq!(w.collider_ids(), &[c, b][..]);
}

/// A homogeneous deformation `x = R A (u, v)` (a 2×2 stretch-and-shear `A`, then any rotation
/// `R` into 3D) has Green strain `E = ½(AᵀA − I)` in every triangle, read back in Voigt order
/// `[E11, E22, 2 E12]`; a triangle listed in reverse order measures the same.
#[test]
fn triangle_strains_are_the_green_strain_of_the_deformation() {
    use weft::strided::StridedMut;
    let mat = [anisotropic()];
    let mut sheet = Sheet::grid(5, 4, 0.4, 0.3);
    let a = [[1.05f32, 0.03], [-0.02, 0.96]];
    let r = glam::Mat3A::from_quat(glam::Quat::from_euler(glam::EulerRot::XYZ, 0.7, -0.3, 1.1));
    for (p, uv) in sheet.positions.iter_mut().zip(&sheet.uvs) {
        let (u, v) = (uv[0], uv[1]);
        let planar = Vec3A::new(a[0][0] * u + a[0][1] * v, a[1][0] * u + a[1][1] * v, 0.0);
        *p = (r * planar + Vec3A::new(0.3, -2.0, 1.0)).to_array();
    }
    // one triangle reversed
    sheet.triangles[5].swap(1, 2);
    let mut mem = memory(&sheet.capacity());
    let w = world(&mut mem, &sheet, &mat, free_settings());
    // AᵀA columns: A's columns a1 = (1.05, −0.02), a2 = (0.03, 0.96)
    let (a1, a2) = (
        glam::Vec2::new(a[0][0], a[1][0]),
        glam::Vec2::new(a[0][1], a[1][1]),
    );
    let expected = [
        0.5 * (a1.length_squared() - 1.0),
        0.5 * (a2.length_squared() - 1.0),
        a1.dot(a2),
    ];
    let nt = w.triangle_count();
    let mut out = vec![[0.0f32; 3]; nt];
    w.triangle_strains(0, &mut StridedMut::from_slice(&mut out))
        .unwrap();
    for e in &out {
        for (got, want) in e.iter().zip(expected) {
            assert!((got - want).abs() < 2e-6, "{e:?} vs {expected:?}");
        }
    }
    // a range, and one past the end
    let mut two = [[9.0f32; 3]; 2];
    w.triangle_strains(nt - 2, &mut StridedMut::from_slice(&mut two))
        .unwrap();
    assert_eq!(two, [out[nt - 2], out[nt - 1]]);
    assert_eq!(
        w.triangle_strains(nt - 1, &mut StridedMut::from_slice(&mut two)),
        Err(EditError::TriangleOutOfRange)
    );
    // the stretch ratio along u
    assert!(((1.0 + 2.0 * out[0][0]).sqrt() - a1.length()).abs() < 1e-6);
}

/// A cloth that can never step is refused at init: (u, v) scaled down against positions in
/// metres stretch every triangle until its elastic force overflows `f32` (from a scale of 1e-9
/// on this sheet), and then every step would fail with `SolverBreakdown` (a failed step keeps
/// its state). Down to the last scale whose forces fit, the cloth is accepted and steps.
#[test]
fn a_cloth_that_can_never_step_is_refused_at_init() {
    use weft::world::{InitError, Materials, StepError};
    let mat = [anisotropic()];
    for (scale, refused) in [(1e-8f32, false), (1e-9, true), (1e-15, true)] {
        let mut sheet = hanging_sheet(8, 0.5);
        for uv in &mut sheet.uvs {
            *uv = [uv[0] * scale, uv[1] * scale];
        }
        let mut mem = memory(&sheet.capacity());
        let r = World::new(
            &mut mem,
            sheet.capacity(),
            &sheet.def(),
            Materials::Table(&mat),
            Settings::default(),
        );
        match r {
            Err(e) => {
                assert!(refused, "{scale:e}: {e:?}");
                assert_eq!(e, InitError::StrainOutOfRange { triangle: 0 });
            }
            Ok(mut w) => {
                assert!(!refused, "{scale:e} accepted");
                assert_ne!(w.step().err(), Some(StepError::SolverBreakdown));
            }
        }
    }
    // the same mistake the other way round: positions 1e10 times too large
    let mut sheet = hanging_sheet(8, 0.5);
    sheet.transform(|p| p.map(|c| c * 1e10));
    let mut mem = memory(&sheet.capacity());
    let r = World::new(
        &mut mem,
        sheet.capacity(),
        &sheet.def(),
        Materials::Table(&mat),
        Settings::default(),
    );
    assert_eq!(r.err(), Some(InitError::StrainOutOfRange { triangle: 0 }));
}

/// The refusal names the triangle to look at: in a sheet stretched 3×, one triangle of a
/// 4e37 N/m material, whose stress (1.6e38 N/m) still fits `f32` but not its force, stiffness
/// or energy. Before, the refusal came from the tensile part of that stress (its square
/// overflowed), and an estimate of the force (area times stress times gradients, which fits)
/// found no triangle and named triangle 0.
#[test]
fn a_refused_cloth_names_the_overstretched_triangle() {
    use weft::world::{InitError, Materials};
    let mats = [anisotropic(), isotropic(4e37, 0.3, 0.15)];
    let mut sheet = hanging_sheet(8, 0.5);
    sheet.transform(|p| p.map(|c| 3.0 * c));
    let stiff = 40;
    sheet.materials[stiff] = 1;
    let mut mem = memory(&sheet.capacity());
    let r = World::new(
        &mut mem,
        sheet.capacity(),
        &sheet.def(),
        Materials::Table(&mats),
        Settings::default(),
    );
    assert_eq!(
        r.err(),
        Some(InitError::StrainOutOfRange {
            triangle: stiff as u32
        })
    );
}

/// The header's promise on triangle orientation: index order is free triangle by triangle
/// (weft orients triangles by their (u, v) layout), so a hanging cloth with every other
/// triangle listed in reverse moves as the original does, to round-off.
#[test]
fn triangle_order_does_not_change_the_simulation() {
    let mat = [anisotropic()];
    let sheet = hanging_sheet(8, 0.4);
    let mut flipped = hanging_sheet(8, 0.4);
    for t in flipped.triangles.iter_mut().step_by(2) {
        t.swap(0, 2);
    }
    let (mut mem_a, mut mem_b) = (memory(&sheet.capacity()), memory(&sheet.capacity()));
    let mut a = world(&mut mem_a, &sheet, &mat, Settings::default());
    let mut b = world(&mut mem_b, &flipped, &mat, Settings::default());
    pin_top_corners(&mut a, &sheet);
    pin_top_corners(&mut b, &flipped);
    for _ in 0..60 {
        a.step().unwrap();
        b.step().unwrap();
    }
    let worst = a
        .positions()
        .iter()
        .zip(b.positions())
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "{worst} m apart");
    for (n, m) in a.normals().iter().zip(b.normals()) {
        assert!(n.dot(*m) > 0.999, "{n} {m}");
    }
}

/// Contacts follow their collider into its new slot: a cloth held by static friction on an
/// inclined plane stays put when a collider added before the plane is removed (a contact
/// that lost its collider would slide for a substep, ~g·sinθ·h² ≈ 1 mm).
#[test]
fn sticking_contacts_survive_the_removal_of_another_collider() {
    use weft::collide::{Collider, Shape};
    let mat = [anisotropic()];
    let theta = 0.3f32;
    let normal = Vec3A::new(0.0, -theta.sin(), theta.cos());
    let mut sheet = Sheet::grid(6, 6, 0.3, 0.3);
    // on the incline, 6 mm above it
    sheet.transform(|p| {
        let p = Vec3A::new(p[0], p[1] * theta.cos(), p[1] * theta.sin()) + normal * 0.006;
        p.to_array()
    });
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        effects: effects::WARPING | effects::GRAVITY | effects::COLLISION | effects::DAMPING,
        ..Settings::default()
    };
    let mut w = world(&mut mem, &sheet, &mat, settings);
    let away = Shape::Sphere {
        center: Vec3A::new(0.0, 5.0, 0.0),
        radius: 0.1,
    };
    let other = w.add_collider(Collider::new(away, 0.5, 0.005)).unwrap();
    let incline = Shape::Plane {
        normal,
        offset: 0.0,
    };
    w.add_collider(Collider::new(incline, 1.0, 0.005)).unwrap();
    for _ in 0..60 {
        w.step().unwrap();
    }
    let before = w.positions().to_vec();
    w.step().unwrap();
    let still = |w: &World<'_>| {
        w.positions()
            .iter()
            .zip(&before)
            .map(|(p, q)| (*p - *q).length())
            .fold(0.0f32, f32::max)
    };
    assert!(still(&w) < 1e-5, "resting: moved {}", still(&w));
    w.remove_collider(other).unwrap();
    w.step().unwrap();
    assert!(still(&w) < 1e-5, "after the removal: moved {}", still(&w));
}
