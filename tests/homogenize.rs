//! Acceptance tests of the cell problem (§4): the sanity anchors of DESIGN.md "The cell
//! problem" — homogeneous cell, laminates, bounds, rotation — plus convergence under refinement
//! and the periodic numbering.
#![cfg(feature = "std")]
// Index loops over 3×3 tensors read like the formulas they check.
#![allow(clippy::needless_range_loop)]

use weft::cell::{mesh_cell, mesh_sheet, rotate90, rotate_tensor90, CellDesc, Material};
use weft::homogenize::{homogenize, laminate, HomogenizeError, Homogenized, LayerNormal};
use weft::membrane::isotropic;
use weft::Voigt;

/// Tiny deterministic generator (PCG-style LCG, high bits): no `rand` dependency.
struct Lcg(u64);

impl Lcg {
    fn next_u32(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 33) as u32
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        self.next_u32() as f64 / (1u64 << 31) as f64
    }
    /// A random symmetric positive definite tensor of magnitude ~`scale` with full coupling
    /// (all off-diagonal terms non-zero): `L Lᵀ + 0.2 scale I`.
    fn spd(&mut self, scale: f64) -> Voigt {
        let mut l = [[0.0; 3]; 3];
        for (i, row) in l.iter_mut().enumerate() {
            for v in row.iter_mut().take(i + 1) {
                *v = self.unit() - 0.3;
            }
        }
        let mut c = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = scale * (0..3).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            }
            c[i][i] += 0.2 * scale;
        }
        c
    }
}

fn material(key: char, c: Voigt) -> Material {
    Material {
        key: key.to_string(),
        c,
        density: 0.1 + key as u32 as f64 * 1e-3,
        bending: 1e-6,
    }
}

/// A cell from text rows (row 0 on top) and `(key, C)` materials.
fn cell(size: f64, rows: &[&str], mats: &[(char, Voigt)]) -> CellDesc {
    let pixels = rows
        .iter()
        .flat_map(|r| r.chars())
        .map(|ch| mats.iter().position(|m| m.0 == ch).expect("key") as u32)
        .collect();
    CellDesc {
        name: "test".into(),
        size,
        cols: rows[0].chars().count(),
        rows: rows.len(),
        pixels,
        materials: mats.iter().map(|&(k, c)| material(k, c)).collect(),
    }
}

fn random_cell(rng: &mut Lcg, cols: usize, rows: usize, mats: &[Voigt]) -> CellDesc {
    CellDesc {
        name: "random".into(),
        size: 0.01,
        cols,
        rows,
        pixels: (0..cols * rows)
            .map(|_| rng.next_u32() % mats.len() as u32)
            .collect(),
        materials: mats
            .iter()
            .enumerate()
            .map(|(i, &c)| material((b'a' + i as u8) as char, c))
            .collect(),
    }
}

fn solve(desc: &CellDesc, refine: usize) -> Homogenized {
    let mesh = mesh_cell(desc, refine);
    homogenize(desc, &mesh, &mut |_| {}).expect("homogenize")
}

fn max_abs(c: &Voigt) -> f64 {
    c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// max |a - b| / max |b|
fn rel(a: &Voigt, b: &Voigt) -> f64 {
    let mut d = 0.0f64;
    for i in 0..3 {
        for j in 0..3 {
            d = d.max((a[i][j] - b[i][j]).abs());
        }
    }
    d / max_abs(b)
}

fn frob_diff(a: &Voigt, b: &Voigt) -> f64 {
    let mut s = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            s += (a[i][j] - b[i][j]).powi(2);
        }
    }
    s.sqrt()
}

fn sub(a: &Voigt, b: &Voigt) -> Voigt {
    let mut r = *a;
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] -= b[i][j];
        }
    }
    r
}

/// Eigenvalues of a symmetric 3×3 matrix by cyclic Jacobi rotations.
fn eigenvalues(m: &Voigt) -> [f64; 3] {
    let mut a = *m;
    for _ in 0..50 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off <= 1e-15 * max_abs(m) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = 0.5 * (2.0 * a[p][q]).atan2(a[q][q] - a[p][p]);
            let (s, c) = theta.sin_cos();
            // A <- Gᵀ A G with G the rotation in the (p, q) plane
            let mut g = [[0.0; 3]; 3];
            for (i, row) in g.iter_mut().enumerate() {
                row[i] = 1.0;
            }
            g[p][p] = c;
            g[q][q] = c;
            g[p][q] = s;
            g[q][p] = -s;
            let mut t = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    t[i][j] = (0..3).map(|k| a[i][k] * g[k][j]).sum();
                }
            }
            for i in 0..3 {
                for j in 0..3 {
                    a[i][j] = (0..3).map(|k| g[k][i] * t[k][j]).sum();
                }
            }
        }
    }
    [a[0][0], a[1][1], a[2][2]]
}

fn min_eig(m: &Voigt) -> f64 {
    eigenvalues(m).into_iter().fold(f64::INFINITY, f64::min)
}

#[test]
fn eigenvalue_helper_is_right() {
    // known spectrum: Q diag(1, 2, 5) Qᵀ with a rotation Q
    let (s, c) = 0.3f64.sin_cos();
    let q = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
    let (s2, c2) = 0.7f64.sin_cos();
    let q2 = [[1.0, 0.0, 0.0], [0.0, c2, -s2], [0.0, s2, c2]];
    let d = [1.0, 2.0, 5.0];
    let mut qq = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            qq[i][j] = (0..3).map(|k| q[i][k] * q2[k][j]).sum();
        }
    }
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| qq[i][k] * d[k] * qq[j][k]).sum();
        }
    }
    let mut e = eigenvalues(&m);
    e.sort_by(f64::total_cmp);
    for k in 0..3 {
        assert!((e[k] - d[k]).abs() < 1e-12, "{e:?}");
    }
}

#[test]
fn homogeneous_cell_gives_c_and_zero_chi() {
    let aniso = [[300.0, 40.0, 12.0], [40.0, 90.0, -7.0], [12.0, -7.0, 30.0]];
    for c in [isotropic(1000.0, 0.3), aniso] {
        // Two keys with the same tensor: the mesh is "heterogeneous" in its indices only.
        let desc = cell(0.02, &["aab", "bab"], &[('a', c), ('b', c)]);
        for refine in [1, 3] {
            let h = solve(&desc, refine);
            assert!(rel(&h.stiffness, &c) < 1e-9, "{:?}", h.stiffness);
            assert!(rel(&h.voigt_bound, &c) < 1e-12);
            assert!(rel(&h.reuss_bound, &c) < 1e-12);
            let chi_max = h
                .chi
                .iter()
                .flatten()
                .flatten()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(chi_max < 1e-12 * desc.size, "{chi_max}");
        }
    }
}

#[test]
fn single_node_cell() {
    // 1×1 pixels at refine 1: one node, no unknowns; chi = 0 and C^H = C.
    let c = [[300.0, 40.0, 12.0], [40.0, 90.0, -7.0], [12.0, -7.0, 30.0]];
    let h = solve(&cell(0.01, &["a"], &[('a', c)]), 1);
    assert_eq!(h.chi.len(), 1);
    assert!(rel(&h.stiffness, &c) < 1e-14);
}

#[test]
fn isotropic_laminate_matches_textbook_rules() {
    // Layers stacked along v, common Poisson ratio: along-layer stiffness by the rule of
    // mixtures, across and shear by the inverse rule (see `laminate`'s doc).
    let nu = 0.25;
    let (y1, y2, f1) = (100.0, 3000.0, 0.4);
    let f2 = 1.0 - f1;
    let hm = |a: f64, b: f64| 1.0 / (f1 / a + f2 / b);
    let cc = |y: f64| y / (1.0 - nu * nu);
    let gg = |y: f64| y / (2.0 * (1.0 + nu));
    let c22 = hm(cc(y1), cc(y2));
    let expected = [
        [f1 * y1 + f2 * y2 + nu * nu * c22, nu * c22, 0.0],
        [nu * c22, c22, 0.0],
        [0.0, 0.0, hm(gg(y1), gg(y2))],
    ];
    let layers = [(f1, isotropic(y1, nu)), (f2, isotropic(y2, nu))];
    let formula = laminate(&layers, LayerNormal::V).unwrap();
    assert!(rel(&formula, &expected) < 1e-13, "{formula:?}");
    // and the cell problem agrees: 2 rows of material 1 over 3 of material 2
    let desc = cell(
        0.01,
        &["aa", "aa", "bb", "bb", "bb"],
        &[('a', isotropic(y1, nu)), ('b', isotropic(y2, nu))],
    );
    let h = solve(&desc, 1);
    assert!(rel(&h.stiffness, &expected) < 1e-8, "{:?}", h.stiffness);
    // stacked along u it is the same with 11 <-> 22 swapped
    let formula_u = laminate(&layers, LayerNormal::U).unwrap();
    assert!((formula_u[1][1] - expected[0][0]).abs() < 1e-10 * expected[0][0]);
    assert!((formula_u[0][0] - expected[1][1]).abs() < 1e-10 * expected[0][0]);
}

#[test]
fn laminates_match_closed_form() {
    let mut rng = Lcg(7);
    for contrast in [10.0, 1000.0] {
        let layer_pairs = [
            (isotropic(100.0, 0.35), isotropic(100.0 * contrast, 0.15)),
            (rng.spd(100.0), rng.spd(100.0 * contrast)),
        ];
        for (ca, cb) in layer_pairs {
            // 3 pixels of a, 2 of b, in rows (normal v) or columns (normal u); a non-square
            // cell and refinement exercise the numbering and the wrap.
            let horizontal = cell(
                0.01,
                &["aaaa", "bbbb", "aaaa", "aaaa", "bbbb"],
                &[('a', ca), ('b', cb)],
            );
            let vertical = cell(0.01, &["abaab", "abaab"], &[('a', ca), ('b', cb)]);
            let layers = [(0.6, ca), (0.4, cb)];
            for (desc, normal) in [(&horizontal, LayerNormal::V), (&vertical, LayerNormal::U)] {
                let expected = laminate(&layers, normal).unwrap();
                for refine in [1, 2] {
                    let h = solve(desc, refine);
                    let e = rel(&h.stiffness, &expected);
                    assert!(
                        e < 1e-8,
                        "{normal:?} contrast {contrast} refine {refine}: {e:e}\n{:?}\n{expected:?}",
                        h.stiffness
                    );
                }
                // the other orientation's formula is really different (the test can fail)
                let other = match normal {
                    LayerNormal::U => LayerNormal::V,
                    LayerNormal::V => LayerNormal::U,
                };
                assert!(rel(&laminate(&layers, other).unwrap(), &expected) > 1e-2);
            }
        }
    }
}

#[test]
fn one_square_wide_laminate() {
    // nu = 1: every triangle wraps onto its own node column; chi depends on v only, which
    // the mesh still represents exactly.
    let (ca, cb) = (Lcg(3).spd(50.0), Lcg(4).spd(900.0));
    let desc = cell(0.01, &["a", "b", "b"], &[('a', ca), ('b', cb)]);
    let expected = laminate(&[(1.0, ca), (2.0, cb)], LayerNormal::V).unwrap();
    let h = solve(&desc, 1);
    assert!(rel(&h.stiffness, &expected) < 1e-8, "{:?}", h.stiffness);
}

#[test]
fn random_cells_lie_between_bounds() {
    let mut rng = Lcg(42);
    for trial in 0..6 {
        let mats = [
            rng.spd(100.0),
            rng.spd(1000.0),
            isotropic(300.0, 0.2 + 0.05 * trial as f64),
        ];
        let (cols, rows) = (3 + trial % 4, 4 + trial % 3);
        let desc = random_cell(&mut rng, cols, rows, &mats);
        let h = solve(&desc, 1 + trial % 2);
        let c = h.stiffness;
        let scale = max_abs(&c);
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(c[i][j], c[j][i]);
            }
        }
        assert!(min_eig(&c) > 0.0, "trial {trial}: not PD {c:?}");
        let upper = min_eig(&sub(&h.voigt_bound, &c));
        let lower = min_eig(&sub(&c, &h.reuss_bound));
        assert!(
            upper >= -1e-9 * scale,
            "trial {trial}: above Voigt ({upper:e})"
        );
        assert!(
            lower >= -1e-9 * scale,
            "trial {trial}: below Reuss ({lower:e})"
        );
        // a heterogeneous cell is strictly inside: the bounds are not just being returned
        assert!(rel(&c, &h.voigt_bound) > 1e-3 && rel(&c, &h.reuss_bound) > 1e-3);
        // density is the area mean
        let mean: f64 = desc
            .pixels
            .iter()
            .map(|&p| desc.materials[p as usize].density)
            .sum::<f64>()
            / desc.pixels.len() as f64;
        assert!((h.density - mean).abs() < 1e-14);
    }
}

/// C^H of the 90°-rotated cell predicted from C^H (the sign rule of `rotate_tensor90`).
fn rotated(c: &Voigt) -> Voigt {
    let r = rotate_tensor90(c);
    // spelled out, as the acceptance criterion states it
    assert_eq!(r[0][0], c[1][1]);
    assert_eq!(r[1][1], c[0][0]);
    assert_eq!(r[2][2], c[2][2]);
    assert_eq!(r[0][1], c[0][1]);
    assert_eq!(r[0][2], -c[1][2]);
    assert_eq!(r[1][2], -c[0][2]);
    r
}

#[test]
fn rotation_by_90_degrees_permutes_c_h() {
    // The continuum C^H permutes exactly. The discrete one does only up to discretization
    // error: the lower-left→upper-right pixel diagonal becomes lower-right→upper-left under
    // the rotation, so the rotated mesh is not the mesh of the rotated pattern. So: exact for
    // laminates (whose FE solution is exact), and converging under refinement otherwise.
    let mut rng = Lcg(11);
    let (ca, cb) = (rng.spd(100.0), rng.spd(800.0));
    let lam = cell(0.01, &["aaa", "bbb", "aaa"], &[('a', ca), ('b', cb)]);
    let h = solve(&lam, 1);
    let hr = solve(&rotate90(&lam), 1);
    assert!(rel(&hr.stiffness, &rotated(&h.stiffness)) < 1e-9);

    let mats = [rng.spd(100.0), rng.spd(400.0), isotropic(200.0, 0.3)];
    let desc = random_cell(&mut rng, 4, 3, &mats);
    let rot = rotate90(&desc);
    let mut mismatch = Vec::new();
    for refine in [1, 4, 16] {
        let h = solve(&desc, refine);
        let hr = solve(&rot, refine);
        mismatch.push(rel(&hr.stiffness, &rotated(&h.stiffness)));
    }
    assert!(mismatch[1] < 0.6 * mismatch[0], "{mismatch:?}");
    assert!(mismatch[2] < 0.6 * mismatch[1], "{mismatch:?}");
    assert!(mismatch[2] < 5e-3, "{mismatch:?}");
}

#[test]
fn diagonal_reflection_and_half_turn_are_exact() {
    // Transposing the pattern (reflection about u = v) and turning it by 180° map the pixel
    // diagonal onto itself, so the discrete C^H must transform exactly.
    let mut rng = Lcg(5);
    let mats = [rng.spd(100.0), rng.spd(700.0), isotropic(250.0, 0.1)];
    let desc = random_cell(&mut rng, 4, 3, &mats);
    let h = solve(&desc, 2);

    // reflection about u = v: e11 <-> e22, shear unchanged (no sign flip for a reflection
    // that swaps the axes): C' = P C P with P the 0 <-> 1 swap.
    let swap = |c: &Voigt| {
        let p = [1usize, 0, 2];
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = c[p[i]][p[j]];
            }
        }
        r
    };
    // pixel (row r, col c) with v up: transposed pixel at u' = v, v' = u
    let (cols, rows) = (desc.rows, desc.cols);
    let mut pixels = vec![0; cols * rows];
    for r in 0..desc.rows {
        for c in 0..desc.cols {
            let (i, j) = (c, desc.rows - 1 - r); // square coordinates, j from the bottom
            let (i2, j2) = (j, i);
            pixels[(rows - 1 - j2) * cols + i2] = desc.pixel(r, c);
        }
    }
    let transposed = CellDesc {
        name: "t".into(),
        size: desc.height(),
        cols,
        rows,
        pixels,
        materials: desc
            .materials
            .iter()
            .map(|m| Material {
                c: swap(&m.c),
                ..m.clone()
            })
            .collect(),
    };
    let ht = solve(&transposed, 2);
    assert!(rel(&ht.stiffness, &swap(&h.stiffness)) < 1e-10);

    // half turn: pixel (r, c) -> (rows-1-r, cols-1-c); tensors unchanged (T = -I on vectors)
    let mut turned = desc.clone();
    for r in 0..desc.rows {
        for c in 0..desc.cols {
            turned.pixels[(desc.rows - 1 - r) * desc.cols + desc.cols - 1 - c] = desc.pixel(r, c);
        }
    }
    assert_ne!(turned.pixels, desc.pixels);
    let h2 = solve(&turned, 2);
    assert!(rel(&h2.stiffness, &h.stiffness) < 1e-10);
    // two quarter turns compose to the half turn (pattern and tensors)
    let twice = rotate90(&rotate90(&desc));
    assert_eq!(twice.pixels, turned.pixels);
    for (a, b) in twice.materials.iter().zip(&desc.materials) {
        assert!(rel(&a.c, &b.c) < 1e-15);
    }
}

#[test]
fn refinement_converges() {
    let mats = [
        isotropic(100.0, 0.3),
        isotropic(600.0, 0.2),
        Lcg(9).spd(300.0),
    ];
    let desc = cell(
        0.01,
        &["abca", "bbac", "cabb", "acca"],
        &[('a', mats[0]), ('b', mats[1]), ('c', mats[2])],
    );
    let c: Vec<Voigt> = [1, 2, 4, 8]
        .iter()
        .map(|&k| solve(&desc, k).stiffness)
        .collect();
    let d: Vec<f64> = c.windows(2).map(|w| frob_diff(&w[1], &w[0])).collect();
    assert!(d[0] > 0.0);
    assert!(d[1] < 0.7 * d[0], "{d:?}");
    assert!(d[2] < 0.7 * d[1], "{d:?}");
    // FE energy is an upper bound: C^H decreases (in the Loewner order) as the mesh refines,
    // because each refined space contains the coarser one.
    for w in c.windows(2) {
        let scale = max_abs(&w[0]);
        assert!(min_eig(&sub(&w[0], &w[1])) >= -1e-9 * scale);
    }
}

#[test]
fn periodic_wrap_is_translation_invariant() {
    // Cyclically shifting the pattern by whole pixels moves material across the cell's
    // periodic seam. With the right wrap this is a pure translation: C^H is unchanged and
    // chi is shifted node-for-node. A wrong wrap (a node on the seam duplicated or connected
    // to the wrong partner) breaks both.
    let mut rng = Lcg(21);
    let mats = [rng.spd(100.0), rng.spd(900.0), isotropic(300.0, 0.3)];
    let desc = random_cell(&mut rng, 5, 4, &mats);
    let (sr, sc) = (1usize, 2usize); // shifted[r][c] = desc[(r + sr) % rows][(c + sc) % cols]
    let mut shifted = desc.clone();
    for r in 0..desc.rows {
        for c in 0..desc.cols {
            shifted.pixels[r * desc.cols + c] =
                desc.pixel((r + sr) % desc.rows, (c + sc) % desc.cols);
        }
    }
    let k = 2;
    let mesh = mesh_cell(&desc, k);
    assert_eq!(mesh.nodes.len(), mesh.nu * mesh.nv);
    let h = homogenize(&desc, &mesh, &mut |_| {}).unwrap();
    let hs = solve(&shifted, k);
    assert_eq!(h.chi.len(), mesh.nu * mesh.nv);
    assert!(rel(&hs.stiffness, &h.stiffness) < 1e-10);
    // shifted field at node (i, j) = original at (i + sc k, j - sr k): rows count from the top.
    let (nu, nv) = (mesh.nu, mesh.nv);
    let chi_scale = h
        .chi
        .iter()
        .flatten()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(chi_scale > 1e-6 * desc.size);
    for j in 0..nv {
        for i in 0..nu {
            let a = hs.chi[j * nu + i];
            let (i0, j0) = ((i + sc * k) % nu, (j + nv - sr * k) % nv);
            let b = h.chi[j0 * nu + i0];
            for kk in 0..3 {
                for r in 0..2 {
                    assert!((a[kk][r] - b[kk][r]).abs() < 1e-9 * chi_scale);
                }
            }
        }
    }
    // zero mean
    for kk in 0..3 {
        for r in 0..2 {
            let m: f64 = h.chi.iter().map(|c| c[kk][r]).sum();
            assert!(m.abs() < 1e-12 * chi_scale * h.chi.len() as f64);
        }
    }
}

#[test]
fn errors_and_progress() {
    let c = isotropic(100.0, 0.3);
    let desc = cell(
        0.01,
        &["ab", "ba"],
        &[('a', c), ('b', isotropic(300.0, 0.3))],
    );
    let mut seen = Vec::new();
    let mesh = mesh_cell(&desc, 2);
    homogenize(&desc, &mesh, &mut |f| seen.push(f)).unwrap();
    assert_eq!(seen.first(), Some(&0.0));
    assert_eq!(seen.last(), Some(&1.0));
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");

    let sheet = mesh_sheet(&desc, 1, 1, 1);
    assert_eq!(
        homogenize(&desc, &sheet, &mut |_| {}),
        Err(HomogenizeError::NotPeriodic)
    );

    let mut relabelled = sheet.clone();
    relabelled.periodic = true;
    assert!(matches!(
        homogenize(&desc, &relabelled, &mut |_| {}),
        Err(HomogenizeError::InconsistentMesh(_))
    ));

    let mut bad = mesh.clone();
    bad.tri_material[3] = 7;
    assert_eq!(
        homogenize(&desc, &bad, &mut |_| {}),
        Err(HomogenizeError::MaterialIndex {
            triangle: 3,
            material: 7
        })
    );
    let mut bad = mesh.clone();
    bad.tri_corners.pop();
    assert!(matches!(
        homogenize(&desc, &bad, &mut |_| {}),
        Err(HomogenizeError::InconsistentMesh(_))
    ));
    let mut bad = mesh.clone();
    bad.triangles[0][1] = 10_000;
    assert!(matches!(
        homogenize(&desc, &bad, &mut |_| {}),
        Err(HomogenizeError::InconsistentMesh(_))
    ));
    let mut bad = mesh.clone();
    bad.tri_corners[5][1] = bad.tri_corners[5][0];
    assert_eq!(
        homogenize(&desc, &bad, &mut |_| {}),
        Err(HomogenizeError::DegenerateTriangle { triangle: 5 })
    );
    // a mesh of a different cell size
    let mut other = desc.clone();
    other.size = 0.02;
    assert!(matches!(
        homogenize(&other, &mesh, &mut |_| {}),
        Err(HomogenizeError::InconsistentMesh(_))
    ));
    // a non-SPD material built in code
    let mut bad_desc = desc.clone();
    bad_desc.materials[1].c = [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!(matches!(
        homogenize(&bad_desc, &mesh, &mut |_| {}),
        Err(HomogenizeError::InvalidMaterial { .. })
    ));
    let mut bad_desc = desc.clone();
    bad_desc.materials[0].density = f64::NAN;
    assert!(matches!(
        homogenize(&bad_desc, &mesh, &mut |_| {}),
        Err(HomogenizeError::InvalidMaterial { .. })
    ));
    // an empty description
    let empty = CellDesc {
        name: String::new(),
        size: 0.01,
        cols: 0,
        rows: 0,
        pixels: vec![],
        materials: vec![],
    };
    assert_eq!(
        homogenize(&empty, &mesh_cell(&empty, 1), &mut |_| {}),
        Err(HomogenizeError::EmptyMesh)
    );
}
