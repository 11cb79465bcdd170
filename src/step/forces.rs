//! Stage 1 of a substep: the forces and the right-hand side of the linearized implicit Euler
//! system (Baraff & Witkin 1998, Eq. 18 discretized):
//!
//! ```text
//!     [(1 + hα) M + (hβ + h²) K_w] Δv = h (f − (β + h) K_w v)
//! ```
//!
//! with `f` the membrane force (`membrane.rs`), hinge bending `−B Q x`
//! (`bending.rs`), gravity, the forces the engine applied, wind and Rayleigh damping
//! `D = αM + βK_w`. The membrane Jacobian
//! `K_w` is assembled into the world's 3×3 blocks here; [`super::system`] folds mass, bending
//! and drag into them.

use glam::Vec3A;

use super::{hinge_pattern, hinge_scalars, live, live_mut, pattern};
use crate::bending;
use crate::membrane;
use crate::normals;
use crate::sparse;
use crate::world::error::StepError;
use crate::world::memory::{Arrays, Counts};
use crate::world::settings::{effects, Settings};

/// Fills `a.rhs` with `h (f − (β + h) K_w v)`, `a.force` with the elastic force and
/// `a.k_diag`/`a.k_off` with the membrane Jacobian `K_w`. Returns the elastic energy (J) of
/// the current positions, which the assembly computes anyway.
pub(crate) fn accumulate(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    h: f32,
) -> Result<f64, StepError> {
    let n = c.n;
    let eff = st.effects;
    let per_node = per_node_warping(st);
    let bending_on = eff & effects::BENDING != 0;
    let (alpha, beta) = if eff & effects::DAMPING != 0 {
        (st.damping_mass, st.damping_stiffness)
    } else {
        (0.0, 0.0)
    };
    if per_node {
        #[cfg(feature = "research")]
        crate::research::per_node::update_rotations(a, c, st.rotation_iterations);
    } else if eff & effects::WIND != 0 {
        // The wind's direction.
        normals::vertex_normals(
            live(a.triangles, c.nt)?,
            live(a.tri_sign, c.nt)?,
            live(a.x, n)?,
            live_mut(a.normals, n)?,
        )
        .map_err(|_| StepError::SolverBreakdown)?;
    }
    // Membrane: Green strain (or plain linear FEM; or, for per-node warping, the unrotated
    // K that Eq. 17 rotates node by node).
    let elastic = membrane::assemble(
        live(a.triangles, c.nt)?,
        live(a.elements, c.nt)?,
        live(a.slots, c.nt)?,
        live(a.x, n)?,
        assembly_strain(st),
        live_mut(a.k_diag, n)?,
        live_mut(a.k_off, c.nnz)?,
        live_mut(a.force, n)?,
    )
    .map_err(|_| StepError::SolverBreakdown)?;
    // Implicit and Rayleigh terms: rhs = f − (β + h) K_w v  (K_w = R K Rᵀ + B Q).
    let c_kv = beta + h;
    if per_node {
        #[cfg(feature = "research")]
        crate::research::per_node::elastic_rhs(a, c, bending_on, c_kv)?;
    } else {
        elastic_rhs(a, c, bending_on, c_kv)?;
    }
    let pattern = pattern(a.row_start, a.cols, c)?;
    let hinges = hinge_pattern(a.hinge_start, a.hinge_cols, c)?;
    let (x, v) = (live(a.x, n)?, live(a.v, n)?);
    let rhs = live_mut(a.rhs, n)?;
    if bending_on {
        // Bending force −B Q x (Q annihilates the flat rest shape, so no rest term), on the
        // edges and on the hinge-only pairs.
        let (q_off, q_hinge) = (live(a.q_off, c.nnz)?, live(a.q_hinge, c.nnz_h)?);
        bending::add_forces(&pattern, q_off, x, rhs)
            .and_then(|()| bending::add_forces(&hinges, q_hinge, x, rhs))
            .map_err(|_| StepError::SolverBreakdown)?;
    }
    let gravity = Vec3A::from(st.gravity);
    let gravity_on = eff & effects::GRAVITY != 0;
    let wind_on = wind_blows(st);
    let wind = Vec3A::from(st.wind);
    for ((((r, &m), vi), (nrm, &area)), applied) in rhs
        .iter_mut()
        .zip(live(a.mass, n)?)
        .zip(v)
        .zip(live(a.normals, n)?.iter().zip(live(a.area, n)?))
        .zip(live(a.applied_force, n)?)
    {
        // the engine's forces for this step (zero unless it applied some)
        let mut f = *r + Vec3A::from(*applied);
        if gravity_on {
            f += gravity * m;
        }
        if alpha > 0.0 {
            f -= *vi * (alpha * m);
        }
        if wind_on {
            // Drag on the velocity relative to the air, along the normal; its velocity
            // derivative −drag·area·n nᵀ is in the system matrix (implicit, any drag is stable).
            f += *nrm * (st.drag * area * (wind - *vi).dot(*nrm));
        }
        *r = f * h;
    }
    Ok(elastic)
}

/// The strain measure the step's membrane assembly uses under `st`: Green when the scene warps
/// per element; linear FEM without warping, and for per-node warping, whose Eq. 17 rotates
/// the unrotated linear `K` node by node.
pub(crate) fn assembly_strain(st: &Settings) -> membrane::Strain {
    membrane_strain(st.effects & effects::WARPING != 0 && !per_node_warping(st))
}

/// Whether the step warps with the paper's per-node rotations (Eq. 14–17, feature
/// `research`): the scene warps and asks for it.
pub(crate) fn per_node_warping(st: &Settings) -> bool {
    st.effects & effects::WARPING != 0 && st.per_node_warping
}

/// The membrane's strain measure: Green (rotation invariant) when the scene warps, linear FEM
/// otherwise.
pub(crate) fn membrane_strain(warping: bool) -> membrane::Strain {
    if warping {
        membrane::Strain::Green
    } else {
        membrane::Strain::Linear
    }
}

/// `rhs = f − c_kv (K_w + B Q) v` with the element-assembled `K_w` (`w_r` holds the product).
fn elastic_rhs(
    a: &mut Arrays<'_>,
    c: &Counts,
    bending_on: bool,
    c_kv: f32,
) -> Result<(), StepError> {
    let n = c.n;
    let pattern = pattern(a.row_start, a.cols, c)?;
    let k = sparse::BlockMatrix {
        diag: live(a.k_diag, n)?,
        pattern,
        off: live(a.k_off, c.nnz)?,
        scalars: hinge_scalars(
            a.hinge_start,
            a.hinge_cols,
            a.q_hinge,
            c,
            if bending_on { 1.0 } else { 0.0 },
        )?,
    };
    let (v, kv) = (live(a.v, n)?, live_mut(a.w_r, n)?);
    // From velocity differences: a cloth moving as a whole feels no elastic force from the
    // f32 cancellation of `K_ii v_i + Σ_j K_ij v_j` (sparse module docs).
    k.mul_stiffness(v, kv)
        .map_err(|_| StepError::SolverBreakdown)?;
    if bending_on {
        let edges = sparse::Scalars {
            pattern,
            off: live(a.q_off, c.nnz)?,
            scale: 1.0,
        };
        // `+ Q v`: the hinge couplings were in the product, these share the blocks' pattern
        edges
            .add_differences(v, kv)
            .map_err(|_| StepError::SolverBreakdown)?;
    }
    for ((r, f), kv) in live_mut(a.rhs, n)?
        .iter_mut()
        .zip(live(a.force, n)?)
        .zip(kv.iter())
    {
        *r = *f - *kv * c_kv;
    }
    Ok(())
}

/// The work (J) the moving air does on the cloth in a substep of length `h` ending with
/// velocities `a.v`: the wind-driven part `drag·area·(w·n) n` of the drag force. The rest of
/// the drag, `−drag·area·(v·n) n`, only dissipates.
pub(crate) fn wind_work(
    a: &Arrays<'_>,
    c: &Counts,
    st: &Settings,
    h: f32,
) -> Result<f64, StepError> {
    if !wind_blows(st) {
        return Ok(0.0);
    }
    let n = c.n;
    let mut work = 0.0f64;
    for ((nrm, &area), vi) in live(a.normals, n)?
        .iter()
        .zip(live(a.area, n)?)
        .zip(live(a.v, n)?)
    {
        work += vertex_wind_work(st, h, *nrm, area, *vi);
    }
    Ok(work)
}

/// [`wind_work`]'s share of one vertex (normal `nrm`, lumped area `area`, end velocity `v`);
/// the caller checks that the wind is on.
#[inline]
pub(crate) fn vertex_wind_work(st: &Settings, h: f32, nrm: Vec3A, area: f32, v: Vec3A) -> f64 {
    let wind = Vec3A::from(st.wind);
    f64::from(st.drag * area * wind.dot(nrm) * nrm.dot(v) * h)
}

/// Whether the air does work on the cloth ([`wind_work`] is not zero).
pub(crate) fn wind_blows(st: &Settings) -> bool {
    st.effects & effects::WIND != 0 && st.drag > 0.0
}
