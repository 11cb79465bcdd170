//! Linear (P1) membrane triangles: the in-plane finite element shared by the cell problem (§4)
//! and the coarse simulation (§5).
//!
//! Two halves: the `f64` element (gradients, `B`, `K_e`, stress forces) computed once, at
//! homogenization or at world init; and the `f32` runtime element ([`Element`]), whose corotated
//! forces, energy and stiffness blocks are re-assembled every substep.
//!
//! Conventions: rest shape in material space `(u, v)` (metres); strain `e = B d` with Voigt order
//! `[e11, e22, 2 e12]` (Eq. 1–3, the operator of Eq. 2 / Eq. 11); stress `s = C e` in N/m.

#![allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas

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
    Some(Gradients {
        grad,
        area: 0.5 * a2.abs(),
    })
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
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
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
            [
                f[0][0] * x[0] + f[0][1] * x[1],
                f[1][0] * x[0] + f[1][1] * x[1],
            ]
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
                    let f: f64 = (0..3)
                        .map(|b| k[a][b][r][0] * d[b][0] + k[a][b][r][1] * d[b][1])
                        .sum();
                    assert!(f.abs() < 1e-10, "{f}");
                }
            }
        }
        // K d = A Bᵀ C B d = stress_forces(C e)
        let d = [[0.01, -0.02], [0.03, 0.0], [-0.01, 0.02]];
        let fs = stress_forces(&g, stress(&c, strain(&g, d)));
        for a in 0..3 {
            for r in 0..2 {
                let f: f64 = (0..3)
                    .map(|b| k[a][b][r][0] * d[b][0] + k[a][b][r][1] * d[b][1])
                    .sum();
                assert!((f - fs[a][r]).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn spd_check_and_inverse() {
        let c = isotropic(1000.0, 0.3);
        assert!(is_spd(&c));
        assert!(!is_spd(&[
            [1.0, 2.0, 0.0],
            [2.0, 1.0, 0.0],
            [0.0, 0.0, 1.0]
        ]));
        assert!(!is_spd(&[
            [1.0, 0.5, 0.0],
            [0.4, 1.0, 0.0],
            [0.0, 0.0, 1.0]
        ]));
        let inv = inverse3(&c).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| c[i][k] * inv[k][j]).sum();
                assert!((p - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Runtime: corotated membrane elements (f32), assembled every substep into 3×3 blocks.
// ---------------------------------------------------------------------------------------------

use glam::{Mat3A, Vec3A};

/// A coarse triangle's constant data: its material `C`, its rest area and the shape-function
/// gradients, from which the element stiffness `K_ab = A B_aᵀ C B_b` (Eq. 10–11), its strain
/// `e = Σ_a B_a d_a` and its nodal forces `A B_aᵀ C e` follow with a few flops — cheaper than
/// loading a stored 6×6 `K_e`, and 56 bytes instead of 136 per triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Element {
    /// `[dN0/du, dN0/dv, dN1/du, dN1/dv, dN2/du, dN2/dv]` (1/m).
    pub grad: [f32; 6],
    /// The material's `C` (N/m) as `[C11, C22, C33, C12, C13, C23]`.
    pub c: [f32; 6],
    /// Rest area (m²).
    pub area: f32,
}

impl Element {
    pub const ZERO: Element = Element {
        grad: [0.0; 6],
        c: [0.0; 6],
        area: 0.0,
    };

    /// The element of the triangle with rest corners `uv` (m) and stiffness `c` (N/m).
    pub fn new(uv: [[f64; 2]; 3], c: &Voigt) -> Option<Element> {
        let g = gradients(uv)?;
        let mut grad = [0.0f32; 6];
        for a in 0..3 {
            grad[2 * a] = g.grad[a][0] as f32;
            grad[2 * a + 1] = g.grad[a][1] as f32;
        }
        let c = [c[0][0], c[1][1], c[2][2], c[0][1], c[0][2], c[1][2]].map(|v| v as f32);
        Some(Element {
            grad,
            c,
            area: g.area as f32,
        })
    }

    /// `σ = C e` (N/m) for a strain `e = [e11, e22, 2 e12]`.
    #[inline]
    pub fn stress(&self, e: [f32; 3]) -> [f32; 3] {
        let [c11, c22, c33, c12, c13, c23] = self.c;
        [
            c11 * e[0] + c12 * e[1] + c13 * e[2],
            c12 * e[0] + c22 * e[1] + c23 * e[2],
            c13 * e[0] + c23 * e[1] + c33 * e[2],
        ]
    }

    /// The strain `e = Σ_a B_a d_a` of in-plane corner displacements `d` (Eq. 3, 11).
    #[inline]
    pub fn strain(&self, d: &[[f32; 2]; 3]) -> [f32; 3] {
        let g = &self.grad;
        let mut e = [0.0f32; 3];
        for (a, da) in d.iter().enumerate() {
            let (gu, gv) = (g[2 * a], g[2 * a + 1]);
            e[0] += gu * da[0];
            e[1] += gv * da[1];
            e[2] += gv * da[0] + gu * da[1];
        }
        e
    }

    /// `A B_aᵀ σ`: corner `a`'s share of a constant stress (the elastic force with the opposite
    /// sign).
    #[inline]
    pub fn corner_force(&self, a: usize, s: [f32; 3]) -> [f32; 2] {
        self.corner_force_spun(a, s, 0.0)
    }

    /// `A Q ∇N_a` with `Q = τ + k J` (see [`spin_stress`]): corner `a`'s share of the in-frame
    /// first Piola–Kirchhoff stress, i.e. the corotated force with the opposite sign.
    #[inline]
    pub fn corner_force_spun(&self, a: usize, s: [f32; 3], k: f32) -> [f32; 2] {
        let (gu, gv) = (self.grad[2 * a], self.grad[2 * a + 1]);
        [
            self.area * (gu * s[0] + gv * (s[2] + k)),
            self.area * (gv * s[1] + gu * (s[2] - k)),
        ]
    }

    /// The 2×2 block `K_ab = A B_aᵀ C B_b`.
    #[inline]
    pub fn block(&self, a: usize, b: usize) -> [[f32; 2]; 2] {
        let [c11, c22, c33, c12, c13, c23] = self.c;
        let (ua, va) = (self.grad[2 * a], self.grad[2 * a + 1]);
        let (ub, vb) = (self.grad[2 * b], self.grad[2 * b + 1]);
        // C B_b, columns for the u and v displacement of b
        let cu = [
            c11 * ub + c13 * vb,
            c12 * ub + c23 * vb,
            c13 * ub + c33 * vb,
        ];
        let cv = [
            c12 * vb + c13 * ub,
            c22 * vb + c23 * ub,
            c23 * vb + c33 * ub,
        ];
        let row = |c: [f32; 3]| [ua * c[0] + va * c[2], va * c[1] + ua * c[2]];
        let (ku, kv) = (row(cu), row(cv));
        [
            [self.area * ku[0], self.area * kv[0]],
            [self.area * ku[1], self.area * kv[1]],
        ]
    }
}

/// The corotated frame of a triangle: the 3D images `(r0, r1)` of the rest u and v axes under
/// the rotational part of its deformation gradient `F` (3×2). `F`'s columns are projected on
/// the deformed plane (normal `f1 × f2`), and the 2×2 in-plane part is split by its closed-form
/// polar decomposition (the rotation maximizing `tr(Rᵀ F₂)`). A collapsed triangle uses
/// `fallback` as its normal.
pub fn corotated_frame(grad: &[f32; 6], x: [Vec3A; 3], fallback: Vec3A) -> (Vec3A, Vec3A) {
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    // Σ_a ∇N_a = 0, so F = Σ_a (x_a − x_0) ⊗ ∇N_a.
    let f1 = e1 * grad[2] + e2 * grad[4];
    let f2 = e1 * grad[3] + e2 * grad[5];
    let cross = f1.cross(f2);
    let scale = f1.length_squared() * f2.length_squared();
    let n = if cross.length_squared() > 1e-12 * scale && scale > 0.0 {
        cross.normalize()
    } else {
        fallback.try_normalize().unwrap_or(Vec3A::Z)
    };
    // an orthonormal basis (b1, b2) of the deformed plane
    let p1 = f1 - n * n.dot(f1);
    let b1 = match p1.try_normalize() {
        Some(b) => b,
        None => n.any_orthonormal_vector(),
    };
    let b2 = n.cross(b1);
    let (a11, a12, a21, a22) = (b1.dot(f1), b1.dot(f2), b2.dot(f1), b2.dot(f2));
    let angle = libm::atan2f(a21 - a12, a11 + a22);
    let (s, c) = (libm::sinf(angle), libm::cosf(angle));
    (b1 * c + b2 * s, b2 * c - b1 * s)
}

/// The rotation term of the corotated force, for any SPD `C`.
///
/// The corotated energy is `Ψ = ½ A eᵀ C e` with `e` the Biot strain of the stretch
/// `S = R_eᵀ F` (`F` the 3×2 deformation gradient, `R_e` its polar rotation, `S` symmetric:
/// `e = [S11 − 1, S22 − 1, 2 S12]`). Its exact gradient is `∂Ψ/∂x_a = A R_e Q ∇N_a` with the
/// in-frame first Piola–Kirchhoff stress
///
/// ```text
///     Q = τ + (S τ − τ S) / tr S,      τ = [[σ11, σ12], [σ12, σ22]],  σ = C e
/// ```
///
/// (differentiate `S² = FᵀF`: `S dS + dS S = dFᵀF + FᵀdF`, solve that 2×2 Sylvester equation in
/// closed form with Cayley–Hamilton, `S² = tr S · S − det S · I`; `det S` cancels). The
/// commutator is antisymmetric, `k J` with `J = [[0, 1], [−1, 0]]`, and this returns `k`.
/// It vanishes when `τ` commutes with `S` — always for isotropic `C`, which is why the classic
/// corotated force `R_e τ ∇N_a` (Etzmuß et al. 2003) is exact there and only there. Dropping it
/// for an anisotropic `C^H` gives forces that do work round closed loops and carry a net
/// torque (a free cloth spins up by itself). In the small-strain limit `k = O(|e|²)`, so the
/// linear response is still exactly `C^H`. `tr S > 0` unless the triangle has collapsed to a
/// point, where the term is dropped.
#[inline]
pub fn spin_stress(e: [f32; 3], s: [f32; 3]) -> f32 {
    // S = I + [[e0, e2/2], [e2/2, e1]]; (Sτ − τS)_12 = τ12 (S11 − S22) − S12 (τ11 − τ22).
    let trace = 2.0 + e[0] + e[1];
    let c = s[2] * (e[0] - e[1]) - 0.5 * e[2] * (s[0] - s[1]);
    if trace > 1e-6 {
        c / trace
    } else {
        0.0
    }
}

/// Why the per-substep membrane assembly refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssemblyError {
    LengthMismatch,
    /// A triangle's block is missing from the pattern.
    MissingBlock,
}

/// Corotated membrane (the warped stiffness of §5.2 per element, Etzmuß et al. 2003): for every
/// triangle with frame `R_e = [r0 r1]` (the polar rotation of its deformation gradient), the
/// elastic force `f_a = −A R_e Q ∇N_a`, the exact gradient of the energy `½ A eᵀ C e` of the
/// Biot strain `e` (with the rotation term of [`spin_stress`], so it is conservative and
/// torque-free for any SPD `C`), is added to `force`. The Jacobian added to the 3×3 blocks
/// (`diag`, `off` at the triangle's `slots`, which hold the block index of its pairs (0,1),
/// (0,2), (1,2), with [`TRANSPOSED`] set when the pair is stored as (j, i)) is the documented
/// SPD approximation `R_e K_ab R_eᵀ + A ∇N_aᵀ σ⁺ ∇N_b I`: the rotated linear stiffness (exact
/// in the small-strain limit) plus the tensile geometric stiffness; the derivative of `R_e`
/// and of the rotation term are left out (they are indefinite under compression). Element
/// forces sum to zero (linear momentum is conserved exactly) and a rigid motion gives exactly
/// zero force. `warping = false` is plain linear FEM (`R_e = I`).
#[allow(clippy::too_many_arguments)]
pub fn assemble_corotated(
    triangles: &[[u32; 3]],
    elements: &[Element],
    slots: &[[u32; 3]],
    rest: &[Vec3A],
    x: &[Vec3A],
    normals: &[Vec3A],
    warping: bool,
    diag: &mut [Mat3A],
    off: &mut [Mat3A],
    force: &mut [Vec3A],
) -> Result<f64, AssemblyError> {
    let n = x.len();
    if elements.len() != triangles.len()
        || slots.len() != triangles.len()
        || rest.len() != n
        || normals.len() != n
        || diag.len() != n
        || force.len() != n
    {
        return Err(AssemblyError::LengthMismatch);
    }
    let mut energy = 0.0f64;
    diag.fill(Mat3A::ZERO);
    off.fill(Mat3A::ZERO);
    force.fill(Vec3A::ZERO);
    for ((tri, e), slot) in triangles.iter().zip(elements).zip(slots) {
        let idx = tri.map(|i| i as usize);
        if idx.iter().any(|&i| i >= n) {
            return Err(AssemblyError::LengthMismatch);
        }
        let (r0, r1, d) = local_displacement(e, idx, rest, x, normals, warping);
        let strain = e.strain(&d);
        let stress = e.stress(strain);
        // f_a = −A R_e Q ∇N_a: the exact gradient of the corotated energy (see `spin_stress`);
        // linear FEM (no warping) has no rotation term.
        let spin = if warping {
            spin_stress(strain, stress)
        } else {
            0.0
        };
        for (a, &i) in idx.iter().enumerate() {
            let s = e.corner_force_spun(a, stress, spin);
            force[i] -= r0 * s[0] + r1 * s[1];
        }
        energy += 0.5
            * f64::from(
                e.area * (stress[0] * strain[0] + stress[1] * strain[1] + stress[2] * strain[2]),
            );
        // Geometric (initial-stress) stiffness `A ∇N_aᵀ σ⁺ ∇N_b I3`, tension only. A taut
        // membrane resists sideways motion only through the turning of its frames, which the
        // rotated K leaves out; without this term that resistance is integrated explicitly and
        // a taut cloth goes unstable once `h > h_e / sqrt(T/ρ)` (a twisted strip at 60 Hz).
        // Keeping only the tensile part σ⁺ keeps the matrix positive semidefinite for CG.
        let geo = if warping {
            let g = &e.grad;
            let s = tension(stress);
            let k = |a: usize, b: usize| {
                let (ua, va, ub, vb) = (g[2 * a], g[2 * a + 1], g[2 * b], g[2 * b + 1]);
                e.area * (ua * (s[0] * ub + s[2] * vb) + va * (s[2] * ub + s[1] * vb))
            };
            [k(0, 0), k(1, 1), k(2, 2), k(0, 1), k(0, 2), k(1, 2)]
        } else {
            [0.0; 6]
        };
        // R K_ab Rᵀ = [r0 r1] K_ab [r0 r1]ᵀ
        let rotate = |k: [[f32; 2]; 2]| {
            let u0 = r0 * k[0][0] + r1 * k[0][1];
            let u1 = r0 * k[1][0] + r1 * k[1][1];
            Mat3A::from_cols(
                r0 * u0.x + r1 * u1.x,
                r0 * u0.y + r1 * u1.y,
                r0 * u0.z + r1 * u1.z,
            )
        };
        for a in 0..3 {
            diag[idx[a]] += rotate(e.block(a, a)) + Mat3A::from_diagonal(glam::Vec3::splat(geo[a]));
        }
        for (p, (a, b)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
            let s = slot[p];
            let m = rotate(e.block(a, b)) + Mat3A::from_diagonal(glam::Vec3::splat(geo[3 + p]));
            let block = off
                .get_mut((s & !TRANSPOSED) as usize)
                .ok_or(AssemblyError::MissingBlock)?;
            *block += if s & TRANSPOSED != 0 {
                m.transpose()
            } else {
                m
            };
        }
    }
    Ok(energy)
}

/// A triangle's corotated frame `(r0, r1)` and the in-plane displacement of its corners in
/// that frame, relative to corner 0 (differences keep f32 cancellation small).
#[inline]
fn local_displacement(
    e: &Element,
    idx: [usize; 3],
    rest: &[Vec3A],
    x: &[Vec3A],
    normals: &[Vec3A],
    warping: bool,
) -> (Vec3A, Vec3A, [[f32; 2]; 3]) {
    let xs = idx.map(|i| x[i]);
    let (r0, r1) = if warping {
        let fallback = normals[idx[0]] + normals[idx[1]] + normals[idx[2]];
        corotated_frame(&e.grad, xs, fallback)
    } else {
        (Vec3A::X, Vec3A::Y)
    };
    let d = core::array::from_fn(|a| {
        let dx = xs[a] - xs[0];
        let dr = rest[idx[a]] - rest[idx[0]];
        [r0.dot(dx) - dr.x, r1.dot(dx) - dr.y]
    });
    (r0, r1, d)
}

/// The corotated elastic energy `Σ_e ½ dᵀ K_e d` (J) of the configuration `x`: what
/// [`assemble_corotated`] returns, without assembling (the step's energy monitor).
pub fn elastic_energy(
    triangles: &[[u32; 3]],
    elements: &[Element],
    rest: &[Vec3A],
    x: &[Vec3A],
    normals: &[Vec3A],
    warping: bool,
) -> Result<f64, AssemblyError> {
    let n = x.len();
    if elements.len() != triangles.len() || rest.len() != n || normals.len() != n {
        return Err(AssemblyError::LengthMismatch);
    }
    let mut energy = 0.0f64;
    for (tri, e) in triangles.iter().zip(elements) {
        let idx = tri.map(|i| i as usize);
        if idx.iter().any(|&i| i >= n) {
            return Err(AssemblyError::LengthMismatch);
        }
        let (_, _, d) = local_displacement(e, idx, rest, x, normals, warping);
        let strain = e.strain(&d);
        let s = e.stress(strain);
        energy +=
            0.5 * f64::from(e.area * (s[0] * strain[0] + s[1] * strain[1] + s[2] * strain[2]));
    }
    Ok(energy)
}

/// The tensile part of a membrane stress `[σ11, σ22, σ12]`: its principal values clamped at 0.
fn tension(s: [f32; 3]) -> [f32; 3] {
    let mean = 0.5 * (s[0] + s[1]);
    let half = 0.5 * (s[0] - s[1]);
    let radius = libm::sqrtf(half * half + s[2] * s[2]);
    let (l1, l2) = (mean + radius, mean - radius);
    if l2 >= 0.0 {
        return s;
    }
    if l1 <= 0.0 {
        return [0.0; 3];
    }
    // only l1 > 0: σ⁺ = l1 v vᵀ with v the first principal direction
    if radius <= 0.0 {
        return [0.0; 3];
    }
    let (c2, s2) = (half / radius, s[2] / radius); // cos 2φ, sin 2φ
    let cc = 0.5 * (1.0 + c2); // cos²φ
    let ss = 0.5 * (1.0 - c2); // sin²φ
    [l1 * cc, l1 * ss, l1 * 0.5 * s2]
}

/// Flag in an element slot: the pair is stored as block (j, i).
pub const TRANSPOSED: u32 = 1 << 31;

#[cfg(test)]
mod runtime_tests {
    use super::*;

    #[test]
    fn frame_of_rigid_motion_is_the_rotation() {
        let uv = [[0.0, 0.0], [0.3, 0.05], [0.1, 0.4]];
        let e = Element::new(uv, &isotropic(100.0, 0.3)).unwrap();
        let q = glam::Quat::from_axis_angle(glam::Vec3::new(0.3, -1.0, 0.5).normalize(), 2.5);
        let x = uv.map(|p| {
            Vec3A::from(q * glam::Vec3::new(p[0] as f32, p[1] as f32, 0.0)) + Vec3A::splat(4.0)
        });
        let (r0, r1) = corotated_frame(&e.grad, x, Vec3A::Z);
        assert!((r0 - Vec3A::from(q * glam::Vec3::X)).length() < 1e-5);
        assert!((r1 - Vec3A::from(q * glam::Vec3::Y)).length() < 1e-5);
        // a pure stretch has the identity frame
        let x = uv.map(|p| Vec3A::new(1.2 * p[0] as f32, 0.9 * p[1] as f32, 0.0));
        let (r0, r1) = corotated_frame(&e.grad, x, Vec3A::Z);
        assert!((r0 - Vec3A::X).length() < 1e-6 && (r1 - Vec3A::Y).length() < 1e-6);
    }

    #[test]
    fn tension_keeps_the_positive_principal_part() {
        // all tensile: unchanged; all compressive: zero
        assert_eq!(tension([2.0, 1.0, 0.5]), [2.0, 1.0, 0.5]);
        assert_eq!(tension([-2.0, -1.0, 0.1]), [0.0; 3]);
        // uniaxial tension along u with compression along v
        let t = tension([3.0, -1.0, 0.0]);
        assert!((t[0] - 3.0).abs() < 1e-6 && t[1].abs() < 1e-6 && t[2].abs() < 1e-6);
        // mixed: σ⁺ is PSD, and σ − σ⁺ is NSD
        let s = [1.0, -2.0, 1.5];
        let t = tension(s);
        let det = |m: [f32; 3]| m[0] * m[1] - m[2] * m[2];
        assert!(t[0] >= 0.0 && t[1] >= 0.0 && det(t) > -1e-5);
        let r = [s[0] - t[0], s[1] - t[1], s[2] - t[2]];
        assert!(r[0] <= 1e-6 && r[1] <= 1e-6 && det(r) > -1e-5);
    }

    /// A small deterministic generator (tests only).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.next()
        }
    }

    /// `C` of an orthotropic material with stiffnesses `(c1, c2, shear)` along axes turned by
    /// `theta` in the (u, v) plane: `Tᵀ C T` with `T` the engineering-strain rotation.
    fn rotated_orthotropic(c1: f64, c2: f64, c12: f64, shear: f64, theta: f64) -> Voigt {
        let local = [[c1, c12, 0.0], [c12, c2, 0.0], [0.0, 0.0, shear]];
        let (c, s) = (theta.cos(), theta.sin());
        let t = [
            [c * c, s * s, c * s],
            [s * s, c * c, -c * s],
            [-2.0 * c * s, 2.0 * c * s, c * c - s * s],
        ];
        let mut out = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    for l in 0..3 {
                        out[i][j] += t[k][i] * local[k][l] * t[l][j];
                    }
                }
            }
        }
        out
    }

    /// One triangle with rest corners `uv`, or a fan of them: the arrays a world would hold.
    struct Patch {
        triangles: Vec<[u32; 3]>,
        elements: Vec<Element>,
        slots: Vec<[u32; 3]>,
        rest: Vec<Vec3A>,
        off: usize,
    }

    impl Patch {
        /// Triangles over the given rest points, each with its own slots (no shared pattern is
        /// needed for forces and energy).
        fn new(uv: &[[f64; 2]], triangles: &[[u32; 3]], c: &Voigt) -> Patch {
            let elements = triangles
                .iter()
                .map(|t| Element::new(t.map(|i| uv[i as usize]), c).unwrap())
                .collect();
            let slots = (0..triangles.len() as u32)
                .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
                .collect();
            Patch {
                triangles: triangles.to_vec(),
                elements,
                slots,
                rest: uv
                    .iter()
                    .map(|p| Vec3A::new(p[0] as f32, p[1] as f32, 0.0))
                    .collect(),
                off: 3 * triangles.len(),
            }
        }
        fn forces(&self, x: &[Vec3A]) -> Vec<Vec3A> {
            let n = x.len();
            let (mut diag, mut off) = (vec![Mat3A::ZERO; n], vec![Mat3A::ZERO; self.off]);
            let mut f = vec![Vec3A::ZERO; n];
            let normals = vec![Vec3A::Z; n];
            assemble_corotated(
                &self.triangles,
                &self.elements,
                &self.slots,
                &self.rest,
                x,
                &normals,
                true,
                &mut diag,
                &mut off,
                &mut f,
            )
            .unwrap();
            f
        }
        fn energy(&self, x: &[Vec3A]) -> f64 {
            let normals = vec![Vec3A::Z; x.len()];
            elastic_energy(
                &self.triangles,
                &self.elements,
                &self.rest,
                x,
                &normals,
                true,
            )
            .unwrap()
        }
    }

    /// The issue's configuration: stretched 1.3 × 0.8 with shear 0.25, then rotated in 3D.
    fn deformed(rest: &[Vec3A], q: glam::Quat) -> Vec<Vec3A> {
        rest.iter()
            .map(|p| {
                let d = glam::Vec3::new(1.3 * p.x + 0.25 * p.y, 0.8 * p.y, 0.0);
                Vec3A::from(q * d)
            })
            .collect()
    }

    fn materials(rng: &mut Lcg) -> Vec<Voigt> {
        let mut cs = vec![
            isotropic(500.0, 0.3),
            [[1000.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            [[600.0, 60.0, 0.0], [60.0, 150.0, 0.0], [0.0, 0.0, 50.0]],
            rotated_orthotropic(1e4, 1.0, 0.5, 1.0, 0.6),
            rotated_orthotropic(1.0, 1e4, 0.0, 3.0, -1.1),
        ];
        for _ in 0..6 {
            // random SPD: L Lᵀ with anisotropy up to 1e4, on random axes
            let l: [[f64; 3]; 3] =
                core::array::from_fn(|_| core::array::from_fn(|_| rng.range(-1.0, 1.0)));
            let mut c = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    c[i][j] = (0..3).map(|k| l[i][k] * l[j][k]).sum::<f64>() * 100.0;
                }
                c[i][i] += 1.0;
            }
            let c = rotated_orthotropic(
                c[0][0] * rng.range(1.0, 1e4),
                c[1][1],
                0.0,
                c[2][2],
                rng.range(-3.0, 3.0),
            );
            assert!(is_spd(&c));
            cs.push(c);
        }
        cs
    }

    #[test]
    fn corotated_force_is_the_energy_gradient_for_any_spd_c() {
        let mut rng = Lcg(7);
        let uv = [[0.0, 0.0], [0.2, 0.03], [0.05, 0.17]];
        for c in materials(&mut rng) {
            let patch = Patch::new(&uv, &[[0, 1, 2]], &c);
            for trial in 0..4 {
                let axis = glam::Vec3::new(
                    rng.range(-1.0, 1.0) as f32,
                    rng.range(-1.0, 1.0) as f32,
                    rng.range(-1.0, 1.0) as f32,
                )
                .normalize();
                let q = glam::Quat::from_axis_angle(axis, trial as f32 * 1.3);
                let x = deformed(&patch.rest, q);
                let f = patch.forces(&x);
                let delta = 2e-4f32;
                let mut err = 0.0f64;
                let mut norm = 0.0f64;
                for i in 0..3 {
                    for k in 0..3 {
                        let mut xp = x.clone();
                        let mut xm = x.clone();
                        xp[i][k] += delta;
                        xm[i][k] -= delta;
                        let fd = -(patch.energy(&xp) - patch.energy(&xm))
                            / f64::from(2.0 * delta);
                        err += (fd - f64::from(f[i][k])).powi(2);
                        norm += fd * fd;
                    }
                }
                let rel = (err / norm).sqrt();
                assert!(rel < 2e-3, "C = {c:?}, trial {trial}: force vs −∂E/∂x off by {rel}");
            }
        }
    }

    #[test]
    fn corotated_forces_do_no_work_round_closed_loops() {
        let mut rng = Lcg(11);
        let uv = [[0.0, 0.0], [0.2, 0.03], [0.05, 0.17]];
        for c in materials(&mut rng) {
            let patch = Patch::new(&uv, &[[0, 1, 2]], &c);
            let q = glam::Quat::from_axis_angle(glam::Vec3::new(0.2, 1.0, -0.4).normalize(), 0.9);
            let x0 = deformed(&patch.rest, q);
            // corner 2 goes round a 1 cm circle in a plane oblique to the triangle
            let (a, b) = (
                Vec3A::new(0.01, 0.0, 0.004),
                Vec3A::new(0.0, 0.008, 0.006),
            );
            let steps = 400;
            let mut work = 0.0f64;
            let at = |s: f64| {
                let mut x = x0.clone();
                let (sin, cos) = (2.0 * core::f64::consts::PI * s).sin_cos();
                x[2] += a * (cos as f32 - 1.0) + b * sin as f32;
                x
            };
            for k in 0..steps {
                // midpoint rule on each segment: W = Σ f(mid) · Δx
                let (s0, s1) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
                let (p0, p1, pm) = (at(s0), at(s1), at(0.5 * (s0 + s1)));
                let f = patch.forces(&pm);
                work += f64::from(f[2].dot(p1[2] - p0[2]));
            }
            let e = patch.energy(&x0);
            assert!(
                work.abs() < 2e-4 * e,
                "C = {c:?}: a closed loop does {work} J of work (energy {e} J)"
            );
        }
    }

    #[test]
    fn corotated_forces_carry_no_net_force_or_torque() {
        let mut rng = Lcg(3);
        // a fan of 6 triangles round a centre vertex, crumpled at random in 3D
        let mut uv = vec![[0.0, 0.0]];
        for k in 0..6 {
            let a = k as f64 * core::f64::consts::PI / 3.0;
            uv.push([0.1 * a.cos(), 0.1 * a.sin()]);
        }
        let tris: Vec<[u32; 3]> = (0..6u32).map(|k| [0, 1 + k, 1 + (k + 1) % 6]).collect();
        for c in materials(&mut rng) {
            let patch = Patch::new(&uv, &tris, &c);
            for _ in 0..4 {
                let x: Vec<Vec3A> = patch
                    .rest
                    .iter()
                    .map(|p| {
                        *p * rng.range(0.7, 1.4) as f32
                            + Vec3A::new(
                                rng.range(-0.03, 0.03) as f32,
                                rng.range(-0.03, 0.03) as f32,
                                rng.range(-0.05, 0.05) as f32,
                            )
                            + Vec3A::new(3.0, -2.0, 1.0)
                    })
                    .collect();
                let f = patch.forces(&x);
                let centre = x.iter().copied().sum::<Vec3A>() / x.len() as f32;
                let (mut net, mut torque, mut scale) = (Vec3A::ZERO, Vec3A::ZERO, 0.0f32);
                for (p, fi) in x.iter().zip(&f) {
                    net += *fi;
                    torque += (*p - centre).cross(*fi);
                    scale += (*p - centre).length() * fi.length();
                }
                let fmax = f.iter().map(|v| v.length()).fold(0.0, f32::max);
                assert!(net.length() < 1e-5 * fmax * 7.0, "net force {net} (C = {c:?})");
                assert!(torque.length() < 1e-5 * scale, "net torque {torque} of {scale} (C = {c:?})");
            }
        }
    }

    #[test]
    fn packed_blocks_match_the_element_stiffness() {
        let uv = [[0.0, 0.0], [0.3, 0.05], [0.1, 0.4]];
        let c = [[300.0, 40.0, 5.0], [40.0, 90.0, -3.0], [5.0, -3.0, 30.0]];
        let e = Element::new(uv, &c).unwrap();
        let ke = element_stiffness(&gradients(uv).unwrap(), &c);
        for a in 0..3 {
            for b in 0..3 {
                let k = e.block(a, b);
                for r in 0..2 {
                    for s in 0..2 {
                        assert!((k[r][s] as f64 - ke[a][b][r][s]).abs() < 1e-3);
                    }
                }
            }
        }
    }
}
