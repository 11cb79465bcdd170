//! Bad input never crashes or corrupts (property tests). Whatever the mesh, materials, settings,
//! pins, colliders and edits, every call returns a value (`Ok` or a specific `Err`) and never
//! panics; a world that was built keeps finite positions, velocities and masses; a step or edit
//! that fails leaves the state exactly as it was; and once the bad input is withdrawn, the same
//! world steps normally again. Case counts keep the file well under a minute in `cargo test`.
//!
//! The fuzz targets (`fuzz/`, `scripts/fuzz.sh`) check the same properties on byte-level input;
//! this file is the part that runs in every `cargo test`.

mod common;

use common::Sheet;
use proptest::prelude::*;
use weft::collide::{Collider, Shape};
use weft::mesh::MeshError;
use weft::world::{
    effects, Capacity, ClothDef, EditError, InitError, Material, Materials, Settings, StepError,
    World,
};

/// Cases per property: the given default (what `cargo test` runs, well under a minute), or
/// `WEFT_PROPTEST_CASES` for a deeper run.
fn cases(default: u32) -> u32 {
    std::env::var("WEFT_PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

// ---- strategies ---------------------------------------------------------------------------------

const SPECIAL_F32: [f32; 14] = [
    0.0,
    -0.0,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    1e30,
    -1e30,
    f32::MAX,
    f32::MIN,
    f32::MIN_POSITIVE,
    1e-30,
    1e-45,
    1e20,
    -1.0,
];

/// Mostly ordinary numbers, often a special one (NaN, ±inf, 1e30, extremes), sometimes any bits.
fn wild_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -2.0f32..2.0,
        2 => proptest::sample::select(SPECIAL_F32.to_vec()),
        1 => proptest::num::f32::ANY,
    ]
}

/// `v` itself most of the time, else a wild value.
fn or_wild(v: f32) -> impl Strategy<Value = f32> {
    prop_oneof![3 => Just(v), 1 => wild_f32()]
}

fn wild_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => 1e-3f64..1e4,
        2 => proptest::sample::select(vec![
            0.0, -0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e30, 1e300, -1e300,
            f64::MAX, f64::MIN_POSITIVE, 5e-324, 1e-30,
        ]),
        1 => proptest::num::f64::ANY,
    ]
}

fn wild3() -> impl Strategy<Value = [f32; 3]> {
    [wild_f32(), wild_f32(), wild_f32()]
}

/// A mesh: random triangles over random vertices (degenerate, repeated and out-of-range indices
/// included), or a grid sheet with some vertices, uvs and triangles spoiled.
#[derive(Clone, Debug)]
struct Mesh {
    positions: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    triangles: Vec<[u32; 3]>,
}

fn index(n: usize) -> impl Strategy<Value = u32> {
    prop_oneof![8 => 0..(n as u32 + 2), 1 => any::<u32>()]
}

fn random_mesh() -> impl Strategy<Value = Mesh> {
    (0usize..10).prop_flat_map(|n| {
        (
            proptest::collection::vec([or_wild(0.5), or_wild(0.5), or_wild(0.0)], n),
            proptest::collection::vec([0.0f32..1.0, 0.0f32..1.0], n),
            proptest::collection::vec([index(n), index(n), index(n)], 0..14),
        )
            .prop_map(|(mut positions, uvs, triangles)| {
                // Positions near the uvs, so some random meshes are valid.
                for (p, uv) in positions.iter_mut().zip(&uvs) {
                    p[0] += uv[0];
                    p[1] += uv[1];
                }
                Mesh {
                    positions,
                    uvs,
                    triangles,
                }
            })
    })
}

#[derive(Clone, Debug)]
enum Spoil {
    Position(usize, usize, f32),
    Uv(usize, usize, f32),
    Corner(usize, usize, u32),
    Flip(usize),
    Copy(usize, usize),
}

fn spoiled_grid() -> impl Strategy<Value = Mesh> {
    (2usize..6, 2usize..6, or_wild(0.4), or_wild(0.3)).prop_flat_map(|(nx, ny, w, h)| {
        let (n, nt) = (nx * ny, 2 * (nx - 1) * (ny - 1));
        let spoil = prop_oneof![
            (0..n, 0..3usize, wild_f32()).prop_map(|(v, k, x)| Spoil::Position(v, k, x)),
            (0..n, 0..2usize, wild_f32()).prop_map(|(v, k, x)| Spoil::Uv(v, k, x)),
            (0..nt, 0..3usize, index(n)).prop_map(|(t, k, i)| Spoil::Corner(t, k, i)),
            (0..nt).prop_map(Spoil::Flip),
            (0..nt, 0..nt).prop_map(|(a, b)| Spoil::Copy(a, b)),
        ];
        proptest::collection::vec(spoil, 0..3).prop_map(move |spoils| {
            let s = Sheet::grid(nx, ny, w, h);
            let mut m = Mesh {
                positions: s.positions,
                uvs: s.uvs,
                triangles: s.triangles,
            };
            for sp in spoils {
                match sp {
                    Spoil::Position(v, k, x) => m.positions[v][k] = x,
                    Spoil::Uv(v, k, x) => m.uvs[v][k] = x,
                    Spoil::Corner(t, k, i) => m.triangles[t][k] = i,
                    Spoil::Flip(t) => m.triangles[t].swap(0, 1),
                    Spoil::Copy(a, b) => m.triangles[a] = m.triangles[b],
                }
            }
            m
        })
    })
}

fn any_mesh() -> impl Strategy<Value = Mesh> {
    prop_oneof![random_mesh(), spoiled_grid()]
}

fn wild_material() -> impl Strategy<Value = Material> {
    prop_oneof![
        // Isotropic from random modulus and Poisson ratio (ν ≥ 0.5 or ≤ -1: not SPD).
        (wild_f64(), -1.5f64..1.0, wild_f64(), wild_f64()).prop_map(|(e, nu, density, bending)| {
            Material {
                stiffness: weft::membrane::isotropic(e, nu),
                density,
                bending,
            }
        }),
        // Any nine entries.
        (
            [
                [wild_f64(), wild_f64(), wild_f64()],
                [wild_f64(), wild_f64(), wild_f64()],
                [wild_f64(), wild_f64(), wild_f64()],
            ],
            wild_f64(),
            wild_f64(),
        )
            .prop_map(|(stiffness, density, bending)| Material {
                stiffness,
                density,
                bending,
            }),
        Just(common::isotropic(1000.0, 0.3, 0.2)),
    ]
}

fn wild_settings() -> impl Strategy<Value = Settings> {
    let d = Settings::default();
    (
        (
            prop_oneof![
                Just(d.effects),
                Just(effects::ALL),
                0u32..(effects::ALL + 1),
                any::<u32>()
            ],
            or_wild(d.time_step),
            prop_oneof![
                1u32..4,
                proptest::sample::select(vec![0, 1000, 1001, u32::MAX])
            ],
            [or_wild(0.0), or_wild(0.0), or_wild(-9.81)],
            or_wild(d.damping_mass),
            or_wild(d.damping_stiffness),
        ),
        (
            [or_wild(2.0), or_wild(0.0), or_wild(0.0)],
            or_wild(0.3),
            or_wild(d.tolerance),
            // Above Settings::MAX_ITERATIONS (10,000) is refused, so u32::MAX is safe to try.
            prop_oneof![0u32..300, Just(10_001), Just(u32::MAX)],
            any::<bool>(),
            prop_oneof![0u32..12, Just(101), Just(u32::MAX)],
            or_wild(d.sleep_velocity),
            prop_oneof![0u32..40, Just(u32::MAX)],
        ),
    )
        .prop_map(
            |(
                (effects, time_step, substeps, gravity, damping_mass, damping_stiffness),
                (
                    wind,
                    drag,
                    tolerance,
                    max_iterations,
                    per_node_warping,
                    rotation_iterations,
                    sleep_velocity,
                    sleep_frames,
                ),
            )| Settings {
                effects,
                time_step,
                substeps,
                gravity,
                damping_mass,
                damping_stiffness,
                wind,
                drag,
                tolerance,
                max_iterations,
                per_node_warping,
                rotation_iterations,
                sleep_velocity,
                sleep_frames,
                ..Settings::default()
            },
        )
}

fn wild_shape() -> impl Strategy<Value = Shape> {
    prop_oneof![
        ([or_wild(0.0), or_wild(0.0), or_wild(1.0)], or_wild(-0.05)).prop_map(|(n, offset)| {
            Shape::Plane {
                normal: n.into(),
                offset,
            }
        }),
        ([or_wild(0.2), or_wild(0.2), or_wild(-0.1)], or_wild(0.15)).prop_map(|(c, radius)| {
            Shape::Sphere {
                center: c.into(),
                radius,
            }
        }),
        (wild3(), wild3(), or_wild(0.05)).prop_map(|(a, b, radius)| Shape::Capsule {
            a: a.into(),
            b: b.into(),
            radius,
        }),
    ]
}

/// An edit or a step on a built world.
#[derive(Clone, Debug)]
enum Op {
    Step,
    StepDt(f32),
    SetPin(u32, [f32; 3]),
    RemovePin(u32),
    AddCollider(Shape, f32, f32),
    SetColliderShape(u32, Shape),
    ClearColliders,
    SetPosition(usize, usize, f32),
    SetVelocity(usize, usize, f32),
    WrongLengthPositions,
    SetSettings(Settings),
}

fn op(n: usize) -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => Just(Op::Step),
        1 => or_wild(1.0 / 60.0).prop_map(Op::StepDt),
        2 => (index(n), [or_wild(0.1), or_wild(0.1), or_wild(0.05)])
            .prop_map(|(v, t)| Op::SetPin(v, t)),
        1 => index(n).prop_map(Op::RemovePin),
        1 => (wild_shape(), or_wild(0.3), or_wild(0.005))
            .prop_map(|(s, f, t)| Op::AddCollider(s, f, t)),
        1 => (0u32..5, wild_shape()).prop_map(|(i, s)| Op::SetColliderShape(i, s)),
        1 => Just(Op::ClearColliders),
        1 => (0..n, 0..3usize, wild_f32()).prop_map(|(v, k, x)| Op::SetPosition(v, k, x)),
        1 => (0..n, 0..3usize, wild_f32()).prop_map(|(v, k, x)| Op::SetVelocity(v, k, x)),
        1 => Just(Op::WrongLengthPositions),
        1 => wild_settings().prop_map(Op::SetSettings),
    ]
}

// ---- checks -------------------------------------------------------------------------------------

/// The invariants of a built world.
fn assert_sane(w: &World<'_>) {
    assert!(w.positions().iter().all(|p| p.is_finite()), "positions");
    assert!(w.velocities().iter().all(|v| v.is_finite()), "velocities");
    assert!(
        w.masses().iter().all(|m| m.is_finite() && *m >= 0.0),
        "masses {:?}",
        w.masses()
    );
    assert!(w.total_mass().is_finite(), "total mass");
}

type State = (Vec<glam::Vec3A>, Vec<glam::Vec3A>);

fn state(w: &World<'_>) -> State {
    (w.positions().to_vec(), w.velocities().to_vec())
}

fn assert_state(w: &World<'_>, s: &State, what: &str) {
    assert!(
        w.positions() == s.0.as_slice() && w.velocities() == s.1.as_slice(),
        "{what} changed the state"
    );
}

/// Steps `k` times: each step succeeds or fails leaving the state untouched; always sane.
fn step_a_few(w: &mut World<'_>, k: usize) {
    for _ in 0..k {
        let before = state(w);
        if w.step().is_err() {
            assert_state(w, &before, "a failed step");
        }
        assert_sane(w);
    }
}

/// Room for every mesh the strategies make.
const ROOMY: Capacity = Capacity {
    vertices: 40,
    triangles: 64,
    edges: 200,
    colliders: 4,
    pins: 8,
};

fn def<'m>(m: &'m Mesh, materials: &'m [u32]) -> ClothDef<'m> {
    ClothDef {
        positions: &m.positions,
        uvs: &m.uvs,
        triangles: &m.triangles,
        materials,
    }
}

/// After a refusal the memory is as good as new: a plain sheet builds in it.
fn memory_is_reusable(mem: &mut [u8]) {
    let s = Sheet::grid(3, 3, 0.2, 0.2);
    let mats = [common::isotropic(1000.0, 0.3, 0.2)];
    let mut w = World::new(
        mem,
        ROOMY,
        &s.def(),
        Materials::Table(&mats),
        Settings::default(),
    )
    .expect("a plain sheet after a refused init");
    step_a_few(&mut w, 2);
    assert!(w.step().is_ok());
}

// ---- properties ---------------------------------------------------------------------------------

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(300)))]

    /// Random meshes (degenerate, repeated, out-of-range, NaN, 1e30 …) with random materials:
    /// `World::new` builds a sane world or names the problem; the memory stays reusable.
    #[test]
    fn init_on_any_mesh_builds_or_refuses(
        mesh in any_mesh(),
        materials in proptest::collection::vec(wild_material(), 0..3),
        which in proptest::collection::vec(0u32..4, 0..70),
    ) {
        let nt = mesh.triangles.len();
        // Per-triangle material: mostly index 0, sometimes another (maybe missing) one; the
        // list itself sometimes has the wrong length.
        let mut tri_mat: Vec<u32> = (0..nt).map(|t| which.get(t).map_or(0, |&m| m / 3)).collect();
        if which.len() == 1 {
            tri_mat.push(0);
        }
        let mut mem = common::memory(&ROOMY);
        let d = def(&mesh, &tri_mat);
        match World::new(&mut mem, ROOMY, &d, Materials::Table(&materials), Settings::default()) {
            Ok(mut w) => {
                assert_sane(&w);
                prop_assert_eq!(w.vertex_count(), mesh.positions.len());
                step_a_few(&mut w, 3);
            }
            Err(e) => {
                // The refusal names a real problem.
                match e {
                    InitError::Mesh(MeshError::IndexOutOfRange { triangle })
                    | InitError::Mesh(MeshError::RepeatedVertex { triangle })
                    | InitError::Mesh(MeshError::DegenerateUv { triangle })
                    | InitError::Mesh(MeshError::Degenerate3d { triangle })
                    | InitError::Mesh(MeshError::UvOutOfRange { triangle }) => {
                        prop_assert!((triangle as usize) < nt)
                    }
                    InitError::Mesh(MeshError::NonFinite { vertex }) => {
                        let (p, uv) = (mesh.positions[vertex as usize], mesh.uvs[vertex as usize]);
                        prop_assert!(p.iter().chain(&uv).any(|c| !c.is_finite()));
                    }
                    InitError::MaterialOutOfRange { triangle, material } => {
                        prop_assert!((triangle as usize) < nt);
                        prop_assert!(material as usize >= materials.len());
                    }
                    InitError::InvalidMaterial { material } => {
                        prop_assert!((material as usize) < materials.len())
                    }
                    InitError::Mesh(MeshError::UnusedVertex { vertex }) => {
                        prop_assert!(mesh.triangles.iter().all(|t| !t.contains(&vertex)));
                    }
                    InitError::MaterialCount => prop_assert_ne!(tri_mat.len(), nt),
                    // e.g. a 1e30 N/m material stretched: its force or energy beyond f32
                    InitError::StrainOutOfRange { triangle } => {
                        prop_assert!((triangle as usize) < nt)
                    }
                    InitError::Mesh(_) | InitError::EdgeCapacity { .. } => {}
                    other => prop_assert!(false, "unexpected refusal {:?}", other),
                }
                memory_is_reusable(&mut mem);
            }
        }
    }

    /// Any settings: init and `set_settings` accept exactly what `Settings::validate` accepts,
    /// and stepping under accepted settings never leaves a non-finite state.
    #[test]
    fn settings_are_validated_and_never_corrupt(
        settings in wild_settings(),
        later in wild_settings(),
        pinned in any::<bool>(),
    ) {
        let s = Sheet::grid(4, 4, 0.3, 0.3);
        let mats = [common::anisotropic()];
        let mut mem = common::memory(&s.capacity());
        let valid = settings.validate().is_ok();
        let r = World::new(&mut mem, s.capacity(), &s.def(), Materials::Table(&mats), settings);
        match r {
            Err(e) => {
                prop_assert!(!valid, "valid settings refused: {:?}", e);
                let is_setting = matches!(e, InitError::InvalidSetting { .. });
                prop_assert!(is_setting, "{:?}", e);
            }
            Ok(mut w) => {
                prop_assert!(valid);
                if pinned {
                    w.set_pin(s.index(0, 3), [0.0, 0.3, 0.0]).unwrap();
                    w.set_pin(s.index(3, 3), [0.3, 0.3, 0.0]).unwrap();
                }
                w.add_collider(Collider::new(
                    Shape::Sphere { center: [0.15, 0.15, -0.2].into(), radius: 0.15 },
                    0.3,
                    0.005,
                ))
                .unwrap();
                step_a_few(&mut w, 3);
                let old = *w.settings();
                match w.set_settings(later) {
                    Ok(()) => prop_assert!(later.validate().is_ok()),
                    Err(_) => {
                        prop_assert!(later.validate().is_err());
                        prop_assert_eq!(*w.settings(), old);
                    }
                }
                step_a_few(&mut w, 2);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases(150)))]

    /// Pins, colliders, positions, velocities, time steps and settings, NaN and huge values
    /// included, in any order: never a panic, never a non-finite state, a failed call changes
    /// nothing; and once the bad input is withdrawn the same world steps normally again.
    #[test]
    fn edits_and_steps_never_corrupt_and_the_world_recovers(
        ops in proptest::collection::vec(op(25), 1..24),
    ) {
        let s = Sheet::grid(5, 5, 0.4, 0.4);
        let n = s.positions.len();
        let mats = [common::isotropic(1000.0, 0.3, 0.2)];
        let cap = Capacity { pins: 4, colliders: 3, ..s.capacity() };
        let mut mem = common::memory(&cap);
        let mut w =
            World::new(&mut mem, cap, &s.def(), Materials::Table(&mats), Settings::default())
                .unwrap();
        for op in ops {
            let before = state(&w);
            match op {
                Op::Step | Op::StepDt(_) => {
                    let r = match op {
                        Op::StepDt(dt) => w.step_dt(dt),
                        _ => w.step(),
                    };
                    if let Err(e) = r {
                        assert_state(&w, &before, "a failed step");
                        if let Op::StepDt(dt) = op {
                            if !(dt.is_finite() && dt > 0.0) {
                                prop_assert_eq!(e, StepError::InvalidTimeStep);
                            }
                        }
                    }
                }
                Op::SetPin(v, t) => {
                    let r = w.set_pin(v, t);
                    if v as usize >= n {
                        prop_assert_eq!(r, Err(EditError::VertexOutOfRange));
                    }
                    assert_state(&w, &before, "set_pin");
                }
                Op::RemovePin(v) => {
                    prop_assert_eq!(w.remove_pin(v).is_ok(), (v as usize) < n);
                    assert_state(&w, &before, "remove_pin");
                }
                Op::AddCollider(shape, friction, thickness) => {
                    let c = Collider::new(shape, friction, thickness);
                    let count = w.collider_count();
                    match w.add_collider(c) {
                        Ok(_) => prop_assert!(c.is_valid()),
                        Err(_) => prop_assert_eq!(w.collider_count(), count),
                    }
                }
                Op::SetColliderShape(i, shape) => {
                    let old = w.collider(i).copied();
                    if w.set_collider_shape(i, shape).is_err() {
                        prop_assert_eq!(w.collider(i).copied(), old);
                    } else {
                        prop_assert!(shape.is_valid());
                    }
                }
                Op::ClearColliders => w.clear_colliders(),
                Op::SetPosition(v, k, x) | Op::SetVelocity(v, k, x) => {
                    let is_pos = matches!(op, Op::SetPosition(..));
                    let src = if is_pos { &before.0 } else { &before.1 };
                    let mut values: Vec<[f32; 3]> = src.iter().map(|p| p.to_array()).collect();
                    values[v][k] = x;
                    let r = if is_pos { w.set_positions(&values) } else { w.set_velocities(&values) };
                    if x.is_finite() {
                        prop_assert!(r.is_ok());
                    } else {
                        prop_assert_eq!(r, Err(EditError::NonFinite));
                        assert_state(&w, &before, "a refused set_positions/velocities");
                    }
                }
                Op::WrongLengthPositions => {
                    prop_assert!(w.set_positions(&[[0.0; 3]; 3]).is_err());
                    assert_state(&w, &before, "a refused set_positions");
                }
                Op::SetSettings(st) => {
                    prop_assert_eq!(w.set_settings(st).is_ok(), st.validate().is_ok());
                }
            }
            assert_sane(&w);
        }

        // Withdraw everything: the world is not poisoned by what it refused.
        for v in 0..n as u32 {
            w.remove_pin(v).unwrap();
        }
        w.clear_colliders();
        w.set_settings(Settings::default()).unwrap();
        w.set_positions(&s.positions).unwrap();
        w.set_velocities(&vec![[0.0; 3]; n]).unwrap();
        for _ in 0..3 {
            let r = w.step();
            prop_assert!(r.is_ok(), "the world did not recover: {:?}", r);
            assert_sane(&w);
        }
    }
}

// ---- regressions: what the properties above found ----------------------------------------------

/// Found by `edits_and_steps_never_corrupt_and_the_world_recovers`: a step that failed (here on a
/// pin target of 1e30, which the solve cannot reach) left its half-done velocity change in the
/// PCG warm start, so every later step broke down too, even with the pin removed and the state
/// reset: one bad input poisoned the world for good.
#[test]
fn a_failed_step_does_not_poison_the_next() {
    let s = Sheet::grid(5, 5, 0.4, 0.4);
    let mats = [common::isotropic(1000.0, 0.3, 0.2)];
    let mut mem = common::memory(&s.capacity());
    let mut w = common::world(&mut mem, &s, &mats, Settings::default());
    let before = state(&w);
    w.set_pin(0, [0.1, 1e30, 0.05]).unwrap();
    assert!(w.step().is_err());
    assert_state(&w, &before, "the failed step");
    w.remove_pin(0).unwrap();
    for _ in 0..3 {
        let r = w.step();
        assert!(r.is_ok(), "{r:?}");
        assert_sane(&w);
    }
}

/// A pin moved a billion metres or more in one step stretches its triangles beyond what `f32`
/// holds as energy while every position still fits. Such a step used to return `Ok` with an
/// infinite elastic energy (its balance read `∞ ≤ ∞`), and every later step failed, the pin
/// removed or not: the world was dead. Now the step fails with its start kept, as one whose
/// state overflowed, and the world steps on once the pin is gone. Also where every attempt
/// balanced no better than holding the cloth still (a 9×9 cloth, the pin 1e8–1e9 m away: the
/// solves did not break down, the limited attempt gained 2e27 J): the hold put the pinned vertex
/// on its target and returned `Ok` with that infinite energy.
#[test]
fn a_step_never_ends_where_the_energy_overflows() {
    for (n, far) in [(5, 1e9f32), (5, 1e12), (9, 1e8), (9, 1e9)] {
        let s = Sheet::grid(n, n, 0.4, 0.4);
        let mats = [common::anisotropic()];
        let mut mem = common::memory(&s.capacity());
        let mut w = common::world(&mut mem, &s, &mats, Settings::default());
        w.set_pin(0, [0.0; 3]).unwrap();
        w.step().unwrap();
        let before = state(&w);
        w.set_pin(0, [far, 0.0, 0.0]).unwrap();
        match w.step() {
            Ok(_) => assert!(w.energy().total().is_finite(), "{far:e}: {:?}", w.energy()),
            Err(_) => assert_state(&w, &before, "the failed step"),
        }
        w.remove_pin(0).unwrap();
        for _ in 0..3 {
            let r = w.step();
            assert!(r.is_ok(), "{far:e}: {r:?}");
            assert_sane(&w);
            assert!(w.energy().total().is_finite(), "{far:e}: {:?}", w.energy());
        }
    }
}

/// Found by `init_on_any_mesh_builds_or_refuses`: a vertex that no triangle uses got zero mass,
/// which the rotation set-up refused as `InitError::Internal` ("a bug if it happens"). It is
/// bad input, and now named as such.
#[test]
fn an_unused_vertex_is_named() {
    let positions = [
        [0.0, 0.0, 0.0],
        [0.0, 0.1, 0.0],
        [0.0, 0.0, 0.0],
        [0.2, 0.0, 0.0],
    ];
    let uvs = [[0.0, 0.0], [0.0, 0.1], [0.0, 0.0], [0.2, 0.0]];
    let mesh = Mesh {
        positions: positions.to_vec(),
        uvs: uvs.to_vec(),
        triangles: vec![[3, 1, 0]],
    };
    let mats = [common::isotropic(1000.0, 0.3, 0.2)];
    let mut mem = common::memory(&ROOMY);
    let r = World::new(
        &mut mem,
        ROOMY,
        &def(&mesh, &[0]),
        Materials::Table(&mats),
        Settings::default(),
    );
    assert_eq!(
        r.err(),
        Some(InitError::Mesh(MeshError::UnusedVertex { vertex: 2 }))
    );
    memory_is_reusable(&mut mem);
}

/// Found by `edits_and_steps_never_corrupt_and_the_world_recovers`: a vertex set to z = -1.2e31
/// under a floor is thrown out at 7e32 m/s (finite, so accepted); resetting positions and
/// velocities then still failed the next step, because the solver warm-started from that step's
/// Δv. `set_velocities` now forgets the warm start.
#[test]
fn resetting_velocities_forgets_the_warm_start() {
    let s = Sheet::grid(5, 5, 0.4, 0.4);
    let mats = [common::isotropic(1000.0, 0.3, 0.2)];
    let mut mem = common::memory(&s.capacity());
    let mut w = World::new(
        &mut mem,
        s.capacity(),
        &s.def(),
        Materials::Table(&mats),
        Settings::default(),
    )
    .unwrap();
    let floor = Shape::Plane {
        normal: glam::Vec3A::Z,
        offset: -0.05,
    };
    w.add_collider(Collider::new(floor, 0.3, 0.005)).unwrap();
    w.step().unwrap();
    let mut p = s.positions.clone();
    p[0][2] = -1.198_385_9e31;
    w.set_positions(&p).unwrap();
    let _ = w.step();
    assert_sane(&w);
    w.clear_colliders();
    w.set_positions(&s.positions).unwrap();
    w.set_velocities(&vec![[0.0; 3]; s.positions.len()])
        .unwrap();
    for _ in 0..3 {
        let r = w.step();
        assert!(r.is_ok(), "{r:?}");
        assert_sane(&w);
    }
}

/// Found by `init_on_any_mesh_builds_or_refuses` (5,000 cases): a density of `f64::MAX` passed the
/// material checks (finite, positive) and became an infinite `f32` lumped mass; a (u,v) extent of
/// 1e21 m did the same to the lumped area, and a tiny one rounded it to zero. Each is now refused
/// at init, naming the material or the triangle.
#[test]
fn values_beyond_f32_are_refused_at_init() {
    let s = Sheet::grid(3, 3, 0.2, 0.2);
    let init = |s: &Sheet, m: Material| {
        let mut mem = common::memory(&s.capacity());
        World::new(
            &mut mem,
            s.capacity(),
            &s.def(),
            Materials::Table(&[m]),
            Settings::default(),
        )
        .err()
    };
    let plain = common::isotropic(1000.0, 0.3, 0.2);
    for density in [f64::MAX, 1e300, 1e-320] {
        assert_eq!(
            init(&s, Material { density, ..plain }),
            Some(InitError::InvalidMaterial { material: 0 }),
            "density {density}"
        );
    }
    let stiff = Material {
        stiffness: weft::membrane::isotropic(1e300, 0.3),
        ..plain
    };
    assert_eq!(
        init(&s, stiff),
        Some(InitError::InvalidMaterial { material: 0 })
    );
    for scale in [1e22f32, 1e-22] {
        let mut big = Sheet::grid(3, 3, 0.2, 0.2);
        for uv in &mut big.uvs {
            uv[0] *= scale;
            uv[1] *= scale;
        }
        assert_eq!(
            init(&big, plain),
            Some(InitError::Mesh(MeshError::UvOutOfRange { triangle: 0 })),
            "uv scale {scale}"
        );
    }
}

/// The world carves its typed arrays out of the caller's bytes (the crate's one `unsafe` block):
/// any start address works, the padding is accounted for, and one byte less is refused. Small
/// enough to run under Miri (`scripts/miri.sh`), which checks the carving for undefined behaviour.
#[test]
fn world_memory_at_any_alignment() {
    let s = Sheet::grid(3, 3, 0.2, 0.2);
    let mats = [common::isotropic(1000.0, 0.3, 0.2)];
    let cap = s.capacity();
    let needed = cap.world_bytes();
    let mut block = vec![0xA5u8; needed + 16];
    for offset in [0usize, 1, 3, 8, 15] {
        let mem = &mut block[offset..offset + needed];
        let mut w = World::new(
            mem,
            cap,
            &s.def(),
            Materials::Table(&mats),
            Settings::default(),
        )
        .unwrap_or_else(|e| panic!("offset {offset}: {e:?}"));
        w.set_pin(0, [0.0, 0.0, 0.0]).unwrap();
        w.step().unwrap();
        assert_sane(&w);
    }
    let short = &mut block[..needed - 1];
    assert_eq!(
        World::new(
            short,
            cap,
            &s.def(),
            Materials::Table(&mats),
            Settings::default()
        )
        .err(),
        Some(InitError::MemoryTooSmall)
    );
}

/// `Capacity::grid(n)` multiplied in `u32` and panicked on overflow for n ≥ 65536 (a
/// `weft-bench --grid` argument reaches it); it now saturates, and such a capacity is refused.
#[test]
fn huge_grid_capacity_saturates_and_is_refused() {
    let cap = Capacity::grid(u32::MAX);
    assert_eq!(cap.vertices, u32::MAX);
    assert_eq!(cap.triangles, u32::MAX);
    assert_eq!(cap.edges, u32::MAX);
    assert!(cap.world_bytes() > 1 << 40);
    let s = Sheet::grid(3, 3, 0.2, 0.2);
    let mats = [common::isotropic(1000.0, 0.3, 0.2)];
    let mut mem = vec![0u8; 4096];
    assert_eq!(
        World::new(
            &mut mem,
            cap,
            &s.def(),
            Materials::Table(&mats),
            Settings::default()
        )
        .err(),
        Some(InitError::MemoryTooSmall)
    );
    assert_eq!(Capacity::grid(16), common_grid_16());
}

/// What `Capacity::grid(16)` always was (3(n-1)² + 2(n-1) edges).
fn common_grid_16() -> Capacity {
    Capacity {
        vertices: 256,
        triangles: 450,
        edges: 705,
        colliders: 8,
        pins: 64,
    }
}
