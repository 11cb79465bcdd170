//! The paper's per-node warping (§5.2, Eq. 17) as a step variant: the constant rest stiffness
//! `K` rotated node by node with the rotations of [`super::rotation`], applied as
//! `R (K (Rᵀ p))` without re-assembly. Research only (see [`super`]).

use glam::{Mat3A, Quat, Vec3, Vec3A};

use super::rotation;
use crate::membrane::AssemblyError;
use crate::normals;
use crate::pcg::{self, Operator};
use crate::sparse::{self, Pattern, Scalars};
use crate::world::error::StepError;
use crate::world::memory::{Arrays, Counts};

/// Vertex normals, then every node's rotation (Eq. 14–16), warm started.
pub(crate) fn update_rotations(a: &mut Arrays<'_>, c: &Counts, iterations: u32) {
    let n = c.n;
    if normals::vertex_normals(
        &a.triangles[..c.nt],
        &a.tri_sign[..c.nt],
        &a.x[..n],
        &mut a.normals[..n],
    )
    .is_err()
    {
        return;
    }
    // A rotation update that refuses its input (inconsistent lengths, which a world never
    // has) leaves the rotations at identity: plain linear FEM rather than stale frames.
    let updated = rotation::update_rotations(
        &a.ring_start[..n + 1],
        &a.ring[..a.ring_start.get(n).map_or(0, |&e| e as usize)],
        &a.mass[..n],
        &a.rest[..n],
        &a.x[..n],
        &a.normals[..n],
        &mut a.rot[..n],
        iterations,
    );
    if updated.is_err() {
        a.rot[..n].fill(Quat::IDENTITY);
    }
}

/// Eq. 17's force on the unrotated `K` (assembled with `warping = false`) into `out`.
pub(crate) fn warped_force(
    a: &mut Arrays<'_>,
    c: &Counts,
    out: &mut [Vec3A],
) -> Result<(), AssemblyError> {
    let n = c.n;
    let pattern = Pattern {
        row_start: &a.row_start[..n + 1],
        cols: &a.cols[..c.nnz],
    };
    node_warped_force(
        &pattern,
        &a.k_off[..c.nnz],
        &a.rot[..n],
        &a.rest[..n],
        &a.x[..n],
        out,
    )
}

/// `rhs = f − c_kv R (K + B Q) Rᵀ v` with Eq. 17's force.
pub(crate) fn elastic_rhs(
    a: &mut Arrays<'_>,
    c: &Counts,
    bending_on: bool,
    c_kv: f32,
) -> Result<(), StepError> {
    let n = c.n;
    let pattern = Pattern {
        row_start: &a.row_start[..n + 1],
        cols: &a.cols[..c.nnz],
    };
    node_warped_force(
        &pattern,
        &a.k_off[..c.nnz],
        &a.rot[..n],
        &a.rest[..n],
        &a.x[..n],
        &mut a.force[..n],
    )
    .map_err(|_| StepError::SolverBreakdown)?;
    a.rhs[..n].copy_from_slice(&a.force[..n]);
    let hinges = crate::step::hinge_scalars(a.hinge_start, a.hinge_cols, a.q_hinge, c, 1.0)?;
    stiffness_apply(
        &pattern,
        &a.k_diag[..n],
        &a.k_off[..c.nnz],
        &a.q_diag[..n],
        &a.q_off[..c.nnz],
        &hinges,
        Some(&a.rot[..n]),
        bending_on,
        &a.v[..n],
        &mut a.force[..n],
        &mut a.w_r[..n],
    );
    for (f, kv) in a.rhs[..n].iter_mut().zip(&a.w_r[..n]) {
        *f -= *kv * c_kv;
    }
    Ok(())
}

/// The solve with the per-node operator and its block-Jacobi preconditioner.
pub(crate) fn solve(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &crate::world::settings::Settings,
    c_m: f32,
    c_k: f32,
    settings: &pcg::Settings,
    constrained: bool,
) -> Result<pcg::Stats, StepError> {
    let n = c.n;
    let bending_on = st.effects & crate::world::settings::effects::BENDING != 0;
    for (i, (p, q)) in a.precond[..n].iter_mut().zip(&a.rot[..n]).enumerate() {
        let r = Mat3A::from_quat(*q);
        let (Some(k), Some(&m), Some(&qd)) = (a.k_diag.get(i), a.mass.get(i), a.q_diag.get(i))
        else {
            return Err(StepError::SolverBreakdown);
        };
        let mut d = r * *k * r.transpose();
        if bending_on {
            d += Mat3A::from_diagonal(Vec3::splat(qd));
        }
        *p = pcg::invert_block(Mat3A::from_diagonal(Vec3::splat(c_m * m)) + d * c_k);
    }
    let pattern = Pattern {
        row_start: &a.row_start[..n + 1],
        cols: &a.cols[..c.nnz],
    };
    let op = SystemOperator {
        pattern: &pattern,
        k_diag: &a.k_diag[..n],
        k_off: &a.k_off[..c.nnz],
        q_diag: &a.q_diag[..n],
        q_off: &a.q_off[..c.nnz],
        hinges: crate::step::hinge_scalars(a.hinge_start, a.hinge_cols, a.q_hinge, c, 1.0)?,
        rot: Some(&a.rot[..n]),
        mass: &a.mass[..n],
        bending: bending_on,
        c_m,
        c_k,
        tmp: core::cell::RefCell::new(&mut a.force[..n]),
    };
    let work = pcg::Work {
        r: &mut a.w_r[..n],
        c: &mut a.w_c[..n],
        q: &mut a.w_q[..n],
        s: &mut a.w_s[..n],
        p: &mut a.w_p[..n],
    };
    let filter = if constrained {
        Some(&a.filter[..n])
    } else {
        None
    };
    let dv = &mut a.dv[..n];
    let stats = pcg::solve(
        &op,
        &a.precond[..n],
        filter,
        &a.rhs[..n],
        dv,
        settings,
        work,
    )
    .map_err(|_| StepError::SolverBreakdown)?;
    if constrained {
        op.apply(dv, &mut a.w_q[..n]);
    }
    Ok(stats)
}

/// `y = K_w x (+ B Q x)`: the assembled corotated stiffness, or for per-node warping
/// `R K Rᵀ x` on the unrotated K (symmetric, so CG applies); `tmp` holds `Rᵀ x`.
#[allow(clippy::too_many_arguments)]
fn stiffness_apply(
    p: &Pattern<'_>,
    k_diag: &[Mat3A],
    k_off: &[Mat3A],
    q_diag: &[f32],
    q_off: &[f32],
    hinges: &Scalars<'_>,
    rot: Option<&[Quat]>,
    bending: bool,
    x: &[Vec3A],
    tmp: &mut [Vec3A],
    y: &mut [Vec3A],
) {
    if let Some(rot) = rot {
        for ((t, &xi), r) in tmp.iter_mut().zip(x).zip(rot) {
            *t = r.inverse() * xi;
        }
        if sparse::mul(k_diag, p, k_off, tmp, y).is_err() {
            y.fill(Vec3A::NAN);
        }
        for (yi, r) in y.iter_mut().zip(rot) {
            *yi = *r * *yi;
        }
    } else if sparse::mul(k_diag, p, k_off, x, y).is_err() {
        y.fill(Vec3A::NAN);
    }
    if bending
        && (sparse::mul_scalar_add(q_diag, p, q_off, 1.0, x, y).is_err()
            || hinges.mul_add(x, y).is_err())
    {
        y.fill(Vec3A::NAN);
    }
}

/// `A p = c_m M p + c_k K_w p`, the matrix of the linearized implicit Euler step.
struct SystemOperator<'s, 't> {
    pattern: &'s Pattern<'s>,
    k_diag: &'s [Mat3A],
    k_off: &'s [Mat3A],
    q_diag: &'s [f32],
    q_off: &'s [f32],
    hinges: Scalars<'s>,
    rot: Option<&'s [Quat]>,
    mass: &'s [f32],
    bending: bool,
    c_m: f32,
    c_k: f32,
    tmp: core::cell::RefCell<&'t mut [Vec3A]>,
}

impl Operator for SystemOperator<'_, '_> {
    fn apply(&self, x: &[Vec3A], y: &mut [Vec3A]) {
        let Ok(mut tmp) = self.tmp.try_borrow_mut() else {
            return;
        };
        stiffness_apply(
            self.pattern,
            self.k_diag,
            self.k_off,
            self.q_diag,
            self.q_off,
            &self.hinges,
            self.rot,
            self.bending,
            x,
            &mut tmp,
            y,
        );
        for ((yi, &xi), &m) in y.iter_mut().zip(x).zip(self.mass) {
            *yi = *yi * self.c_k + xi * (self.c_m * m);
        }
    }
}
/// The paper's per-node warped force (Eq. 17), `f_i = -R_i Σ_j K_ij (R_iᵀ x_j − x0_j)`, on the
/// unrotated assembled `K` (only its off-diagonal blocks are needed: rows of `K` sum to zero,
/// so the sum is taken over edge vectors `x_j − x_i`, which also keeps f32 cancellation small).
/// Overwrites `force`.
pub fn node_warped_force(
    p: &Pattern<'_>,
    k_off: &[Mat3A],
    rot: &[Quat],
    rest: &[Vec3A],
    x: &[Vec3A],
    force: &mut [Vec3A],
) -> Result<(), AssemblyError> {
    let n = x.len();
    if rot.len() != n || rest.len() != n || force.len() != n || p.n() != n || k_off.len() < p.nnz()
    {
        return Err(AssemblyError::LengthMismatch);
    }
    force.fill(Vec3A::ZERO);
    for i in 0..n {
        let Some(range) = p.row_range(i) else {
            return Err(AssemblyError::LengthMismatch);
        };
        let (ri_t, xi, x0i) = (rot[i].inverse(), x[i], rest[i]);
        for k in range {
            let (Some(&j), Some(&kij)) = (p.cols.get(k), k_off.get(k)) else {
                return Err(AssemblyError::LengthMismatch);
            };
            let j = j as usize;
            let (xj, x0j) = (x[j], rest[j]);
            // block (i, j) acts in node i's frame, its transpose (j, i) in node j's
            force[i] += kij * (ri_t * (xj - xi) - (x0j - x0i));
            force[j] += kij.transpose() * (rot[j].inverse() * (xi - xj) - (x0i - x0j));
        }
    }
    for (f, r) in force.iter_mut().zip(rot) {
        *f = -(*r * *f);
    }
    Ok(())
}
