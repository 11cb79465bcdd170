//! Stages 2 and 5 of a substep: pins and contacts, in one place.
//!
//! Before the solve ([`constrain`]): each pin and each contact becomes a per-vertex filter of
//! the modified PCG (Baraff & Witkin §5.3: `S = 0` for a pin, `S = I − n nᵀ` for a contact or
//! a pin in a plane, `S = d dᵀ` for a pin on a line) and a prescribed part of `Δv`. A vertex's
//! contacts (with every collider it touches, and the edge and face contacts of the thin
//! colliders between its neighbours) share one filter: `I −` the projection onto the span of
//! their normals ([`Held`]). A pin overrides contacts at its vertex. After it: [`release`] lets
//! go of a vertex whose contact impulse pulls it (a contact only pushes), and [`engage`] holds
//! a free one that the solve itself carried a little way into a collider, for the solve to go
//! on without or with them; then ([`resolve`]) Coulomb friction for the contacts the solve held,
//! projection out of every collider, pins put exactly on their targets. In between,
//! [`constraint_work`] measures what moving pins and colliders put into the cloth.

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

/// Flag in `Arrays::contact`: the vertex is held by this one contact alone in the substep (its
/// filter is this contact's), so [`release`] may let it go.
const ALONE: u32 = 1 << 30;

/// Flag in `Arrays::contact`: this substep tested the vertex's own contacts without the slop
/// (it had been let go, [`LET_GO`]).
const STRICT: u32 = 1 << 29;

/// Flag in `Arrays::contact`: [`release`] let the vertex go (in this substep or before, and
/// nothing has held it since): the next substep holds it only where it would reach a surface,
/// so a vertex the membrane holds just above a surface is not caught and let go again at
/// every substep.
const LET_GO: u32 = 1 << 28;

/// The flags of a contact state; the rest is the collider index.
const FLAGS: u32 = STICK | ALONE | STRICT | LET_GO;

/// The collider index of a state whose vertex no collider holds, but which keeps flags.
const NO_COLLIDER: u32 = !FLAGS;

/// Colliders a world holds at most, whatever its capacity: every index fits below the flags.
pub(crate) const MAX_COLLIDERS: usize = NO_COLLIDER as usize;

/// Whether contact state `state` has `flag` (`mesh::NONE` has none).
fn has_flag(state: u32, flag: u32) -> bool {
    state != mesh::NONE && state & flag != 0
}

/// Contact state `state` after collider `removed` was removed and the last one, `last`, moved
/// into its slot: a contact with the removed collider is gone, one with the last follows it
/// (flags kept).
pub(crate) fn collider_removed(state: u32, removed: u32, last: u32) -> u32 {
    if state == mesh::NONE {
        return state;
    }
    let (collider, flags) = (state & !FLAGS, state & FLAGS);
    if collider == removed {
        mesh::NONE
    } else if collider == last {
        removed | flags
    } else {
        state
    }
}

/// The collider index of a contact state (out of range for `mesh::NONE`).
fn collider_of(contact: u32) -> usize {
    if contact == mesh::NONE {
        usize::MAX
    } else {
        (contact & !FLAGS) as usize
    }
}

fn collide_on(c: &Counts, st: &Settings) -> bool {
    st.effects & effects::COLLISION != 0 && c.colliders > 0
}

pub(crate) fn pins_on(c: &Counts, st: &Settings) -> bool {
    st.effects & effects::PINS != 0 && c.pins > 0
}

/// The directions a vertex is held along in a substep, orthonormalized (at most three; Gram–
/// Schmidt over the contact normals in the order they come), each with the velocity the vertex
/// must have along it at the end of the substep and the velocity along it of the surfaces that
/// hold it (what a moving collider's work is measured with). One normal gives the filter
/// `I − n nᵀ`, two independent ones the line along `n₁ × n₂`, three none: a vertex in the
/// groove of two colliders satisfies both at once instead of being pushed out of each in turn.
#[derive(Clone, Copy, Default)]
struct Held {
    axes: [Vec3A; 3],
    /// The contact normal each axis was made from (before Gram–Schmidt): see
    /// [`Held::multipliers`].
    made_from: [Vec3A; 3],
    /// Per axis: the target velocity, the same without drawing toward a surface (`firm`), and
    /// the surface's velocity (see [`Held::add`]).
    values: [Vec3A; 3],
    count: usize,
    /// Contacts added (more than the axes when some were nearly parallel).
    contacts: usize,
    /// The vertex's velocity at the substep's start: what its free directions are taken to
    /// carry when a contact rides on a held axis ([`Held::add`]).
    start: Vec3A,
}

impl Held {
    /// Holds `n · v = target` (`n` unit; `vs`: the holding surface's velocity; a `target`
    /// below `n · vs` draws the vertex toward the surface). Returns the axis that holds it
    /// (its own, or the held one it is nearly parallel to).
    fn add(&mut self, n: Vec3A, target: f32, vs: Vec3A) -> Option<usize> {
        self.contacts += 1;
        let surface = vs.dot(n);
        let (mut rest, mut rhs) = (n, Vec3A::new(target, target.max(surface), surface));
        let mut most_aligned = (0.0f32, 0usize);
        let held = self.axes.iter().zip(&self.values).take(self.count);
        for (k, (&axis, &values)) in held.enumerate() {
            let along = n.dot(axis);
            rest -= axis * along;
            rhs -= values * along;
            if along.abs() > most_aligned.0.abs() {
                most_aligned = (along, k);
            }
        }
        let len = rest.length();
        // Below ~12° from the held span a contact adds no direction of its own: what it asks
        // beyond the held velocities (more outward motion) goes on the held axis it is closest
        // to, so the stricter of two nearly parallel contacts wins.
        if len > 0.2 {
            if let (Some(axis), Some(values), Some(made_from)) = (
                self.axes.get_mut(self.count),
                self.values.get_mut(self.count),
                self.made_from.get_mut(self.count),
            ) {
                (*axis, *values, *made_from) = (rest / len, rhs / len, n);
                self.count += 1;
                return Some(self.count - 1);
            }
        }
        // Its normal's part `rest` outside the held span is along free directions: of `n · v`
        // they give `rest · v`, taken at the vertex's velocity at the substep's start (and the
        // surface's `rest · vs` of its velocity). Taken as 0, a cloth carried with its sphere
        // read its own common motion along the tilt of each edge contact beside a vertex
        // contact as an approach, and was pushed off the sphere (measured: 0.11 m/s at 1 m/s
        // carried, where the cloth at rest stayed on it): the same scene moving as a whole
        // must do what it does at rest.
        rhs -= Vec3A::new(rest.dot(self.start), rest.dot(self.start), rest.dot(vs));
        let (along, k) = most_aligned;
        let values = self.values.get_mut(k).filter(|_| along != 0.0)?;
        let raise = |r: f32| r.max(0.0) / along;
        let target = raise(rhs.x);
        let surface = if target != 0.0 { rhs.z / along } else { 0.0 };
        *values += Vec3A::new(target, raise(rhs.y), surface);
        Some(k)
    }

    /// The contact impulse `j` (in the held span) as a sum over the axes' contact normals,
    /// `j = Σ λ_k n_k` (`n_k` = `made_from[k]`): `λ_k < 0` is a contact that pulls. Back
    /// substitution: `n_m` lies in the span of the axes up to `m`, so `a_k · j = λ_k a_k·n_k +
    /// Σ_{m>k} λ_m a_k·n_m`, and `a_k·n_k` is the length Gram–Schmidt kept (> 0.2).
    fn multipliers(&self, j: Vec3A) -> [f32; 3] {
        let mut lambda = [0.0f32; 3];
        for k in (0..self.count).rev() {
            let (Some(&axis), Some(&own)) = (self.axes.get(k), self.made_from.get(k)) else {
                continue;
            };
            let later = self
                .made_from
                .iter()
                .zip(&lambda)
                .take(self.count)
                .skip(k + 1);
            let along = later.fold(axis.dot(j), |r, (&n, &l)| r - axis.dot(n) * l);
            if let Some(l) = lambda.get_mut(k) {
                *l = along / axis.dot(own);
            }
        }
        lambda
    }

    /// The held axes with the velocity each prescribes and its surface's velocity. A vertex
    /// held by one contact may be drawn toward its surface; one held by several is not: their
    /// normals can be nearly parallel (an edge's and a vertex's on a sphere), and two different
    /// draws along them would ask a large velocity across them (measured: energy put in).
    fn axes(&self) -> impl Iterator<Item = (Vec3A, f32, f32)> + '_ {
        let single = self.contacts <= 1;
        self.axes
            .iter()
            .zip(&self.values)
            .take(self.count)
            .map(move |(&a, &v)| (a, if single { v.x } else { v.y }, v.z))
    }

    /// The PCG filter: the directions left free, `I − Σ a aᵀ`.
    fn free(&self) -> Mat3A {
        self.axes()
            .fold(Mat3A::IDENTITY, |f, (a, _, _)| f - outer(a, a))
    }

    /// The velocity with the held components prescribed and the free ones of `free_v`.
    fn velocity(&self, free_v: Vec3A) -> Vec3A {
        self.axes()
            .fold(self.free() * free_v, |v, (a, t, _)| v + a * t)
    }

    /// The velocity of what holds the vertex along the held axes (the free part 0, or a
    /// sticking contact's surface velocity `stuck`).
    fn surface_velocity(&self, stuck: Vec3A) -> Vec3A {
        self.axes()
            .fold(self.free() * stuck, |v, (a, _, s)| v + a * s)
    }
}

/// What holds one vertex in a substep: its contacts' normals, and its own deepest contact (the
/// collider, and the surface velocity at the vertex), the one friction acts through.
#[derive(Clone, Copy, Default)]
struct Hold {
    held: Held,
    primary: Option<(usize, Vec3A)>,
    /// Contacts found so far, held or dropped: the next one's bit in a dropped set
    /// (`Arrays::contact_dropped`; from the 33rd on a contact has none and is never dropped).
    found: u32,
    /// Per held axis, the contacts it holds (bits, as in a dropped set).
    on_axis: [u32; 3],
}

impl Hold {
    /// Holds contact `t`, unless it is in `dropped`; returns whether it holds.
    fn add(&mut self, t: &Touch, dropped: u32) -> bool {
        let bit = 1u32.checked_shl(self.found).unwrap_or(0);
        self.found = self.found.saturating_add(1);
        if dropped & bit != 0 {
            return false;
        }
        let axis = self.held.add(t.normal, t.target, t.vs);
        if let Some(on_axis) = axis.and_then(|k| self.on_axis.get_mut(k)) {
            *on_axis |= bit;
        }
        true
    }

    /// The vertex's contact state once this holds it, from its state `before`: on the same
    /// collider it keeps sticking (or sliding), since `resolve` decides again from the solve's
    /// impulse; a new contact starts sliding. A vertex let go ([`LET_GO`]) stays let go until
    /// something holds it again.
    fn state(&self, before: u32) -> u32 {
        let mut state = match self.primary {
            Some((k, _)) if collider_of(before) == k => before & (STICK | !FLAGS),
            Some((k, _)) => k as u32,
            None => NO_COLLIDER,
        };
        if self.primary.is_some() && self.held.contacts == 1 {
            state |= ALONE;
        }
        if has_flag(before, LET_GO) {
            state |= STRICT | if self.held.count == 0 { LET_GO } else { 0 };
        }
        if state == NO_COLLIDER {
            mesh::NONE
        } else {
            state
        }
    }

    /// The PCG filter and prescribed `Δv` of a vertex this holds (in contact state `state`),
    /// at velocity `vi`; the free directions keep the `Δv` they have. Static friction (a
    /// sticking state) moves it with the surface, all three directions prescribed; the
    /// solve's impulse says whether the friction cone still holds it (`resolve`).
    fn prescribe(&self, state: u32, vi: Vec3A, filter: &mut Mat3A, dv: &mut Vec3A) {
        match self.primary {
            Some((_, vs)) if has_flag(state, STICK) => {
                *filter = Mat3A::ZERO;
                *dv = self.held.velocity(vs) - vi;
            }
            _ => {
                let free = self.held.free();
                *filter = free;
                *dv = self.held.velocity(vi + free * *dv) - vi;
            }
        }
    }

    /// The contacts to let go (bits, as in a dropped set) when `j` is the impulse that holds
    /// the vertex: those of the axis that pulls hardest (its multiplier most negative,
    /// [`Held::multipliers`]), or none. One axis per solve, as an active-set method drops one
    /// constraint at a time: a vertex held along three axes by a small sphere's edge and face
    /// contacts splits a sideways pull into a pull on two of them, and letting go of both at
    /// once freed it altogether in the next solve while its edge's other corner stayed held:
    /// the edge pivoted 4 mm into the sphere (1 mm one axis at a time).
    fn pulling(&self, j: Vec3A) -> u32 {
        let lambda = self.held.multipliers(j);
        lambda
            .iter()
            .zip(&self.on_axis)
            .take(self.held.count)
            .filter(|(&l, _)| l < 0.0)
            .fold(
                (0.0f32, 0),
                |most, (&l, &bits)| if l < most.0 { (l, bits) } else { most },
            )
            .1
    }
}

/// The substep's view of the contacts: the colliders, the cloth's state at the substep's start
/// and its topology, and the rules that turn a proximity into a contact.
struct Scene<'s> {
    sweep: Sweep<'s>,
    x: &'s [Vec3A],
    v: &'s [Vec3A],
    ring_start: &'s [u32],
    ring: &'s [u32],
    vt_start: &'s [u32],
    vt: &'s [u32],
    triangles: &'s [[u32; 3]],
    sub: Substep,
    gravity: Vec3A,
    /// The contact slop beyond the thickness is a tenth of it, the rounding of the distance
    /// and this: how far gravity moves a point in a substep ([`Scene::slop`]).
    slop_fall: f32,
    max_depenetration_speed: f32,
    /// The cloth's longest edge at the substep's start (every ring edge and face side is one),
    /// or `+∞` when unknown (no sphere or capsule to test edges and faces against, or a
    /// non-finite position): see [`Scene::may_cut`].
    longest_edge: f32,
}

/// A point's contact with one collider in a substep.
struct Touch {
    normal: Vec3A,
    /// Its own motion ends the substep within the thickness (no slop needed).
    reaches: bool,
    /// Its predicted end lies within the contact slop only by the slop's part for gravity's
    /// fall (`Scene::slop_fall`): a vertex so near a surface is not held before the solve
    /// ([`Scene::hold_onto`]), but it still counts as touching for its neighbours' edges.
    falling: bool,
    /// Signed distance beyond the thickness at the substep's start (negative: inside).
    depth: f32,
    /// Normal velocity the point must end the substep with.
    target: f32,
    /// The surface's velocity there.
    vs: Vec3A,
}

/// A collider placed in the substep: its shape at the start (`before`) and the end
/// (`after`), and its surface velocity when that is the same everywhere (a plane's, a
/// sphere's). Placed once per substep and collider ([`Sweep`]) and handed to every test.
#[derive(Clone, Copy)]
struct Placed<'c> {
    col: &'c collide::Collider,
    before: collide::Shape,
    after: collide::Shape,
    uniform_velocity: Option<Vec3A>,
}

impl<'c> Placed<'c> {
    fn new(col: &'c collide::Collider, sub: Substep) -> Self {
        let before = col.previous.lerp(&col.shape, sub.t0);
        let after = col.previous.lerp(&col.shape, sub.t);
        Placed {
            col,
            before,
            after,
            uniform_velocity: after.uniform_surface_velocity(&before, sub.h),
        }
    }

    /// The surface's velocity at the point nearest to `p` over the substep (length `h`).
    fn surface_velocity(&self, p: Vec3A, h: f32) -> Vec3A {
        self.uniform_velocity
            .unwrap_or_else(|| self.after.surface_velocity(&self.before, p, h))
    }

    /// How far across the offset surface a point at `p` may be and still be where the step
    /// itself put it: a tenth of the thickness, `extra`, and the rounding of its distance
    /// (`Shape::rounding`), to which a projection puts a point on the surface. The contact
    /// slop ([`Scene::slop`]) and the depth a substep may begin at inside a collider without
    /// counting as a push ([`project`]).
    fn allowance(&self, p: Vec3A, extra: f32) -> f32 {
        self.col.thickness * 0.1 + extra + self.before.rounding(p)
    }

    /// Whether a point at `p` is deeper across the offset surface than [`Placed::allowance`]
    /// lets the step itself put it (something else did: a push from outside): the surface's
    /// normal there and the depth beyond the allowance. The projection's test of where a
    /// vertex began the substep ([`project`]) and the push credit's ([`constraint_work`]).
    fn beyond_allowance(&self, p: Vec3A, extra: f32) -> Option<(Vec3A, f32)> {
        let prox = self.before.proximity(p);
        let depth = self.col.thickness - prox.distance;
        let allowed = self.allowance(p, extra);
        (depth > allowed).then_some((prox.normal, depth - allowed))
    }

    /// Whether projecting a vertex that began the substep at `start` out of this collider is a
    /// push from outside, which the energy balance counts as input: the collider moves, or the
    /// vertex began deeper than [`Placed::allowance`] with `depenetration` (what the
    /// depenetration speed moves in the substep). Otherwise the projection is the step's own
    /// ([`project`]'s still pass, and what the energy-limited end weighs of it,
    /// [`place_outside_still`]).
    fn pushes(&self, start: Vec3A, depenetration: f32) -> bool {
        self.col.previous != self.col.shape || self.beyond_allowance(start, depenetration).is_some()
    }
}

/// Colliders placed beforehand, this many at most (a world usually has a few); the others
/// are placed where used.
const PLACED: usize = 8;

/// The colliders placed in a substep ([`Placed`]), once for all vertices: the contact tests
/// visit every vertex and collider at least once per substep, and placing a collider (its
/// sweep, its surface velocity) per vertex was a good part of the test of a far one.
struct Sweep<'c> {
    colliders: &'c [collide::Collider],
    first: [Option<Placed<'c>>; PLACED],
    sub: Substep,
}

impl<'c> Sweep<'c> {
    fn new(colliders: &'c [collide::Collider], sub: Substep) -> Self {
        let mut first = [None; PLACED];
        for (slot, col) in first.iter_mut().zip(colliders) {
            *slot = Some(Placed::new(col, sub));
        }
        Sweep {
            colliders,
            first,
            sub,
        }
    }

    /// Collider `k` (it is `col`) placed: beforehand, or now into `spare` (by reference:
    /// copying a `Placed` per vertex cost about what placing a sphere does).
    fn placed<'a>(
        &'a self,
        k: usize,
        col: &'c collide::Collider,
        spare: &'a mut Option<Placed<'c>>,
    ) -> &'a Placed<'c> {
        match self.first.get(k) {
            Some(Some(placed)) => placed,
            _ => spare.insert(Placed::new(col, self.sub)),
        }
    }
}

impl Scene<'_> {
    /// Whether a point at `p` (proximity `prox` at the substep's start) moving at `vp` touches
    /// `col` in this substep. Its distance at the start, advanced by its velocity relative to
    /// the collider's surface, must end within the thickness plus a small slop (a linear sweep
    /// of both, so a fast collider neither tunnels nor pushes what it does not reach within the
    /// substep). `at_vertex`: the point is a vertex, not a point of an edge or a face.
    fn touch(
        &self,
        placed: &Placed,
        p: Vec3A,
        vp: Vec3A,
        prox: collide::Proximity,
        at_vertex: bool,
    ) -> Option<Touch> {
        let h = self.sub.h;
        let col = placed.col;
        let vs = placed.surface_velocity(p, h);
        let nrm = prox.normal;
        let predicted = prox.distance + h * (vp - vs).dot(nrm);
        // Contact slop: a point predicted to end within this of its offset surface is held too.
        // A cloth resting on a collider sits exactly on it after each substep; with a strict
        // test its vertices flicker in and out of the contact set, and the ones let go fall in
        // for a substep and are projected back against the membrane's tension, which puts
        // energy in. "Exactly on it" is to within the rounding of the projection, which the
        // slop always covers: with a thickness of zero and no gravity it was zero, and a vertex
        // the projection had put on a shell's surface, a rounding above it, was not held; a pin
        // pulling the cloth out through the shell drew it 2 mm through in the next solve, and
        // the projection put it back against the stretched edges to the pin, at every substep
        // (adversarial scene 5202: 119 steps held still, 73 in a row). A vertex within the
        // slop's part for gravity's fall alone is not held (`Touch::falling`).
        if predicted >= col.thickness + self.slop(placed, p) {
            return None;
        }
        // End the substep on the offset surface, moving with the collider. A vertex is pushed
        // out of a penetration no faster than the depenetration speed (the projection after
        // the step corrects the rest by position only), and one held within the slop above the
        // surface is drawn to it no faster than gravity's pull toward the surface alone would
        // in a substep (held, not glued). A contact between vertices holds every corner, so it
        // does not draw: it approaches no faster than it already does (an inelastic stop).
        // Measured: drawing the corners of the edges resting on a sphere put energy in at most
        // steps.
        let approach = (vp - vs).dot(nrm).min(0.0);
        let (push_max, pull) = if at_vertex {
            let pull = (-self.gravity.dot(nrm)).max(0.0) * h;
            (self.max_depenetration_speed, pull)
        } else {
            (0.0, -approach)
        };
        let push = ((col.thickness - prox.distance) / h)
            .min(push_max)
            .max(-pull);
        Some(Touch {
            normal: nrm,
            reaches: predicted < col.thickness,
            falling: predicted >= col.thickness + placed.allowance(p, 0.0),
            depth: prox.distance - col.thickness,
            target: vs.dot(nrm) + push,
            vs,
        })
    }

    /// Whether vertex `i` touches `col` itself.
    fn vertex_touch(&self, placed: &Placed, i: usize) -> Option<Touch> {
        let (&xi, &vi) = (self.x.get(i)?, self.v.get(i)?);
        let prox = placed.before.proximity(xi);
        self.touch(placed, xi, vi, prox, true)
    }

    /// Whether a free vertex at `p` whose solve gave it the end velocity `end` reaches `col`
    /// within the substep by that motion, by little enough to be held ([`engage`]): its
    /// predicted end lies inside the offset surface by at most the contact slop (what the
    /// prediction at the substep's start holds above it, [`Scene::slop`], whose part for
    /// gravity's fall in the substep catches here the vertices that part did not hold,
    /// [`Scene::hold_onto`]) or what the depenetration speed moves in a substep, whichever is
    /// more. The hold lands it on the offset surface, moving with it: it approaches no faster
    /// than that asks, and no faster than `end` already does; a vertex inside is pushed out no
    /// faster than the depenetration speed.
    fn end_touch(&self, placed: &Placed, p: Vec3A, end: Vec3A) -> Option<Touch> {
        let h = self.sub.h;
        let col = placed.col;
        let prox = placed.before.proximity(p);
        let vs = placed.surface_velocity(p, h);
        let nrm = prox.normal;
        let approach = (end - vs).dot(nrm);
        let overshoot = col.thickness - (prox.distance + h * approach);
        let band = self.slop(placed, p).max(h * self.max_depenetration_speed);
        if !(overshoot > 0.0 && overshoot <= band) {
            return None;
        }
        let push = ((col.thickness - prox.distance) / h)
            .min(self.max_depenetration_speed)
            .max(approach);
        Some(Touch {
            normal: nrm,
            reaches: true,
            falling: false,
            depth: prox.distance - col.thickness,
            target: vs.dot(nrm) + push,
            vs,
        })
    }

    /// Everything vertex `i` touches, but the contacts in `dropped` (let go in this substep,
    /// [`release`]): each collider at the vertex; and, for a sphere or a capsule, the interior
    /// of each edge and face around it long enough to cut into it (a thin collider between
    /// vertices). Such a contact holds every corner along its normal, to the contact point's
    /// target velocity: conservative (it also stops the edge from tilting along the normal),
    /// but what the per-vertex filter can hold, and the contact point then moves as required.
    /// A corner that touches the collider itself holds the contacts of its edges whose other
    /// corner does not: with its own contact alone it slid along the surface while the edge's
    /// other end was held, and the edge swung into the collider (a 9×9 cloth slid off a 3 cm
    /// sphere with an edge 17 mm inside). Like every contact, they hold only while they push
    /// ([`release`]). Edge and face contacts are frictionless.
    fn hold(&self, i: usize, strict: bool, dropped: u32) -> Hold {
        let mut hold = Hold::default();
        hold.held.start = self.v.get(i).copied().unwrap_or(Vec3A::ZERO);
        self.hold_onto(hold, i, strict, dropped)
    }

    /// [`Scene::hold`] added to `hold`, whose contacts come first (the axes are made in the
    /// order the normals come) and keep its primary contact, if it has one.
    fn hold_onto(&self, mut hold: Hold, i: usize, strict: bool, dropped: u32) -> Hold {
        let mut deepest = if hold.primary.is_some() {
            f32::NEG_INFINITY
        } else {
            f32::INFINITY
        };
        // Computed at the first sphere or capsule with edge and face tests, once per vertex
        // (planes and shells have none).
        let mut reach = None;
        let mut spare = None;
        for (k, col) in self.sweep.colliders.iter().enumerate() {
            let placed = self.sweep.placed(k, col, &mut spare);
            let touches = self.vertex_touch(placed, i);
            if let Some(t) = &touches {
                if (strict && !t.reaches) || t.falling {
                    // Let go ([`LET_GO`]): held again only where its own motion reaches the
                    // surface, not by the slop, so the membrane that lifted it is not
                    // overruled at once. It is at the surface: no edge or face tests either.
                    // Within the slop above the surface only by gravity's fall in the substep
                    // (`Touch::falling`): not held before the solve either, by its own contact
                    // nor by its edges' and faces'; where it does fall in, the solve's motion
                    // says so and [`engage`] holds it then (its band has the fall). Held by its
                    // own contact, every vertex that the membrane held within `g h²` above a
                    // surface was drawn toward it: on a fine cloth (3.3 mm edges) dropped on a
                    // sphere with a thickness of 1 mm at 1/60 s, 38–61 contacts still did work
                    // on it after the release rounds, 4–5e-4 J a substep (the cloth held
                    // ~2.3e-4 J), and the energy balance redid every step. Held by its edges'
                    // and faces' contacts alone (they keep the fall in their slop, as nothing
                    // catches them after the solve), such vertices wedged a cloth on a thin
                    // capsule: 20 held, two of them along all three axes, kept 109 J of stretch
                    // in it for 200 steps after the scene switched its pins off (adversarial
                    // scene 16085, where the version before let it go at once). The edges of
                    // its neighbours still count it as touching ([`Scene::edge_touches`]):
                    // counted as free, it let them hold the edges beside it by their own
                    // contacts, which pulled (16085 again: 107 of 295 steps redone).
                    continue;
                }
                if hold.add(t, dropped) && t.depth < deepest {
                    deepest = t.depth;
                    hold.primary = Some((k, t.vs));
                }
                if t.depth < -0.1 * col.thickness {
                    // Inside: its own contact pushes it out. An edge's contact beside it, which
                    // stops its corners along another normal, asks for a velocity beyond the
                    // push (measured: 7.3 m/s out of a push at 5).
                    continue;
                }
            }
            let Some(cutting) = placed
                .before
                .shortest_cutting_edge(col.thickness)
                .filter(|&cutting| self.may_cut(cutting))
                .filter(|&cutting| cutting <= *reach.get_or_insert_with(|| self.reach(i)))
            else {
                continue;
            };
            let clearance = self.clearance(placed, i);
            for t in self.edge_touches(placed, i, touches.is_some(), clearance, cutting) {
                hold.add(&t, dropped);
            }
            for t in self.face_touches(placed, i, clearance, cutting) {
                hold.add(&t, dropped);
            }
        }
        hold
    }

    /// Whether any edge or face of the cloth is long enough to pass the first test of
    /// [`Scene::edge_touches`] (`len ≥ cutting`) or [`Scene::face_touches`] (`longest side ·
    /// 2/√3 ≥ cutting`). When none is, a sphere or capsule cannot lie between vertices and the
    /// vertex contacts are all there is: the usual case of a cloth finer than its colliders
    /// (21×21 on a 0.3 m sphere: 7 cm diagonals, 11 cm cutting edge). Without this bound every
    /// vertex near no collider went through the tests of its 6 edges and 6 faces only to have
    /// each one rejected, ~10 % of a step. The bound is exact: a side's length here is the one
    /// those tests compute (rounding is monotone and `√` of the largest square is the largest
    /// length), so it rejects only what they would.
    fn may_cut(&self, cutting: f32) -> bool {
        let longest = self.longest_edge;
        longest >= cutting || longest * 2.0 * FRAC_1_SQRT_3 >= cutting
    }

    /// No face around vertex `i` has a side longer than twice its longest edge (the side
    /// opposite the vertex is at most the sum of the other two): a bound that spares the edge
    /// and face tests where the cloth is finer than the colliders.
    fn reach(&self, i: usize) -> f32 {
        self.x.get(i).map_or(0.0, |&xi| {
            let ring = ring_of(self.ring_start, self.ring, i);
            let longest = ring
                .iter()
                .filter_map(|&j| self.x.get(j as usize))
                .map(|&xj| (xj - xi).length_squared())
                .fold(0.0, f32::max);
            2.0 * libm::sqrtf(longest) * 2.0 * FRAC_1_SQRT_3
        })
    }

    /// How far `col` stays from vertex `i` beyond what a contact reaches in this substep: an
    /// edge or face around the vertex can touch `col` only where it extends (or moves relative
    /// to the vertex) further than this. A cheap bound before the exact edge and face tests.
    fn clearance(&self, placed: &Placed, i: usize) -> f32 {
        let (Some(&xi), Some(&vi)) = (self.x.get(i), self.v.get(i)) else {
            return f32::INFINITY;
        };
        let vs = placed.surface_velocity(xi, self.sub.h);
        let travel = self.sub.h * (vi - vs).length();
        placed.before.proximity(xi).distance - travel - placed.col.thickness - self.slop(placed, xi)
    }

    /// How far beyond the thickness of `placed` a point at `p` may be predicted to end and
    /// still be held ([`Scene::touch`]): a tenth of the thickness, how far gravity moves it in
    /// the substep, and the rounding of its distance (`Shape::rounding`).
    fn slop(&self, placed: &Placed, p: Vec3A) -> f32 {
        placed.allowance(p, self.slop_fall)
    }

    fn edge_touches<'a>(
        &'a self,
        placed: &'a Placed<'a>,
        i: usize,
        touches: bool,
        clearance: f32,
        cutting: f32,
    ) -> impl Iterator<Item = Touch> + 'a {
        let ring = ring_of(self.ring_start, self.ring, i);
        ring.iter().filter_map(move |&j| {
            let j = j as usize;
            let (&xi, &vi, &xj, &vj) = (
                self.x.get(i)?,
                self.v.get(i)?,
                self.x.get(j)?,
                self.v.get(j)?,
            );
            // a distance changes no faster than the point moves: the edge's points lie within
            // its length of the vertex and move relative to it no faster than the other end
            let len = (xj - xi).length();
            if len < cutting || clearance >= len + self.sub.h * (vj - vi).length() {
                return None;
            }
            let (s, prox) = placed.before.segment_proximity(xi, xj)?;
            // a corner is nearest: the vertex contact's
            if s <= 0.0 || s >= 1.0 {
                return None;
            }
            // Both corners touching `col` hold the edge by their own contacts (as a face with
            // a second corner touching, below); only an edge held at its far corner alone
            // swings in as a touching corner slides. Held at both, such edges caught the cloth
            // on a sphere moving through it at 50 m/s and carried it 5 m.
            if touches && self.vertex_touch(placed, j).is_some() {
                return None;
            }
            self.touch(placed, xi.lerp(xj, s), vi.lerp(vj, s), prox, false)
        })
    }

    fn face_touches<'a>(
        &'a self,
        placed: &'a Placed<'a>,
        i: usize,
        clearance: f32,
        cutting: f32,
    ) -> impl Iterator<Item = Touch> + 'a {
        let faces = ring_of(self.vt_start, self.vt, i);
        faces.iter().filter_map(move |&t| {
            let corners = *self.triangles.get(t as usize)?;
            let [a, b, c] = corners.map(|k| k as usize);
            let p = [*self.x.get(a)?, *self.x.get(b)?, *self.x.get(c)?];
            let q = [*self.v.get(a)?, *self.v.get(b)?, *self.v.get(c)?];
            // as for an edge; a face's points lie within its circumradius of a corner, at
            // most its longest side over √3 (half of it for an obtuse one)
            let longest = (p[1] - p[0])
                .length()
                .max((p[2] - p[1]).length())
                .max((p[0] - p[2]).length());
            if longest * 2.0 * FRAC_1_SQRT_3 < cutting {
                return None; // (before the six lengths below: the cheaper test)
            }
            let (xi, vi) = (*self.x.get(i)?, *self.v.get(i)?);
            let size = p.iter().map(|&pk| (pk - xi).length()).fold(0.0, f32::max);
            let speed = q.iter().map(|&vk| (vk - vi).length()).fold(0.0, f32::max);
            if clearance >= size + self.sub.h * speed {
                return None;
            }
            let (w, prox) = placed.before.triangle_proximity(p)?;
            if w.iter().any(|&wk| wk <= 0.0) {
                return None; // an edge or a corner is nearest: theirs
            }
            if corners
                .iter()
                .any(|&k| k as usize != i && self.vertex_touch(placed, k as usize).is_some())
            {
                return None;
            }
            let at = |y: [Vec3A; 3]| y[0] * w[0] + y[1] * w[1] + y[2] * w[2];
            self.touch(placed, at(p), at(q), prox, false)
        })
    }
}

/// `1/√3`: a face's circumradius is at most its longest side times this.
const FRAC_1_SQRT_3: f32 = 0.577_350_26;

/// The CSR row `i` of `(start, items)`, empty when out of range.
fn ring_of<'r>(start: &[u32], items: &'r [u32], i: usize) -> &'r [u32] {
    match (start.get(i), start.get(i + 1)) {
        (Some(&s), Some(&e)) => items.get(s as usize..e as usize).unwrap_or(&[]),
        _ => &[],
    }
}

/// The substep's [`Scene`]. `edges`: whether its edge and face tests will run (`Scene::hold`);
/// without them the longest edge, a pass over every triangle, is left unknown.
fn scene<'s>(
    a: &'s Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
    edges: bool,
) -> Result<Scene<'s>, StepError> {
    let n = c.n;
    let gravity = if st.effects & effects::GRAVITY != 0 {
        Vec3A::from(st.gravity)
    } else {
        Vec3A::ZERO
    };
    let colliders = live(a.colliders, c.colliders)?;
    let x = live(a.x, n)?;
    let triangles = live(a.triangles, c.nt)?;
    let longest_edge = if edges && colliders.iter().any(|col| col.shape.between_vertices()) {
        longest_edge(triangles, x)
    } else {
        f32::INFINITY
    };
    Ok(Scene {
        sweep: Sweep::new(colliders, sub),
        x,
        v: live(a.v, n)?,
        ring_start: live(a.ring_start, n + 1)?,
        ring: a.ring,
        vt_start: live(a.vt_start, n + 1)?,
        vt: a.vt,
        triangles,
        sub,
        gravity,
        slop_fall: gravity.length() * sub.h * sub.h,
        max_depenetration_speed: st.max_depenetration_speed,
        longest_edge,
    })
}

/// The longest side of any triangle at positions `x` (the mesh's rings are made of these
/// sides, `mesh::build`), or `+∞` when a side's length is not a number: the edge and face
/// tests do not reject a NaN length, so neither may [`Scene::may_cut`].
fn longest_edge(triangles: &[[u32; 3]], x: &[Vec3A]) -> f32 {
    // Per side a lane (NaN checked first, so the lanes' plain `max` is exact): a scalar
    // `f32::max` chain, NaN-aware, was most of this pass's time.
    let mut longest2 = Vec3A::ZERO;
    for tri in triangles {
        let [Some(&p0), Some(&p1), Some(&p2)] = tri.map(|k| x.get(k as usize)) else {
            continue; // no face test either (it finds no corners)
        };
        let sides = Vec3A::new(
            (p1 - p0).length_squared(),
            (p2 - p1).length_squared(),
            (p0 - p2).length_squared(),
        );
        if sides.is_nan() {
            return f32::INFINITY;
        }
        longest2 = longest2.max(sides);
    }
    libm::sqrtf(longest2.max_element())
}

/// The contacts' part of [`constrain`]: each vertex's filter, prescribed `Δv` and contact
/// state from what holds it. Returns whether any vertex is held.
fn hold_all(
    a: &Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
    lent: &mut Lent<'_>,
) -> Result<bool, StepError> {
    let n = c.n;
    let scene = scene(a, c, st, sub, true)?;
    let mut constrained = false;
    // a new substep: every contact holds until it pulls
    live_mut(lent.dropped, n)?.fill(0);
    let vertices = live_mut(lent.contact, n)?
        .iter_mut()
        .zip(live_mut(lent.filter, n)?.iter_mut())
        .zip(live_mut(lent.dv, n)?.iter_mut().zip(scene.v));
    for (i, ((contact, filter_i), (dv_i, &vi))) in vertices.enumerate() {
        let hold = scene.hold(i, has_flag(*contact, LET_GO), 0);
        *contact = hold.state(*contact);
        if hold.held.count == 0 {
            continue;
        }
        hold.prescribe(*contact, vi, filter_i, dv_i);
        constrained = true;
    }
    Ok(constrained)
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
    live_mut(a.filter, n)?.fill(Mat3A::IDENTITY);
    if collide {
        constrained = lend(a, |a, lent| hold_all(a, c, st, sub, lent))?;
    }
    if pins {
        let (x, v) = (live(a.x, n)?, live(a.v, n)?);
        let (filter, dv) = (live_mut(a.filter, n)?, live_mut(a.dv, n)?);
        for (vertex, previous, target, free) in
            pins_of((a.pin_vertex, a.pin_previous, a.pin_target, a.pin_free), c)?
        {
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

/// A contact only pushes (Baraff & Witkin §5.3 release a constraint whose force pulls): after a
/// solve, a contact whose part of the impulse `A Δv − rhs` pulls its vertex toward the surface
/// is let go, and the caller solves again from the current `Δv` (`a.w_q` must hold `A Δv`). A
/// vertex no contact holds any more is free, and from the next substep on it is held only
/// where its own motion reaches a surface ([`LET_GO`]). Returns how many vertices changed
/// (listed in `a.w_s`, in ascending order: [`engage`] searches it), and whether any of their
/// `Δv` changed (a vertex still held by its other contacts is prescribed anew; one let go
/// entirely keeps its `Δv`, and then `a.w_q` is still `A Δv`).
///
/// Why: a held vertex moves along the normal exactly as its contact prescribes: the surface's
/// velocity, or toward the surface within the slop. Where the membrane would lift it faster,
/// the impulse that holds it pulls: cloth lying on the floor stayed glued to it when a corner
/// was lifted (measured: an edge stretched 25× in 1.5 s), and the rim of a drape was drawn
/// toward a sphere against its tension at every step, which put energy in: the energy
/// balance redid 304 / 5 / 535 of 600 steps at 21 / 31 / 41 per side. A vertex let go moves
/// away from the surface by itself (for one contact, `n·Δv_free = target − λ nᵀA⁻¹n` with
/// `λ < 0`), so it does not enter. Letting go only from the next substep on (no second
/// solve) was measured too: 11 % faster at 81×81, but a fine cloth (1.25 mm edges, 1 mm
/// thickness) then churned: hundreds of vertices per step held, let go, fallen in and
/// projected out, still moving at 0.29 m/s after 1 s where two substeps rest (5e-5 m/s).
/// Held for good, the thin colliders' edge and face contacts froze the corners that touch a
/// small sphere themselves (three of them hold every direction).
pub(crate) fn release(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
) -> Result<(u32, bool), StepError> {
    if !collide_on(c, st) {
        return Ok((0, false));
    }
    lend(a, |a, lent| release_pulling(a, c, st, sub, lent))
}

/// After a solve: holds every free vertex that the solve's own velocity `v + Δv` carries a
/// little way into a collider within the substep (its vertex contacts, predicted as at the
/// substep's start but from the end velocity, [`Scene::end_touch`]), for the solve to go on
/// with it held. Returns how many vertices it held, listed in `a.w_s` after the `listed` ones
/// [`release`] let go there (which it leaves free: they were just let go for pulling).
/// A vertex held only by the contacts of edges or faces around it, with no contact of its
/// own, counts as free here: those contacts hold it along their normals, and its free
/// directions carry it into the collider as well. Its hold is made again, its own contacts
/// first (their normals are its first axes, below). Skipped, it was carried in and projected
/// out at every substep: a strip resting on a sphere beside a vertex pinned inside it (the
/// edges to the pin cut through the sphere) had three such vertices carried ~0.1 mm in and put
/// back against 28 kN, +9 J in a step from rest, which the balance refused, so the strip was
/// held still at every step once it had come to rest (`tests/hard_cases.rs`).
///
/// Why: contacts are predicted from the velocity at the substep's start, so a vertex at rest
/// beside a collider, which the membrane or gravity accelerates into it within the substep,
/// was not held in the solve; it ended inside and the projection moved it back by position
/// against its neighbours. On a stiff fabric that made stretch: measured, up to 2.5e-2 J in a
/// substep from moving vertices by ~1e-4 m (7.4e5 N/m). For a still collider that is the step's
/// own gain (the projection is no input), and more substeps do not shrink it: the energy
/// balance redid such a step up to 32× and then held the cloth still at its start, which made
/// the next step the same, and the cloth froze in its collider for good.
///
/// The hold only slows an approach the solve made (an inelastic stop), and the test is
/// relative to the collider's surface, so a scene carried as a whole does what it does at rest.
/// Like every contact it holds only while it pushes ([`release`], in the next round). Only a
/// small overshoot is held: a resting contact the prediction missed. A large one is an impact
/// the solve made, left to the projection and the next substep's prediction as before.
/// Measured: a sphere moving through a pinned cloth at 50 m/s, which carries it, has the
/// membrane pull vertices back into it at 10–25 m/s; held, they kept the cloth on the sphere a
/// frame longer (3.3e4 J of stretch, input) and its snap-back peaked at 976 J of kinetic
/// energy, against 170 J without and the test's bound of an elastic bounce, 750 J
/// (`tests/hard_cases.rs`). Only the vertex's own contacts: the thin colliders' edge and face
/// contacts are predicted at the substep's start alone (engaged too, they broke the thin
/// colliders' tests: redos and a pole that lifted the cloth 10 % too fast).
pub(crate) fn engage(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
    listed: u32,
) -> Result<u32, StepError> {
    if !collide_on(c, st) {
        return Ok(0);
    }
    lend(a, |a, lent| engage_reaching(a, c, st, sub, lent, listed))
}

/// [`engage`] on the lent arrays.
fn engage_reaching(
    a: &Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
    lent: &mut Lent<'_>,
    listed: u32,
) -> Result<u32, StepError> {
    let n = c.n;
    let pins = pins_on(c, st);
    // A vertex that only the contacts of edges or faces around it hold: held, but by no
    // contact of its own. Only a sphere or a capsule makes such contacts, and the edge and
    // face tests (and the longest edge they need) are made only when such a vertex exists,
    // which is rare.
    let colliders = live(a.colliders, c.colliders)?;
    let by_edges_alone = |contact: u32, filter: &Mat3A| {
        *filter != Mat3A::IDENTITY && collider_of(contact) >= colliders.len()
    };
    let edge_held = colliders.iter().any(|col| col.shape.between_vertices())
        && live(lent.contact, n)?
            .iter()
            .zip(live(lent.filter, n)?)
            .zip(live(a.pin_of, n)?)
            .any(|((&contact, filter), &pin)| {
                !(pins && pin != mesh::NONE) && by_edges_alone(contact, filter)
            });
    let scene = scene(a, c, st, sub, edge_held)?;
    let list: &mut [u32] = bytemuck::cast_slice_mut(live_mut(lent.list, n)?);
    let (just_released, rest) = list.split_at_mut((listed as usize).min(n));
    let mut engaged = 0usize;
    let vertices = live_mut(lent.contact, n)?
        .iter_mut()
        .zip(live_mut(lent.filter, n)?.iter_mut())
        .zip(live_mut(lent.dv, n)?.iter_mut().zip(live(lent.dropped, n)?))
        .zip(live(a.pin_of, n)?.iter().zip(scene.x.iter().zip(scene.v)));
    for (i, (((contact, filter), (dv, &dropped)), (&pin, (&xi, &vi)))) in vertices.enumerate() {
        if pins && pin != mesh::NONE {
            continue;
        }
        let edges_alone = by_edges_alone(*contact, filter);
        if !(*filter == Mat3A::IDENTITY || edges_alone) {
            continue;
        }
        let mut hold = Hold::default();
        hold.held.start = vi;
        let mut deepest = f32::INFINITY;
        let mut spare = None;
        for (k, col) in scene.sweep.colliders.iter().enumerate() {
            let placed = scene.sweep.placed(k, col, &mut spare);
            let Some(touch) = scene.end_touch(placed, xi, vi + *dv) else {
                continue;
            };
            hold.held.add(touch.normal, touch.target, touch.vs);
            if touch.depth < deepest {
                deepest = touch.depth;
                hold.primary = Some((k, touch.vs));
            }
        }
        // `release` lists its vertices in ascending order: a search, not a scan per vertex
        // (a scan made many catches among many releases quadratic)
        if hold.held.count == 0 || just_released.binary_search(&(i as u32)).is_ok() {
            continue;
        }
        // The vertex's own contacts are its first axes, and the edges' and faces' ride on
        // them where nearly parallel (`Held::add`): the other way round its own contact rode
        // on an edge's axis up to ~12° off its normal, and the solve slid it along that
        // axis's plane into the collider (a strip resting on a sphere beside a vertex pinned
        // inside it: 3.8 mm along it, 0.5 mm in, projected back against the tension, +35 J
        // in a step from rest, refused at every step). They have no bit in a dropped set
        // (`release` makes the hold again from the scene's contacts alone).
        if edges_alone {
            hold = scene.hold_onto(hold, i, has_flag(*contact, STRICT), dropped);
        }
        *contact = hold.state(*contact);
        hold.prescribe(*contact, vi, filter, dv);
        *rest.get_mut(engaged).ok_or(StepError::SolverBreakdown)? = i as u32;
        engaged += 1;
    }
    Ok(engaged as u32)
}

/// The arrays the contact stages change ([`hold_all`], [`release`]), lent out of the world's
/// while the scene reads the rest.
struct Lent<'a> {
    contact: &'a mut [u32],
    dropped: &'a mut [u32],
    filter: &'a mut [Mat3A],
    dv: &'a mut [Vec3A],
    /// `w_s`, the PCG's scratch, which no one reads between two solves: the vertices let go,
    /// listed for the next solve (`system::Resume`).
    list: &'a mut [Vec3A],
}

/// Runs `stage` with the [`Lent`] arrays taken out of `a`, and puts them back.
fn lend<'a, R>(a: &mut Arrays<'a>, stage: impl FnOnce(&Arrays<'a>, &mut Lent<'a>) -> R) -> R {
    let mut lent = Lent {
        contact: core::mem::take(&mut a.contact),
        dropped: core::mem::take(&mut a.contact_dropped),
        filter: core::mem::take(&mut a.filter),
        dv: core::mem::take(&mut a.dv),
        list: core::mem::take(&mut a.w_s),
    };
    let result = stage(a, &mut lent);
    let Lent {
        contact,
        dropped,
        filter,
        dv,
        list,
    } = lent;
    (a.contact, a.contact_dropped, a.filter, a.dv, a.w_s) = (contact, dropped, filter, dv, list);
    result
}

/// [`release`] on the lent arrays. A vertex held by its own contact alone is let go when that
/// pulls (`ALONE`: its normal is the collider's at the vertex). One held by several contacts
/// (grooves, the thin colliders' edge and face contacts) lets go of those that pull: its
/// impulse is split into the contacts' normals ([`Hold::pulling`]), the pulling ones join its
/// dropped set, and the rest hold it, their filter and velocities set again (the free
/// directions keep the solve's `Δv`). Pinned vertices stay held, and so do sticking ones
/// with several contacts (friction decides there, in [`resolve`]).
fn release_pulling(
    a: &Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
    lent: &mut Lent<'_>,
) -> Result<(u32, bool), StepError> {
    let n = c.n;
    let pins = pins_on(c, st);
    let sweep = Sweep::new(live(a.colliders, c.colliders)?, sub);
    // the full scene (its edge and face tests) only where a vertex has several contacts
    let mut several = None;
    let (mut released, mut moved) = (0, false);
    let list: &mut [u32] = bytemuck::cast_slice_mut(live_mut(lent.list, n)?);
    let vertices = live_mut(lent.contact, n)?
        .iter_mut()
        .zip(live_mut(lent.dropped, n)?.iter_mut())
        .zip(live_mut(lent.filter, n)?.iter_mut())
        .zip(live_mut(lent.dv, n)?.iter_mut())
        .zip(
            live(a.pin_of, n)?
                .iter()
                .zip(live(a.x, n)?.iter().zip(live(a.v, n)?)),
        )
        .zip(live(a.w_q, n)?.iter().zip(live(a.rhs, n)?));
    for (i, (((((contact, dropped), filter), dv), (&pin, (&xi, &vi))), (&aq, &b))) in
        vertices.enumerate()
    {
        if *filter == Mat3A::IDENTITY || (pins && pin != mesh::NONE) {
            continue;
        }
        let kept = if has_flag(*contact, ALONE) {
            let k = collider_of(*contact);
            let Some(col) = sweep.colliders.get(k) else {
                continue;
            };
            let normal = sweep.placed(k, col, &mut None).before.proximity(xi).normal;
            if (aq - b).dot(normal) >= 0.0 {
                continue;
            }
            None
        } else if has_flag(*contact, STICK) {
            continue;
        } else {
            let scene = match &mut several {
                Some(scene) => scene,
                None => several.insert(scene(a, c, st, sub, true)?),
            };
            let strict = has_flag(*contact, STRICT);
            let hold = scene.hold(i, strict, *dropped);
            let pulling = hold.pulling((Mat3A::IDENTITY - *filter) * (aq - b));
            if pulling == 0 {
                continue;
            }
            *dropped |= pulling;
            Some(scene.hold(i, strict, *dropped)).filter(|kept| kept.held.count > 0)
        };
        match kept {
            Some(kept) => {
                // friction acts through the deepest vertex contact still held, if any (not
                // sticking: a sticking vertex with several contacts was passed over above)
                let flags = *contact & FLAGS;
                *contact = match kept.primary {
                    Some((k, _)) => k as u32 | flags,
                    None if flags == 0 => mesh::NONE,
                    None => NO_COLLIDER | flags,
                };
                let before = dv.to_array().map(f32::to_bits);
                kept.prescribe(*contact, vi, filter, dv);
                moved |= dv.to_array().map(f32::to_bits) != before;
            }
            None => {
                *contact = NO_COLLIDER | LET_GO;
                *filter = Mat3A::IDENTITY;
            }
        }
        *list
            .get_mut(released as usize)
            .ok_or(StepError::SolverBreakdown)? = i as u32;
        released += 1;
    }
    Ok((released, moved))
}

/// The work (J) moving pins and colliders did on the cloth during the solve: the constraint
/// impulse `J = (I − S)(A Δv − rhs)` (`a.w_q` holds `A Δv`, see `system::solve`) times the
/// velocity of what holds the vertex (a pin's target, the surfaces of its contacts: along each
/// contact normal the velocity of that contact's surface). Still pins and colliders do no
/// work: their impulses only redirect motion.
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
        for (vertex, previous, target, free) in
            pins_of((a.pin_vertex, a.pin_previous, a.pin_target, a.pin_free), c)?
        {
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
        // the same contacts `constrain` held (the state is unchanged until `integrate`); a
        // still collider's surfaces do not move
        let colliders = live(a.colliders, c.colliders)?;
        let moving = colliders.iter().any(|col| col.previous != col.shape);
        let scene = if moving {
            Some(scene(a, c, st, sub, true)?)
        } else {
            None
        };
        let sweep = Sweep::new(colliders, sub);
        let vertices = live(a.contact, n)?
            .iter()
            .zip(live(a.contact_dropped, n)?)
            .zip(live(a.pin_of, n)?)
            .zip(live(a.filter, n)?)
            .zip(w_q.iter().zip(rhs))
            .zip(live(a.v, n)?.iter().zip(live(a.dv, n)?))
            .zip(live(a.mass, n)?.iter().zip(live(a.x, n)?));
        for (i, ((((((&contact, &dropped), &pin), &filter), (&aq, &b)), (&v, &dv)), (&mass, &x))) in
            vertices.enumerate()
        {
            if pin != mesh::NONE || filter == Mat3A::IDENTITY {
                continue;
            }
            let surface = match &scene {
                Some(scene) => {
                    let hold = scene.hold(i, has_flag(contact, STRICT), dropped);
                    let stuck = match hold.primary {
                        Some((_, vs)) if contact & STICK != 0 => vs,
                        _ => Vec3A::ZERO,
                    };
                    hold.held.surface_velocity(stuck)
                }
                None => Vec3A::ZERO,
            };
            let held = Mat3A::IDENTITY - filter;
            let impulse = held * (aq - b);
            work += f64::from(impulse.dot(surface));
            // A contact that pushes a vertex out faster than its surface moves (out of a
            // penetration, at up to `max_depenetration_speed`) puts in what its impulse does
            // in the implicit step, relative to the surface. For linear forces implicit Euler
            // keeps `E₁ − E₀ = J·v₁ − ½ Δvᵀ M Δv − ½ Δxᵀ K Δx` (damping takes more): the
            // held impulse at the *end* velocity, less the step's own dissipation. Its inertial
            // part, the momentum it changes, `J_m = m Δv` (on the held axes), is counted at the
            // vertex's mean velocity, `J_m·(v + ½Δv − v_s)`: exactly the kinetic energy it gives
            // the vertex (at the end velocity it would also credit the vertex's own share of
            // the dissipation, `½ m Δv²`). The rest, the load `J − J_m` that holds the vertex
            // against the membrane, bending and gravity at the substep's end, does
            // `(J − J_m)·(v + Δv − v_s)` as the vertex moves. So a push from rest in the cloth's
            // plane is credited what the step puts in, and the balance reads exactly the free
            // vertices' dissipation, `−(½ Σ m Δv² + ½ Δxᵀ K Δx)` (`tests/hard_cases.rs`,
            // within 1.4 %). At the mean velocity, or by the trapezoid rule between the start's
            // `−rhs` and that end load, a push against a load that grows within the substep
            // was credited less than the step puts in: the balance read a push from rest as
            // gaining nothing at best, and a harder one as a gain to redo (at the mean
            // velocity: a tent pushed up by a sphere appearing under it, adversarial seed 5161
            // at 46 of its steps). Against a load that falls, the trapezoid credited more, and
            // covered the linearized step's own gains: seeds 5240 (cloth sliding on a plane
            // that oscillates under it) and 5203 (stiff cloth pushed out of a shell at up to
            // 37 m/s) are now redone at 93 and 130 of their steps (16 and 76).
            // Stopped or drawn toward its surface, a vertex gives energy up: the step's own
            // loss, not counted.
            // Only a vertex's own contact pushes it out of a penetration, and only while its
            // impulse pushes. An edge's or a face's contact never pushes (its target only stops
            // an approach), and a contact that still pulls after the release rounds (the
            // impulses of a solve that did not converge) drags its vertex along: what either
            // puts in is the step's own, for the balance to see. Credited, it hid a tenfold
            // rise (adversarial scene 5108: a pulling face contact on a 1.3 cm sphere, 0.22 J
            // credited to a 0.02 J cloth among still colliders).
            // And it pushes out of a penetration only from inside, and only as far as it was
            // inside (beyond `Placed::allowance`: the slop's tenth of the thickness and the
            // rounding of the distance): the credit is the share of the push's way that lies
            // inside. A vertex resting on a surface that its contact moves off it (a target
            // raised by a nearly parallel edge contact, a solve's error) against a large load
            // gains what nothing outside supplied: a strip resting on a sphere beside a vertex
            // pinned inside it (0.6 mm/s off the surface against 28 kN) was credited ~1 J a
            // step and oscillated on it for good (`tests/hard_cases.rs`).
            let k = collider_of(contact);
            let Some((normal, depth)) = colliders.get(k).and_then(|col| {
                let mut spare = None;
                let (normal, depth) = sweep.placed(k, col, &mut spare).beyond_allowance(x, 0.0)?;
                (impulse.dot(normal) > 0.0).then_some((normal, depth))
            }) else {
                continue;
            };
            let inertial = held * (dv * mass);
            let pushed =
                inertial.dot(v + 0.5 * dv - surface) + (impulse - inertial).dot(v + dv - surface);
            let out = sub.h * (v + dv - surface).dot(normal);
            let share = if out > depth { depth / out } else { 1.0 };
            work += f64::from(pushed.max(0.0) * share);
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
    let pins = pins_on(c, st);
    let mut contacts = 0;
    let mut work = 0.0f64;
    if collide_on(c, st) {
        // The projection moves vertices by position. Where a moving collider pushes, or a
        // vertex began the substep deeper inside a collider than its contact could push it
        // out of (the engine put it there, or a collider appeared around it), that is work
        // done on the cloth from outside: the potential energy those pushes change is input
        // to the energy balance (measured, as it can be far from linear). A still collider's
        // projection of a vertex that entered during the substep is not input: a gain there
        // is the step's own, whatever else moves. So the still projections come first, and
        // only what the pushes change after them is counted.
        let (still_contacts, still_work, pushes) = project(a, c, st, sub, Pass::Still)?;
        contacts += still_contacts;
        work += still_work;
        if pushes {
            let before = monitor::potential(a, c, st)?;
            let (pushed_contacts, pushed_work, _) = project(a, c, st, sub, Pass::Pushes)?;
            contacts += pushed_contacts;
            work += pushed_work;
            // What the pushes put in. Where they took potential energy out instead, that is
            // the step's loss, not negative input: counted, it let the balance demand that
            // loss back from the rest of the step (an outside fuzzer's 9×9 cloth inside
            // oscillating colliders: a 378 J stretch projected away, read as −378 J of input,
            // and every later step refused).
            work += (monitor::potential(a, c, st)? - before).max(0.0);
        }
    }
    if pins {
        place_pins(a, c, sub.t)?;
    }
    Ok((contacts, work))
}

/// Which projections a pass of [`project`] makes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// Friction, and the projections that are the step's own: out of still colliders, of
    /// vertices that entered them during the substep.
    Still,
    /// The pushes: out of moving colliders, and out of any collider a vertex began the
    /// substep deeper inside than `0.1·thickness + h·max_depenetration_speed` and the
    /// rounding of its distance (`Shape::rounding`).
    Pushes,
}

/// One pass of the projection (see [`Pass`]) over the free vertices. Returns the vertices it
/// newly touched (the second pass does not count those the first touched), the kinetic work
/// (J) moving surfaces did through the velocity they changed, and whether it left a push for
/// the second pass (the first pass marks the vertices in `a.w_p` and keeps where each began
/// the substep in `a.w_c`: both are free between the solve and the next substep).
fn project(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
    pass: Pass,
) -> Result<(u32, f64, bool), StepError> {
    let (n, h) = (c.n, sub.h);
    let pins = pins_on(c, st);
    let mut pushes_left = false;
    let (mut contacts, mut work) = (0u32, 0.0f64);
    // How deep a vertex may begin the substep inside a collider and still be the step's own
    // (its contact pushes it out): `Placed::allowance` with what the depenetration speed moves
    // in the substep. Without the allowance's rounding a collider of thickness zero with no
    // depenetration speed allowed no depth at all, and a vertex resting on it a rounding
    // inside was taken for one put there from outside: the whole projection after its motion
    // in the substep, millimetres, was credited as input (adversarial scene 12035: a disc in a
    // shell of thickness zero gained 67 % of its energy in a step whose balance read a loss).
    let depenetration = h * st.max_depenetration_speed;
    let sweep = Sweep::new(live(a.colliders, c.colliders)?, sub);
    let held = live(a.pin_of, n)?
        .iter()
        .zip(live(a.mass, n)?)
        .zip(live(a.w_q, n)?.iter().zip(live(a.rhs, n)?));
    let moving = live_mut(a.x, n)?
        .iter_mut()
        .zip(live_mut(a.v, n)?.iter_mut())
        .zip(live_mut(a.contact, n)?.iter_mut())
        .zip(
            live_mut(a.w_c, n)?
                .iter_mut()
                .zip(live_mut(a.w_p, n)?.iter_mut()),
        );
    for (((&pin, &mass), (&aq, &b)), (((xi, vi), contact), (mark, seen))) in held.zip(moving) {
        if pins && pin != mesh::NONE {
            continue;
        }
        let mut touched = false;
        let v_before = *vi;
        let mut vs_held = Vec3A::ZERO;
        if pass == Pass::Still {
            // where the vertex began the substep: x was just advanced by exactly h v (friction
            // changes v below, so the second pass reads it here)
            *mark = *xi - *vi * h;
            // Coulomb friction from the solve's own contact impulse `J = A Δv − rhs` (`a.w_q`
            // holds `A Δv`): a sticking contact keeps sticking while `|J_t| ≤ μ J_n`; a
            // sliding one loses at most `μ J_n / m` of its tangential velocity relative to the
            // surface. It sticks again once that stops it *and* the static cone holds its own
            // load (the tangential part of `rhs`, the impulse of its forces over the substep).
            // Without the second test a vertex whose neighbours pull it along cycled: held, it
            // needs more than `μ J_n` (the hold also stops the neighbours it drags), so it
            // slides; sliding alone, its velocity is small enough for `μ J_n / m` to stop it,
            // so it sticks. Each cycle moved it by `h v_t`: a drape let go at its rim crept at
            // ~1 mm/s forever (41×41 on a sphere, 50 such vertices per step). On a uniform
            // incline both tests are Coulomb's `tan θ ≤ μ`.
            let k = collider_of(*contact);
            if let Some(col) = sweep.colliders.get(k) {
                let mut spare = None;
                let placed = sweep.placed(k, col, &mut spare);
                let vs = placed.surface_velocity(*xi, h);
                let nrm = placed.after.proximity(*xi).normal;
                let impulse = aq - b;
                let normal = impulse.dot(nrm).max(0.0);
                let limit = col.friction * normal;
                let tangential = |j: Vec3A| j - nrm * j.dot(nrm);
                if *contact & STICK != 0 {
                    if tangential(impulse).length() > limit {
                        *contact &= !STICK;
                    }
                } else {
                    let vt = tangential(*vi - vs);
                    let vt_len = vt.length();
                    let stop = limit / mass.max(f32::MIN_POSITIVE);
                    if vt_len <= stop {
                        *vi -= vt;
                        if tangential(b).length() <= limit {
                            *contact |= STICK;
                        }
                    } else {
                        *vi -= vt * (stop / vt_len);
                    }
                }
                vs_held = vs;
                touched = true;
            }
        }
        // Whether the first pass touched the vertex already, and whether a push reaches it
        // (`seen`'s x and y, written below).
        let start = *mark;
        let (counted, pushed) = match pass {
            Pass::Still => (false, false),
            Pass::Pushes => (seen.x != 0.0, seen.y != 0.0),
        };
        if pass == Pass::Pushes && !pushed {
            continue;
        }
        // Projection: nothing ends the substep deeper than `thickness`. The first pass leaves
        // the pushes out; a vertex a push reaches goes through every collider again in the
        // second, so that one pushed into a still collider ends outside it too (that
        // projection is the push's doing).
        let mut pushes = false;
        let mut spare = None;
        for (k, col) in sweep.colliders.iter().enumerate() {
            let placed = sweep.placed(k, col, &mut spare);
            let shape = &placed.after;
            if shape.proximity(*xi).distance >= col.thickness {
                continue;
            }
            if pass == Pass::Still && placed.pushes(start, depenetration) {
                pushes = true;
                continue;
            }
            let vs = placed.surface_velocity(*xi, h);
            let hit = collide::resolve(shape, vs, col.thickness, col.friction, xi, vi);
            if hit && vs != Vec3A::ZERO {
                vs_held = vs;
            }
            touched |= hit;
        }
        pushes_left |= pushes;
        if touched && has_flag(*contact, LET_GO) {
            // it reached a surface after all: the next substep holds it as any other
            *contact = mesh::NONE;
        }
        if touched && vs_held != Vec3A::ZERO {
            // a moving surface does work m Δv · v_s through what it changed
            work += f64::from(mass * (*vi - v_before).dot(vs_held));
        }
        contacts += (touched && !counted) as u32;
        if pass == Pass::Still {
            *seen = Vec3A::new(
                f32::from(u8::from(touched)),
                f32::from(u8::from(pushes)),
                0.0,
            );
        }
    }
    Ok((contacts, work, pushes_left))
}

/// Puts the pinned vertices on their targets (the held directions of them) as they are at the
/// fraction `t` of the step (the targets move linearly across it).
pub(crate) fn place_pins(a: &mut Arrays<'_>, c: &Counts, t: f32) -> Result<(), StepError> {
    let x = live_mut(a.x, c.n)?;
    for (vertex, previous, target, free) in
        pins_of((a.pin_vertex, a.pin_previous, a.pin_target, a.pin_free), c)?
    {
        // pinned vertices are < n
        let xi = x
            .get_mut(vertex as usize)
            .ok_or(StepError::SolverBreakdown)?;
        let target = previous.lerp(target, t);
        *xi = if free == Mat3A::ZERO {
            target
        } else {
            // onto the plane or line through the target, along the held directions
            *xi + (Mat3A::IDENTITY - free) * (target - *xi)
        };
    }
    Ok(())
}

/// Puts the free vertices out of the still colliders by position alone, as the substep's
/// projection will (its still pass, [`Pass::Still`]): what the energy-limited end
/// (`system::limit`) weighs of it. `a.w_c` holds where each vertex began the substep. Left
/// where they are: the pushes, which the balance counts as input (a moving collider's, and a
/// vertex that began deeper than its allowance). Velocities are not touched: the projection
/// also takes a vertex's velocity into the surface away, so the limit's end weighs at most
/// the kinetic energy the substep ends with.
pub(crate) fn place_outside_still(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
    sub: Substep,
) -> Result<(), StepError> {
    if !collide_on(c, st) {
        return Ok(());
    }
    let pins = pins_on(c, st);
    let depenetration = sub.h * st.max_depenetration_speed;
    let sweep = Sweep::new(live(a.colliders, c.colliders)?, sub);
    let vertices = live_mut(a.x, c.n)?
        .iter_mut()
        .zip(live(a.w_c, c.n)?.iter().zip(live(a.pin_of, c.n)?));
    for (xi, (&start, &pin)) in vertices {
        if pins && pin != mesh::NONE {
            continue;
        }
        let mut spare = None;
        for (k, col) in sweep.colliders.iter().enumerate() {
            let placed = sweep.placed(k, col, &mut spare);
            if placed.after.proximity(*xi).distance >= col.thickness
                || placed.pushes(start, depenetration)
            {
                continue;
            }
            let mut v = Vec3A::ZERO;
            collide::resolve(&placed.after, Vec3A::ZERO, col.thickness, 0.0, xi, &mut v);
        }
    }
    Ok(())
}

/// Puts every free vertex out of every collider, where the colliders are at the end of the
/// step: what each substep's projection does, for a cloth held still (`World::stop`), whose
/// vertices keep no velocity. Pinned vertices are left to their pins, and a vertex inside two
/// colliders ends outside the later one, as in the projection. Returns whether any moved.
pub(crate) fn place_outside(
    a: &mut Arrays<'_>,
    c: &Counts,
    st: &Settings,
) -> Result<bool, StepError> {
    if !collide_on(c, st) {
        return Ok(false);
    }
    let pins = pins_on(c, st);
    let colliders = live(a.colliders, c.colliders)?;
    let mut moved = false;
    for (xi, &pin) in live_mut(a.x, c.n)?.iter_mut().zip(live(a.pin_of, c.n)?) {
        if pins && pin != mesh::NONE {
            continue;
        }
        for col in colliders {
            let mut v = Vec3A::ZERO;
            moved |= collide::resolve(&col.shape, Vec3A::ZERO, col.thickness, 0.0, xi, &mut v);
        }
    }
    Ok(moved)
}

/// Every pin as `(vertex, previous target, target, free directions)`: the target moves from
/// the previous one to the current one over the step.
///
/// Takes the pin arrays, not the world's, so that a caller may hold other arrays mutably.
fn pins_of<'p>(
    (vertex, previous, target, free): (&'p [u32], &'p [Vec3A], &'p [Vec3A], &'p [Mat3A]),
    c: &Counts,
) -> Result<impl Iterator<Item = (u32, Vec3A, Vec3A, Mat3A)> + 'p, StepError> {
    let pinned = live(vertex, c.pins)?
        .iter()
        .zip(live(previous, c.pins)?)
        .zip(live(target, c.pins)?.iter().zip(live(free, c.pins)?));
    Ok(pinned.map(|((&vertex, &previous), (&target, &free))| (vertex, previous, target, free)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the balance credits as input from a substep's projection is what the pushes
    /// change (a moving collider, here), not a still collider's projection of a vertex that
    /// the substep itself carried into it, even when both happen in one substep: crediting
    /// the whole projection hid the still collider's gain from the balance whenever anything
    /// else moved. A 5×5 sheet at rest: its centre vertex falls 5 cm into a still sphere
    /// within the substep (projected above its rest height: the stretch and the height it
    /// gains are the step's own), while a sphere that moved this step overlaps the far corner
    /// (no element holds both vertices, so the energies of the two projections add), which
    /// also rests a little inside another still sphere.
    #[test]
    fn only_the_pushes_of_a_projection_are_input() {
        use crate::collide::{Collider, Shape};
        let nx = 5usize;
        let n = nx * nx;
        let grid = crate::world::TestGrid::new(nx, 1.0);
        let positions = &grid.positions;
        let (centre, corner) = (2 * nx + 2, n - 1);
        let h = 1.0 / 60.0;
        // The credited work, the potential before and after the projection, the vertices
        // touching a collider.
        let project = |still: bool| -> (f64, f64, f64, u32) {
            let mut mem = grid.memory();
            let mut w = grid.world(&mut mem);
            let mut v = vec![[0.0f32; 3]; n];
            v[centre] = [0.0, 0.0, -3.0]; // it began the substep 5 cm above where it is
            w.set_velocities(&v).unwrap();
            let c = positions[centre];
            if still {
                // top 3 cm above the centre vertex, clear of its neighbours (25 cm away)
                let sphere = Shape::Sphere {
                    center: Vec3A::new(c[0], c[1], -0.07),
                    radius: 0.1,
                };
                w.add_collider(Collider::new(sphere, 0.0, 0.01)).unwrap();
            }
            let p = Vec3A::from(positions[corner]);
            // The corner rests 3 mm inside a still sphere too (not deep: the first pass puts
            // it back), so both passes touch it.
            let under = Shape::Sphere {
                center: p - Vec3A::new(0.0, 0.0, 0.047),
                radius: 0.05,
            };
            w.add_collider(Collider::new(under, 0.0, 0.01)).unwrap();
            let at = |dx: f32| Shape::Sphere {
                center: p + Vec3A::new(dx, 0.0, 0.0),
                radius: 0.1,
            };
            let id = w.add_collider(Collider::new(at(0.2), 0.0, 0.01)).unwrap();
            w.set_collider_shape(id, at(0.095)).unwrap(); // moved 10.5 cm onto the corner
            let (a, c, st) = w.stage();
            let before = monitor::potential(a, &c, &st).unwrap();
            let sub = Substep { h, t0: 0.0, t: 1.0 };
            let (touching, work) = resolve(a, &c, &st, sub).unwrap();
            (
                work,
                before,
                monitor::potential(a, &c, &st).unwrap(),
                touching,
            )
        };
        let (with_still, before, after, touching) = project(true);
        let (push_alone, alone_before, alone_after, touching_alone) = project(false);
        // each vertex counted once, whichever passes touched it (the corner: both)
        assert_eq!((touching, touching_alone), (2, 1));
        let pushed = alone_after - alone_before;
        let own = (after - before) - pushed;
        assert!(
            pushed > 1e-6,
            "the push changed the potential by {pushed} J"
        );
        assert!(own > 1e-4, "the still projection changed it by {own} J");
        assert!(
            (with_still - push_alone).abs() <= 1e-9,
            "credited {with_still} J with the still sphere, {push_alone} J without (its own \
             projection: {own} J)"
        );
    }

    /// A vertex that began the substep on a still collider's surface to within the rounding
    /// of its distance (where the projection of the substep before put it) was not put there
    /// by anything from outside: its projection at the end is the step's own, not input. With
    /// a thickness of zero and no depenetration speed the depth allowed at the start was zero,
    /// so a start a rounding inside counted as a push and the balance credited the whole
    /// projection after the substep's motion, millimetres (adversarial scene 12035: a disc
    /// inside a shell of thickness zero gained 67 % of its energy in a step whose balance
    /// read a loss). The centre vertex of a 5×5 sheet ends 2 mm inside a still sphere of
    /// thickness zero, having begun the substep a quarter of that rounding inside it, with no
    /// depenetration speed; a start 1 mm inside (the engine put it there) is still a push.
    #[test]
    fn a_start_within_rounding_of_a_still_surface_is_no_push() {
        use crate::collide::{Collider, Shape};
        let nx = 5usize;
        let n = nx * nx;
        let grid = crate::world::TestGrid::new(nx, 1.0);
        let centre = 2 * nx + 2;
        let p = Vec3A::from(grid.positions[centre]);
        let h = 1.0 / 60.0;
        let radius = 0.5f32;
        // the sphere's top 2 mm above the centre vertex (its neighbours, 25 cm away, clear)
        let ball = Shape::Sphere {
            center: p - Vec3A::new(0.0, 0.0, radius - 0.002),
            radius,
        };
        let credited = |inside: f32| -> f64 {
            let mut mem = grid.memory();
            let mut w = grid.world(&mut mem);
            // it began the substep `inside` below the top: `x − h v`
            let start = p + Vec3A::new(0.0, 0.0, 0.002 - inside);
            let mut v = vec![[0.0f32; 3]; n];
            v[centre] = ((p - start) / h).into();
            w.set_velocities(&v).unwrap();
            let settings = Settings {
                max_depenetration_speed: 0.0,
                ..Settings::default()
            };
            w.set_settings(settings).unwrap();
            w.add_collider(Collider::new(ball, 0.0, 0.0)).unwrap();
            let began = p - Vec3A::from(v[centre]) * h;
            let depth = -ball.proximity(began).distance;
            assert!(
                depth > 0.0 && (inside > 1e-4 || depth <= ball.rounding(began)),
                "the start is {depth} m inside (rounding {})",
                ball.rounding(began)
            );
            let (a, c, st) = w.stage();
            let sub = Substep { h, t0: 0.0, t: 1.0 };
            let (touching, work) = resolve(a, &c, &st, sub).unwrap();
            assert_eq!(touching, 1);
            work
        };
        let rounding = ball.rounding(p + Vec3A::new(0.0, 0.0, 0.002));
        let own = credited(0.25 * rounding);
        assert_eq!(own, 0.0, "a start a rounding inside was credited {own} J");
        let pushed = credited(1e-3);
        assert!(pushed > 0.0, "a start 1 mm inside was credited {pushed} J");
    }

    /// The work a held vertex's contact is credited with (input to the energy balance) is a
    /// push's out of a penetration: the vertex's own contact pushing it out along the
    /// collider's normal from inside, for as far as it was inside. The centre vertex of a 5×5
    /// sheet is held by a still sphere (normal +z there) and its hold is given an impulse and a
    /// velocity change along the normal. Pushed out from 1 cm inside, it is credited what the
    /// impulse does; pushed out from 1 mm inside, over 1.7 mm, only the first millimetre's
    /// share. Nothing is credited when it is pulled in while moving in (a contact still pulling
    /// after the release rounds), when it is held only by an edge's or a face's contact (no
    /// contact of its own), or when it starts on the surface, though the impulse does work in
    /// each. Credited, a pulling face contact hid a tenfold rise of adversarial scene 5108's
    /// energy; and a vertex resting on a sphere beside a vertex pinned inside it, pushed out a
    /// little by the contacts of the edges to the pin (0.6 mm/s against 28 kN) and drawn back
    /// by their tension, was credited ~1 J a step, on which the strip oscillated for good
    /// (`tests/hard_cases.rs`, the strip held still inside a sphere).
    #[test]
    fn only_a_push_of_a_vertexs_own_contact_out_of_a_penetration_is_input() {
        use crate::collide::{Collider, Shape};
        let nx = 5usize;
        let grid = crate::world::TestGrid::new(nx, 1.0);
        let centre = 2 * nx + 2;
        let p = Vec3A::from(grid.positions[centre]);
        let credited = |own: bool, impulse: f32, dv: f32, depth: f32| -> f64 {
            let ball = Shape::Sphere {
                center: p - Vec3A::new(0.0, 0.0, 0.5),
                radius: 0.5 + depth,
            };
            let mut mem = grid.memory();
            let mut w = grid.world(&mut mem);
            w.add_collider(Collider::new(ball, 0.0, 0.0)).unwrap();
            let (a, c, st) = w.stage();
            let z = Vec3A::Z;
            a.contact[centre] = if own { 0 } else { mesh::NONE };
            a.filter[centre] = Mat3A::IDENTITY - outer(z, z);
            a.rhs[centre] = Vec3A::ZERO;
            a.w_q[centre] = z * impulse; // the impulse `A Δv − rhs`
            a.dv[centre] = z * dv;
            let sub = Substep {
                h: 1.0 / 60.0,
                t0: 0.0,
                t: 1.0,
            };
            constraint_work(a, &c, &st, sub).unwrap()
        };
        let push = credited(true, 1.0, 0.1, 0.01);
        assert!(push > 0.09, "a push out was credited {push} J");
        let short = credited(true, 1.0, 0.1, 0.001);
        assert!(
            (short / push - 0.6).abs() < 0.01,
            "a push 1.7 times as far as the depth was credited {short} J of {push} J"
        );
        let pull = credited(true, -1.0, -0.1, 0.01);
        assert_eq!(pull, 0.0, "a pull in was credited {pull} J");
        let edge = credited(false, 1.0, 0.1, 0.01);
        assert_eq!(
            edge, 0.0,
            "an edge's or face's contact was credited {edge} J"
        );
        let resting = credited(true, 1.0, 0.1, 0.0);
        assert_eq!(
            resting, 0.0,
            "a push off the surface was credited {resting} J"
        );
    }

    /// An impulse split into the normals that hold a vertex: exact for one, two and three
    /// independent normals; a nearly parallel contact rides on its axis; the contacts to let go
    /// are those of the axis that pulls hardest.
    #[test]
    fn an_impulse_splits_into_its_contacts_normals() {
        // a contact with a still surface, at rest on it
        let still = |normal| Touch {
            normal,
            reaches: true,
            falling: false,
            depth: 0.0,
            target: 0.0,
            vs: Vec3A::ZERO,
        };
        let normals = [
            Vec3A::Z,
            Vec3A::new(0.6, 0.0, 0.8),
            Vec3A::new(0.0, 0.6, 0.8),
        ];
        let lambda = [2.0f32, -0.5, 0.25];
        for count in 1..=3 {
            let mut hold = Hold::default();
            for &n in normals.iter().take(count) {
                assert!(hold.add(&still(n), 0));
            }
            let j = normals
                .iter()
                .zip(&lambda)
                .take(count)
                .fold(Vec3A::ZERO, |j, (&n, &l)| j + n * l);
            let split = hold.held.multipliers(j);
            for k in 0..count {
                assert!((split[k] - lambda[k]).abs() < 1e-5, "{count}: {split:?}");
            }
            let pulling = hold.pulling(j);
            assert_eq!(pulling, if count >= 2 { 0b10 } else { 0 }, "{count}");
            // dropped, the contact holds nothing and keeps its bit: the others' are unchanged
            let mut kept = Hold::default();
            for &n in normals.iter().take(count) {
                kept.add(&still(n), pulling);
            }
            assert_eq!(kept.held.count, count - pulling.count_ones() as usize);
            assert_eq!(kept.found, count as u32);
        }
        // a contact 5° off the first rides on its axis: both go together
        let mut hold = Hold::default();
        let tilted = Vec3A::new(0.087, 0.0, 0.996).normalize();
        for n in [Vec3A::Z, tilted] {
            hold.add(&still(n), 0);
        }
        assert_eq!((hold.held.count, hold.on_axis[0]), (1, 0b11));
        assert_eq!(hold.pulling(-Vec3A::Z), 0b11);
        assert_eq!(hold.pulling(Vec3A::Z), 0);
    }

    /// One normal leaves its plane free, two independent ones the line along their cross
    /// product, three nothing; the velocity meets every target at once; a nearly parallel
    /// contact adds no direction, and the stricter target wins.
    #[test]
    fn held_normals_span_the_filter() {
        let (s, c) = 15f32.to_radians().sin_cos();
        let (left, right) = (Vec3A::new(s, 0.0, c), Vec3A::new(-s, 0.0, c));
        let mut held = Held::default();
        held.add(left, 0.1, Vec3A::ZERO);
        let free = held.free();
        assert!((free * left).length() < 1e-5 && (free * Vec3A::Y - Vec3A::Y).length() < 1e-5);
        held.add(right, 0.2, right * 0.1);
        let free = held.free();
        assert!((free - outer(Vec3A::Y, Vec3A::Y))
            .to_cols_array()
            .iter()
            .all(|e| e.abs() < 1e-5));
        let v = held.velocity(Vec3A::new(5.0, 7.0, -9.0));
        assert!((v.dot(left) - 0.1).abs() < 1e-5 && (v.dot(right) - 0.2).abs() < 1e-5);
        assert!((v.y - 7.0).abs() < 1e-5, "the free direction is kept: {v}");
        let w = held.surface_velocity(Vec3A::ZERO);
        assert!(w.dot(left).abs() < 1e-5 && (w.dot(right) - 0.1).abs() < 1e-5);
        held.add(Vec3A::Y, 0.5, Vec3A::ZERO);
        assert_eq!(held.count, 3);
        assert!(held.free().to_cols_array().iter().all(|e| e.abs() < 1e-5));
        let v = held.velocity(Vec3A::ZERO);
        assert!((v.y - 0.5).abs() < 1e-5 && (v.dot(right) - 0.2).abs() < 1e-5);
        // a fourth contact cannot add a direction
        held.add(Vec3A::X, 1.0, Vec3A::ZERO);
        assert_eq!(held.count, 3);

        let mut twins = Held::default();
        twins.add(Vec3A::Z, 0.1, Vec3A::ZERO);
        let tilted = Vec3A::new(0.05, 0.0, 1.0).normalize();
        twins.add(tilted, 0.3, Vec3A::ZERO);
        assert_eq!(twins.count, 1);
        assert!((twins.velocity(Vec3A::ZERO).dot(tilted) - 0.3).abs() < 1e-5);
        // a looser one changes nothing
        twins.add(tilted, 0.0, Vec3A::ZERO);
        assert!((twins.velocity(Vec3A::ZERO).dot(tilted) - 0.3).abs() < 1e-5);

        // one contact may draw the vertex toward its surface; with two, neither draws
        let mut drawn = Held::default();
        drawn.add(Vec3A::Z, -0.2, Vec3A::ZERO);
        assert!((drawn.velocity(Vec3A::ZERO).z + 0.2).abs() < 1e-6);
        drawn.add(Vec3A::X, -0.1, Vec3A::ZERO);
        assert!(drawn
            .velocity(Vec3A::ONE)
            .abs()
            .cmple(Vec3A::new(1e-6, 1.0, 1e-6))
            .all());
    }

    /// The same contacts seen from a frame moving at `u` (the surfaces and the vertex carried
    /// along) hold the vertex the same way: every held velocity is the one at rest plus `u`,
    /// including a contact riding on a nearly parallel held axis (whose tilt once read the
    /// common motion as an approach).
    #[test]
    fn held_velocities_are_the_same_in_a_moving_frame() {
        let tilted = Vec3A::new(0.087, 0.0, 0.996).normalize();
        let side = Vec3A::new(0.0, 0.8, 0.6);
        let contacts = [(Vec3A::Z, -0.05), (tilted, 0.02), (side, 0.01)];
        let free_v = Vec3A::new(0.3, -0.2, 0.1);
        let held = |u: Vec3A, count: usize| {
            let mut held = Held {
                start: free_v + u,
                ..Held::default()
            };
            for &(n, push) in contacts.iter().take(count) {
                held.add(n, u.dot(n) + push, u);
            }
            held
        };
        for count in 1..=3 {
            let rest = held(Vec3A::ZERO, count);
            for u in [Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(-3.0, 2.0, 5.0)] {
                let moving = held(u, count);
                assert_eq!(moving.count, rest.count);
                let (v0, v1) = (rest.velocity(free_v), moving.velocity(free_v + u));
                let w1 = moving.surface_velocity(u);
                assert!(
                    (v1 - u - v0).length() < 1e-5,
                    "{count}, {u}: {v1} against {v0}"
                );
                assert!((w1 - u).length() < 1e-5, "{count}, {u}: surface {w1}");
            }
        }
    }
}
