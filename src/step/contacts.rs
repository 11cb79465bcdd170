//! Stages 2 and 5 of a substep: pins and contacts, in one place.
//!
//! Before the solve ([`constrain`]): each pin and each contact becomes a per-vertex filter of
//! the modified PCG (Baraff & Witkin §5.3: `S = 0` for a pin, `S = I − n nᵀ` for a contact) and
//! a prescribed part of `Δv`. After it ([`resolve`]): Coulomb friction for the contacts the
//! solve held, projection out of every collider, pins put exactly on their targets. In
//! between, [`constraint_work`] measures what moving pins and colliders put into the cloth.

use glam::{Mat3A, Vec3A};

use super::system::outer;
use super::{monitor, Substep};
use crate::collide;
use crate::mesh;
use crate::world::{effects, Arrays, Counts, Settings};

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
pub(crate) fn constrain(a: &mut Arrays<'_>, c: &Counts, st: &Settings, sub: Substep) -> bool {
    let (n, h) = (c.n, sub.h);
    let collide = collide_on(c, st);
    let pins = pins_on(c, st);
    if !(collide || pins) {
        return false;
    }
    let mut constrained = false;
    a.filter[..n].fill(Mat3A::IDENTITY);
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
        for i in 0..n {
            let before_substep = a.contact[i];
            a.contact[i] = mesh::NONE;
            let (xi, vi) = (a.x[i], a.v[i]);
            let mut deepest = f32::INFINITY;
            for (k, col) in a.colliders[..c.colliders].iter().enumerate() {
                let shape = col.previous.lerp(&col.shape, sub.t);
                let before = col.previous.lerp(&col.shape, sub.t0);
                let prox = shape.proximity(xi);
                let vs = shape.surface_velocity(&before, xi, h);
                let vn_rel = (vi - vs).dot(prox.normal);
                // predicted distance at the end of the substep
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
                        a.filter[i] = Mat3A::ZERO;
                        a.dv[i] = vs - nrm * vs.dot(nrm) + nrm * target_vn - vi;
                    } else {
                        let filter = Mat3A::IDENTITY - outer(nrm, nrm);
                        a.filter[i] = filter;
                        a.dv[i] = filter * a.dv[i] + nrm * (target_vn - vi.dot(nrm));
                    }
                    // on the same collider it keeps sticking (or sliding): `resolve` decides
                    // again from the solve's impulse; a new contact starts sliding
                    a.contact[i] = if collider_of(before_substep) == k {
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
        for p in 0..c.pins {
            let i = a.pin_vertex[p] as usize;
            let target = a.pin_previous[p].lerp(a.pin_target[p], sub.t);
            // land exactly on the target at the end of the substep
            a.dv[i] = (target - a.x[i]) / h - a.v[i];
            a.filter[i] = Mat3A::ZERO;
            constrained = true;
        }
    }
    constrained
}

/// The work (J) moving pins and colliders did on the cloth during the solve: the constraint
/// impulse `J = (I − S)(A Δv − rhs)` (`a.w_q` holds `A Δv`, see `system::solve`) times the
/// velocity of what holds the vertex (a pin's target, a collider's surface). Still pins and
/// colliders do no work: their impulses only redirect motion.
pub(crate) fn constraint_work(a: &Arrays<'_>, c: &Counts, st: &Settings, sub: Substep) -> f64 {
    let mut work = 0.0f64;
    if pins_on(c, st) {
        for p in 0..c.pins {
            let i = a.pin_vertex[p] as usize;
            let moved = a.pin_previous[p].lerp(a.pin_target[p], sub.t)
                - a.pin_previous[p].lerp(a.pin_target[p], sub.t0);
            if moved != Vec3A::ZERO {
                let impulse = a.w_q[i] - a.rhs[i];
                work += f64::from(impulse.dot(moved / sub.h));
            }
        }
    }
    if collide_on(c, st) {
        for i in 0..c.n {
            let Some(col) = a.colliders[..c.colliders].get(collider_of(a.contact[i])) else {
                continue;
            };
            if col.previous == col.shape || a.pin_of[i] != mesh::NONE {
                continue;
            }
            let shape = col.previous.lerp(&col.shape, sub.t);
            let before = col.previous.lerp(&col.shape, sub.t0);
            let vs = shape.surface_velocity(&before, a.x[i], sub.h);
            let held = Mat3A::IDENTITY - a.filter[i];
            work += f64::from((held * (a.w_q[i] - a.rhs[i])).dot(vs));
        }
    }
    work
}

/// After `x += h v`: friction for held contacts, projection out of every collider, pins
/// exactly on target. Returns the vertices touching a collider and the work (J) done from
/// outside through friction and projection (moving colliders, depenetration).
pub(crate) fn resolve(a: &mut Arrays<'_>, c: &Counts, st: &Settings, sub: Substep) -> (u32, f64) {
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
    let driven = collide_on(c, st) && projection_is_driven(a, c, st, sub);
    let potential_before = if driven {
        monitor::potential(a, c, st)
    } else {
        0.0
    };
    if collide_on(c, st) {
        for i in 0..n {
            if pins && a.pin_of[i] != mesh::NONE {
                continue;
            }
            let mut touched = false;
            let v_before = a.v[i];
            let mut vs_held = Vec3A::ZERO;
            // Coulomb friction from the solve's own contact impulse `J = A Δv − rhs` (`a.w_q`
            // holds `A Δv`): a sticking contact keeps sticking while `|J_t| ≤ μ J_n`; a sliding
            // one loses at most `μ J_n / m` of its tangential velocity relative to the surface
            // and sticks once that stops it.
            if let Some(col) = a.colliders[..c.colliders].get(collider_of(a.contact[i])) {
                let shape = col.previous.lerp(&col.shape, sub.t);
                let before = col.previous.lerp(&col.shape, sub.t0);
                let vs = shape.surface_velocity(&before, a.x[i], h);
                let nrm = shape.proximity(a.x[i]).normal;
                let impulse = a.w_q[i] - a.rhs[i];
                let normal = impulse.dot(nrm).max(0.0);
                let limit = col.friction * normal;
                if a.contact[i] & STICK != 0 {
                    let tangential = impulse - nrm * impulse.dot(nrm);
                    if tangential.length() > limit {
                        a.contact[i] &= !STICK;
                    }
                } else {
                    let rel = a.v[i] - vs;
                    let vt = rel - nrm * rel.dot(nrm);
                    let vt_len = vt.length();
                    let stop = limit / a.mass[i].max(f32::MIN_POSITIVE);
                    if vt_len <= stop {
                        a.v[i] -= vt;
                        a.contact[i] |= STICK;
                    } else {
                        a.v[i] -= vt * (stop / vt_len);
                    }
                }
                vs_held = vs;
                touched = true;
            }
            // Projection: nothing ends the substep deeper than `thickness`.

            for col in &a.colliders[..c.colliders] {
                let shape = col.previous.lerp(&col.shape, sub.t);
                let before = col.previous.lerp(&col.shape, sub.t0);
                let vs = shape.surface_velocity(&before, a.x[i], h);
                let hit = collide::resolve(
                    &shape,
                    vs,
                    col.thickness,
                    col.friction,
                    &mut a.x[i],
                    &mut a.v[i],
                );
                if hit && vs != Vec3A::ZERO {
                    vs_held = vs;
                }
                touched |= hit;
            }
            if touched && vs_held != Vec3A::ZERO {
                // a moving surface does work m Δv · v_s through what it changed
                work += f64::from(a.mass[i] * (a.v[i] - v_before).dot(vs_held));
            }
            contacts += touched as u32;
        }
    }
    if pins {
        for p in 0..c.pins {
            let i = a.pin_vertex[p] as usize;
            a.x[i] = a.pin_previous[p].lerp(a.pin_target[p], sub.t);
        }
    }
    if driven {
        work += monitor::potential(a, c, st) - potential_before;
    }
    (contacts, work)
}

/// Whether a moving collider will push a vertex out in this substep's projection, or a vertex
/// began the substep deeper inside a collider than its contact could push it out of.
fn projection_is_driven(a: &Arrays<'_>, c: &Counts, st: &Settings, sub: Substep) -> bool {
    let pins = pins_on(c, st);
    for i in 0..c.n {
        if pins && a.pin_of[i] != mesh::NONE {
            continue;
        }
        // where the vertex began the substep (x was just advanced by exactly h v)
        let (x, start) = (a.x[i], a.x[i] - a.v[i] * sub.h);
        for col in &a.colliders[..c.colliders] {
            let shape = col.previous.lerp(&col.shape, sub.t);
            if shape.proximity(x).distance >= col.thickness {
                continue;
            }
            if col.previous != col.shape {
                return true;
            }
            let before = col.previous.lerp(&col.shape, sub.t0);
            let depth = col.thickness - before.proximity(start).distance;
            if depth > 0.1 * col.thickness + sub.h * st.max_depenetration_speed {
                return true;
            }
        }
    }
    false
}
