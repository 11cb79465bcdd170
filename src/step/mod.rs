//! One substep of the coarse cloth, as stage functions over the world's arrays (in the spirit
//! of Box2D v3's solver stages). [`crate::world::World::step_dt`] calls [`substep`] for each
//! substep and then checks the step's energy balance ([`monitor`]).
//!
//! 1. [`forces`]: frames, membrane forces and Jacobian, bending, gravity, wind, damping → rhs;
//! 2. [`contacts`]: pins and contacts into the PCG filter and the prescribed `Δv`;
//! 3. [`system`]: fold mass, bending and drag into the blocks, precondition, solve; a contact
//!    that pulls is let go ([`contacts::release`]) and the solve goes on;
//! 4. integrate `v += Δv`, `x += h v`;
//! 5. [`contacts`]: friction, projection, pins exactly on target.

pub(crate) mod contacts;
pub(crate) mod forces;
pub(crate) mod monitor;
pub(crate) mod system;

use glam::Vec3A;

use crate::pcg;
use crate::sparse::{Pattern, Scalars};
use crate::world::error::StepError;
use crate::world::memory::{Arrays, Counts};
use crate::world::settings::Settings;

/// The live prefix `..n` of one of the world's capacity-long arrays. A world's counts never
/// exceed its capacity, so the error cannot happen; it stands in for the index that is not
/// made (the kernel does not index).
pub(crate) fn live<T>(array: &[T], n: usize) -> Result<&[T], StepError> {
    array.get(..n).ok_or(StepError::SolverBreakdown)
}

/// [`live`] for an array the stage writes.
pub(crate) fn live_mut<T>(array: &mut [T], n: usize) -> Result<&mut [T], StepError> {
    array.get_mut(..n).ok_or(StepError::SolverBreakdown)
}

/// The world's block pattern (`row_start[..n + 1]`, `cols[..nnz]`), checked like [`live`].
pub(crate) fn pattern<'p>(
    row_start: &'p [u32],
    cols: &'p [u32],
    c: &Counts,
) -> Result<Pattern<'p>, StepError> {
    Ok(Pattern {
        row_start: live(row_start, c.n + 1)?,
        cols: live(cols, c.nnz)?,
    })
}

/// The world's scalar (hinge-only) pattern, checked like [`live`].
pub(crate) fn hinge_pattern<'p>(
    hinge_start: &'p [u32],
    hinge_cols: &'p [u32],
    c: &Counts,
) -> Result<Pattern<'p>, StepError> {
    Ok(Pattern {
        row_start: live(hinge_start, c.n + 1)?,
        cols: live(hinge_cols, c.nnz_h)?,
    })
}

/// The bending couplings of vertices that share no edge, `scale · q_hinge` on the scalar
/// pattern.
pub(crate) fn hinge_scalars<'p>(
    hinge_start: &'p [u32],
    hinge_cols: &'p [u32],
    q_hinge: &'p [f32],
    c: &Counts,
    scale: f32,
) -> Result<Scalars<'p>, StepError> {
    Ok(Scalars {
        pattern: hinge_pattern(hinge_start, hinge_cols, c)?,
        off: live(q_hinge, c.nnz_h)?,
        scale,
    })
}

/// Where a substep lies in its step: its length `h` (s), and the fractions of the step at
/// which it starts (`t0`) and ends (`t`); pins and colliders are swept linearly across a step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Substep {
    pub h: f32,
    pub t0: f32,
    pub t: f32,
}

/// What a substep did.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Report {
    pub solve: pcg::Stats,
    /// Linear solves: one, plus one per round of contacts let go.
    pub solves: u32,
    /// Iterations of the first solve (`solve.iterations` sums all of them).
    pub first_iterations: u32,
    /// Vertices touching a collider at its end.
    pub contacts: u32,
    /// Work (J) done on the cloth from outside: moving pins and colliders, wind.
    pub input: f64,
    /// Energy (J) the energy-limited end took out ([`system::limit`]).
    pub removed: f64,
}

/// Solves after contacts were let go or engaged, at most (`contacts::release`, `contacts::engage`).
const RELEASE_ROUNDS: u32 = 2;

/// One linearized implicit Euler substep; `limited`: its end is energy-limited
/// ([`system::limit`], the last attempt at a step that gained at every other).
pub(crate) fn substep(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
    limited: bool,
) -> Result<Report, StepError> {
    forces::accumulate(a, c, st, sub.h)?;
    let mut constrained = contacts::constrain(a, c, st, sub)?;
    system::fold(a, c, st, sub.h)?;
    let first = system::solve(a, c, st, sub.h, constrained, None)?;
    let (mut solve, mut operators_kept) = (first.stats, first.operators_kept);
    let first_iterations = solve.iterations;
    let mut solves = 1;
    // A contact that pulls is let go, and the solve goes on without it (a vertex let go can
    // leave another one pulling, hence the rounds): with the first solve's reference, and
    // with the multilevel operators set up again only around the vertices let go.
    // Likewise a free vertex the solve itself drove a little way into a collider is held, and
    // the solve goes on with it (`contacts::engage`, in the same rounds).
    for _ in 0..RELEASE_ROUNDS {
        let (released, moved) = if constrained {
            contacts::release(a, c, st, sub)?
        } else {
            (0, false)
        };
        let engaged = contacts::engage(a, c, st, sub, released)?;
        if released + engaged == 0 {
            break;
        }
        // An unconstrained solve's operators are those of the identity filter, which is what
        // `constrain` left at every vertex not listed.
        constrained |= engaged > 0;
        // Contacts only let go change the filter alone: `A Δv` (in `w_q`, which every
        // constrained solve leaves) is still the product of the start.
        let resume = system::Resume {
            reference: solve.reference,
            changed: (released + engaged) as usize,
            operators_kept,
            product_kept: !moved && engaged == 0,
        };
        let more = system::solve(a, c, st, sub.h, constrained, Some(resume))?;
        operators_kept = more.operators_kept;
        solves += 1;
        solve = pcg::Stats {
            iterations: solve.iterations + more.stats.iterations,
            ..more.stats
        };
    }
    #[cfg(feature = "research")]
    let limited = limited && !forces::per_node_warping(st);
    let removed = if limited {
        system::limit(a, c, st, sub, constrained)?
    } else {
        0.0
    };
    let mut input = if constrained {
        contacts::constraint_work(a, c, st, sub)?
    } else {
        0.0
    };
    integrate(a, c, sub.h, solve.converged)?;
    input += forces::wind_work(a, c, st, sub.h)?;
    let (touching, work) = contacts::resolve(a, c, st, sub)?;
    input += work;
    let n = c.n;
    if !live(a.x, n)?
        .iter()
        .chain(live(a.v, n)?)
        .all(|p| p.is_finite())
    {
        return Err(StepError::NonFiniteState);
    }
    Ok(Report {
        solve,
        solves,
        first_iterations,
        contacts: touching,
        input,
        removed,
    })
}

/// `v += Δv`, `x += h v`. A solve stopped by the iteration cap leaves a `Δv` that is no warm
/// start to trust (warm-starting from it injected energy at 161×161): the next solve starts
/// from zero instead.
fn integrate(a: &mut Arrays<'_>, c: &Counts, h: f32, converged: bool) -> Result<(), StepError> {
    let n = c.n;
    let (x, v, dv) = (live_mut(a.x, n)?, live_mut(a.v, n)?, live_mut(a.dv, n)?);
    for ((x, v), d) in x.iter_mut().zip(v.iter_mut()).zip(dv.iter()) {
        *v += *d;
        *x += *v * h;
    }
    if !converged {
        dv.fill(Vec3A::ZERO);
    }
    Ok(())
}
