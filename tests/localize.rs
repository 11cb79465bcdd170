//! Localization acceptance (issue: bind a fine mesh once, localize it every frame), on real
//! blobs homogenized from `cells/*.toml`: no strain gives no micro displacement, a laminate
//! pulled across its layers splits the strain as the closed form says, no cracks across coarse
//! edges and cells (also after a drape over a sphere), binding errors write nothing, ranges
//! compose.

mod common;

use std::path::PathBuf;
use std::sync::OnceLock;

use bytemuck::Zeroable;
use common::*;
use glam::{Mat3A, Vec3A};
use weft::blob::{AlignedBytes, Blob};
use weft::collide::ColliderSet;
use weft::collide::{Collider, Shape};
use weft::localize::{
    bind, bind_to_triangle, bindings_needed, blocks, localize, localize_colliding,
    localize_recomputed, prepare, prepare_mesh, recompute_normals, tiled_mesh, tiled_mesh_counts,
    BindError, Binding, Coarse, LocalizeError, NormalTarget, StrainMeasure, VertexFrame,
};
use weft::strided::{StrideError, Strided, StridedMut};
use weft::world::{Materials, Settings, World};

// ----- fixtures -----

fn build(names: &[&str], refine: usize) -> AlignedBytes {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("cells");
    let paths: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
    let bytes = weft::homogenize::build_blob(&paths, refine, &mut |_, _| {}).unwrap();
    AlignedBytes::copy_from(&bytes)
}

/// `stripes` (cell 0) and `three` (cell 1) at refine 1.
fn blob_bytes() -> &'static AlignedBytes {
    static B: OnceLock<AlignedBytes> = OnceLock::new();
    B.get_or_init(|| build(&["stripes.toml", "three.toml"], 1))
}

fn blob() -> Blob<'static> {
    Blob::parse(blob_bytes()).unwrap()
}

fn blob_world<'a>(mem: &'a mut [u8], sheet: &Sheet, blob: &Blob<'_>, s: Settings) -> World<'a> {
    World::new(
        mem,
        sheet.capacity(),
        &sheet.def(),
        Materials::Blob(blob),
        s,
    )
    .unwrap()
}

fn frames_of(w: &World<'_>, m: StrainMeasure) -> Vec<VertexFrame> {
    let mut f = vec![VertexFrame::REST; w.vertex_count()];
    prepare(w, m, &mut f).unwrap();
    f
}

fn run(frames: &[VertexFrame], tris: &[[u32; 3]], b: &[Binding]) -> Vec<[f32; 3]> {
    let mut out = vec![[f32::NAN; 3]; b.len()];
    localize(
        frames,
        tris,
        b,
        0,
        &mut StridedMut::from_slice(&mut out),
        None,
    )
    .unwrap();
    out
}

fn bind_all(w: &World<'_>, blob: &Blob<'_>, uv: &[[f32; 2]]) -> Vec<Binding> {
    let mut b = vec![Binding::ZERO; uv.len()];
    bind(w, blob, &Strided::from_slice(uv), &mut b).unwrap();
    b
}

fn tiled(w: &World<'_>, blob: &Blob<'_>, cell: u32) -> (Vec<[f32; 2]>, Vec<[u32; 3]>, Vec<u32>) {
    let (nv, nt) = tiled_mesh_counts(w, blob, cell).unwrap();
    let (mut uv, mut tris, mut mats) = (vec![[0.0; 2]; nv], vec![[0; 3]; nt], vec![0; nt]);
    assert_eq!(
        tiled_mesh(w, blob, cell, &mut uv, &mut tris, Some(&mut mats)).unwrap(),
        (nv, nt)
    );
    (uv, tris, mats)
}

fn dist(a: [f32; 3], b: [f32; 3]) -> f32 {
    (Vec3A::from(a) - Vec3A::from(b)).length()
}

/// Grid sheet with every triangle using `cell`.
fn sheet_of(n: usize, size: f32, cell: u32) -> Sheet {
    let mut s = Sheet::grid(n, n, size, size);
    s.materials.fill(cell);
    s
}

/// A smooth, non-uniform deformation: stretches of a few percent, shear, a bend and a turn.
fn wavy(p: [f32; 3], size: f32) -> [f32; 3] {
    let (u, v) = (p[0] / size, p[1] / size);
    let x = Vec3A::new(
        p[0] * (1.0 + 0.03 * (3.0 * v).sin()) + 0.01 * size * (2.0 * u).sin(),
        p[1] * (1.0 + 0.02 * (2.0 * u).cos()) + 0.015 * size * u * v,
        0.2 * size * (2.5 * u).sin() * (1.5 * v).cos(),
    );
    (Mat3A::from_rotation_y(0.4) * Mat3A::from_rotation_z(-0.3) * x).to_array()
}

// ----- no strain, no micro displacement -----

#[test]
fn rest_and_rigid_motion_localize_to_the_rigidly_moved_rest_mesh() {
    let blob = blob();
    let size = 0.2f32;
    let sheet = sheet_of(11, size, 1); // the three-material cell, 20 cells across
    let mut mem = memory(&sheet.capacity());
    let mut w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let (uv, ftris, _) = tiled(&w, &blob, 1);
    assert_eq!(uv.len(), 201 * 201);
    let b = bind_all(&w, &blob, &uv);
    // the bindings do carry micro displacements: a strained cloth would move them
    let chi_max = b
        .iter()
        .flat_map(|b| b.chi)
        .fold(0.0f32, |m, c| m.max(c.abs()));
    assert!(chi_max > 1e-5, "chi is {chi_max}: nothing to test");

    let rot = Mat3A::from_rotation_z(0.9) * Mat3A::from_rotation_x(-2.1);
    let shift = Vec3A::new(0.05, -0.1, 0.08);
    type Motion = Box<dyn Fn(Vec3A) -> Vec3A>;
    let motions: [(&str, Motion); 2] = [
        ("rest", Box::new(|p| p)),
        ("rigid", Box::new(move |p| rot * p + shift)),
    ];
    for (name, motion) in motions {
        let x: Vec<[f32; 3]> = sheet
            .positions
            .iter()
            .map(|&p| motion(Vec3A::from(p)).to_array())
            .collect();
        w.set_positions(&x).unwrap();
        for m in [StrainMeasure::Corotated, StrainMeasure::Green] {
            let frames = frames_of(&w, m);
            let mut pos = vec![[0.0f32; 3]; uv.len()];
            let mut nrm = vec![[0.0f32; 3]; uv.len()];
            localize(
                &frames,
                w.triangles(),
                &b,
                0,
                &mut StridedMut::from_slice(&mut pos),
                Some(NormalTarget::Buffer(&mut StridedMut::from_slice(&mut nrm))),
            )
            .unwrap();
            let mut worst = 0.0f32;
            for (p, q) in pos.iter().zip(&uv) {
                let expect = motion(Vec3A::new(q[0], q[1], 0.0)).to_array();
                worst = worst.max(dist(*p, expect));
            }
            assert!(
                worst <= 1e-6 * size,
                "{name} {m:?}: fine vertex off its moved rest place by {worst}"
            );
            let z = motion(Vec3A::Z) - motion(Vec3A::ZERO);
            for n in &nrm {
                assert!(dist(*n, z.to_array()) < 1e-5, "{name}: normal {n:?}");
            }
            // exact normals from the fine mesh agree
            let mut exact = vec![[0.0f32; 3]; uv.len()];
            recompute_normals(
                &ftris,
                &mut StridedMut::from_slice(&mut pos),
                NormalTarget::Buffer(&mut StridedMut::from_slice(&mut exact)),
            )
            .unwrap();
            for n in &exact {
                assert!(dist(*n, z.to_array()) < 1e-4, "{name}: exact normal {n:?}");
            }
        }
    }
}

// ----- the laminate -----

/// Mean engineering strain of the fine edges along v and along u, per cell material.
fn layer_strains(pos: &[[f32; 3]], uv: &[[f32; 2]], mats: &[u32], nx: usize) -> Vec<[f64; 2]> {
    let ny = uv.len() / nx;
    let nm = 1 + *mats.iter().max().unwrap() as usize;
    let mut sum = vec![[0.0f64; 2]; nm];
    let mut cnt = vec![[0usize; 2]; nm];
    let stretch = |a: usize, b: usize| {
        let d = dist(pos[a], pos[b]) as f64;
        let r = ((uv[a][0] - uv[b][0]) as f64).hypot((uv[a][1] - uv[b][1]) as f64);
        d / r - 1.0
    };
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let m = mats[2 * (j * (nx - 1) + i)] as usize;
            let a = j * nx + i;
            for (dir, b) in [(0, a + 1), (1, a + nx)] {
                sum[m][dir] += stretch(a, b);
                cnt[m][dir] += 1;
            }
        }
    }
    sum.iter()
        .zip(&cnt)
        .map(|(s, c)| [s[0] / c[0] as f64, s[1] / c[1] as f64])
        .collect()
}

/// Horizontal stripes pulled across the layers (along v) with u held: the along-layer strain
/// is the macro one (0) in every layer, the across-layer stress `c22 e22` is continuous, and
/// the layer strains average to the macro strain, so `e_m = ε (1/c22_m) / <1/c22>`. Measured
/// from the localized fine positions (edge lengths), not from χ.
#[test]
fn stripes_pulled_across_split_the_strain_as_the_laminate_closed_form() {
    let blob = blob();
    let cell = blob.cell(0).unwrap();
    assert_eq!(cell.name, "stripes");
    let size = 0.04f32;
    let sheet = sheet_of(5, size, 0);
    let mut mem = memory(&sheet.capacity());
    let mut w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let (uv, _, mats) = tiled(&w, &blob, 0);
    let nx = 33;
    assert_eq!(uv.len(), nx * nx);
    let b = bind_all(&w, &blob, &uv);

    // closed form from the cell's own materials and pattern fractions
    let inv_c22: Vec<f64> = cell.materials.iter().map(|m| 1.0 / m.c[1][1]).collect();
    let mut frac = vec![0.0f64; inv_c22.len()];
    for &m in cell.tri_material {
        frac[m as usize] += 1.0 / cell.tri_material.len() as f64;
    }
    let mean_inv: f64 = frac.iter().zip(&inv_c22).map(|(f, i)| f * i).sum();
    let hard = (0..inv_c22.len())
        .min_by(|&a, &b| inv_c22[a].total_cmp(&inv_c22[b]))
        .unwrap();
    let soft = 1 - hard;

    let rot = Mat3A::from_rotation_x(0.6) * Mat3A::from_rotation_z(0.3);
    let measure = |w: &mut World<'_>, eps: f32, m: StrainMeasure| {
        let x: Vec<[f32; 3]> = sheet
            .uvs
            .iter()
            .map(|q| (rot * Vec3A::new(q[0], q[1] * (1.0 + eps), 0.0)).to_array())
            .collect();
        w.set_positions(&x).unwrap();
        let pos = run(&frames_of(w, m), w.triangles(), &b);
        layer_strains(&pos, &uv, &mats, nx)
    };
    let expect = |eps: f64, m: usize| eps * inv_c22[m] / mean_inv;

    let eps = 0.02;
    let got = measure(&mut w, eps as f32, StrainMeasure::Corotated);
    for m in [soft, hard] {
        let (e, want) = (got[m][1], expect(eps, m));
        assert!(
            (e / want - 1.0).abs() < 0.02,
            "material {m}: across-layer strain {e}, closed form {want}"
        );
        assert!(
            got[m][0].abs() < 0.01 * eps,
            "along-layer strain {}",
            got[m][0]
        );
    }
    let ratio = got[soft][1] / got[hard][1];
    let want = inv_c22[soft] / inv_c22[hard];
    assert!(
        (ratio / want - 1.0).abs() < 0.02,
        "soft/hard {ratio}, closed form {want}"
    );
    assert!(want > 5.0, "the cell should be a strong laminate");

    // The paper's Green strain + F agrees to first order (checked at 0.2 %); beyond, it
    // over-shoots the fluctuation and the hard layers' small strain comes out too small: by
    // 7 % at 1 % stretch and 14 % at 2 % on this 10:1 laminate (more at higher contrast).
    let green = measure(&mut w, 0.002, StrainMeasure::Green);
    for m in [soft, hard] {
        let (e, want) = (green[m][1], expect(0.002, m));
        assert!((e / want - 1.0).abs() < 0.02, "Green, 0.2 %: {e} vs {want}");
    }
    let green = measure(&mut w, eps as f32, StrainMeasure::Green);
    let off = green[hard][1] / expect(eps, hard) - 1.0;
    eprintln!(
        "stripes at 2 %: corotated soft {:.5} hard {:.5}; Green hard {:.5} ({:+.1} %); closed form soft {:.5} hard {:.5}",
        got[soft][1],
        got[hard][1],
        green[hard][1],
        100.0 * off,
        expect(eps, soft),
        expect(eps, hard)
    );
    assert!(off.abs() > 0.05, "Green at 2 % unexpectedly exact: {off}");
    let green = measure(&mut w, 0.01, StrainMeasure::Green);
    let off_1 = green[hard][1] / expect(0.01, hard) - 1.0;
    eprintln!(
        "stripes at 1 %: Green hard layer off by {:+.1} %",
        100.0 * off_1
    );
    // (the header's WEFT_STRAIN_GREEN quotes these: −7 % at 1 %, −14 % at 2 % on this 10:1 cell)
    assert!((-0.09..-0.05).contains(&off_1), "Green at 1 %: {off_1}");
    assert!((-0.16..-0.11).contains(&off), "Green at 2 %: {off}");
}

// ----- no cracks -----

/// Rest (u, v) of the points of a lattice of spacing `size / (cells · m)`, each with every
/// coarse triangle that contains it (f64 barycentrics ≥ −1e-9).
fn lattice_owners(w: &World<'_>, n: usize) -> Vec<([f32; 2], Vec<u32>)> {
    let rest = w.rest_positions();
    let (lo, hi) = rest.iter().fold(
        (Vec3A::splat(f32::MAX), Vec3A::splat(f32::MIN)),
        |(l, h), &p| (l.min(p), h.max(p)),
    );
    let mut out = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let q = [
                lo.x + (hi.x - lo.x) * i as f32 / n as f32,
                lo.y + (hi.y - lo.y) * j as f32 / n as f32,
            ];
            let mut owners = Vec::new();
            for (t, tri) in w.triangles().iter().enumerate() {
                let [a, b, c] = tri.map(|v| rest[v as usize].as_dvec3());
                let p = glam::DVec3::new(q[0] as f64, q[1] as f64, 0.0);
                let det = (b - a).truncate().perp_dot((c - a).truncate());
                let b1 = (p - a).truncate().perp_dot((c - a).truncate()) / det;
                let b2 = (b - a).truncate().perp_dot((p - a).truncate()) / det;
                if b1 >= -1e-9 && b2 >= -1e-9 && 1.0 - b1 - b2 >= -1e-9 {
                    owners.push(t as u32);
                }
            }
            out.push((q, owners));
        }
    }
    out
}

/// Localizes every shared lattice point once per triangle containing it; returns the largest
/// distance between the copies of a point.
fn edge_gap(
    w: &World<'_>,
    blob: &Blob<'_>,
    frames: &[VertexFrame],
    pts: &[([f32; 2], Vec<u32>)],
) -> f32 {
    let mut worst = 0.0f32;
    for (q, owners) in pts.iter().filter(|p| p.1.len() > 1) {
        let b: Vec<Binding> = owners
            .iter()
            .map(|&t| bind_to_triangle(w, blob, t, *q).unwrap())
            .collect();
        let x = run(frames, w.triangles(), &b);
        for p in &x[1..] {
            worst = worst.max(dist(*p, x[0]));
        }
    }
    worst
}

/// The same gap with each triangle's own, unblended strain and frame (what the blending is
/// for): proves the check can see a crack.
fn unblended_gap(w: &World<'_>, blob: &Blob<'_>, pts: &[([f32; 2], Vec<u32>)]) -> f32 {
    let mut worst = 0.0f32;
    let mut frames = vec![VertexFrame::REST; w.vertex_count()];
    for (q, owners) in pts.iter().filter(|p| p.1.len() > 1) {
        let x: Vec<[f32; 3]> = owners
            .iter()
            .map(|&t| {
                let tri = [w.triangles()[t as usize]];
                prepare_mesh(
                    w.rest_positions(),
                    w.positions(),
                    &tri,
                    StrainMeasure::Corotated,
                    &mut frames,
                )
                .unwrap();
                let mut b = bind_to_triangle(w, blob, t, *q).unwrap();
                b.triangle = 0;
                run(&frames, &tri, &[b])[0]
            })
            .collect();
        for p in &x[1..] {
            worst = worst.max(dist(*p, x[0]));
        }
    }
    worst
}

/// Two cells in a checkerboard of 2×2-square blocks, a wavy deformation: points shared by
/// coarse triangles (and by cells) land at the same place from every side, and a render mesh
/// with vertices duplicated along every coarse edge binds the copies identically.
#[test]
fn no_cracks_across_coarse_edges_and_cells() {
    let blob = blob();
    let size = 0.08f32;
    let n = 9;
    let mut sheet = Sheet::grid(n, n, size, size);
    let q = size / (n - 1) as f32;
    for (t, tri) in sheet.triangles.iter().enumerate() {
        let c = tri.iter().fold([0.0f32; 2], |c, &v| {
            let uv = sheet.uvs[v as usize];
            [c[0] + uv[0] / 3.0, c[1] + uv[1] / 3.0]
        });
        sheet.materials[t] = ((c[0] / (2.0 * q)) as u32 + (c[1] / (2.0 * q)) as u32) % 2;
    }
    assert!(sheet.materials.contains(&0) && sheet.materials.contains(&1));
    sheet.transform(|p| wavy(p, size));
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let pts = lattice_owners(&w, 8 * 6);
    assert!(pts.iter().filter(|p| p.1.len() > 1).count() > 500);
    for m in [StrainMeasure::Corotated, StrainMeasure::Green] {
        let frames = frames_of(&w, m);
        let gap = edge_gap(&w, &blob, &frames, &pts);
        eprintln!("two cells, wavy, {m:?}: largest gap {gap} m");
        assert!(
            gap <= 1e-6 * size,
            "{m:?}: crack of {gap} m across coarse edges"
        );
    }
    let naive = unblended_gap(&w, &blob, &pts);
    eprintln!("two cells, wavy: unblended frames would open cracks of {naive} m");
    assert!(
        naive > 100.0 * 1e-6 * size,
        "the check cannot see cracks ({naive})"
    );

    // Each triangle's own cell's χ (no blending across cells) opens cracks where cells meet.
    let frames = frames_of(&w, StrainMeasure::Corotated);
    let mut own_gap = 0.0f32;
    let single: Vec<Sheet> = (0..2)
        .map(|c| {
            let mut s = Sheet::grid(n, n, size, size);
            s.materials.fill(c);
            s
        })
        .collect();
    let mut mems: Vec<Vec<u8>> = single.iter().map(|s| memory(&s.capacity())).collect();
    let worlds: Vec<World<'_>> = mems
        .iter_mut()
        .zip(&single)
        .map(|(m, s)| blob_world(m, s, &blob, settings_quiet()))
        .collect();
    for (q, owners) in pts.iter().filter(|p| p.1.len() > 1) {
        let b: Vec<Binding> = owners
            .iter()
            .map(|&t| {
                let mut b = bind_to_triangle(&w, &blob, t, *q).unwrap();
                let cell = w.triangle_materials()[t as usize] as usize;
                b.chi = bind_to_triangle(&worlds[cell], &blob, t, *q).unwrap().chi;
                b
            })
            .collect();
        let x = run(&frames, w.triangles(), &b);
        for p in &x[1..] {
            own_gap = own_gap.max(dist(*p, x[0]));
        }
    }
    eprintln!("two cells, wavy: each triangle's own cell's chi would open cracks of {own_gap} m");
    assert!(
        own_gap > 100.0 * 1e-6 * size,
        "the check cannot see cell cracks ({own_gap})"
    );

    // A render mesh made per coarse triangle: every point on a coarse edge is duplicated.
    // Binding is a pure function of (u, v), in any vertex order.
    let dup: Vec<[f32; 2]> = pts
        .iter()
        .flat_map(|(q, owners)| owners.iter().map(move |_| *q))
        .collect();
    let mut order: Vec<usize> = (0..dup.len()).collect();
    order.sort_by_key(|&i| (i * 7919) % dup.len()); // scrambled, incoherent
    let scrambled: Vec<[f32; 2]> = order.iter().map(|&i| dup[i]).collect();
    let b = bind_all(&w, &blob, &dup);
    let bs = bind_all(&w, &blob, &scrambled);
    for (k, &i) in order.iter().enumerate() {
        assert_eq!(bytemuck::bytes_of(&bs[k]), bytemuck::bytes_of(&b[i]));
    }
    let x = run(&frames_of(&w, StrainMeasure::Corotated), w.triangles(), &b);
    let mut k = 0;
    for (_, owners) in &pts {
        for j in 1..owners.len() {
            assert_eq!(bytemuck::bytes_of(&b[k + j]), bytemuck::bytes_of(&b[k]));
            assert_eq!(x[k + j], x[k], "duplicates of a seam vertex differ");
        }
        k += owners.len();
    }
}

/// A 1 m cloth of 21×21 vertices (the paper's Fig. 8 coarse size) of both cells (a disc of
/// `three` in `stripes`) draped for 300 steps over a sphere standing on a floor: the largest
/// gap between the copies of a shared point stays below 1e-6 of the cloth's size.
///
/// Two substeps and 500 PCG iterations: with the defaults (1 substep, 200 iterations) the
/// solve does not converge for these cells at this spacing and the cloth leaves the sphere.
#[test]
fn no_cracks_on_a_draped_collided_cloth() {
    let blob = blob();
    let (size, radius) = (1.0f32, 0.3f32);
    let n = 21;
    let mut sheet = Sheet::grid(n, n, size, size);
    let centre = Vec3A::new(0.5 * size, 0.5 * size, 0.0);
    for (tri, m) in sheet.triangles.iter().zip(&mut sheet.materials) {
        let c: Vec3A = tri
            .iter()
            .map(|&v| Vec3A::from(sheet.positions[v as usize]))
            .sum();
        *m = u32::from((c / 3.0 - centre).length() < 0.25 * size);
    }
    assert!(sheet.materials.contains(&0) && sheet.materials.contains(&1));
    sheet.transform(|p| [p[0] - 0.5 * size, p[1] - 0.5 * size, radius + 0.05]);
    let mut mem = memory(&sheet.capacity());
    let settings = Settings {
        substeps: 2,
        max_iterations: 500,
        ..Settings::default()
    };
    let mut w = blob_world(&mut mem, &sheet, &blob, settings);
    let sphere = Shape::Sphere {
        center: Vec3A::ZERO,
        radius,
    };
    let floor = Shape::Plane {
        normal: Vec3A::Z,
        offset: -0.8 * radius,
    };
    for shape in [sphere, floor] {
        w.add_collider(Collider::new(shape, 0.5, 0.003)).unwrap();
    }
    let mut contacts = 0;
    for _ in 0..300 {
        contacts = contacts.max(w.step().unwrap().contacts);
    }
    assert!(contacts > 10, "the cloth never met the sphere");
    let top = w.positions()[(n * n) / 2];
    assert!(
        top.z > 0.9 * radius,
        "the cloth left the sphere: centre at {top}"
    );
    assert!(w.positions()[0].z < 0.0, "the corners do not hang");

    let pts = lattice_owners(&w, 20 * 4);
    for m in [StrainMeasure::Corotated, StrainMeasure::Green] {
        let frames = frames_of(&w, m);
        let gap = edge_gap(&w, &blob, &frames, &pts);
        eprintln!("draped, {m:?}: largest gap {gap} m");
        assert!(
            gap <= 1e-6 * size,
            "{m:?}: crack of {gap} m after the drape"
        );
    }
    let naive = unblended_gap(&w, &blob, &pts);
    eprintln!("draped: unblended frames would open cracks of {naive} m");
    assert!(
        naive > 10.0 * 1e-6 * size,
        "the check cannot see cracks ({naive})"
    );
}

// ----- the fine mesh outside colliders -----

/// Localizes with the colliders of `w` (every binding, positions only).
fn run_outside(w: &World<'_>, frames: &[VertexFrame], b: &[Binding]) -> Vec<[f32; 3]> {
    let mut out = vec![[f32::NAN; 3]; b.len()];
    let coarse = Coarse {
        frames,
        triangles: w.triangles(),
    };
    let mut pos = StridedMut::from_slice(&mut out);
    localize_colliding(coarse, b, 0, &mut pos, None, w.collider_set()).unwrap();
    out
}

/// The lowest signed distance of `x` to the offset surfaces of `w`'s colliders (negative:
/// inside by that much).
fn clearance(w: &World<'_>, x: [f32; 3]) -> f32 {
    (0..w.collider_count() as u32)
        .map(|i| w.collider(i).unwrap())
        .map(|c| c.shape.proximity(Vec3A::from(x)).distance - c.thickness)
        .fold(f32::MAX, f32::min)
}

/// A coarse cloth of spacing `spacing` (the `stripes` laminate) wrapped over a collider as a
/// drape would leave it: its vertices lie on the collider's offset surface (`surface`, which
/// maps a vertex's (u, v) offset from the cloth's centre to its position) and hang straight
/// down past it. Its localized fine mesh (a lattice of 101 × 101 points) cuts centimetres into
/// the collider; localized with the collider it is outside everywhere, crack-free (each point
/// shared by coarse triangles localized from each), and unchanged wherever it was outside.
fn wrapped_cloth_stays_outside(
    n: [usize; 2],
    spacing: f32,
    collider: Collider,
    surface: impl Fn(f32, f32) -> [f32; 3],
) {
    let blob = blob();
    let size = [(n[0] - 1) as f32 * spacing, (n[1] - 1) as f32 * spacing];
    let mut sheet = Sheet::grid(n[0], n[1], size[0], size[1]);
    for (p, q) in sheet.positions.iter_mut().zip(&sheet.uvs) {
        *p = surface(q[0] - 0.5 * size[0], q[1] - 0.5 * size[1]);
    }
    let mut mem = memory(&sheet.capacity());
    let mut w = blob_world(&mut mem, &sheet, &blob, Settings::default());
    w.add_collider(collider).unwrap();
    for &p in w.positions() {
        assert!(
            clearance(&w, p.to_array()) > -1e-5,
            "a coarse vertex is inside"
        );
    }
    let pts = lattice_owners(&w, 100);
    let uv: Vec<[f32; 2]> = pts.iter().map(|p| p.0).collect();
    let b = bind_all(&w, &blob, &uv);
    let frames = frames_of(&w, StrainMeasure::Corotated);

    let plain = run(&frames, w.triangles(), &b);
    let deepest = plain.iter().map(|&x| clearance(&w, x)).fold(0.0, f32::min);
    eprintln!(
        "{:?}: plain localization {deepest} m inside",
        collider.shape
    );
    assert!(deepest < -0.01, "the test cannot see the cut ({deepest})");

    let outside = run_outside(&w, &frames, &b);
    let worst = outside
        .iter()
        .map(|&x| clearance(&w, x))
        .fold(0.0, f32::min);
    eprintln!(
        "{:?}: colliding localization {worst} m inside",
        collider.shape
    );
    assert!(worst > -1e-5, "a fine vertex is {worst} m inside");
    for (x, p) in outside.iter().zip(&plain) {
        if clearance(&w, *p) >= 0.0 {
            assert_eq!(x, p, "a vertex outside was moved");
        } else {
            let c = clearance(&w, *x);
            assert!(c < 1e-4, "a vertex was pushed {c} m beyond the thickness");
        }
    }

    // Shared points localized from each of their coarse triangles land together.
    let mut gap = 0.0f32;
    for (q, owners) in pts.iter().filter(|p| p.1.len() > 1) {
        let b: Vec<Binding> = owners
            .iter()
            .map(|&t| bind_to_triangle(&w, &blob, t, *q).unwrap())
            .collect();
        let x = run_outside(&w, &frames, &b);
        for p in &x[1..] {
            gap = gap.max(dist(*p, x[0]));
        }
    }
    eprintln!("{:?}: largest gap {gap} m", collider.shape);
    assert!(gap <= 1e-6 * size[0], "crack of {gap} m");

    // With no colliders the colliding call is the plain one, bit for bit.
    let mut none = vec![[f32::NAN; 3]; b.len()];
    let coarse = Coarse {
        frames: &frames,
        triangles: w.triangles(),
    };
    let mut pos = StridedMut::from_slice(&mut none);
    localize_colliding(coarse, &b, 0, &mut pos, None, ColliderSet::new(&[])).unwrap();
    assert_eq!(none, plain);
}

/// Where a cloth draped over a cylinder of radius `r` (axis along y through the origin) puts
/// the point `s` along the cloth across the axis (0 on top): on the cylinder while it wraps
/// it, then straight down.
fn over_cylinder(s: f32, r: f32) -> [f32; 2] {
    let quarter = 0.5 * std::f32::consts::PI * r;
    if s.abs() <= quarter {
        [r * (s / r).sin(), r * (s / r).cos()]
    } else {
        [r * s.signum(), quarter - s.abs()]
    }
}

/// A pole (a 4 cm capsule) under a cloth of 10 cm spacing: the fine mesh between the vertex
/// on top and the hanging ones would be 1.6 cm inside.
#[test]
fn fine_mesh_stays_outside_a_pole_the_coarse_cloth_wraps() {
    let (radius, thickness) = (0.04f32, 0.005f32);
    let pole = Shape::Capsule {
        a: Vec3A::new(0.0, -1.0, 0.0),
        b: Vec3A::new(0.0, 1.0, 0.0),
        radius,
    };
    let r = radius + thickness;
    wrapped_cloth_stays_outside([9, 5], 0.1, Collider::new(pole, 0.5, thickness), |s, y| {
        let [x, z] = over_cylinder(s, r);
        [x, y, z]
    });
}

/// A 6 cm sphere under a cloth of 10 cm spacing, its vertices placed by the distance from the
/// top along the cloth (wrapped on the sphere, then hanging).
#[test]
fn fine_mesh_stays_outside_a_sphere_the_coarse_cloth_wraps() {
    let (radius, thickness) = (0.06f32, 0.003f32);
    let sphere = Shape::Sphere {
        center: Vec3A::ZERO,
        radius,
    };
    let r = radius + thickness;
    let collider = Collider::new(sphere, 0.5, thickness);
    wrapped_cloth_stays_outside([7, 7], 0.1, collider, |su, sv| {
        let s = (su * su + sv * sv).sqrt();
        let [out, z] = over_cylinder(s, r);
        let dir = if s > 0.0 {
            [su / s, sv / s]
        } else {
            [0.0, 0.0]
        };
        [out * dir[0], out * dir[1], z]
    });
}

// ----- binding errors -----

#[test]
fn binding_errors_name_their_cause_and_write_nothing() {
    let blob = blob();
    let sheet = sheet_of(5, 0.04, 0);
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let sentinel = Binding {
        triangle: 0xDEAD_BEEF,
        bary: [f32::NAN; 2],
        chi: [-7.0; 6],
    };
    let bytes_of = |v: &[Binding]| bytemuck::cast_slice::<Binding, u8>(v).to_vec();
    let mut uv: Vec<[f32; 2]> = (0..20)
        .map(|i| [0.002 * i as f32, 0.04 - 0.0015 * i as f32])
        .collect();
    let mut out = vec![sentinel; uv.len()];
    let before = bytes_of(&out);
    // all good first, to show the same call writes when it may
    bind(&w, &blob, &Strided::from_slice(&uv), &mut out).unwrap();
    assert_ne!(bytes_of(&out), before);

    // out of domain: the lowest offending vertex is named
    out.fill(sentinel);
    uv[13] = [0.041, 0.02];
    uv[17] = [-0.5, 0.01];
    assert_eq!(
        bind(&w, &blob, &Strided::from_slice(&uv), &mut out),
        Err(BindError::OutOfDomain { vertex: 13 })
    );
    assert_eq!(bytes_of(&out), before);
    uv[13] = [f32::NAN, 0.0];
    assert_eq!(
        bind(&w, &blob, &Strided::from_slice(&uv), &mut out),
        Err(BindError::OutOfDomain { vertex: 13 })
    );
    assert_eq!(bytes_of(&out), before);
    // within the tolerance of the boundary is inside
    uv[13] = [0.04 + 1e-9, 0.0];
    uv[17] = [0.0, -1e-9];
    let mut tmp = vec![sentinel; uv.len()];
    bind(&w, &blob, &Strided::from_slice(&uv), &mut tmp).unwrap();

    // output too small
    let mut short = vec![sentinel; uv.len() - 1];
    let short_before = bytes_of(&short);
    assert_eq!(
        bind(&w, &blob, &Strided::from_slice(&uv), &mut short),
        Err(BindError::BufferTooSmall {
            needed: 20,
            len: 19
        })
    );
    assert_eq!(bytes_of(&short), short_before);
    assert_eq!(bindings_needed(&Strided::from_slice(&uv)), 20);

    // bad stride and a short input buffer are refused when the view is made
    let raw: Vec<u8> = bytemuck::cast_slice(&uv).to_vec();
    let e = Strided::<2>::new(&raw, 4, uv.len()).unwrap_err();
    assert!(matches!(e, StrideError::BadStride { .. }));
    assert_eq!(BindError::from(e), BindError::BadStride);
    let e = Strided::<2>::new(&raw[..raw.len() - 1], 8, uv.len()).unwrap_err();
    assert_eq!(
        BindError::from(e),
        BindError::BufferTooSmall {
            needed: 160,
            len: 159
        }
    );

    // a triangle whose cell the blob does not have
    let only_stripes = build(&["stripes.toml"], 1);
    let one = Blob::parse(&only_stripes).unwrap();
    let mut two_cells = sheet_of(5, 0.04, 0);
    two_cells.materials[5] = 1;
    let mut mem2 = memory(&two_cells.capacity());
    let w2 = blob_world(&mut mem2, &two_cells, &blob, settings_quiet());
    out.fill(sentinel);
    uv[13] = [0.01, 0.01];
    uv[17] = [0.02, 0.01];
    assert_eq!(
        bind(&w2, &one, &Strided::from_slice(&uv), &mut out),
        Err(BindError::CellMissing { triangle: 5 })
    );
    assert_eq!(bytes_of(&out), before);
    assert_eq!(
        bind_to_triangle(&w2, &blob, 32, [0.0, 0.0]),
        Err(BindError::NoSuchTriangle { triangle: 32 })
    );
    assert_eq!(
        tiled_mesh_counts(&w2, &blob, 2),
        Err(BindError::NoSuchCell { cell: 2 })
    );
    let (mut tuv, mut ttri) = (vec![[0.0; 2]; 10], vec![[0; 3]; 10]);
    assert!(matches!(
        tiled_mesh(&w2, &blob, 0, &mut tuv, &mut ttri, None),
        Err(BindError::BufferTooSmall { .. })
    ));
}

// ----- ranges, interleaved buffers, per-frame errors -----

#[test]
fn range_localization_composes_into_the_full_call() {
    let blob = blob();
    let size = 0.06f32;
    let mut sheet = sheet_of(7, size, 1);
    sheet.transform(|p| wavy(p, size));
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let (uv, _, _) = tiled(&w, &blob, 1);
    let b = bind_all(&w, &blob, &uv);
    let frames = frames_of(&w, StrainMeasure::Corotated);
    let n = uv.len();
    // 32-byte records: position, normal, uv
    let stride = 32;
    let whole = {
        let mut buf = vec![0u8; n * stride];
        let mut p = StridedMut::<3>::new(&mut buf, stride, n).unwrap();
        localize(
            &frames,
            w.triangles(),
            &b,
            0,
            &mut p,
            Some(NormalTarget::Interleaved { offset: 12 }),
        )
        .unwrap();
        buf
    };
    let mut pieces = vec![0u8; n * stride];
    let all = StridedMut::<3>::new(&mut pieces, stride, n).unwrap();
    let (mut a, rest) = all.split_at(n / 3);
    let (mut bb, mut c) = rest.split_at(n / 2 - n / 3);
    let cuts = [0, n / 3, n / 2];
    for (first, part) in cuts.into_iter().zip([&mut a, &mut bb, &mut c]) {
        localize(
            &frames,
            w.triangles(),
            &b,
            first,
            part,
            Some(NormalTarget::Interleaved { offset: 12 }),
        )
        .unwrap();
    }
    assert_eq!(pieces, whole);
    // and the interleaved records hold what the separate buffers get
    let pos = run(&frames, w.triangles(), &b);
    let p = Strided::<3>::new(&whole, stride, n).unwrap();
    for (i, q) in pos.iter().enumerate() {
        assert_eq!(p.get(i).unwrap(), *q);
    }
    // the uv bytes were left alone
    assert!(whole
        .chunks(stride)
        .all(|r| r[24..].iter().all(|&x| x == 0)));

    // errors: range, layout, short normals, bad binding
    let mut buf = vec![0u8; 10 * stride];
    let mut p = StridedMut::<3>::new(&mut buf, stride, 10).unwrap();
    assert_eq!(
        localize(&frames, w.triangles(), &b, n - 5, &mut p, None),
        Err(LocalizeError::Range {
            first: n - 5,
            count: 10,
            len: n
        })
    );
    assert_eq!(
        localize(
            &frames,
            w.triangles(),
            &b,
            0,
            &mut p,
            Some(NormalTarget::Interleaved { offset: 8 })
        ),
        Err(LocalizeError::NormalLayout)
    );
    let mut short = vec![[0.0f32; 3]; 9];
    assert_eq!(
        localize(
            &frames,
            w.triangles(),
            &b,
            0,
            &mut p,
            Some(NormalTarget::Buffer(&mut StridedMut::from_slice(
                &mut short
            )))
        ),
        Err(LocalizeError::BufferTooSmall { needed: 10, len: 9 })
    );
    let mut bad = b[..10].to_vec();
    bad[4].triangle = w.triangle_count() as u32;
    assert_eq!(
        localize(&frames, w.triangles(), &bad, 0, &mut p, None),
        Err(LocalizeError::BadBinding { index: 4 })
    );
    assert_eq!(
        localize(&frames[..3], w.triangles(), &b, 0, &mut p, None),
        Err(LocalizeError::BadBinding { index: 0 })
    );
    let mut few = vec![VertexFrame::REST; 3];
    assert!(matches!(
        prepare(&w, StrainMeasure::Corotated, &mut few),
        Err(LocalizeError::FrameCount { .. })
    ));
}

/// Garbage bindings (any triangle index, NaN and huge values) never panic: an error or
/// some output, nothing else.
#[test]
fn garbage_bindings_do_not_panic() {
    let blob = blob();
    let sheet = sheet_of(4, 0.03, 0);
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let frames = frames_of(&w, StrainMeasure::Green);
    let mut s: u64 = 1;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 32) as u32
    };
    let specials = [f32::NAN, f32::INFINITY, -1e30, 0.0, 0.5, 1e-40];
    for _ in 0..2000 {
        let b = Binding {
            triangle: next() % 40,
            bary: [0; 2].map(|_| specials[next() as usize % 6]),
            chi: [0; 6].map(|_| specials[next() as usize % 6]),
        };
        let mut out = [[0.0f32; 3]; 1];
        let mut nrm = [[0.0f32; 3]; 1];
        let _ = localize(
            &frames,
            w.triangles(),
            &[b],
            0,
            &mut StridedMut::from_slice(&mut out),
            Some(NormalTarget::Buffer(&mut StridedMut::from_slice(&mut nrm))),
        );
    }
    // garbage fine triangles for the exact normals
    let mut pos = vec![[0.0f32; 3]; 4];
    let mut nrm = vec![[0.0f32; 3]; 4];
    assert_eq!(
        recompute_normals(
            &[[0, 1, 4]],
            &mut StridedMut::from_slice(&mut pos),
            NormalTarget::Buffer(&mut StridedMut::from_slice(&mut nrm))
        ),
        Err(LocalizeError::BadTriangle { triangle: 0 })
    );
    // collapsed triangles keep the previous normal
    nrm.fill([0.0, 1.0, 0.0]);
    recompute_normals(
        &[[0, 1, 2], [1, 2, 3]],
        &mut StridedMut::from_slice(&mut pos),
        NormalTarget::Buffer(&mut StridedMut::from_slice(&mut nrm)),
    )
    .unwrap();
    assert!(nrm.iter().all(|n| dist(*n, [0.0, 1.0, 0.0]) < 1e-6));
}

/// The tiled mesh covers the cloth's box on the cell's lattice; a box that is not a multiple
/// of the node spacing gets clamped edge columns, and every vertex binds.
#[test]
fn tiled_mesh_covers_the_cloth_on_the_cell_lattice() {
    let blob = blob();
    let cell = blob.cell(1).unwrap();
    let h = (cell.width() / cell.nu() as f64) as f32; // 1 mm
    let mut sheet = Sheet::grid(4, 3, 0.0305, 0.02);
    sheet.materials.fill(1);
    for (uv, p) in sheet.uvs.iter_mut().zip(&mut sheet.positions) {
        uv[0] += 0.0042; // off the lattice
        p[0] = uv[0];
    }
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let (uv, tris, mats) = tiled(&w, &blob, 1);
    // u from 0.0042 to 0.0347: lattice lines 4..=35 clamped -> 32 columns; v 0..=20 -> 21 rows
    assert_eq!(uv.len(), 32 * 21);
    assert_eq!(tris.len(), 2 * 31 * 20);
    assert_eq!(uv[0], [0.0042, 0.0]);
    assert!((uv[1][0] - 5.0 * h).abs() < 1e-7);
    assert!((uv[31][0] - 0.0347).abs() < 1e-7 && uv[31][0] == uv[32 * 21 - 1][0]);
    assert!((uv[32 * 21 - 1][1] - 0.02).abs() < 1e-7);
    // materials follow the cell's micro mesh: square (i, j) of the lattice is cell square
    // (i mod nu, j mod nv)
    let nu = cell.nu() as usize;
    for (k, &m) in mats.iter().enumerate().step_by(2) {
        let (i, j) = ((k / 2) % 31 + 4, (k / 2) / 31);
        assert_eq!(m, cell.tri_material[2 * ((j % nu) * nu + i % nu)]);
    }
    // counter-clockwise in (u, v)
    for t in &tris {
        let [a, b, c] = t.map(|v| uv[v as usize]);
        let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
        assert!(area2 > 0.0);
    }
    let b = bind_all(&w, &blob, &uv);
    // at rest the mesh localizes onto itself
    let x = run(&frames_of(&w, StrainMeasure::Corotated), w.triangles(), &b);
    for (p, q) in x.iter().zip(&uv) {
        assert!(dist(*p, [q[0], q[1], 0.0]) < 1e-8);
    }
}

/// χ in a binding is the cell's nodal χ at a node, and its linear interpolation in between.
#[test]
fn binding_chi_interpolates_the_cell() {
    let blob = blob();
    let cell = blob.cell(1).unwrap();
    let h = cell.width() / cell.nu() as f64;
    let nu = cell.nu() as usize;
    let sheet = sheet_of(3, 0.03, 1);
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    // a node of the second tile, and the midpoint of a lower-triangle edge
    let (i, j) = (3usize, 7usize);
    let scale = cell
        .chi
        .iter()
        .flatten()
        .fold(0.0f32, |m, x| m.max(x.abs()));
    assert!(scale > 0.0);
    let node = [(10 + i) as f64 * h, (10 + j) as f64 * h].map(|x| x as f32);
    let b = bind_all(&w, &blob, &[node])[0];
    let want = cell.chi[j * nu + i];
    for (a, c) in b.chi.iter().zip(want) {
        assert!((a - c).abs() < 1e-5 * scale, "{a} vs {c}");
    }
    // in square (i, j), the point (s, t) = (0.75, 0.25) of the lower triangle [ll, lr, ur]
    let q = [((10 + i) as f64 + 0.75) * h, ((10 + j) as f64 + 0.25) * h].map(|x| x as f32);
    let b = bind_all(&w, &blob, &[q])[0];
    let (ll, lr, ur) = (j * nu + i, j * nu + i + 1, (j + 1) * nu + i + 1);
    for k in 0..6 {
        let want = 0.25 * cell.chi[ll][k] + 0.5 * cell.chi[lr][k] + 0.25 * cell.chi[ur][k];
        assert!(
            (b.chi[k] - want).abs() < 1e-5 * scale,
            "{} vs {want}",
            b.chi[k]
        );
    }
}

/// Every check comes before any write: a bad binding late in the range, or a bad fine
/// triangle, leaves every output byte as it was (the kernel's own all-or-nothing guarantee,
/// which the C API relies on).
#[test]
fn localize_writes_nothing_on_any_error() {
    let blob = blob();
    let sheet = sheet_of(5, 0.03, 0);
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let (uv, tris, _) = tiled(&w, &blob, 0);
    let mut b = bind_all(&w, &blob, &uv);
    let frames = frames_of(&w, StrainMeasure::Corotated);
    let n = uv.len();
    let last = n - 1;
    b[last].triangle = w.triangle_count() as u32;
    let pristine = vec![7.0f32; n * 8];
    let mut buf = pristine.clone();
    let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut buf);
    let mut pos = StridedMut::<3>::new(bytes, 32, n).unwrap();
    for normals in [None, Some(NormalTarget::Interleaved { offset: 12 })] {
        assert_eq!(
            localize(&frames, w.triangles(), &b, 0, &mut pos, normals),
            Err(LocalizeError::BadBinding { index: last })
        );
    }
    let target = NormalTarget::Interleaved { offset: 12 };
    assert_eq!(
        localize_recomputed(&frames, w.triangles(), &b, 0, &mut pos, &tris, target),
        Err(LocalizeError::BadBinding { index: last })
    );
    // good bindings, one fine triangle out of the range
    let good = bind_all(&w, &blob, &uv);
    let mut bad_tris = tris.clone();
    bad_tris[3][1] = n as u32;
    let target = NormalTarget::Interleaved { offset: 12 };
    assert_eq!(
        localize_recomputed(
            &frames,
            w.triangles(),
            &good,
            0,
            &mut pos,
            &bad_tris,
            target
        ),
        Err(LocalizeError::BadTriangle { triangle: 3 })
    );
    assert_eq!(buf, pristine);
    // and the combined call equals localize followed by recompute_normals
    let mut a = vec![[0.0f32; 3]; n];
    let mut an = vec![[0.0f32; 3]; n];
    let (mut c, mut cn) = (a.clone(), an.clone());
    let mut ap = StridedMut::from_slice(&mut a);
    localize(&frames, w.triangles(), &good, 0, &mut ap, None).unwrap();
    let mut anv = StridedMut::from_slice(&mut an);
    recompute_normals(&tris, &mut ap, NormalTarget::Buffer(&mut anv)).unwrap();
    let mut cp = StridedMut::from_slice(&mut c);
    let mut cnv = StridedMut::from_slice(&mut cn);
    let target = NormalTarget::Buffer(&mut cnv);
    localize_recomputed(&frames, w.triangles(), &good, 0, &mut cp, &tris, target).unwrap();
    assert_eq!((a, an), (c, cn));
}

/// The blocks the C API hands out are the kernel's: binding into a block and reading it back
/// gives the records `bind` writes; frames prepared into a block are refused by another world.
#[test]
fn bindings_and_frames_blocks_round_trip() {
    let blob = blob();
    let sheet = sheet_of(4, 0.03, 0);
    let mut mem = memory(&sheet.capacity());
    let w = blob_world(&mut mem, &sheet, &blob, settings_quiet());
    let (uv, _, _) = tiled(&w, &blob, 0);
    let key = blocks::cloth_key(&w, &blob);
    let size = blocks::bindings_bytes(uv.len()).unwrap();
    let mut words = vec![0u32; size / 4];
    let block: &mut [u8] = bytemuck::cast_slice_mut(&mut words);
    assert_eq!(
        blocks::bind_block(
            &w,
            &blob,
            key,
            &Strided::from_slice(&uv),
            &mut block[..size - 1]
        ),
        Err(blocks::BlockError::TooSmall {
            needed: uv.len(),
            room: uv.len() - 1
        })
    );
    blocks::bind_block(&w, &blob, key, &Strided::from_slice(&uv), block).unwrap();
    let (k, records) = blocks::read_bindings(block).unwrap();
    assert_eq!((k, records), (key, &bind_all(&w, &blob, &uv)[..]));

    let mut header = blocks::FramesHeader::zeroed();
    assert_eq!(header.check(&w, key), Err(blocks::BlockError::NotPrepared));
    let mut frames = vec![VertexFrame::REST; w.vertex_count()];
    blocks::prepare_block(&w, key, StrainMeasure::Corotated, &mut header, &mut frames).unwrap();
    assert_eq!(header.check(&w, key), Ok(()));
    assert_eq!(frames, frames_of(&w, StrainMeasure::Corotated));
    assert_eq!(
        header.check(&w, key ^ 1),
        Err(blocks::BlockError::OtherWorld)
    );
    let mut mem2 = memory(&sheet.capacity());
    let twin = blob_world(&mut mem2, &sheet, &blob, settings_quiet());
    assert_eq!(
        header.check(&twin, key),
        Err(blocks::BlockError::OtherWorld)
    );
    let copy = header;
    assert_eq!(copy.check(&w, key), Err(blocks::BlockError::NotPrepared));
}
