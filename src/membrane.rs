//! Linear (P1) membrane triangles: the in-plane finite element shared by the cell problem (§4)
//! and the coarse simulation (§5).
//!
//! Everything here is computed once (at homogenization or at world init), so it works in `f64`;
//! the runtime converts the resulting 3×3 blocks to `f32`.
//!
//! Conventions: rest shape in material space `(u, v)` (metres); strain `e = B d` with Voigt order
//! `[e11, e22, 2 e12]` (Eq. 1–3, the operator of Eq. 2 / Eq. 11); stress `s = C e` in N/m.

use crate::Voigt;

/// Shape-function gradients of a P1 triangle: `grad[a] = [dN_a/du, dN_a/dv]`, and its area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gradients {
    pub grad: [[f64; 2]; 3],
    /// Unsigned area in m².
    pub area: f64,
}

/// Relative area below which a triangle counts as degenerate (area / longest-edge²).
pub const DEGENERATE_RATIO: f64 = 1e-12;

/// Gradients of the linear shape functions of the triangle `uv` (any orientation).
/// Returns `None` for a degenerate (zero-area) or non-finite triangle.
pub fn gradients(uv: [[f64; 2]; 3]) -> Option<Gradients> {
    let [p0, p1, p2] = uv;
    let a2 = (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (p1[1] - p0[1]);
    let mut longest: f64 = 0.0;
    for (a, b) in [(p0, p1), (p1, p2), (p2, p0)] {
        let d = (b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]);
        longest = longest.max(d);
    }
    if !a2.is_finite() || !longest.is_finite() || a2.abs() <= DEGENERATE_RATIO * longest {
        return None;
    }
    // dN_a/du = (v_b - v_c) / 2A, dN_a/dv = (u_c - u_b) / 2A with (a, b, c) cyclic.
    let mut grad = [[0.0; 2]; 3];
    for a in 0..3 {
        let b = uv[(a + 1) % 3];
        let c = uv[(a + 2) % 3];
        grad[a] = [(b[1] - c[1]) / a2, (c[0] - b[0]) / a2];
    }
    Some(Gradients { grad, area: 0.5 * a2.abs() })
}

/// The 3×2 block `B_a` of the strain-displacement operator (Eq. 11) for node `a`.
#[inline]
pub fn b_block(g: [f64; 2]) -> [[f64; 2]; 3] {
    [[g[0], 0.0], [0.0, g[1]], [g[1], g[0]]]
}

/// Constant strain of the triangle under nodal in-plane displacements `d` (Eq. 3).
pub fn strain(g: &Gradients, d: [[f64; 2]; 3]) -> [f64; 3] {
    let mut e = [0.0; 3];
    for a in 0..3 {
        let b = b_block(g.grad[a]);
        for (i, ei) in e.iter_mut().enumerate() {
            *ei += b[i][0] * d[a][0] + b[i][1] * d[a][1];
        }
    }
    e
}

/// `s = C e`.
#[inline]
pub fn stress(c: &Voigt, e: [f64; 3]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for (i, si) in s.iter_mut().enumerate() {
        *si = c[i][0] * e[0] + c[i][1] * e[1] + c[i][2] * e[2];
    }
    s
}

/// Element stiffness `K_e = A Bᵀ C B` as 2×2 blocks: `k[a][b]` couples node `a` to node `b`.
/// The elastic force on node `a` is `-Σ_b k[a][b] d_b`.
pub fn element_stiffness(g: &Gradients, c: &Voigt) -> [[[[f64; 2]; 2]; 3]; 3] {
    let mut k = [[[[0.0; 2]; 2]; 3]; 3];
    for a in 0..3 {
        let ba = b_block(g.grad[a]);
        for b in 0..3 {
            let bb = b_block(g.grad[b]);
            // C B_b (3×2)
            let mut cb = [[0.0; 2]; 3];
            for i in 0..3 {
                for j in 0..2 {
                    cb[i][j] = c[i][0] * bb[0][j] + c[i][1] * bb[1][j] + c[i][2] * bb[2][j];
                }
            }
            for r in 0..2 {
                for s in 0..2 {
                    k[a][b][r][s] =
                        g.area * (ba[0][r] * cb[0][s] + ba[1][r] * cb[1][s] + ba[2][r] * cb[2][s]);
                }
            }
        }
    }
    k
}

/// Nodal forces `A Bᵀ s` of a constant stress `s` over the triangle: the right-hand side
/// `∫ Bᵀ C E dy` of the cell problem (Eq. 10) with `s = C E`, and the internal force of a
/// strained element (with the opposite sign).
pub fn stress_forces(g: &Gradients, s: [f64; 3]) -> [[f64; 2]; 3] {
    let mut f = [[0.0; 2]; 3];
    for (a, fa) in f.iter_mut().enumerate() {
        let b = b_block(g.grad[a]);
        for r in 0..2 {
            fa[r] = g.area * (b[0][r] * s[0] + b[1][r] * s[1] + b[2][r] * s[2]);
        }
    }
    f
}

/// Isotropic membrane stiffness (DESIGN.md): `Y/(1-ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1-ν)/2]]`.
pub fn isotropic(stiffness: f64, poisson: f64) -> Voigt {
    let f = stiffness / (1.0 - poisson * poisson);
    [
        [f, f * poisson, 0.0],
        [f * poisson, f, 0.0],
        [0.0, 0.0, f * (1.0 - poisson) * 0.5],
    ]
}

/// True when `c` is finite, symmetric (to a relative 1e-9) and positive definite (Sylvester's
/// criterion on the leading minors).
pub fn is_spd(c: &Voigt) -> bool {
    let scale = c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if !scale.is_finite() || scale <= 0.0 || c.iter().flatten().any(|v| !v.is_finite()) {
        return false;
    }
    for i in 0..3 {
        for j in 0..i {
            if (c[i][j] - c[j][i]).abs() > 1e-9 * scale {
                return false;
            }
        }
    }
    let m1 = c[0][0];
    let m2 = c[0][0] * c[1][1] - c[0][1] * c[1][0];
    let m3 = det3(c);
    let tol = 1e-14;
    m1 > tol * scale && m2 > tol * scale * scale && m3 > tol * scale * scale * scale
}

/// Determinant of a 3×3 matrix.
pub fn det3(m: &Voigt) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Inverse of a 3×3 matrix, `None` when singular or non-finite.
pub fn inverse3(m: &Voigt) -> Option<Voigt> {
    let d = det3(m);
    if !d.is_finite() || d == 0.0 {
        return None;
    }
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let (i1, i2) = ((j + 1) % 3, (j + 2) % 3);
            let (j1, j2) = ((i + 1) % 3, (i + 2) % 3);
            r[i][j] = (m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]) / d;
        }
    }
    Some(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [[f64; 2]; 3] {
        [[0.1, 0.2], [0.7, 0.25], [0.3, 0.9]]
    }

    #[test]
    fn gradients_reproduce_linear_fields() {
        let g = gradients(tri()).unwrap();
        // u(x) = 2 + 3x - 5y: gradient (3, -5) whatever the orientation.
        for uv in [tri(), [tri()[0], tri()[2], tri()[1]]] {
            let g = gradients(uv).unwrap();
            let f: [f64; 3] = core::array::from_fn(|a| 2.0 + 3.0 * uv[a][0] - 5.0 * uv[a][1]);
            let du: f64 = (0..3).map(|a| g.grad[a][0] * f[a]).sum();
            let dv: f64 = (0..3).map(|a| g.grad[a][1] * f[a]).sum();
            assert!((du - 3.0).abs() < 1e-12 && (dv + 5.0).abs() < 1e-12);
        }
        assert!((g.area - 0.5 * ((0.6 * 0.7) - (0.2 * 0.05))).abs() < 1e-12);
    }

    #[test]
    fn degenerate_triangle_is_rejected() {
        assert!(gradients([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_none());
        assert!(gradients([[0.0, 0.0], [f64::NAN, 1.0], [2.0, 2.0]]).is_none());
    }

    #[test]
    fn strain_of_affine_displacement_is_exact() {
        let g = gradients(tri()).unwrap();
        // d = F x with F = [[a, b], [c, d]]: e = [a, d, b + c].
        let f = [[0.01, 0.02], [-0.03, 0.04]];
        let d: [[f64; 2]; 3] = core::array::from_fn(|n| {
            let x = tri()[n];
            [f[0][0] * x[0] + f[0][1] * x[1], f[1][0] * x[0] + f[1][1] * x[1]]
        });
        let e = strain(&g, d);
        assert!((e[0] - 0.01).abs() < 1e-14 && (e[1] - 0.04).abs() < 1e-14);
        assert!((e[2] - (-0.01)).abs() < 1e-14);
    }

    #[test]
    fn stiffness_is_symmetric_and_annihilates_rigid_modes() {
        let g = gradients(tri()).unwrap();
        let c = [[300.0, 40.0, 5.0], [40.0, 90.0, -3.0], [5.0, -3.0, 30.0]];
        let k = element_stiffness(&g, &c);
        for a in 0..3 {
            for b in 0..3 {
                for r in 0..2 {
                    for s in 0..2 {
                        assert!((k[a][b][r][s] - k[b][a][s][r]).abs() < 1e-9);
                    }
                }
            }
        }
        // translations and the infinitesimal rotation (-y, x) give zero force
        let modes: [[[f64; 2]; 3]; 3] = [
            [[1.0, 0.0]; 3],
            [[0.0, 1.0]; 3],
            core::array::from_fn(|n| [-tri()[n][1], tri()[n][0]]),
        ];
        for d in modes {
            for a in 0..3 {
                for r in 0..2 {
                    let f: f64 = (0..3).map(|b| k[a][b][r][0] * d[b][0] + k[a][b][r][1] * d[b][1]).sum();
                    assert!(f.abs() < 1e-10, "{f}");
                }
            }
        }
        // K d = A Bᵀ C B d = stress_forces(C e)
        let d = [[0.01, -0.02], [0.03, 0.0], [-0.01, 0.02]];
        let fs = stress_forces(&g, stress(&c, strain(&g, d)));
        for a in 0..3 {
            for r in 0..2 {
                let f: f64 = (0..3).map(|b| k[a][b][r][0] * d[b][0] + k[a][b][r][1] * d[b][1]).sum();
                assert!((f - fs[a][r]).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn spd_check_and_inverse() {
        let c = isotropic(1000.0, 0.3);
        assert!(is_spd(&c));
        assert!(!is_spd(&[[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]));
        assert!(!is_spd(&[[1.0, 0.5, 0.0], [0.4, 1.0, 0.0], [0.0, 0.0, 1.0]]));
        let inv = inverse3(&c).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| c[i][k] * inv[k][j]).sum();
                assert!((p - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
    }
}
