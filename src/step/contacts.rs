//! Stages 2 and 5 of a substep: pins and contacts, in one place.
//!
//! Before the solve ([`constrain`]): each pin and each contact becomes a per-vertex filter of
//! the modified PCG (Baraff & Witkin §5.3: `S = 0` for a pin, `S = I − n nᵀ` for a contact or
//! a pin in a plane, `S = d dᵀ` for a pin on a line) and
//! a prescribed part of `Δv`. After it ([`resolve`]): Coulomb friction for the contacts the
//! solve held, projection out of every collider, pins put exactly on their targets. In
//! between, [`constraint_work`] measures what moving pins and colliders put into the cloth.

use glam::{Mat3A, Vec3A};

use super::system::outer;
use super::{live, live_mut, monitor, Substep};
use crate::collide;
use crate::mesh;
use crate::world::error::StepError;
use crate::world::memory::{Arrays, Counts};
use crate::world::settings::{effects, Settings};

/// Flag in `Arrays::contact`: static friction holds the vertex to its collider.
pub(crate) const STICK: u32 = 1 << 31;

/// The collider index of a contact state (out of range for `mesh::NONE`).
fn collider_of(contact: u32) -> usize {
    if contact == mesh::NONE {
        usize::MAX
    } else {
        (contact & !STICK) as usize
    }
}

fn collide_on(c: &Counts, st: &Settings) -> bool {
    st.effects & effects::COLLISION != 0 && c.colliders > 0
}

fn pins_on(c: &Counts, st: &Settings) -> bool {
    st.effects & effects::PINS != 0 && c.pins > 0
}

/// Sets the PCG filter and the prescribed velocity changes; returns whether any vertex is
/// constrained (without constraints the solve runs its filter-free path).
pub(crate) fn constrain(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
) -> Result<bool, StepError> {
    let (n, h) = (c.n, sub.h);
    let collide = collide_on(c, st);
    let pins = pins_on(c, st);
    if !(collide || pins) {
        return Ok(false);
    }
    let mut constrained = false;
    let (x, v) = (live(a.x, n)?, live(a.v, n)?);
    let (filter, dv) = (live_mut(a.filter, n)?, live_mut(a.dv, n)?);
    filter.fill(Mat3A::IDENTITY);
    // Contact slop: a vertex predicted to end within this of its offset surface is held too.
    // A cloth resting on a collider sits exactly on it after each substep; with a strict test
    // its vertices flicker in and out of the contact set, and the ones let go fall in for a
    // substep and are projected back against the membrane's tension, which puts energy in.
    let gravity = if st.effects & effects::GRAVITY != 0 {
        Vec3A::from(st.gravity)
    } else {
        Vec3A::ZERO
    };
    let fall = gravity.length() * h * h;
    let slop = |thickness: f32| 0.1 * thickness + fall;
    if collide {
        let colliders = live(a.colliders, c.colliders)?;
        let vertices = live_mut(a.contact, n)?
            .iter_mut()
            .zip(filter.iter_mut())
            .zip(dv.iter_mut())
            .zip(x.iter().zip(v));
        for (((contact, filter_i), dv_i), (&xi, &vi)) in vertices {
            let before_substep = *contact;
            *contact = mesh::NONE;
            let mut deepest = f32::INFINITY;
            for (k, col) in colliders.iter().enumerate() {
                let shape = col.previous.lerp(&col.shape, sub.t);
                let before = col.previous.lerp(&col.shape, sub.t0);
                // Where the collider is at the start of the substep, and the vertex's motion
                // relative to its surface over the substep: the predicted distance at the end
                // (a linear sweep of both, so a fast collider neither tunnels nor pushes what
                // it does not reach within the substep).
                let prox = before.proximity(xi);
                let vs = shape.surface_velocity(&before, xi, h);
                let vn_rel = (vi - vs).dot(prox.normal);
                let predicted = prox.distance + h * vn_rel;
                if predicted < col.thickness + slop(col.thickness)
                    && prox.distance - col.thickness < deepest
                {
                    deepest = prox.distance - col.thickness;
                    let nrm = prox.normal;
                    // end the substep on the offset surface, moving with the collider, but
                    // push out of a penetration no faster than the depenetration speed (the
                    // projection after the step corrects the rest by position only); and a
                    // vertex held within the slop above the surface is drawn to it no faster
                    // than gravity's pull toward the surface alone would in a substep (held,
                    // not glued)
                    let pull = (-gravity.dot(nrm)).max(0.0) * h;
                    let push = ((col.thickness - prox.distance) / h)
                        .min(st.max_depenetration_speed)
                        .max(-pull);
                    let target_vn = vs.dot(nrm) + push;
                    if before_substep == k as u32 | STICK {
                        // Static friction held it: it moves with the surface (all three
                        // directions prescribed); the solve's impulse says whether the
                        // friction cone still holds it (`resolve`).
                        *filter_i = Mat3A::ZERO;
                        *dv_i = vs - nrm * vs.dot(nrm) + nrm * target_vn - vi;
                    } else {
                        let filter = Mat3A::IDENTITY - outer(nrm, nrm);
                        *filter_i = filter;
                        *dv_i = filter * *dv_i + nrm * (target_vn - vi.dot(nrm));
                    }
                    // on the same collider it keeps sticking (or sliding): `resolve` decides
                    // again from the solve's impulse; a new contact starts sliding
                    *contact = if collider_of(before_substep) == k {
                        before_substep
                    } else {
                        k as u32
                    };
                    constrained = true;
                }
            }
        }
    }
    if pins {
        let pinned = live(a.pin_vertex, c.pins)?
            .iter()
            .zip(live(a.pin_previous, c.pins)?)
            .zip(
                live(a.pin_target, c.pins)?
                    .iter()
                    .zip(live(a.pin_free, c.pins)?),
            );
        for ((&vertex, &previous), (&target, &free)) in pinned {
            let i = vertex as usize;
            let target = previous.lerp(target, sub.t);
            let (Some(dv_i), Some(filter_i), Some(&xi), Some(&vi)) =
                (dv.get_mut(i), filter.get_mut(i), x.get(i), v.get(i))
            else {
                return Err(StepError::SolverBreakdown); // pinned vertices are < n
            };
            // land exactly on the target (the held directions of it) at the end of the
            // substep; the free directions are the solve's (a pin overrides a contact)
            let held = Mat3A::IDENTITY - free;
            *dv_i = free * *dv_i + held * ((target - xi) / h - vi);
            *filter_i = free;
            constrained = true;
        }
    }
    Ok(constrained)
}

/// The work (J) moving pins and colliders did on the cloth during the solve: the constraint
/// impulse `J = (I − S)(A Δv − rhs)` (`a.w_q` holds `A Δv`, see `system::solve`) times the
/// velocity of what holds the vertex (a pin's target, a collider's surface). Still pins and
/// colliders do no work: their impulses only redirect motion.
pub(crate) fn constraint_work(
    a: &Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
) -> Result<f64, StepError> {
    let n = c.n;
    let (w_q, rhs) = (live(a.w_q, n)?, live(a.rhs, n)?);
    let mut work = 0.0f64;
    if pins_on(c, st) {
        let pinned = live(a.pin_vertex, c.pins)?
            .iter()
            .zip(live(a.pin_previous, c.pins)?)
            .zip(
                live(a.pin_target, c.pins)?
                    .iter()
                    .zip(live(a.pin_free, c.pins)?),
            );
        for ((&vertex, &previous), (&target, &free)) in pinned {
            let i = vertex as usize;
            let moved = previous.lerp(target, sub.t) - previous.lerp(target, sub.t0);
            if moved != Vec3A::ZERO {
                let (Some(&aq), Some(&b)) = (w_q.get(i), rhs.get(i)) else {
                    return Err(StepError::SolverBreakdown); // pinned vertices are < n
                };
                // the pin pushes only along what it holds (the free part is the solve's
                // residual)
                let impulse = (Mat3A::IDENTITY - free) * (aq - b);
                work += f64::from(impulse.dot(moved / sub.h));
            }
        }
    }
    if collide_on(c, st) {
        let colliders = live(a.colliders, c.colliders)?;
        let vertices = live(a.contact, n)?
            .iter()
            .zip(live(a.pin_of, n)?)
            .zip(live(a.x, n)?.iter().zip(live(a.filter, n)?))
            .zip(w_q.iter().zip(rhs));
        for (((&contact, &pin), (&xi, &filter)), (&aq, &b)) in vertices {
            let Some(col) = colliders.get(collider_of(contact)) else {
                continue;
            };
            if col.previous == col.shape || pin != mesh::NONE {
                continue;
            }
            let shape = col.previous.lerp(&col.shape, sub.t);
            let before = col.previous.lerp(&col.shape, sub.t0);
            let vs = shape.surface_velocity(&before, xi, sub.h);
            let held = Mat3A::IDENTITY - filter;
            work += f64::from((held * (aq - b)).dot(vs));
        }
    }
    Ok(work)
}

/// After `x += h v`: friction for held contacts, projection out of every collider, pins
/// exactly on target. Returns the vertices touching a collider and the work (J) done from
/// outside through friction and projection (moving colliders, depenetration).
pub(crate) fn resolve(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
) -> Result<(u32, f64), StepError> {
    let (n, h) = (c.n, sub.h);
    let pins = pins_on(c, st);
    let mut contacts = 0;
    let mut work = 0.0f64;
    // The projection below moves vertices by position. Where a moving collider pushes, or a
    // vertex began the substep inside a collider (the engine put it there, or a collider
    // appeared around it) and is put back beyond the depenetration speed, that is work done
    // on the cloth from outside: the potential energy it changes is input to the energy
    // balance (measured, as it can be far from linear). A still collider's projection of a
    // vertex that entered during the substep is not input: a gain there is the step's own.
    let driven = collide_on(c, st) && projection_is_driven(a, c, st, sub)?;
    let potential_before = if driven {
        monitor::potential(a, c, st)?
    } else {
        0.0
    };
    if collide_on(c, st) {
        let colliders = live(a.colliders, c.colliders)?;
        let held = live(a.pin_of, n)?
            .iter()
            .zip(live(a.mass, n)?)
            .zip(live(a.w_q, n)?.iter().zip(live(a.rhs, n)?));
        let moving = live_mut(a.x, n)?
            .iter_mut()
            .zip(live_mut(a.v, n)?.iter_mut())
            .zip(live_mut(a.contact, n)?.iter_mut());
        for (((&pin, &mass), (&aq, &b)), ((xi, vi), contact)) in held.zip(moving) {
            if pins && pin != mesh::NONE {
                continue;
            }
            let mut touched = false;
            let v_before = *vi;
            let mut vs_held = Vec3A::ZERO;
            // Coulomb friction from the solve's own contact impulse `J = A Δv − rhs` (`a.w_q`
            // holds `A Δv`): a sticking contact keeps sticking while `|J_t| ≤ μ J_n`; a sliding
            // one loses at most `μ J_n / m` of its tangential velocity relative to the surface
            // and sticks once that stops it.
            if let Some(col) = colliders.get(collider_of(*contact)) {
                let shape = col.previous.lerp(&col.shape, sub.t);
                let before = col.previous.lerp(&col.shape, sub.t0);
                let vs = shape.surface_velocity(&before, *xi, h);
                let nrm = shape.proximity(*xi).normal;
                let impulse = aq - b;
                let normal = impulse.dot(nrm).max(0.0);
                let limit = col.friction * normal;
                if *contact & STICK != 0 {
                    let tangential = impulse - nrm * impulse.dot(nrm);
                    if tangential.length() > limit {
                        *contact &= !STICK;
                    }
                } else {
                    let rel = *vi - vs;
                    let vt = rel - nrm * rel.dot(nrm);
                    let vt_len = vt.length();
                    let stop = limit / mass.max(f32::MIN_POSITIVE);
                    if vt_len <= stop {
                        *vi -= vt;
                        *contact |= STICK;
                    } else {
                        *vi -= vt * (stop / vt_len);
                    }
                }
                vs_held = vs;
                touched = true;
            }
            // Projection: nothing ends the substep deeper than `thickness`.

            for col in colliders {
                let shape = col.previous.lerp(&col.shape, sub.t);
                let before = col.previous.lerp(&col.shape, sub.t0);
                let vs = shape.surface_velocity(&before, *xi, h);
                let hit = collide::resolve(&shape, vs, col.thickness, col.friction, xi, vi);
                if hit && vs != Vec3A::ZERO {
                    vs_held = vs;
                }
                touched |= hit;
            }
            if touched && vs_held != Vec3A::ZERO {
                // a moving surface does work m Δv · v_s through what it changed
                work += f64::from(mass * (*vi - v_before).dot(vs_held));
            }
            contacts += touched as u32;
        }
    }
    if pins {
        let x = live_mut(a.x, n)?;
        let pinned = live(a.pin_vertex, c.pins)?
            .iter()
            .zip(live(a.pin_previous, c.pins)?)
            .zip(
                live(a.pin_target, c.pins)?
                    .iter()
                    .zip(live(a.pin_free, c.pins)?),
            );
        for ((&vertex, &previous), (&target, &free)) in pinned {
            // pinned vertices are < n
            let xi = x
                .get_mut(vertex as usize)
                .ok_or(StepError::SolverBreakdown)?;
            let target = previous.lerp(target, sub.t);
            *xi = if free == Mat3A::ZERO {
                target
            } else {
                // onto the plane or line through the target, along the held directions
                *xi + (Mat3A::IDENTITY - free) * (target - *xi)
            };
        }
    }
    if driven {
        work += monitor::potential(a, c, st)? - potential_before;
    }
    Ok((contacts, work))
}

/// Whether a moving collider will push a vertex out in this substep's projection, or a vertex
/// began the substep deeper inside a collider than its contact could push it out of.
fn projection_is_driven(
    a: &Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
) -> Result<bool, StepError> {
    let pins = pins_on(c, st);
    let colliders = live(a.colliders, c.colliders)?;
    let vertices = live(a.pin_of, c.n)?
        .iter()
        .zip(live(a.x, c.n)?.iter().zip(live(a.v, c.n)?));
    for (&pin, (&xi, &vi)) in vertices {
        if pins && pin != mesh::NONE {
            continue;
        }
        // where the vertex began the substep (x was just advanced by exactly h v)
        let (x, start) = (xi, xi - vi * sub.h);
        for col in colliders {
            let shape = col.previous.lerp(&col.shape, sub.t);
            if shape.proximity(x).distance >= col.thickness {
                continue;
            }
            if col.previous != col.shape {
                return Ok(true);
            }
            let before = col.previous.lerp(&col.shape, sub.t0);
            let depth = col.thickness - before.proximity(start).distance;
            if depth > 0.1 * col.thickness + sub.h * st.max_depenetration_speed {
                return Ok(true);
            }
        }
    }
    Ok(false)
}
