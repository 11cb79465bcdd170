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

pub use crate::voigt::{det3, inverse3, is_spd, isotropic};
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
    let [p0, p1, p2] = uv;
    let grad =
        [[p1, p2], [p2, p0], [p0, p1]].map(|[b, c]| [(b[1] - c[1]) / a2, (c[0] - b[0]) / a2]);
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
    for (&ga, da) in g.grad.iter().zip(&d) {
        let b = b_block(ga);
        for (ei, bi) in e.iter_mut().zip(&b) {
            *ei += bi[0] * da[0] + bi[1] * da[1];
        }
    }
    e
}

/// `s = C e`.
#[inline]
pub fn stress(c: &Voigt, e: [f64; 3]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for (si, ci) in s.iter_mut().zip(c) {
        *si = ci[0] * e[0] + ci[1] * e[1] + ci[2] * e[2];
    }
    s
}

/// Element stiffness `K_e = A Bᵀ C B` as 2×2 blocks: `k[a][b]` couples node `a` to node `b`.
/// The elastic force on node `a` is `-Σ_b k[a][b] d_b`.
pub fn element_stiffness(g: &Gradients, c: &Voigt) -> [[[[f64; 2]; 2]; 3]; 3] {
    let mut k = [[[[0.0; 2]; 2]; 3]; 3];
    for (ka, &ga) in k.iter_mut().zip(&g.grad) {
        // columns r of B_a
        let ba = columns(b_block(ga));
        for (kab, &gb) in ka.iter_mut().zip(&g.grad) {
            // C B_b (3×2), column by column: cb[s][i] = Σ_j c[i][j] B_b[j][s]
            let cb = columns(b_block(gb))
                .map(|bs| c.map(|ci| ci[0] * bs[0] + ci[1] * bs[1] + ci[2] * bs[2]));
            for (krow, bar) in kab.iter_mut().zip(&ba) {
                for (krs, cbs) in krow.iter_mut().zip(&cb) {
                    *krs = g.area * (bar[0] * cbs[0] + bar[1] * cbs[1] + bar[2] * cbs[2]);
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
    for (fa, &ga) in f.iter_mut().zip(&g.grad) {
        for (far, br) in fa.iter_mut().zip(&columns(b_block(ga))) {
            *far = g.area * (br[0] * s[0] + br[1] * s[1] + br[2] * s[2]);
        }
    }
    f
}

/// The two columns of a 3×2 matrix.
fn columns(m: [[f64; 2]; 3]) -> [[f64; 3]; 2] {
    [[m[0][0], m[1][0], m[2][0]], [m[0][1], m[1][1], m[2][1]]]
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
        let [g0, g1, g2] = g.grad;
        let grad = [g0[0], g0[1], g1[0], g1[1], g2[0], g2[1]].map(|v| v as f32);
        let c = [c[0][0], c[1][1], c[2][2], c[0][1], c[0][2], c[1][2]].map(|v| v as f32);
        Some(Element {
            grad,
            c,
            area: g.area as f32,
        })
    }

    /// `∇N_a = (dN_a/du, dN_a/dv)` of corner `a` (0, 1 or 2; zero for any other `a`).
    #[inline]
    fn corner_gradient(&self, a: usize) -> (f32, f32) {
        (
            self.grad.get(2 * a).copied().unwrap_or(0.0),
            self.grad.get(2 * a + 1).copied().unwrap_or(0.0),
        )
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
        let mut e = [0.0f32; 3];
        for (a, da) in d.iter().enumerate() {
            let (gu, gv) = self.corner_gradient(a);
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
        let (gu, gv) = self.corner_gradient(a);
        [
            self.area * (gu * s[0] + gv * s[2]),
            self.area * (gv * s[1] + gu * s[2]),
        ]
    }

    /// The 2×2 block `K_ab = A B_aᵀ C B_b`.
    #[inline]
    pub fn block(&self, a: usize, b: usize) -> [[f32; 2]; 2] {
        let [c11, c22, c33, c12, c13, c23] = self.c;
        let (ua, va) = self.corner_gradient(a);
        let (ub, vb) = self.corner_gradient(b);
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

/// Why the per-substep membrane assembly refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssemblyError {
    LengthMismatch,
    /// A triangle's block is missing from the pattern.
    MissingBlock,
}

impl core::fmt::Display for AssemblyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            AssemblyError::LengthMismatch => "slice lengths or triangle indices disagree",
            AssemblyError::MissingBlock => "a triangle's block is missing from the pattern",
        })
    }
}

/// How the runtime membrane measures strain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strain {
    /// Green strain `E = ½(FᵀF − I)` of the 3×2 deformation gradient `F`: a St Venant–Kirchhoff
    /// membrane, invariant under any rotation (the warped stiffness of §5.2, exactly).
    Green,
    /// The small-strain `e = B u` of plain linear FEM, in the rest plane (for the accuracy
    /// study: not rotation invariant).
    Linear,
}

impl Element {
    /// The columns `(f1, f2)` of the deformation gradient `F = Σ_a x_a ⊗ ∇N_a` of corners `x`
    /// (from differences to corner 0, since `Σ_a ∇N_a = 0`: keeps f32 cancellation small).
    #[inline]
    pub fn deformation(&self, x: [Vec3A; 3]) -> (Vec3A, Vec3A) {
        let g = &self.grad;
        let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
        (e1 * g[2] + e2 * g[4], e1 * g[3] + e2 * g[5])
    }

    /// The membrane's strain `[e11, e22, 2 e12]` of corners `x`, and the two vectors `(d1, d2)`
    /// through which it varies with them: `∂e/∂x_a` has rows `[a_u d1, a_v d2, a_u d2 + a_v d1]`
    /// (`(a_u, a_v) = ∇N_a`). Green: `d = (f1, f2)`; linear: the rest axes.
    #[inline]
    pub(crate) fn measure(&self, x: [Vec3A; 3], strain: Strain) -> ([f32; 3], Vec3A, Vec3A) {
        let (f1, f2) = self.deformation(x);
        match strain {
            Strain::Green => (
                [
                    0.5 * (f1.length_squared() - 1.0),
                    0.5 * (f2.length_squared() - 1.0),
                    f1.dot(f2),
                ],
                f1,
                f2,
            ),
            Strain::Linear => ([f1.x - 1.0, f2.y - 1.0, f1.y + f2.x], Vec3A::X, Vec3A::Y),
        }
    }

    /// `∂e/∂x_a` as its three rows.
    #[inline]
    fn strain_rows(&self, a: usize, d1: Vec3A, d2: Vec3A) -> [Vec3A; 3] {
        let (u, v) = (
            self.grad.get(2 * a).copied().unwrap_or(0.0),
            self.grad.get(2 * a + 1).copied().unwrap_or(0.0),
        );
        [d1 * u, d2 * v, d2 * u + d1 * v]
    }
}

crate::cpu::multiversion! {
    /// The membrane of the coarse cloth (§5.1–5.2): for every triangle the energy
    /// `Ψ = ½ A eᵀ C e` of its strain `e` (Green by default, see [`Strain`]), its exact
    /// gradient `f_a = −A Σ_i σ_i ∂e_i/∂x_a` (σ = C e) added to `force`, and its Hessian
    ///
    /// ```text
    ///     K_ab = A (∂e/∂x_a)ᵀ C (∂e/∂x_b)  +  A (∇N_aᵀ Σ⁺ ∇N_b) I₃
    /// ```
    ///
    /// added to the 3×3 blocks (`diag`, `off` at the triangle's `slots`, which hold the block
    /// index of its pairs (0,1), (0,2), (1,2), with [`TRANSPOSED`] set when the pair is stored
    /// as (j, i)). The first term is the material stiffness (PSD for SPD `C`); the second the
    /// geometric (initial-stress) stiffness with the stress tensor `Σ` clamped to its tensile
    /// part `Σ⁺`, so the Hessian is exact for a membrane in tension and its SPD approximation
    /// under compression (where a membrane buckles rather than resists). The energy depends on
    /// `FᵀF` only, so the forces carry no net force or torque and do no work round a closed
    /// loop for *any* SPD `C`; in the small-strain limit `K` is the linear FEM stiffness
    /// `A Bᵀ C B` (Eq. 10–11), so `C^H` is reproduced exactly (patch test). Returns the elastic
    /// energy (J).
    ///
    /// Runs the AVX2 build of the same code where the processor has it (`crate::cpu`;
    /// bit-identical).
    #[allow(clippy::too_many_arguments)]
    pub fn assemble, assemble_avx2 => assemble_body(
        triangles: &[[u32; 3]],
        elements: &[Element],
        slots: &[[u32; 3]],
        x: &[Vec3A],
        strain: Strain,
        diag: &mut [Mat3A],
        off: &mut [Mat3A],
        force: &mut [Vec3A],
    ) -> Result<f64, AssemblyError>
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn assemble_body(
    triangles: &[[u32; 3]],
    elements: &[Element],
    slots: &[[u32; 3]],
    x: &[Vec3A],
    strain: Strain,
    diag: &mut [Mat3A],
    off: &mut [Mat3A],
    force: &mut [Vec3A],
) -> Result<f64, AssemblyError> {
    let n = x.len();
    if elements.len() != triangles.len()
        || slots.len() != triangles.len()
        || diag.len() != n
        || force.len() != n
    {
        return Err(AssemblyError::LengthMismatch);
    }
    // Σ A σ·e, halved at the end (exact: a power of two), one product per triangle less
    let mut twice_energy = 0.0f64;
    diag.fill(Mat3A::ZERO);
    off.fill(Mat3A::ZERO);
    force.fill(Vec3A::ZERO);
    for ((tri, el), slot) in triangles.iter().zip(elements).zip(slots) {
        let xs = corners(tri, x)?;
        let (e, d1, d2) = el.measure(xs, strain);
        let s = el.stress(e);
        twice_energy += f64::from(el.area * (s[0] * e[0] + s[1] * e[1] + s[2] * e[2]));
        let rows: [[Vec3A; 3]; 3] = core::array::from_fn(|a| el.strain_rows(a, d1, d2));
        for (r, &i) in rows.iter().zip(tri) {
            let f = force
                .get_mut(i as usize)
                .ok_or(AssemblyError::LengthMismatch)?;
            *f -= (r[0] * s[0] + r[1] * s[1] + r[2] * s[2]) * el.area;
        }
        // C (∂e/∂x_b), row by row
        let [c11, c22, c33, c12, c13, c23] = el.c;
        let c_rows = |r: &[Vec3A; 3]| {
            [
                r[0] * c11 + r[1] * c12 + r[2] * c13,
                r[0] * c12 + r[1] * c22 + r[2] * c23,
                r[0] * c13 + r[1] * c23 + r[2] * c33,
            ]
        };
        // Geometric stiffness `A ∇N_aᵀ Σ⁺ ∇N_b I3`, tension only: a taut membrane resists
        // sideways motion only through it, and without it that resistance is integrated
        // explicitly (a taut strip at 60 Hz goes unstable). Linear FEM has none.
        let sp = match strain {
            Strain::Green => tension(s),
            Strain::Linear => [0.0; 3],
        };
        let g = &el.grad;
        let geo = |a: usize, b: usize| {
            let (ua, va, ub, vb) = (
                g.get(2 * a).copied().unwrap_or(0.0),
                g.get(2 * a + 1).copied().unwrap_or(0.0),
                g.get(2 * b).copied().unwrap_or(0.0),
                g.get(2 * b + 1).copied().unwrap_or(0.0),
            );
            el.area * (ua * (sp[0] * ub + sp[2] * vb) + va * (sp[2] * ub + sp[1] * vb))
        };
        // `K_ab` from corner a's strain rows `ra`, corner b's `C (∂e/∂x_b)` rows `tb` and
        // its geometric part; `transposed`: `K_abᵀ`, from the transposed outer products
        // (the same products, so the same numbers as transposing `K_ab`, without the shuffles)
        let block = |ra: &[Vec3A; 3], tb: &[Vec3A; 3], geo: f32, transposed: bool| {
            let m = if transposed {
                outer(tb[0], ra[0]) + outer(tb[1], ra[1]) + outer(tb[2], ra[2])
            } else {
                outer(ra[0], tb[0]) + outer(ra[1], tb[1]) + outer(ra[2], tb[2])
            };
            m * el.area + Mat3A::from_diagonal(glam::Vec3::splat(geo))
        };
        let mut add_diag = |i: u32, m: Mat3A| -> Result<(), AssemblyError> {
            *diag
                .get_mut(i as usize)
                .ok_or(AssemblyError::LengthMismatch)? += m;
            Ok(())
        };
        // pair p of (0,1), (0,2), (1,2)
        let mut add_off = |p: usize, ra: &[Vec3A; 3], tb: &[Vec3A; 3], geo: f32| {
            let s = slot.get(p).copied().unwrap_or(0);
            let target = off
                .get_mut((s & !TRANSPOSED) as usize)
                .ok_or(AssemblyError::MissingBlock)?;
            *target += block(ra, tb, geo, s & TRANSPOSED != 0);
            Ok(())
        };
        // Corner by corner, each `C (∂e/∂x_b)` just before the blocks that need it: with all
        // nine made first, 18 vectors were live at once and most of the time went to spills.
        // (Each block of the triangle is a different target, so the order is free.)
        let [r0, r1, r2] = &rows;
        let [i0, i1, i2] = *tri;
        let t0 = c_rows(r0);
        add_diag(i0, block(r0, &t0, geo(0, 0), false))?;
        let t1 = c_rows(r1);
        add_diag(i1, block(r1, &t1, geo(1, 1), false))?;
        add_off(0, r0, &t1, geo(0, 1))?;
        let t2 = c_rows(r2);
        add_diag(i2, block(r2, &t2, geo(2, 2), false))?;
        add_off(1, r0, &t2, geo(0, 2))?;
        add_off(2, r1, &t2, geo(1, 2))?;
    }
    Ok(0.5 * twice_energy)
}

/// The elastic energy `Σ_e ½ A eᵀ C e` (J) of the configuration `x`: what [`assemble`]
/// returns, without assembling (the step's energy balance).
pub fn elastic_energy(
    triangles: &[[u32; 3]],
    elements: &[Element],
    x: &[Vec3A],
    strain: Strain,
) -> Result<f64, AssemblyError> {
    Ok(elastic_energy_with_noise(triangles, elements, x, strain, f32::INFINITY)?.0)
}

/// [`elastic_energy`] and the energy a strain of `f32` round-off carries (J): positions are
/// `f32`, so a triangle's strain is only known to within `δe ≈ 2 ε |x|_∞ Σ|∇N|` (an ulp of
/// its corners' coordinates over its size), and its energy to within `½ A ‖C‖ δe²` even at
/// rest, where the energy itself is that round-off. (The part that grows with the strain,
/// `A σ·δe`, is relative to the energy; the balance bounds it as such.) Without this a cloth
/// at rest, whose energy is 1e-15..1e-12 J of round-off, read every round-off change as a
/// gain and was refused at almost every step.
///
/// `reach` caps the coordinate size the round-off is taken at (`f32::INFINITY`: the
/// positions' own): the energy balance judges a step's end by where a sound step could have
/// put the cloth, not by where an unsound one threw it (`step::monitor::reach_bound`).
pub fn elastic_energy_with_noise(
    triangles: &[[u32; 3]],
    elements: &[Element],
    x: &[Vec3A],
    strain: Strain,
    reach: f32,
) -> Result<(f64, f64), AssemblyError> {
    if elements.len() != triangles.len() {
        return Err(AssemblyError::LengthMismatch);
    }
    let (mut energy, mut noise) = (0.0f64, 0.0f64);
    for (tri, el) in triangles.iter().zip(elements) {
        let xs = corners(tri, x)?;
        let (e, _, _) = el.measure(xs, strain);
        let s = el.stress(e);
        energy += 0.5 * f64::from(el.area * (s[0] * e[0] + s[1] * e[1] + s[2] * e[2]));
        let reach = xs
            .iter()
            .fold(0.0f32, |m, p| m.max(p.abs().max_element()))
            .min(reach);
        let [_, _, g1u, g1v, g2u, g2v] = el.grad;
        let de =
            2.0 * f64::from(f32::EPSILON * reach * (g1u.abs() + g1v.abs() + g2u.abs() + g2v.abs()));
        let [c11, c22, c33, c12, c13, c23] = el.c.map(|c| f64::from(c.abs()));
        noise += 0.5 * f64::from(el.area) * (c11 + c22 + c33 + 2.0 * (c12 + c13 + c23)) * de * de;
    }
    Ok((energy, noise))
}

/// A triangle's corner positions, checked.
#[inline]
fn corners(tri: &[u32; 3], x: &[Vec3A]) -> Result<[Vec3A; 3], AssemblyError> {
    let get = |i: u32| {
        x.get(i as usize)
            .copied()
            .ok_or(AssemblyError::LengthMismatch)
    };
    Ok([get(tri[0])?, get(tri[1])?, get(tri[2])?])
}

/// `a bᵀ`.
#[inline]
fn outer(a: Vec3A, b: Vec3A) -> Mat3A {
    Mat3A::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The tensile part of a membrane stress `[σ11, σ22, σ12]`: its principal values clamped at 0.
fn tension(s: [f32; 3]) -> [f32; 3] {
    let mean = 0.5 * (s[0] + s[1]);
    let half = 0.5 * (s[0] - s[1]);
    let mut radius = libm::sqrtf(half * half + s[2] * s[2]);
    if !radius.is_finite() {
        // the squares overflow f32 (stresses beyond ~1e19 N/m): scaled by the larger one
        let big = half.abs().max(s[2].abs());
        if big.is_finite() {
            let k = 1.0 / big;
            radius = big * libm::sqrtf((half * k) * (half * k) + (s[2] * k) * (s[2] * k));
        }
    }
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

    /// Stresses whose squares overflow `f32` (a 1e30 N/m material compressed, found by the
    /// init property test): the tensile part stays finite. Before, the principal radius was
    /// `+∞`, the tensile part `∞` and the stiffness `∞ − ∞`, so `World::new` refused as
    /// overstretched a cloth whose forces, stiffness and energy all fit `f32`.
    #[test]
    fn tension_of_huge_stresses_is_finite() {
        for s in [
            [1e30f32, -1e30, 5e29],
            [-4e29, 2e29, 0.0],
            [1e38, -1e38, 5e37],
        ] {
            let t = tension(s);
            assert!(t.iter().all(|v| v.is_finite()), "{s:?} -> {t:?}");
            let det = t[0] as f64 * t[1] as f64 - (t[2] as f64).powi(2);
            assert!(t[0] >= 0.0 && t[1] >= 0.0 && det >= -1e-6 * (t[0] as f64).powi(2));
        }
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
        fn assembled(&self, x: &[Vec3A]) -> (Vec<Vec3A>, Vec<Mat3A>, Vec<Mat3A>) {
            let n = x.len();
            let (mut diag, mut off) = (vec![Mat3A::ZERO; n], vec![Mat3A::ZERO; self.off]);
            let mut f = vec![Vec3A::ZERO; n];
            assemble(
                &self.triangles,
                &self.elements,
                &self.slots,
                x,
                Strain::Green,
                &mut diag,
                &mut off,
                &mut f,
            )
            .unwrap();
            (f, diag, off)
        }
        fn forces(&self, x: &[Vec3A]) -> Vec<Vec3A> {
            self.assembled(x).0
        }
        fn energy(&self, x: &[Vec3A]) -> f64 {
            elastic_energy(&self.triangles, &self.elements, x, Strain::Green).unwrap()
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
    fn membrane_force_is_the_energy_gradient_for_any_spd_c() {
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
                        let fd = -(patch.energy(&xp) - patch.energy(&xm)) / f64::from(2.0 * delta);
                        err += (fd - f64::from(f[i][k])).powi(2);
                        norm += fd * fd;
                    }
                }
                let rel = (err / norm).sqrt();
                assert!(
                    rel < 2e-3,
                    "C = {c:?}, trial {trial}: force vs −∂E/∂x off by {rel}"
                );
            }
        }
    }

    #[test]
    fn membrane_forces_do_no_work_round_closed_loops() {
        let mut rng = Lcg(11);
        let uv = [[0.0, 0.0], [0.2, 0.03], [0.05, 0.17]];
        for c in materials(&mut rng) {
            let patch = Patch::new(&uv, &[[0, 1, 2]], &c);
            let q = glam::Quat::from_axis_angle(glam::Vec3::new(0.2, 1.0, -0.4).normalize(), 0.9);
            let x0 = deformed(&patch.rest, q);
            // corner 2 goes round a 1 cm circle in a plane oblique to the triangle
            let (a, b) = (Vec3A::new(0.01, 0.0, 0.004), Vec3A::new(0.0, 0.008, 0.006));
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
    fn membrane_forces_carry_no_net_force_or_torque() {
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
                assert!(
                    net.length() < 1e-5 * fmax * 7.0,
                    "net force {net} (C = {c:?})"
                );
                assert!(
                    torque.length() < 1e-5 * scale,
                    "net torque {torque} of {scale} (C = {c:?})"
                );
            }
        }
    }

    /// In tension the assembled blocks are the exact Hessian, `K = −∂f/∂x` (finite differences
    /// of the force), for anisotropic `C` on turned axes; at rest they are linear FEM's `K_ab`.
    #[test]
    fn membrane_hessian_matches_the_force_derivative_in_tension() {
        let mut rng = Lcg(5);
        let uv = [[0.0, 0.0], [0.2, 0.03], [0.05, 0.17]];
        for c in materials(&mut rng) {
            let patch = Patch::new(&uv, &[[0, 1, 2]], &c);
            // stretched in both directions (all principal stresses tensile), turned in 3D
            let q = glam::Quat::from_axis_angle(glam::Vec3::new(0.4, -0.2, 1.0).normalize(), 0.7);
            let x: Vec<Vec3A> = patch
                .rest
                .iter()
                .map(|p| Vec3A::from(q * glam::Vec3::new(1.2 * p.x + 0.05 * p.y, 1.1 * p.y, 0.0)))
                .collect();
            let (_, diag, off) = patch.assembled(&x);
            let block = |a: usize, b: usize| -> Mat3A {
                match (a, b) {
                    _ if a == b => diag[a],
                    (0, 1) => off[0],
                    (0, 2) => off[1],
                    (1, 2) => off[2],
                    (1, 0) => off[0].transpose(),
                    (2, 0) => off[1].transpose(),
                    _ => off[2].transpose(),
                }
            };
            let delta = 1e-4f32;
            let (mut err, mut norm) = (0.0f64, 0.0f64);
            for b in 0..3 {
                for k in 0..3 {
                    let (mut xp, mut xm) = (x.clone(), x.clone());
                    xp[b][k] += delta;
                    xm[b][k] -= delta;
                    let (fp, fm) = (patch.forces(&xp), patch.forces(&xm));
                    for a in 0..3 {
                        let fd = -(fp[a] - fm[a]) / (2.0 * delta);
                        let want = block(a, b).col(k);
                        err += f64::from((fd - want).length_squared());
                        norm += f64::from(want.length_squared());
                    }
                }
            }
            let rel = (err / norm).sqrt();
            assert!(rel < 5e-3, "C = {c:?}: K vs −∂f/∂x off by {rel}");
            // at rest: the linear FEM stiffness, in the sheet's plane
            let rest = patch.rest.clone();
            let (_, diag, off) = patch.assembled(&rest);
            let e = &patch.elements[0];
            for (m, (a, b)) in [(diag[1], (1, 1)), (off[2], (1, 2))] {
                let k = e.block(a, b);
                let scale = k.iter().flatten().fold(0.0f32, |s, v| s.max(v.abs()));
                for r in 0..2 {
                    for s in 0..2 {
                        assert!((m.col(s)[r] - k[r][s]).abs() <= 1e-5 * scale);
                    }
                    assert!(m.col(2)[r].abs() <= 1e-5 * scale && m.col(r)[2].abs() <= 1e-5 * scale);
                }
            }
        }
    }

    /// The AVX2 build of the assembly (`crate::cpu`) gives the same bits as the baseline one:
    /// forces, blocks and energy, on a fan of anisotropic triangles crumpled at random (some
    /// stretched, some compressed: both sides of the tension clamp).
    #[test]
    fn the_avx2_assembly_is_bit_identical() {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2() {
            let mut rng = Lcg(31);
            let uv = [
                [0.0, 0.0],
                [0.2, 0.03],
                [0.05, 0.17],
                [-0.15, 0.1],
                [-0.1, -0.12],
            ];
            let fan = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
            for c in materials(&mut rng) {
                let patch = Patch::new(&uv, &fan, &c);
                let x: Vec<Vec3A> = patch
                    .rest
                    .iter()
                    .map(|p| {
                        let kick = Vec3A::new(
                            rng.range(-0.08, 0.08) as f32,
                            rng.range(-0.08, 0.08) as f32,
                            rng.range(-0.08, 0.08) as f32,
                        );
                        *p * rng.range(0.7, 1.4) as f32 + kick
                    })
                    .collect();
                let run = |wide: bool| {
                    let n = x.len();
                    let (mut diag, mut off) = (vec![Mat3A::ZERO; n], vec![Mat3A::ZERO; patch.off]);
                    let mut f = vec![Vec3A::ZERO; n];
                    let args = (&patch.triangles, &patch.elements, &patch.slots, &x[..]);
                    let e = if wide {
                        // SAFETY: the processor supports AVX2 (checked above).
                        unsafe {
                            assemble_avx2(
                                args.0,
                                args.1,
                                args.2,
                                args.3,
                                Strain::Green,
                                &mut diag,
                                &mut off,
                                &mut f,
                            )
                        }
                    } else {
                        assemble_body(
                            args.0,
                            args.1,
                            args.2,
                            args.3,
                            Strain::Green,
                            &mut diag,
                            &mut off,
                            &mut f,
                        )
                    }
                    .unwrap();
                    let bits = f
                        .iter()
                        .flat_map(|v| v.to_array())
                        .chain(diag.iter().chain(&off).flat_map(|m| m.to_cols_array()))
                        .map(f32::to_bits)
                        .collect::<Vec<_>>();
                    (e.to_bits(), bits)
                };
                assert_eq!(run(false), run(true));
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
