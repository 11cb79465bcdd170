//! Synthetic, physically correct cells for the blob and tool tests: laminates (stripes), whose
//! cell problem has a closed form, so the tests need neither the homogenization solver nor any
//! hard-coded numbers.
#![allow(dead_code)] // each test crate uses a different subset
#![allow(clippy::needless_range_loop)] // index loops mirror the tensor notation

use weft::blob::{CellRecord, MaterialRecord};
use weft::membrane::{inverse3, isotropic};
use weft::Voigt;

/// Direction along which the material varies (the stripes' normal).
#[derive(Clone, Copy, Debug)]
pub enum Axis {
    /// Material changes from column to column: vertical stripes.
    U,
    /// Material changes from row to row: horizontal bands.
    V,
}

pub fn material(stiffness: f64, poisson: f64, density: f64, bending: f64) -> MaterialRecord {
    MaterialRecord {
        c: isotropic(stiffness, poisson),
        density,
        bending,
    }
}

/// Two contrasting materials, stiff and soft.
pub fn two_materials() -> Vec<MaterialRecord> {
    vec![
        material(2000.0, 0.3, 0.25, 2e-5),
        material(300.0, 0.45, 0.15, 5e-6),
    ]
}

fn matvec(m: &Voigt, v: [f64; 3]) -> [f64; 3] {
    core::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

fn inv2(a: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    let d = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    [[a[1][1] / d, -a[0][1] / d], [-a[1][0] / d, a[0][0] / d]]
}

fn mul2(a: [[f64; 2]; 2], v: [f64; 2]) -> [f64; 2] {
    [
        a[0][0] * v[0] + a[0][1] * v[1],
        a[1][0] * v[0] + a[1][1] * v[1],
    ]
}

/// A laminate cell. `layers` gives the material of each pixel column (axis U, left to right) or
/// each pixel row (axis V, top to bottom, row 0 = top, DESIGN.md); `across` is the pixel count in
/// the other direction.
///
/// Closed form: the fluctuation `w` varies only along the normal, so `B w = G d` with
/// `d = dw/dn` constant per layer and `G` selecting the strains it produces (axis U:
/// `[w1', 0, w2']`, axis V: `[0, w2', w1']`). Traction `Gᵀσ` is continuous and `<d> = 0`
/// (periodicity), giving `t = <A⁻¹>⁻¹ <A⁻¹ GᵀC E>` with `A = GᵀCG`, `d = A⁻¹(t - GᵀC E)`.
/// P1 elements represent the piecewise-linear `w` exactly.
pub fn laminate(
    name: &str,
    axis: Axis,
    layers: &[u32],
    across: u32,
    refine: u32,
    size: f64,
    materials: Vec<MaterialRecord>,
) -> CellRecord {
    let n_layers = layers.len() as u32;
    let (cols, rows) = match axis {
        Axis::U => (n_layers, across),
        Axis::V => (across, n_layers),
    };
    let (nu, nv) = ((cols * refine) as usize, (rows * refine) as usize);
    let h = size / nu as f64;
    // G as (row of the strain vector) for d[0] and d[1].
    let (g0, g1) = match axis {
        Axis::U => (0usize, 2usize), // d = [w1,u ; w2,u] -> e11 += d0, 2e12 += d1
        Axis::V => (2usize, 1usize), // d = [w1,v ; w2,v] -> 2e12 += d0, e22 += d1
    };
    let gtcg = |c: &Voigt| [[c[g0][g0], c[g0][g1]], [c[g1][g0], c[g1][g1]]];
    let f = 1.0 / n_layers as f64; // every layer is one pixel thick

    let mut stiffness = [[0.0; 3]; 3];
    // d per layer per load case
    let mut d = vec![[[0.0f64; 2]; 3]; layers.len()];
    for k in 0..3 {
        let e: [f64; 3] = core::array::from_fn(|i| if i == k { 1.0 } else { 0.0 });
        let mut mean_ainv = [[0.0; 2]; 2];
        let mut mean_rhs = [0.0; 2];
        for &m in layers {
            let c = &materials[m as usize].c;
            let ainv = inv2(gtcg(c));
            let ce = matvec(c, e);
            let r = mul2(ainv, [ce[g0], ce[g1]]);
            for a in 0..2 {
                mean_rhs[a] += f * r[a];
                for b in 0..2 {
                    mean_ainv[a][b] += f * ainv[a][b];
                }
            }
        }
        let t = mul2(inv2(mean_ainv), mean_rhs);
        for (l, &m) in layers.iter().enumerate() {
            let c = &materials[m as usize].c;
            let ce = matvec(c, e);
            let dl = mul2(inv2(gtcg(c)), [t[0] - ce[g0], t[1] - ce[g1]]);
            d[l][k] = dl;
            let mut strain = e;
            strain[g0] += dl[0];
            strain[g1] += dl[1];
            let s = matvec(c, strain);
            for i in 0..3 {
                stiffness[i][k] += f * s[i];
            }
        }
    }
    // Symmetrize away round-off so the stored C^H is exactly symmetric.
    for i in 0..3 {
        for j in 0..i {
            let m = 0.5 * (stiffness[i][j] + stiffness[j][i]);
            stiffness[i][j] = m;
            stiffness[j][i] = m;
        }
    }

    // Layer index of square (i, j) along the normal, and position of node (i, j) along it.
    let layer_of_square = |i: usize, j: usize| match axis {
        Axis::U => i / refine as usize,
        Axis::V => (rows as usize - 1) - j / refine as usize,
    };
    let material_of_square = |i: usize, j: usize| layers[layer_of_square(i, j)];
    // w^k(node) = ∫ d along the normal from 0 to the node; chi^k = -w^k minus its mean.
    let mut chi = vec![[0.0f64; 6]; nu * nv];
    for j in 0..nv {
        for i in 0..nu {
            let mut w = [[0.0f64; 2]; 3];
            let steps = match axis {
                Axis::U => i,
                Axis::V => j,
            };
            for s in 0..steps {
                let l = match axis {
                    Axis::U => layer_of_square(s, 0),
                    Axis::V => layer_of_square(0, s),
                };
                for k in 0..3 {
                    w[k][0] += d[l][k][0] * h;
                    w[k][1] += d[l][k][1] * h;
                }
            }
            for k in 0..3 {
                chi[j * nu + i][2 * k] = -w[k][0];
                chi[j * nu + i][2 * k + 1] = -w[k][1];
            }
        }
    }
    let mut mean = [0.0; 6];
    for x in &chi {
        for c in 0..6 {
            mean[c] += x[c] / (nu * nv) as f64;
        }
    }

    let mut nodes = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            nodes.push([(i as f64 * h) as f32, (j as f64 * h) as f32]);
        }
    }
    let mut triangles = Vec::new();
    let mut tri_material = Vec::new();
    let id = |i: usize, j: usize| ((j % nv) * nu + i % nu) as u32;
    for j in 0..nv {
        for i in 0..nu {
            let (ll, lr, ur, ul) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            triangles.push([ll, lr, ur]);
            triangles.push([ll, ur, ul]);
            tri_material.extend([material_of_square(i, j); 2]);
        }
    }

    let avg = |g: &dyn Fn(&MaterialRecord) -> f64| {
        layers
            .iter()
            .map(|&m| f * g(&materials[m as usize]))
            .sum::<f64>()
    };
    let mut voigt = [[0.0; 3]; 3];
    let mut compliance = [[0.0; 3]; 3];
    for &m in layers {
        let c = &materials[m as usize].c;
        let s = inverse3(c).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                voigt[i][j] += f * c[i][j];
                compliance[i][j] += f * s[i][j];
            }
        }
    }
    let mut reuss = inverse3(&compliance).unwrap();
    for i in 0..3 {
        for j in 0..i {
            let m = 0.5 * (reuss[i][j] + reuss[j][i]);
            reuss[i][j] = m;
            reuss[j][i] = m;
        }
    }

    CellRecord {
        name: name.into(),
        size,
        cols,
        rows,
        refine,
        stiffness,
        density: avg(&|m| m.density),
        bending: avg(&|m| m.bending),
        voigt_bound: voigt,
        reuss_bound: reuss,
        nodes,
        triangles,
        tri_material,
        chi: chi
            .iter()
            .map(|x| core::array::from_fn(|c| (x[c] - mean[c]) as f32))
            .collect(),
        materials,
    }
}

/// The smallest useful cell: 2×2 pixels at refine 1 (4 nodes, 8 triangles), two vertical stripes.
pub fn small_cell() -> CellRecord {
    laminate("small", Axis::U, &[0, 1], 2, 1, 0.01, two_materials())
}
