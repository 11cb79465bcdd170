//! Thin colliders and coarse cloth (issue 13, item 8): a pole or a small sphere thinner than the
//! cloth's spacing must not slip between its vertices, and a vertex touching two colliders at
//! once must rest outside both, without jitter and without gaining energy. The cloth is the
//! bundled stripes cell (anisotropic).

mod common;

use std::sync::OnceLock;

use common::*;
use glam::Vec3A;
use weft::blob::{AlignedBytes, Blob};
use weft::collide::{Collider, Shape};
use weft::world::{Materials, Settings, Solver, StepStats, World};

/// `cells/stripes.toml` homogenized at refine 1.
fn stripes() -> &'static AlignedBytes {
    static BLOB: OnceLock<AlignedBytes> = OnceLock::new();
    BLOB.get_or_init(|| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cells/stripes.toml");
        let bytes = weft::homogenize::build_blob(&[path], 1, &mut |_, _| {}).unwrap();
        AlignedBytes::copy_from(&bytes)
    })
}

const THICKNESS: f32 = 0.005;

/// A 9×9 cloth over 1 m (spacing 12.5 cm), flat at height `z`, shifted by `(dx, dy)`.
fn coarse_sheet(dx: f32, dy: f32, z: f32) -> Sheet {
    let mut sheet = Sheet::grid(9, 9, 1.0, 1.0);
    sheet.transform(|p| [p[0] - 0.5 + dx, p[1] - 0.5 + dy, z]);
    sheet
}

fn stripes_world<'a>(mem: &'a mut Vec<u8>, sheet: &Sheet, blob: &'a Blob<'a>) -> World<'a> {
    *mem = memory(&sheet.capacity());
    World::new(
        mem,
        sheet.capacity(),
        &sheet.def(),
        Materials::Blob(blob),
        Settings::default(),
    )
    .unwrap()
}

/// The deepest any point of the cloth's edges gets below `shape`'s surface (m, positive when
/// inside), sampling each edge densely.
fn deepest_edge_point(w: &World<'_>, sheet: &Sheet, shape: &Shape) -> f32 {
    let x = w.positions();
    let mut deepest = f32::NEG_INFINITY;
    for t in &sheet.triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let (p, q) = (x[a as usize], x[b as usize]);
            for k in 0..=200 {
                let s = k as f32 / 200.0;
                deepest = deepest.max(-shape.proximity(p.lerp(q, s)).distance);
            }
        }
    }
    deepest
}

/// Steps `steps` times and checks every step's energy balance: no step keeps energy that
/// nothing supplied (a step that gained is redone with more substeps; nothing may be left to
/// remove after that). Calls `each` after every step; returns the number of redone steps.
fn run(
    w: &mut World<'_>,
    steps: usize,
    mut each: impl FnMut(&World<'_>, usize, &StepStats),
) -> u32 {
    let mut redone = 0;
    for step in 0..steps {
        let s = w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        assert!(
            s.energy_removed == 0.0,
            "step {step}: gained energy without input: {s:?}"
        );
        redone += s.redone.min(1);
        each(w, step, &s);
    }
    redone
}

/// [`run`] for 300 steps, checking after each that no edge cuts more than 2 mm into `shape`
/// (`case` names the scene in the message); returns the number of redone steps.
fn run_outside(w: &mut World<'_>, sheet: &Sheet, shape: &Shape, case: &str) -> u32 {
    run(w, 300, |w, step, _| {
        let inside = deepest_edge_point(w, sheet, shape);
        assert!(
            inside < 0.002,
            "{case}, step {step}: an edge cuts {inside} m into {shape:?}"
        );
    })
}

/// A coarse cloth dropped across a 2 cm pole, the pole between two rows of vertices: it hangs
/// over the pole (only its edges touch it), no edge ever cuts into the pole, and its swing dies
/// out.
#[test]
fn a_coarse_cloth_hangs_over_a_thin_pole() {
    let blob_bytes = stripes();
    let blob = Blob::parse(blob_bytes).unwrap();
    // 9 × 10 vertices 12.5 cm apart, rows at y = ±0.0625, ±0.1875, …: the pole at y = 0 lies
    // between the middle two
    let mut sheet = Sheet::grid(9, 10, 1.0, 1.125);
    sheet.transform(|p| [p[0] - 0.5, p[1] - 0.5625, 0.05]);
    let mut mem = Vec::new();
    let mut w = stripes_world(&mut mem, &sheet, &blob);
    let pole = Shape::Capsule {
        a: Vec3A::new(-1.0, 0.0, 0.0),
        b: Vec3A::new(1.0, 0.0, 0.0),
        radius: 0.02,
    };
    w.add_collider(Collider::new(pole, 0.5, THICKNESS)).unwrap();
    let mut kinetic = Vec::new();
    let redone = run(&mut w, 600, |w, step, _| {
        let inside = deepest_edge_point(w, &sheet, &pole);
        assert!(
            inside < 0.002,
            "step {step}: an edge cuts {inside} m into the pole"
        );
        kinetic.push(kinetic_energy(w));
    });
    // hanging over the pole: the rows either side of it sit on it, the rest hangs below
    let x = w.positions();
    for i in 0..9 {
        for j in [4, 5] {
            let z = x[sheet.index(i, j) as usize].z;
            assert!(
                z > 0.0 && z < 0.03,
                "vertex ({i}, {j}) at z = {z} is not on the pole"
            );
        }
    }
    println!("{redone} of 600 steps redone");
    let lowest = x.iter().map(|p| p.z).fold(f32::INFINITY, f32::min);
    assert!(lowest > -0.5, "hangs down to {lowest}: slid off or through");
    let peak = kinetic.iter().fold(0.0f64, |a, &b| a.max(b));
    let last = kinetic[kinetic.len() - 60..]
        .iter()
        .fold(0.0f64, |a, &b| a.max(b));
    assert!(
        last < 3e-3 * peak,
        "the swing does not die out: {last} J over the last second, {peak} J at the peak"
    );
}

/// A lifting pole carries the cloth up; the energy balance counts the pole's work through the
/// edge contacts (a missed work would be flagged as a gain and redone).
#[test]
fn a_rising_pole_lifts_a_coarse_cloth_through_its_edges() {
    let blob_bytes = stripes();
    let blob = Blob::parse(blob_bytes).unwrap();
    let sheet = coarse_sheet(0.0, 0.0625, 0.03);
    let mut mem = Vec::new();
    let mut w = stripes_world(&mut mem, &sheet, &blob);
    let pole = |z: f32| Shape::Capsule {
        a: Vec3A::new(-1.0, 0.0, z),
        b: Vec3A::new(1.0, 0.0, z),
        radius: 0.02,
    };
    w.add_collider(Collider::new(pole(0.0), 0.5, THICKNESS))
        .unwrap();
    let mut z = 0.0;
    let mut redone = 0;
    for step in 0..180 {
        if step >= 60 {
            z += 0.5 / 60.0;
            w.set_collider_shape(0, pole(z)).unwrap();
        }
        let s = w.step().unwrap();
        assert!(s.energy_removed == 0.0, "step {step}: {s:?}");
        redone += s.redone.min(1);
        let inside = deepest_edge_point(&w, &sheet, &pole(z));
        assert!(
            inside < 0.002,
            "step {step}: an edge cuts {inside} m into the pole"
        );
    }
    println!("{redone} of 180 steps redone");
    let x = w.positions();
    let top = x[sheet.index(4, 4) as usize].z;
    assert!(
        top > z && top < z + 0.03,
        "the cloth stayed behind: vertex at {top}, pole at {z}"
    );
}

/// A 3 cm sphere under the middle of a triangle (its incircle, 3.66 cm, is wider than the
/// sphere's offset surface): no vertex and no edge touches it, only the face.
#[test]
fn a_coarse_cloth_rests_on_a_small_sphere_inside_one_triangle() {
    let blob_bytes = stripes();
    let blob = Blob::parse(blob_bytes).unwrap();
    // the triangle [ll, lr, ur] of the square whose lower-left corner is vertex (4, 4) has its
    // right angle at lr and its incentre at (h − ρ, ρ) from ll, ρ = h (2 − √2) / 2
    let h = 0.125f32;
    let rho = h * (2.0 - 2f32.sqrt()) / 2.0;
    let sheet = coarse_sheet(-(h - rho), -rho, 0.04);
    let mut mem = Vec::new();
    let mut w = stripes_world(&mut mem, &sheet, &blob);
    let sphere = Shape::Sphere {
        center: Vec3A::ZERO,
        radius: 0.03,
    };
    w.add_collider(Collider::new(sphere, 0.5, THICKNESS))
        .unwrap();
    let mut lowest = f32::INFINITY;
    let redone = run(&mut w, 300, |w, step, _| {
        let inside = deepest_edge_point(w, &sheet, &sphere);
        assert!(
            inside < 0.002,
            "step {step}: an edge cuts {inside} m into the sphere"
        );
        let x = w.positions();
        let t = &sheet.triangles[2 * (4 * 8 + 4)];
        let centroid = (x[t[0] as usize] + x[t[1] as usize] + x[t[2] as usize]) / 3.0;
        lowest = lowest.min(centroid.z);
    });
    println!("{redone} of 300 steps redone; the face's centre went down to {lowest}");
    assert!(
        lowest > 0.0,
        "the cloth fell through the sphere (the face's centre went down to {lowest})"
    );
}

/// A cloth lying in a V-shaped valley of two floors tilted 15° toward each other: the vertices
/// along the valley's bottom touch both. They come to rest outside both, without
/// jitter.
#[test]
fn a_vertex_in_the_groove_of_two_colliders_rests_outside_both() {
    let blob_bytes = stripes();
    let blob = Blob::parse(blob_bytes).unwrap();
    let (s, c) = 15f32.to_radians().sin_cos();
    // laid in the valley, folded along its middle column: the fold's bending presses the
    // middle column into the groove
    let mut sheet = Sheet::grid(17, 17, 1.0, 1.0);
    sheet.transform(|p| {
        let x = (p[0] - 0.5) * c;
        [x, p[1] - 0.5, x.abs() * s / c + THICKNESS / c]
    });
    let mut mem = Vec::new();
    let mut w = stripes_world(&mut mem, &sheet, &blob);
    let left = Shape::Plane {
        normal: Vec3A::new(s, 0.0, c),
        offset: 0.0,
    };
    let right = Shape::Plane {
        normal: Vec3A::new(-s, 0.0, c),
        offset: 0.0,
    };
    w.add_collider(Collider::new(left, 0.0, THICKNESS)).unwrap();
    w.add_collider(Collider::new(right, 0.0, THICKNESS))
        .unwrap();
    let mut speeds = Vec::new();
    let redone = run(&mut w, 600, |w, step, _| {
        for (i, x) in w.positions().iter().enumerate() {
            for shape in [&left, &right] {
                let d = shape.proximity(*x).distance;
                assert!(
                    d > THICKNESS - 1e-4,
                    "step {step}: vertex {i} at {d} from {shape:?}"
                );
            }
        }
        speeds.push(top_speed(w));
    });
    let x = w.positions();
    let in_groove = x
        .iter()
        .filter(|p| {
            left.proximity(**p).distance < 2.0 * THICKNESS
                && right.proximity(**p).distance < 2.0 * THICKNESS
        })
        .count();
    let tail = &speeds[speeds.len() - 60..];
    let peak = tail.iter().fold(0.0f32, |a, &b| a.max(b));
    println!(
        "{in_groove} vertices in the groove; fastest over the last second {peak} m/s; {redone} steps redone"
    );
    assert!(in_groove > 0, "no vertex touches both colliders");
    assert!(
        peak < 1e-3,
        "does not rest: {peak} m/s over the last second"
    );
    assert!(redone <= 5, "{redone} steps gained energy and were redone");
}

/// A coarse cloth dropped on a large sphere (edges longer than the sphere's curvature allows:
/// their chords dip into the thickness between resting vertices) and on a small sphere under
/// one vertex: the edge contacts next to the vertex contacts put no energy in (no step is
/// even redone). Drawing vertices toward the surface along several nearly parallel normals
/// did, at most steps.
#[test]
fn edge_contacts_beside_vertex_contacts_put_no_energy_in() {
    let blob_bytes = stripes();
    let blob = Blob::parse(blob_bytes).unwrap();
    for radius in [0.3f32, 0.03] {
        let sheet = coarse_sheet(0.0, 0.0, radius + 0.01);
        let mut mem = Vec::new();
        let mut w = stripes_world(&mut mem, &sheet, &blob);
        let sphere = Shape::Sphere {
            center: Vec3A::ZERO,
            radius,
        };
        w.add_collider(Collider::new(sphere, 0.5, THICKNESS))
            .unwrap();
        let redone = run_outside(&mut w, &sheet, &sphere, &format!("radius {radius}"));
        assert_eq!(redone, 0, "radius {radius}: steps redone");
    }
}

/// A coarse cloth dropped a little off the top of a small sphere slides off it (its edge and
/// face contacts are frictionless) and drapes around it: as it slides, no edge cuts into the
/// sphere, with either solver. A corner that touched the sphere used to keep its own contact
/// only and slide along the surface while its edge's other end was held: started 5 mm off
/// centre, an edge ended 17 mm inside.
#[test]
fn a_coarse_cloth_sliding_off_a_small_sphere_never_cuts_it() {
    let blob_bytes = stripes();
    let blob = Blob::parse(blob_bytes).unwrap();
    let sphere = Shape::Sphere {
        center: Vec3A::ZERO,
        radius: 0.03,
    };
    for solver in [Solver::Multigrid, Solver::BlockJacobi] {
        for (dx, dy) in [(0.005, 0.0), (0.01, 0.0), (0.02, 0.01), (0.03, -0.02)] {
            let sheet = coarse_sheet(dx, dy, 0.04);
            let mut mem = Vec::new();
            let mut w = stripes_world(&mut mem, &sheet, &blob);
            w.set_solver(solver);
            w.add_collider(Collider::new(sphere, 0.5, THICKNESS))
                .unwrap();
            let case = format!("{solver:?}, ({dx}, {dy}) off centre");
            let redone = run_outside(&mut w, &sheet, &sphere, &case);
            assert_eq!(
                redone, 0,
                "{solver:?}, ({dx}, {dy}) off centre: steps redone"
            );
        }
    }
}

/// A sphere and a pole that inflate under a resting cloth at 3 m/s lift it at their surface's
/// speed: a growing radius moves the surface along its normal, and the contact takes that
/// velocity, as a moving centre's. Before, only a shell's radius counted: the vertices on an
/// inflating sphere or capsule were pushed out by position alone and kept no velocity
/// (0.0–0.3 m/s while moving at 3 m/s). No energy may be left for the balance to remove, and
/// the cloth is never held still.
#[test]
fn an_inflating_sphere_or_pole_lifts_the_cloth_at_its_surface_speed() {
    let blob_bytes = stripes();
    let blob = Blob::parse(blob_bytes).unwrap();
    let sphere = |r: f32| Shape::Sphere {
        center: Vec3A::new(0.0, 0.0, -0.25),
        radius: r,
    };
    let pole = |r: f32| Shape::Capsule {
        a: Vec3A::new(-1.0, 0.0, -0.25),
        b: Vec3A::new(1.0, 0.0, -0.25),
        radius: r,
    };
    let speed = 3.0;
    for (name, shape) in [
        ("sphere", &sphere as &dyn Fn(f32) -> Shape),
        ("pole", &pole),
    ] {
        let sheet = coarse_sheet(0.0, 0.0, 0.0);
        let mut mem = Vec::new();
        let mut w = stripes_world(&mut mem, &sheet, &blob);
        w.add_collider(Collider::new(shape(0.2), 0.5, THICKNESS))
            .unwrap();
        let mut radius = 0.2;
        let middle = sheet.index(4, 4) as usize;
        for step in 0..60 {
            // the cloth lands on the sphere or pole first; it then grows for 6 steps
            let growing = (5..11).contains(&step);
            if growing {
                radius += speed / 60.0;
                w.set_collider_shape(0, shape(radius)).unwrap();
            }
            let s = w.step().unwrap();
            assert!(
                s.energy_removed == 0.0 && !s.stopped,
                "{name}, step {step}: {s:?}"
            );
            // the middle vertex lies on top (the surface's normal is +z there)
            let vz = w.velocities()[middle].z;
            assert!(
                !growing || (vz - speed).abs() < 0.1 * speed,
                "{name}, step {step}: the middle rises at {vz} m/s on a surface rising at {speed}"
            );
        }
    }
}
