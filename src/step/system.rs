//! Stage 3 of a substep: the system `A = (1 + hα) M + (hβ + h²)(K_w + B Q) + h D_air`
//! (`D_air = Σ drag·area·n nᵀ`, the implicit air drag), its preconditioner, and the filtered
//! PCG solve of `A Δv = rhs` (Baraff & Witkin §5.3, `pcg.rs`), preconditioned by the multilevel
//! K-cycle of `multigrid/` (the default) or by block Jacobi.
//!
//! `K_w` was assembled this substep anyway (`forces.rs`): mass, bending and drag are folded
//! into the same 3×3 blocks, so a CG iteration is one block-sparse product.

use glam::{DVec3, Mat3A, Vec3, Vec3A};

use super::{hinge_scalars, live, live_mut, pattern};
use crate::multigrid;
use crate::pcg;
use crate::sparse;
use crate::world::error::StepError;
use crate::world::memory::{Arrays, Counts};
use crate::world::settings::{effects, Settings, Solver};

/// Absolute floor of the step's CG (`pcg::Settings::floor`) as a velocity: the solve stops
/// once the remaining error of `Δv` is below this RMS velocity (m/s) in the energy norm, so a
/// cloth at rest (right-hand side = round-off) costs no iterations.
const FLOOR_VELOCITY: f64 = 1e-6;

/// `c_m` and `c_k` of the system: `A = c_m M + c_k (K_w + B Q) + …` (Rayleigh damping in both).
fn coefficients(st: &Settings, h: f32) -> (f32, f32) {
    let (alpha, beta) = if st.effects & effects::DAMPING != 0 {
        (st.damping_mass, st.damping_stiffness)
    } else {
        (0.0, 0.0)
    };
    (1.0 + h * alpha, h * beta + h * h)
}

/// Folds mass, bending and drag into the blocks the forces stage assembled (`K_w`), in place:
/// `a.k_diag` and `a.k_off` become `A` (the hinge-only bending couplings, which have no
/// blocks, are scaled in [`solve`]'s operator). Once per substep, before the first [`solve`].
pub(crate) fn fold(a: &mut Arrays<'_>, c: &Counts, st: &Settings, h: f32) -> Result<(), StepError> {
    let n = c.n;
    let eff = st.effects;
    #[cfg(feature = "research")]
    if super::forces::per_node_warping(st) {
        return Ok(()); // the research solver assembles its own system
    }
    let (c_m, c_k) = coefficients(st, h);
    let bending_on = eff & effects::BENDING != 0;
    let drag = if eff & effects::WIND != 0 {
        st.drag
    } else {
        0.0
    };
    for (k, q) in live_mut(a.k_off, c.nnz)?
        .iter_mut()
        .zip(live(a.q_off, c.nnz)?)
    {
        let b = if bending_on { *q } else { 0.0 };
        *k = (*k + Mat3A::from_diagonal(Vec3::splat(b))) * c_k;
    }
    for (((d, &m), &q), (nrm, &area)) in live_mut(a.k_diag, n)?
        .iter_mut()
        .zip(live(a.mass, n)?)
        .zip(live(a.q_diag, n)?)
        .zip(live(a.normals, n)?.iter().zip(live(a.area, n)?))
    {
        let b = if bending_on { q } else { 0.0 };
        *d = *d * c_k + Mat3A::from_diagonal(Vec3::splat(b * c_k + c_m * m));
        if drag > 0.0 {
            *d += outer(*nrm, *nrm) * (h * drag * area);
        }
    }
    Ok(())
}

/// A solve that goes on from an earlier one of the same system after contacts were let go
/// or engaged (`contacts::release`, `contacts::engage`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Resume {
    /// The earlier solve's reference `δ₀` (the same right-hand side, so the same scale for
    /// "small": it saves a cycle).
    pub reference: f64,
    /// How many vertices were let go or newly held; their indices are the first `u32`s of
    /// `a.w_s`, which `contacts::release` and `contacts::engage` wrote there.
    pub changed: usize,
    /// The earlier solve left its multilevel operators in the lent pools (it did not fall
    /// back to block Jacobi), so only what the listed vertices touch is set up again.
    pub operators_kept: bool,
    /// `a.w_q` still holds `A Δv` of the current `Δv` (the earlier solve left it, and only the
    /// filter changed since): the solve's start needs no product
    /// ([`pcg::Settings::product_given`]).
    pub product_kept: bool,
}

/// What [`solve`] did.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solved {
    pub stats: pcg::Stats,
    /// Its multilevel operators are in the lent pools (see [`Resume::operators_kept`]).
    pub operators_kept: bool,
}

/// The system [`fold`] made, `A`, as a [`sparse::BlockMatrix`] over the arrays `$a` (a macro,
/// not a function, so that it borrows only the fields it reads and the caller may write the
/// others). The hinge-only bending couplings were not folded (they have no blocks): `c_k`
/// scales them in the product.
macro_rules! operator {
    ($a:expr, $c:expr, $st:expr, $h:expr) => {{
        let c_k = if $st.effects & effects::BENDING != 0 {
            coefficients($st, $h).1
        } else {
            0.0
        };
        sparse::BlockMatrix {
            diag: live($a.k_diag, $c.n)?,
            pattern: pattern($a.row_start, $a.cols, $c)?,
            off: live($a.k_off, $c.nnz)?,
            scalars: hinge_scalars($a.hinge_start, $a.hinge_cols, $a.q_hinge, $c, c_k)?,
        }
    }};
}

/// The PCG's work vectors over the arrays `$a` (a macro, as [`operator!`], so that it borrows
/// only the fields it lends).
macro_rules! work {
    ($a:expr, $n:expr) => {
        pcg::Work {
            r: live_mut($a.w_r, $n)?,
            c: live_mut($a.w_c, $n)?,
            q: live_mut($a.w_q, $n)?,
            s: live_mut($a.w_s, $n)?,
            p: live_mut($a.w_p, $n)?,
        }
    };
}

/// Solves `A Δv = rhs` for `a.dv` (the system [`fold`] made), starting from the current `a.dv`.
/// With constraints (`constrained`), `a.w_q` holds `A Δv` on return, so that `A Δv − rhs` is
/// the impulse the pins and contacts supplied (their work enters the step's energy balance,
/// and a contact that pulls is let go, `contacts::release`). `resume`: the earlier solve this
/// one goes on from, or `None` for a substep's first solve.
pub(crate) fn solve(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    h: f32,
    constrained: bool,
    resume: Option<Resume>,
) -> Result<Solved, StepError> {
    let reference = resume.map_or(0.0, |r| r.reference);
    let n = c.n;
    let settings = pcg::Settings {
        tolerance: st.tolerance,
        max_iterations: st.max_iterations,
        floor: (c.total_mass * FLOOR_VELOCITY * FLOOR_VELOCITY) as f32,
        reference,
        product_given: resume.is_some_and(|r| r.product_kept),
    };
    #[cfg(feature = "research")]
    if super::forces::per_node_warping(st) {
        let (c_m, c_k) = coefficients(st, h);
        let stats = crate::research::per_node::solve(a, c, st, c_m, c_k, &settings, constrained)?;
        return Ok(Solved {
            stats,
            operators_kept: false,
        });
    }
    let op = operator!(a, c, st, h);
    let filter = if constrained {
        Some(live(a.filter, n)?)
    } else {
        None
    };
    let dv = live_mut(a.dv, n)?;
    let rhs = live(a.rhs, n)?;
    let mut result = Err(pcg::PcgError::Breakdown);
    // Whether the multilevel operators in the pools are those the solver's own smoother makes
    // (see below).
    let mut own_operators = true;
    if c.solver.is_multilevel() {
        // The line smoother's `T` need not dominate `A` everywhere (it is checked only where
        // a line is made, not against the couplings it leaves out), and where it does not the
        // cycle is not positive and the CG breaks down (adversarial scene 12033, a stiff cloth
        // driven hard: 25 failed steps, none since). A solve with lines that breaks down is
        // tried again with block-Jacobi smoothing, from its last good iterate, before
        // block-Jacobi PCG; its product of the start is not trusted (the first attempt used
        // `q` as scratch).
        let smoothers: &[multigrid::Smoother] = if c.solver == Solver::MultigridLines {
            &[multigrid::Smoother::Lines, multigrid::Smoother::Jacobi]
        } else {
            &[multigrid::Smoother::Jacobi]
        };
        for (attempt, &smoother) in smoothers.iter().enumerate() {
            // Lent for the solve: the block-Jacobi array and the force vector (read into rhs
            // by the forces stage): the coarsest factor first, the levels' vectors after it (a
            // mesh whose levels do not fit steps with block Jacobi).
            let (dense, vectors) = a
                .force
                .split_at_mut(dense_vectors(n, c.nnz).min(a.force.len()));
            let mem = multigrid::Memory {
                agg: live(a.scratch_b, n)?,
                index: a.scratch_a,
                blocks: bytemuck::cast_slice_mut(&mut *a.precond),
                dense: bytemuck::cast_slice_mut(dense),
                vectors,
            };
            let options = multigrid::Options {
                smoother,
                ..multigrid::Options::default()
            };
            let built = match resume {
                Some(r) if r.operators_kept && attempt == 0 => {
                    let listed: &[u32] = bytemuck::cast_slice(live(a.w_s, n)?);
                    let changed = listed.get(..r.changed).ok_or(StepError::SolverBreakdown)?;
                    multigrid::Multigrid::renew(mem, op, filter, changed, options)
                }
                // The line smoother is probed for positivity at each full setup (its power
                // iterate kept in `line_probe`, `w_r` free until the solve).
                _ if smoother == multigrid::Smoother::Lines => {
                    let probe = multigrid::Probe {
                        x: live_mut(a.line_probe, n)?,
                        t: live_mut(a.w_r, n)?,
                    };
                    multigrid::Multigrid::new_probed(mem, op, filter, options, Some(probe))
                }
                _ => multigrid::Multigrid::new(mem, op, filter, options),
            };
            if let Ok(mut mg) = built {
                let work = work!(a, n);
                let settings = pcg::Settings {
                    product_given: settings.product_given && attempt == 0,
                    ..settings
                };
                result = pcg::solve_with(&op, &mut mg, filter, rhs, dv, &settings, work);
            }
            own_operators = attempt == 0;
            if result.is_ok() {
                break;
            }
        }
    }
    // (a re-solve renews the operators of its own smoother only)
    let operators_kept = result.is_ok() && own_operators;
    // The residual's energy `δ` at the end of the solve (in its preconditioner's norm).
    let settled = |stats: &pcg::Stats| {
        let residual = f64::from(stats.residual);
        residual * residual * stats.reference <= f64::from(settings.floor)
    };
    let (stats, settled) = match result {
        Ok(stats) => (stats, settled(&stats)),
        Err(_) => {
            // Block Jacobi: the design's named solver, and the fallback should the multilevel
            // cycle ever break down (not positive); it restarts from the partial iterate,
            // whose constrained components the solve has kept.
            for (p, d) in live_mut(a.precond, n)?.iter_mut().zip(op.diag) {
                *p = pcg::invert_block(*d);
            }
            let work = work!(a, n);
            // Its reference is its own (another preconditioner, another norm), and so is
            // the next solve's. `A Δv` is still in `w_q` unless a multilevel solve ran and
            // broke down (its scratch).
            let own = pcg::Settings {
                reference: 0.0,
                product_given: settings.product_given && !c.solver.is_multilevel(),
                ..settings
            };
            let stats = pcg::solve(&op, live(a.precond, n)?, filter, rhs, dv, &own, work)
                .map_err(|_| StepError::SolverBreakdown)?;
            let own_settled = settled(&stats);
            let stats = pcg::Stats {
                reference: 0.0,
                ..stats
            };
            (stats, own_settled)
        }
    };
    // The contact impulses need `A Δv` (in `w_q`); a converged solve left it there.
    if constrained && !stats.product_kept {
        op.mul(dv, live_mut(a.w_q, n)?)
            .map_err(|_| StepError::SolverBreakdown)?;
    }
    // A solve whose whole residual is below the floor has no rigid-motion error worth the
    // products (a cloth at rest costs what it did).
    if !constrained && !settled {
        let scratch = [live_mut(a.w_r, n)?, live_mut(a.w_c, n)?];
        let kept = stats.product_kept;
        correct_rigid(
            &op,
            rhs,
            live(a.x, n)?,
            dv,
            kept,
            live_mut(a.w_q, n)?,
            scratch,
        )?;
    }
    Ok(Solved {
        stats,
        operators_kept,
    })
}

/// Halvings of the free velocity [`limit`] tries before it stops the free part.
const LIMIT_HALVINGS: u32 = 6;

/// The energy-limited end of a substep, for the last attempt at a step whose every attempt
/// gained energy (`World::step_dt`): the end velocity `u = v + Δv`, split into the part its
/// pins prescribe, `p = (I − F) u` (`F`: a pinned vertex's free directions; `p = 0` at every
/// other vertex), and the rest `f = u − p`, becomes `p + β f` with the first `β` of `1, ½, ¼,
/// …, 1/64` whose end state holds no more energy than the substep's start,
///
/// ```text
///     ½ |p + β f|²_M + P(Π(x + h (p + β f))) − W(p + β f)  ≤  ½ |v|²_M + P(x)
/// ```
///
/// (`P`: elastic, bending, and the potential of gravity and the applied forces; `Π`: the substep's
/// projection out of the still colliders, [`super::contacts::place_outside_still`]; `W`: the wind's
/// work), or `β = 0`, where only the pins move. Why: the linearized implicit step is one Newton
/// step, and on a non-convex energy (a membrane squeezed around a pin inside a collider, Green
/// strains of 2–3) it can overshoot at every substep count, from rest too: the balance then held
/// the cloth still at every step, each costing every redo, while it crept toward rest (a stiff
/// strip pinned 2 cm inside a sphere: 38 steps in a row, `tests/hard_cases.rs`). The Newton
/// direction descends the substep's incremental potential, which from rest is this energy, so a
/// fraction of it goes on downhill; `β = 0` balances wherever the pins stand still. The contacts'
/// prescribed velocities are scaled with the rest: they were set for the whole `Δv` (a vertex the
/// solve carries toward a surface is drawn onto it), and kept alone they moved the held vertices
/// against their still neighbours (that strip: +4.5e-4 J at `β = 0`); scaled, a vertex still
/// approaches a still surface no further than its contact allows. The wind's work on the end
/// velocity (what the step counts as the wind's input) is credited to the end: without it a limited
/// substep in a wind was slowed below what the wind gave it. The projection is weighed because it
/// is part of the end: where the membrane's pull carries free vertices deep into a still collider
/// within the substep, the end before it has relaxed and the projection puts the stretch back, and
/// more (adversarial scene 8067, a 2.6 m cloth hanging through a 1.3 m sphere inside a shell:
/// vertices carried up to 10 cm in within 0.7 ms, every limited attempt ended above its start, and
/// the cloth was held still at 189 of its 193 steps). The projection also takes the velocity into
/// the surface away, which `½ |p + β f|²_M` keeps: the end weighed is never below the one the
/// substep ends with. Damping and the drag's own part are left out (they only lower the end).
/// Leaves `Δv = p + β f − v` and, with constraints, `a.w_q = A Δv`; returns the energy the scaling
/// took out (J). `a.w_c` and `a.w_p` (free between the solve and the projection) hold `x` and `f`.
pub(crate) fn limit(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: super::Substep,
    constrained: bool,
) -> Result<f64, StepError> {
    let (n, h) = (c.n, sub.h);
    let start = super::monitor::kinetic(live(a.mass, n)?, live(a.v, n)?)
        + super::monitor::loaded_potential(a, c, st)?;
    {
        let (x, v, dv) = (live(a.x, n)?, live(a.v, n)?, live(a.dv, n)?);
        let (x_n, free) = (live_mut(a.w_c, n)?, live_mut(a.w_p, n)?);
        x_n.copy_from_slice(x);
        let pins = super::contacts::pins_on(c, st);
        let (filter, pin_of) = (live(a.filter, n)?, live(a.pin_of, n)?);
        let vertices = free
            .iter_mut()
            .zip(v.iter().zip(dv))
            .zip(filter.iter().zip(pin_of));
        for ((f, (&v, &d)), (&s, &pin)) in vertices {
            // a pin's filter is its free directions (pins override contacts)
            *f = if pins && pin != crate::mesh::NONE {
                s * (v + d)
            } else {
                v + d
            };
        }
    }
    // The end energy with the free part scaled by `beta`, less the wind's work on the end
    // velocity (`forces::wind_work`'s, which the step counts as input); leaves `x` there.
    let wind = super::forces::wind_blows(st);
    let end = |a: &mut Arrays<'_>, beta: f32| -> Result<f64, StepError> {
        let (mut kinetic, mut work) = (0.0f64, 0.0f64);
        let moved = live_mut(a.x, n)?
            .iter_mut()
            .zip(live(a.w_c, n)?.iter().zip(live(a.w_p, n)?))
            .zip(
                live(a.v, n)?
                    .iter()
                    .zip(live(a.dv, n)?)
                    .zip(live(a.mass, n)?),
            )
            .zip(live(a.normals, n)?.iter().zip(live(a.area, n)?));
        for (((x, (&x_n, &f)), ((&v, &d), &m)), (&nrm, &area)) in moved {
            let u = v + d - f + f * beta;
            *x = x_n + u * h;
            kinetic += 0.5 * f64::from(m) * f64::from(u.length_squared());
            if wind {
                work += super::forces::vertex_wind_work(st, h, nrm, area, u);
            }
        }
        // where the substep's projection will put them (see the doc above)
        super::contacts::place_outside_still(a, c, st, sub)?;
        Ok(kinetic - work + super::monitor::loaded_potential(a, c, st)?)
    };
    let full = end(a, 1.0)?;
    let mut beta = 1.0f32;
    let mut kept = full;
    // (an end that overflowed to NaN, as a diverged solve's `Δv` on one vertex makes its kinetic
    // and elastic energy overflow, is scaled like one above the start: compared as
    // `full > start` it went through whole)
    if full.is_nan() || full > start {
        beta = 0.0;
        let mut tried = 1.0f32;
        for _ in 0..LIMIT_HALVINGS {
            tried *= 0.5;
            let e = end(a, tried)?;
            if e <= start {
                (beta, kept) = (tried, e);
                break;
            }
        }
        if beta == 0.0 {
            kept = end(a, 0.0)?;
        }
    }
    live_mut(a.x, n)?.copy_from_slice(live(a.w_c, n)?);
    if beta != 1.0 {
        for (d, &f) in live_mut(a.dv, n)?.iter_mut().zip(live(a.w_p, n)?) {
            *d = *d - f + f * beta;
        }
        if constrained {
            operator!(a, c, st, h)
                .mul(live(a.dv, n)?, live_mut(a.w_q, n)?)
                .map_err(|_| StepError::SolverBreakdown)?;
        }
    }
    // An end whose energy overflowed (a diverged solve's `Δv`) is no measure of what the
    // scaling took: counted from the start instead, what `removed` reports stays finite.
    let from = if full.is_finite() { full } else { start };
    Ok((from - kept).max(0.0))
}

/// The Galerkin correction of an unconstrained solve's `Δv` on the six rigid modes `W`, the
/// translations and the rotations about the vertices' centroid `c`: `Δv_i += t + ω × (x_i − c)`
/// with `(Wᵀ A W) (t, ω) = Wᵀ (rhs − A Δv)`, the rigid motion that brings `Δv` closest to the
/// exact solution in the `A`-norm (so never farther), and leaves a residual with no net force
/// and no net torque about `c`.
///
/// Why: with nothing holding the cloth, `K` (elastic, bending, damping) annihilates the
/// translations, so the exact step changes the momentum by the external impulse alone. A CG
/// stopped at its tolerance leaves an error of that relative size in every mode, the rigid
/// ones included, and nothing but air damping takes it out again: a free anisotropic cloth
/// tumbling with no external force drifted 1.1e-3 of its momentum in 200 steps at the default
/// tolerance, 4e-3 at 1e-2 (`tests/world.rs`); corrected on the translations, 1e-6 to 4e-6,
/// either preconditioner, tolerance 1e-3 to 1e-1. The rotations are corrected too because
/// their error is what a loose tolerance leaves in a free cloth: at 1e-2, without them, a
/// free crumpled cloth still spun after 10 s (9.5e-6 J, 1.7e-3 of its peak) and a cloth
/// coasting 2 km drifted apart at 5.1e-3 m/s (1.5e-3 at 1e-3); with them both rest (the tests
/// `a_free_cloth_rests_at_a_loose_tolerance` and
/// `a_cloth_that_travels_far_at_a_loose_tolerance_stays_whole`).
/// `K` annihilates a rotation only where the cloth is unstressed, so the linearized step still
/// loses angular momentum of its own (README, Limits); this removes only the solve's share.
///
/// Cost: one pass over the blocks (`Tᵀ A T = Σ_ij A_ij`), three products (`A` times each
/// rotation field, built in `scratch[0]`, into `scratch[1]`) and, where the solve did not keep
/// `A Δv` (`kept`: `adv` holds it), one product into `adv`; a 6×6 Cholesky in `f64`, the
/// coarsest multigrid level's (`multigrid::factor_packed`), which leaves a rotation that is no
/// motion (all the vertices on its axis) uncorrected. [`solve`] skips it where the solve's
/// whole residual is below its absolute floor: a cloth at rest, whose right-hand side is
/// round-off, stays exactly at rest (as the CG's floor keeps it). Skipping every correction
/// whose own energy was below the floor instead let the drift build up to 1.5e-5 of the scale
/// in those 200 steps (block Jacobi at 1e-3; 4e-6 with the solve's residual as the gate).
fn correct_rigid(
    op: &sparse::BlockMatrix<'_>,
    rhs: &[Vec3A],
    x: &[Vec3A],
    dv: &mut [Vec3A],
    kept: bool,
    adv: &mut [Vec3A],
    scratch: [&mut [Vec3A]; 2],
) -> Result<(), StepError> {
    let breakdown = |_| StepError::SolverBreakdown;
    let [field, image] = scratch;
    if !kept {
        op.mul(dv, adv).map_err(breakdown)?;
    }
    let n = x.len().max(1) as f64;
    let centre = (x.iter().map(|p| p.as_dvec3()).sum::<DVec3>() / n).as_vec3();
    let centre = Vec3A::from(centre);
    let axes = [Vec3A::X, Vec3A::Y, Vec3A::Z];
    // g = Wᵀ (rhs − A Δv), translations first: the residual's net force and its torque about c
    let (net, torque) =
        force_and_torque(x, centre, rhs.iter().zip(adv.iter()).map(|(&b, &q)| b - q));
    let mut g = [0.0f64; 6];
    g[..3].copy_from_slice(&net.to_array());
    g[3..].copy_from_slice(&torque.to_array());
    // The Gram matrix G = Wᵀ A W as its packed lower triangle (`multigrid::tri`): Tᵀ A T is the
    // block sum; column k of the rest is A R_k's net force (Tᵀ A R_k) and torque (R_jᵀ A R_k).
    let mut gram = [0.0f64; 21];
    let mut put = |r: usize, c: usize, value: f64| {
        if let Some(e) = gram.get_mut(multigrid::tri(r, c)) {
            *e = value;
        }
    };
    let a_tt = op.block_sum().map_err(breakdown)?;
    for r in 0..3 {
        for c in 0..=r {
            put(r, c, a_tt.col(c)[r]);
        }
    }
    let mut rotations = [DVec3::ZERO; 3];
    for ((k, &axis), moment) in axes.iter().enumerate().zip(rotations.iter_mut()) {
        for (f, &p) in field.iter_mut().zip(x) {
            *f = axis.cross(p - centre);
        }
        op.mul(field, image).map_err(breakdown)?;
        let force;
        (force, *moment) = force_and_torque(x, centre, image.iter().copied());
        for (j, f) in force.to_array().into_iter().enumerate() {
            put(3 + k, j, f);
        }
    }
    // the rotation block is symmetric up to round-off: its symmetric part
    let [r0, r1, r2] = rotations;
    let rot = glam::DMat3::from_cols(r0, r1, r2);
    for j in 0..3 {
        for k in 0..=j {
            put(3 + j, 3 + k, 0.5 * (rot.col(k)[j] + rot.col(j)[k]));
        }
    }
    // Lifted by 1e-9 of its mean diagonal, as the correction's own factorization was before it
    // shared the multigrid's (the same bits); a rotation that is no motion (all vertices on its
    // axis) stays below the factor's pivot, a decoupled direction that gets no correction.
    let lift = 1e-9
        * (0..6)
            .map(|i| gram.get(multigrid::tri(i, i)).copied().unwrap_or(0.0))
            .sum::<f64>()
        / 6.0;
    for i in 0..6 {
        if let Some(d) = gram.get_mut(multigrid::tri(i, i)) {
            *d += lift;
        }
    }
    let mut s = g;
    if multigrid::factor_packed(&mut gram, 6)
        .and_then(|()| multigrid::solve_packed(&gram, &mut s))
        .is_none()
    {
        return Ok(());
    }
    let descent: f64 = s.iter().zip(&g).map(|(a, b)| a * b).sum();
    if !(descent > 0.0 && s.iter().all(|v| v.is_finite())) {
        return Ok(());
    }
    let t = Vec3A::new(s[0] as f32, s[1] as f32, s[2] as f32);
    let omega = Vec3A::new(s[3] as f32, s[4] as f32, s[5] as f32);
    for (d, &p) in dv.iter_mut().zip(x) {
        *d += t + omega.cross(p - centre);
    }
    Ok(())
}

/// `(Σ f_i, Σ (x_i − c) × f_i)` in `f64`, in vertex order, in one pass: what a rigid motion
/// about `c` sees of the per-vertex vectors `f` (its translations' and its rotations' parts).
fn force_and_torque(x: &[Vec3A], centre: Vec3A, f: impl Iterator<Item = Vec3A>) -> (DVec3, DVec3) {
    let (mut force, mut torque) = (DVec3::ZERO, DVec3::ZERO);
    for (&p, fi) in x.iter().zip(f) {
        let fi = fi.as_dvec3();
        force += fi;
        torque += (p - centre).as_dvec3().cross(fi);
    }
    (force, torque)
}

/// `Vec3A` entries of the force array that hold the coarsest level's `f64` factor while the
/// multilevel solver has it on loan.
pub(crate) const fn dense_vectors(n: usize, nnz: usize) -> usize {
    multigrid::dense_len(n, nnz).div_ceil(2)
}

/// The multilevel vectors a force array of `len` entries lends (after the coarsest factor):
/// what the hierarchy is built for (`world/build.rs`).
pub(crate) fn multigrid_vectors(len: usize, n: usize, nnz: usize) -> usize {
    len.saturating_sub(dense_vectors(n, nnz))
}

/// `a bᵀ`.
pub(crate) fn outer(a: Vec3A, b: Vec3A) -> Mat3A {
    Mat3A::from_cols(a * b.x, a * b.y, a * b.z)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::sparse::tests::{random_pairs, spring_system, Lcg};
    use crate::sparse::Scalars;

    fn energy_norm(a: &sparse::BlockMatrix<'_>, e: &[Vec3A]) -> f64 {
        let mut ae = vec![Vec3A::ZERO; e.len()];
        a.mul(e, &mut ae).unwrap();
        e.iter().zip(&ae).map(|(&u, &v)| pcg::dot64(u, v)).sum()
    }

    /// The energy-limited substep (`limit`) ends with no more energy (kinetic + elastic +
    /// bending + the potential of gravity and of the applied forces) than it began with,
    /// whatever the state: an anisotropic cloth (600/60/150/50 N/m) squeezed to 40 % and
    /// thrown at up to 3 m/s, held by a point pin and a line pin, pushed by random forces, in
    /// one long substep. The same substep unlimited gains in some of these trials (else the
    /// test would test nothing); there the limit takes out at least that gain, and elsewhere
    /// nothing.
    #[test]
    fn an_energy_limited_substep_never_ends_above_its_start() {
        use crate::strided::Strided;
        use crate::world::{effects, PinAxes, Settings};
        let grid = crate::world::TestGrid::new(6, 0.3);
        let n = grid.positions.len();
        let mut rng = Lcg(11);
        let mut gained = 0;
        let mut kept = 0;
        for trial in 0..40 {
            // every other trial squeezed and thrown; the rest hang in their rest shape, upright,
            // moving slowly within their plane (where the linearized step is nearly exact)
            let squeezed = trial % 2 == 0;
            let x: Vec<[f32; 3]> = grid
                .positions
                .iter()
                .map(|p| {
                    if squeezed {
                        let q = Vec3A::from(*p) * 0.4 + rng.vec() * 0.02;
                        [q.x, q.y, q.z + 0.03 * rng.uniform()]
                    } else {
                        [p[0], 0.0, p[1]]
                    }
                })
                .collect();
            let v: Vec<[f32; 3]> = (0..n)
                .map(|_| {
                    let r = rng.vec();
                    if squeezed {
                        (r * 3.0).to_array()
                    } else {
                        [0.01 * r.x, 0.0, 0.01 * r.z]
                    }
                })
                .collect();
            let f: Vec<[f32; 3]> = (0..n)
                .map(|_| {
                    let r = rng.vec() * 0.05;
                    if squeezed {
                        r.to_array()
                    } else {
                        [r.x, 0.0, r.z]
                    }
                })
                .collect();
            let rail = rng.vec().normalize_or(Vec3A::X).to_array();
            // the energy at the start and at the end of the substep, limited or not
            let run = |limited: bool| {
                let mut mem = grid.memory();
                let mut w = grid.world(&mut mem);
                let settings = Settings {
                    effects: effects::GRAVITY | effects::PINS | effects::WARPING | effects::BENDING,
                    time_step: 1.0 / 30.0,
                    substeps: 1,
                    ..Settings::default()
                };
                w.set_settings(settings).unwrap();
                w.set_positions(&x).unwrap();
                w.set_velocities(&v).unwrap();
                w.add_forces(0, &Strided::from_slice(&f)).unwrap();
                w.set_pin(0, x[0]).unwrap();
                w.set_pin_axes(7, x[7], PinAxes::Line { direction: rail })
                    .unwrap();
                one_substep(&mut w, limited)
            };
            let (start, free_end, _, _) = run(false);
            let (same_start, end, removed, _) = run(true);
            assert_eq!(start, same_start);
            let scale = start.abs().max(free_end.abs()).max(1e-9);
            assert!(
                end <= start + 1e-6 * scale,
                "trial {trial}: {start} J -> {end} J limited ({free_end} J unlimited)"
            );
            if free_end > start + 1e-6 * scale {
                gained += 1;
                assert!(
                    removed >= free_end - start - 1e-6 * scale,
                    "trial {trial}: removed {removed} J of a {} J gain",
                    free_end - start
                );
            } else {
                kept += 1;
                assert_eq!(removed, 0.0, "trial {trial}");
            }
        }
        std::println!("{gained} of 40 unlimited substeps gained");
        assert!(
            gained >= 5 && kept >= 5,
            "{gained} of 40 unlimited substeps gained, {kept} did not"
        );
    }

    /// The energy-limited end weighs the substep's projection out of still colliders: whatever
    /// `Δv` the solve leaves, the substep ends (`limit`, `x += h v`, the projection) with no
    /// more energy than it began with. An anisotropic cloth stretched 20 % over a still sphere,
    /// at rest just off it, and a `Δv` that carries it 25 % of the radius into the sphere
    /// while it spreads 10 % along it: before the projection the cloth has relaxed (β = 1
    /// balanced), after it the spread is all stretch. The solve leaves such a `Δv` where the
    /// membrane's pull carries free vertices deep into a collider in one substep (adversarial
    /// scene 8067: 10 cm in 0.7 ms, then held still at 189 of its 193 steps).
    #[test]
    fn an_energy_limited_end_weighs_the_projection_out_of_still_colliders() {
        use crate::collide::{Collider, Shape};
        use crate::world::{effects, Settings};
        let grid = crate::world::TestGrid::new(8, 0.3);
        let (radius, thickness) = (0.2f32, 1e-3f32);
        let center = Vec3A::new(0.15, 0.15, -radius);
        // the grid's point `p` on the sphere's cap, its angles from the top spread by `spread`,
        // at distance `r` from the centre
        let on_cap = |p: &[f32; 3], spread: f32, r: f32| {
            let (a, b) = (
                (p[0] - 0.15) * spread / radius,
                (p[1] - 0.15) * spread / radius,
            );
            center + Vec3A::new(a.sin() * b.cos(), b.sin(), a.cos() * b.cos()) * r
        };
        let x: Vec<[f32; 3]> = grid
            .positions
            .iter()
            .map(|p| on_cap(p, 1.2, radius + thickness + 1e-4).to_array())
            .collect();
        let h = 1.0 / 30.0;
        let mut mem = grid.memory();
        let mut w = grid.world(&mut mem);
        w.add_collider(Collider::new(
            Shape::Sphere { center, radius },
            0.5,
            thickness,
        ))
        .unwrap();
        w.set_settings(Settings {
            effects: effects::COLLISION | effects::WARPING,
            time_step: h,
            substeps: 1,
            ..Settings::default()
        })
        .unwrap();
        w.set_positions(&x).unwrap();
        let (a, c, st) = w.stage();
        let n = c.n;
        let start = weighed(a, &c, &st);
        let dv = live_mut(a.dv, n).unwrap();
        for ((d, p), &x) in dv.iter_mut().zip(&grid.positions).zip(&x) {
            *d = (on_cap(p, 1.32, 0.75 * radius) - Vec3A::from(x)) / h;
        }
        let sub = super::super::Substep { h, t0: 0.0, t: 1.0 };
        let removed = limit(a, &c, &st, sub, false).unwrap();
        super::super::integrate(a, &c, h, true).unwrap();
        super::super::contacts::resolve(a, &c, &st, sub).unwrap();
        let end = weighed(a, &c, &st);
        assert!(
            end <= start * (1.0 + 1e-6),
            "{start} J -> {end} J (the limit took {removed} J)"
        );
        assert!(
            removed > 0.0,
            "the limit took nothing: {start} J -> {end} J"
        );
    }

    /// A `Δv` whose end overflows (a diverged solve's) is limited like any other, and what the
    /// limit reports taking stays finite: counted from the start, not from the overflowed end
    /// (`StepStats::energy_removed` read `inf` after adversarial scene 16038's limited step,
    /// whose end's kinetic energy overflowed). Here every vertex is given 2e19 m/s, whose
    /// square overflows `f32`, over a substep so short that the cloth moves 2 m rigidly, so
    /// that only the kinetic energy overflows; and one vertex alone over a whole substep, whose
    /// end's elastic energy overflows too (an end of NaN, which went through the limit whole).
    #[test]
    fn an_overflowed_end_is_limited_and_reported_finite() {
        use crate::world::{effects, Settings};
        let grid = crate::world::TestGrid::new(6, 0.3);
        for one in [false, true] {
            let mut mem = grid.memory();
            let mut w = grid.world(&mut mem);
            w.set_settings(Settings {
                effects: effects::GRAVITY | effects::WARPING,
                substeps: 1,
                ..Settings::default()
            })
            .unwrap();
            let (a, c, st) = w.stage();
            let n = c.n;
            let fast = Vec3A::new(2e19, 0.0, 0.0);
            let dv = live_mut(a.dv, n).unwrap();
            if one {
                dv[7] = fast;
            } else {
                dv.fill(fast);
            }
            let sub = super::super::Substep {
                h: if one { st.time_step } else { 1e-19 },
                t0: 0.0,
                t: 1.0,
            };
            let removed = limit(a, &c, &st, sub, false).unwrap();
            assert!(
                removed.is_finite() && removed >= 0.0,
                "one: {one}, removed {removed} J"
            );
            let dv = live(a.dv, n).unwrap();
            assert!(
                dv.iter().all(|d| *d == Vec3A::ZERO),
                "one: {one}, {:?}",
                dv[7]
            );
        }
    }

    /// The energy the limit weighs (J): kinetic, and the loaded potential.
    fn weighed(a: &Arrays<'_>, c: &Counts, st: &Settings) -> f64 {
        super::super::monitor::kinetic(live(a.mass, c.n).unwrap(), live(a.v, c.n).unwrap())
            + super::super::monitor::loaded_potential(a, c, st).unwrap()
    }

    /// One substep of `w`, as long as its settings' time step, limited or not: the energy the
    /// limit weighs (kinetic and loaded potential) at its start and at its end, the energy the
    /// limit took, and the end velocities.
    fn one_substep(
        w: &mut crate::world::World<'_>,
        limited: bool,
    ) -> (f64, f64, f64, std::vec::Vec<Vec3A>) {
        let (a, c, st) = w.stage();
        let n = c.n;
        let start = weighed(a, &c, &st);
        let sub = super::super::Substep {
            h: st.time_step,
            t0: 0.0,
            t: 1.0,
        };
        let report = super::super::substep(a, &c, &st, sub, limited).unwrap();
        (
            start,
            weighed(a, &c, &st),
            report.removed,
            live(a.v, n).unwrap().to_vec(),
        )
    }

    /// A substep that gains only what the wind gives it is not limited: the limit credits the
    /// wind's work on the end velocity (`forces::wind_work`'s, which the step counts as input)
    /// to the end. Without it a flat anisotropic cloth at rest in a wind along its normal was
    /// slowed to a stop (`β = 0`, all of the wind's push taken out).
    #[test]
    fn a_substep_that_gains_only_the_wind_s_work_is_not_limited() {
        use crate::world::{effects, Settings};
        let grid = crate::world::TestGrid::new(6, 0.3);
        let run = |limited: bool| {
            let mut mem = grid.memory();
            let mut w = grid.world(&mut mem);
            let normal = *w.normals().first().unwrap();
            w.set_settings(Settings {
                effects: effects::WIND | effects::WARPING | effects::BENDING,
                time_step: 1.0 / 30.0,
                substeps: 1,
                wind: (normal * 4.0).to_array(),
                drag: 0.5,
                ..Settings::default()
            })
            .unwrap();
            one_substep(&mut w, limited)
        };
        let (start, free_end, _, free_v) = run(false);
        let (_, _, removed, v) = run(true);
        assert!(
            free_end > start + 1e-6,
            "the wind gives the cloth {} J",
            free_end - start
        );
        assert_eq!(
            removed, 0.0,
            "the limit took {removed} J of the wind's push"
        );
        assert_eq!(v, free_v);
    }

    /// The correction leaves a residual with no net force and no net torque and an error no
    /// larger in the `A`-norm, whatever the approximate solution it starts from, with `A Δv`
    /// given or not.
    #[test]
    fn the_rigid_correction_removes_the_residual_s_net_force_and_torque() {
        let mut rng = Lcg(3);
        for n in [1usize, 30, 80] {
            // mass plus springs: every row of the stiffness sums to zero, as a cloth's does
            let pairs = random_pairs(&mut rng, n, 2 * n);
            let (op, diag, off) = spring_system(&mut rng, n, &pairs, 20.0, 0.7, None);
            let a = sparse::BlockMatrix {
                diag: &diag,
                pattern: op.pattern(),
                off: &off,
                scalars: Scalars::NONE,
            };
            let x: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let centre = x.iter().fold(Vec3A::ZERO, |s, &p| s + p) / n as f32;
            let exact: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let mut rhs = vec![Vec3A::ZERO; n];
            a.mul(&exact, &mut rhs).unwrap();
            // an approximate solution: a rigid drift plus some noise
            let (drift, spin) = (rng.vec(), rng.vec());
            let noisy: Vec<Vec3A> = exact.iter().map(|&e| e + 0.05 * rng.vec()).collect();
            let start: Vec<Vec3A> = noisy
                .iter()
                .zip(&x)
                .map(|(&e, &p)| e + drift + spin.cross(p - centre))
                .collect();
            let error = |dv: &[Vec3A]| {
                let e: Vec<Vec3A> = dv.iter().zip(&exact).map(|(&d, &e)| d - e).collect();
                energy_norm(&a, &e)
            };
            let mut scratch = (vec![Vec3A::NAN; n], vec![Vec3A::NAN; n]);
            let mut adv = vec![Vec3A::NAN; n];
            let mut dv = start.clone();
            let lent = [&mut scratch.0[..], &mut scratch.1[..]];
            correct_rigid(&a, &rhs, &x, &mut dv, false, &mut adv, lent).unwrap();
            // the best rigid motion is at least as good as taking the drift out exactly
            let (before, after, best) = (error(&start), error(&dv), error(&noisy));
            assert!(
                after <= best * (1.0 + 1e-4) && after < before,
                "n {n}: error {after} after, {before} before, {best} without the drift"
            );
            a.mul(&dv, &mut adv).unwrap();
            let (mut force, mut torque, mut size) = (DVec3::ZERO, DVec3::ZERO, 0.0);
            for ((&b, &q), &p) in rhs.iter().zip(&adv).zip(&x) {
                let r = (b - q).as_dvec3();
                force += r;
                torque += (p - centre).as_dvec3().cross(r);
                size += b.as_dvec3().length() * (1.0 + (p - centre).as_dvec3().length());
            }
            assert!(
                force.length() < 1e-5 * size && torque.length() < 1e-5 * size,
                "n {n}: net force {force}, torque {torque} of {size}"
            );
            // the same from a product the solve kept
            let mut kept = start.clone();
            a.mul(&kept, &mut adv).unwrap();
            let lent = [&mut scratch.0[..], &mut scratch.1[..]];
            correct_rigid(&a, &rhs, &x, &mut kept, true, &mut adv, lent).unwrap();
            assert_eq!(kept, dv);
            // from the exact solution (to f32) there is nothing to correct above the noise
            let mut dv = exact.clone();
            let lent = [&mut scratch.0[..], &mut scratch.1[..]];
            correct_rigid(&a, &rhs, &x, &mut dv, false, &mut adv, lent).unwrap();
            assert!(error(&dv) <= 1e-9 * before, "n {n}: {}", error(&dv));
        }
    }
}
