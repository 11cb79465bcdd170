//! Kinematic colliders (plane, sphere, capsule, shell: a hollow sphere) and cloth–collider
//! contact shapes: proximity, sweep, surface velocity, projection, and pushing a point out along a
//! direction (collision-aware localization).
//!
//! Contact enters the step twice (docs/ARCHITECTURE.md, "One step, in order"):
//! * before the solve, a vertex that is within `thickness` of a collider and moving into it gets
//!   a one-direction constraint in the PCG filter (Baraff & Witkin 1998 §5.3): its velocity
//!   along the contact normal is prescribed so that it ends the step on the offset surface. A
//!   sphere or capsule thinner than the cloth's spacing is also found between vertices, at the
//!   nearest point of an edge ([`Shape::segment_proximity`]) or a face
//!   ([`Shape::triangle_proximity`]), whose corners are then held along that normal;
//! * after the solve, positions are projected out of every collider's offset surface (so no
//!   vertex ever ends a step deeper than `thickness`), the inward relative velocity is removed
//!   and Coulomb friction scales the tangential relative velocity down.
//!
//! Colliders are kinematic: the engine moves them, the cloth does not push back. A collider
//! that moved since the last step is swept linearly across the substeps, so a fast collider is
//! seen at every substep instead of jumping over the cloth.

use glam::{DVec3, Vec3A};

/// A collider's geometry, in world space (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The half-space `dot(normal, x) < offset` is solid; `normal` is unit length.
    Plane {
        normal: Vec3A,
        offset: f32,
    },
    Sphere {
        center: Vec3A,
        radius: f32,
    },
    /// A segment `a`–`b` swept by a sphere of `radius`.
    Capsule {
        a: Vec3A,
        b: Vec3A,
        radius: f32,
    },
    /// A hollow sphere: the cloth is kept *inside* `radius` (everything outside is solid),
    /// e.g. a container, or a shrinking sphere that crumples a cloth into a ball.
    Shell {
        center: Vec3A,
        radius: f32,
    },
}

/// A contact query's answer: signed distance from the surface (negative inside) and the
/// outward unit normal at the closest surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Proximity {
    pub distance: f32,
    pub normal: Vec3A,
}

impl Shape {
    /// True when every number is finite and sizes are valid (unit plane normal, radii > 0).
    pub fn is_valid(&self) -> bool {
        match *self {
            Shape::Plane { normal, offset } => {
                normal.is_finite() && offset.is_finite() && (normal.length() - 1.0).abs() < 1e-3
            }
            Shape::Sphere { center, radius } => {
                center.is_finite() && radius.is_finite() && radius > 0.0
            }
            Shape::Capsule { a, b, radius } => {
                a.is_finite() && b.is_finite() && radius.is_finite() && radius > 0.0
            }
            Shape::Shell { center, radius } => {
                center.is_finite() && radius.is_finite() && radius > 0.0
            }
        }
    }

    /// How far the shape reaches from the origin (largest coordinate, m): its farthest surface
    /// point for a sphere, capsule or shell; for a plane, which has none, its point nearest the
    /// origin. A point pushed out of the shape ([`Shape::push_out_along`]) lands within a few
    /// times this, its own reach and the thickness: the energy balance's bound on where a
    /// step can put the cloth (`step::monitor::reach_bound`).
    pub(crate) fn reach(&self) -> f32 {
        match *self {
            Shape::Plane { offset, .. } => offset.abs(),
            Shape::Sphere { center, radius } | Shape::Shell { center, radius } => {
                center.abs().max_element() + radius
            }
            Shape::Capsule { a, b, radius } => a.abs().max(b.abs()).max_element() + radius,
        }
    }

    /// Signed distance and outward normal at point `p`.
    #[inline]
    pub fn proximity(&self, p: Vec3A) -> Proximity {
        match *self {
            Shape::Plane { normal, offset } => Proximity {
                distance: normal.dot(p) - offset,
                normal,
            },
            Shape::Sphere { center, radius } => sphere_proximity(center, radius, p),
            Shape::Capsule { a, b, radius } => {
                sphere_proximity(a.lerp(b, closest_on_segment(a, b, p)), radius, p)
            }
            Shape::Shell { center, radius } => {
                let inside = sphere_proximity(center, radius, p);
                Proximity {
                    distance: -inside.distance,
                    normal: -inside.normal,
                }
            }
        }
    }

    /// How far [`Shape::proximity`]'s distance at `p` may be from the true one by the `f32`
    /// rounding of the coordinates it is computed from: a few units in the last place of the
    /// largest of them. A point [`resolve`] put on the offset surface is on it to within this,
    /// above it as well as below (the factor 4 is what the test of that measures, not a bound
    /// derived for every shape's formula).
    #[inline]
    pub fn rounding(&self, p: Vec3A) -> f32 {
        let scale = match *self {
            Shape::Plane { offset, .. } => offset.abs(),
            Shape::Sphere { center, radius } | Shape::Shell { center, radius } => {
                center.abs().max_element() + radius
            }
            Shape::Capsule { a, b, radius } => a.abs().max(b.abs()).max_element() + radius,
        };
        4.0 * f32::EPSILON * (p.abs().max_element() + scale)
    }

    /// `proximity(p).distance < thickness`, without the square root and the normal where the
    /// shape allows (the per-vertex test of collision-aware localization).
    #[inline]
    pub fn within(&self, thickness: f32, p: Vec3A) -> bool {
        match *self {
            Shape::Plane { normal, offset } => normal.dot(p) - offset < thickness,
            Shape::Sphere { center, radius } => {
                let r = radius + thickness;
                (p - center).length_squared() < r * r
            }
            Shape::Capsule { a, b, radius } => {
                let r = radius + thickness;
                (p - a - (b - a) * closest_on_segment(a, b, p)).length_squared() < r * r
            }
            Shape::Shell { .. } => self.proximity(p).distance < thickness,
        }
    }

    /// The same shape moved by `by` (for a change of coordinates; in f64, so that a shape
    /// far from zero moves by one rounding: a plane's offset gains `normal · by`).
    pub fn translated(&self, by: DVec3) -> Shape {
        let moved = |p: Vec3A| (p.as_dvec3() + by).as_vec3a();
        match *self {
            Shape::Plane { normal, offset } => Shape::Plane {
                normal,
                offset: (f64::from(offset) + normal.as_dvec3().dot(by)) as f32,
            },
            Shape::Sphere { center, radius } => Shape::Sphere {
                center: moved(center),
                radius,
            },
            Shape::Capsule { a, b, radius } => Shape::Capsule {
                a: moved(a),
                b: moved(b),
                radius,
            },
            Shape::Shell { center, radius } => Shape::Shell {
                center: moved(center),
                radius,
            },
        }
    }

    /// The shape moved by `t` ∈ [0, 1] of the way from `self` to `to` (linear sweep of the
    /// defining points; a plane's normal is re-normalized).
    pub fn lerp(&self, to: &Shape, t: f32) -> Shape {
        match (*self, *to) {
            (
                Shape::Plane {
                    normal: n0,
                    offset: o0,
                },
                Shape::Plane {
                    normal: n1,
                    offset: o1,
                },
            ) => Shape::Plane {
                normal: n0.lerp(n1, t).normalize_or(n1),
                offset: o0 + (o1 - o0) * t,
            },
            (
                Shape::Sphere {
                    center: c0,
                    radius: r0,
                },
                Shape::Sphere {
                    center: c1,
                    radius: r1,
                },
            ) => Shape::Sphere {
                center: c0.lerp(c1, t),
                radius: r0 + (r1 - r0) * t,
            },
            (
                Shape::Capsule {
                    a: a0,
                    b: b0,
                    radius: r0,
                },
                Shape::Capsule {
                    a: a1,
                    b: b1,
                    radius: r1,
                },
            ) => Shape::Capsule {
                a: a0.lerp(a1, t),
                b: b0.lerp(b1, t),
                radius: r0 + (r1 - r0) * t,
            },
            // A shape that changed kind teleports.
            _ => *to,
        }
    }

    /// Velocity of the surface point nearest to `p` when the shape moves from `from` to `self`
    /// over `dt` seconds (translation of the nearest defining point; rotation of a capsule is
    /// approximated by its endpoints' interpolation).
    pub fn surface_velocity(&self, from: &Shape, p: Vec3A, dt: f32) -> Vec3A {
        if dt <= 0.0 {
            return Vec3A::ZERO;
        }
        let v = match (*from, *self) {
            (
                Shape::Plane {
                    normal: _,
                    offset: o0,
                },
                Shape::Plane { normal, offset },
            ) => {
                // only the normal motion of a plane is observable
                normal * (offset - o0)
            }
            // a shrinking or growing sphere, shell or capsule moves its surface along the
            // radius too
            (
                Shape::Sphere {
                    center: c0,
                    radius: r0,
                },
                Shape::Sphere { center, radius },
            )
            | (
                Shape::Shell {
                    center: c0,
                    radius: r0,
                },
                Shape::Shell { center, radius },
            ) => (center - c0) + outward(p - center) * (radius - r0),
            (
                Shape::Capsule {
                    a: a0,
                    b: b0,
                    radius: r0,
                },
                Shape::Capsule { a, b, radius },
            ) => {
                let s = closest_on_segment(a, b, p);
                (a - a0).lerp(b - b0, s) + outward(p - a.lerp(b, s)) * (radius - r0)
            }
            _ => Vec3A::ZERO,
        };
        v / dt
    }

    /// [`Shape::surface_velocity`] when it is the same at every point (the shape moves without
    /// turning or resizing around it: a plane, a sphere of constant radius, a change of kind),
    /// else `None`: the contact tests place a collider once per substep and reuse this for
    /// every vertex.
    pub fn uniform_surface_velocity(&self, from: &Shape, dt: f32) -> Option<Vec3A> {
        match (*from, *self) {
            (Shape::Sphere { radius: r0, .. }, Shape::Sphere { radius, .. }) if radius != r0 => {
                None
            }
            (Shape::Capsule { .. }, Shape::Capsule { .. })
            | (Shape::Shell { .. }, Shape::Shell { .. }) => None,
            // (the point is not read for these)
            _ => Some(self.surface_velocity(from, Vec3A::ZERO, dt)),
        }
    }
}

/// Below this cosine between a push's direction and the collider's normal, a push along the
/// direction would travel far along the surface for little depth (and not at all when
/// tangent): the vertex goes straight out along the collider's normal instead.
const MIN_PUSH_COSINE: f32 = 0.25;

/// Newton steps along the push direction before the last correction along the normal: one
/// ends outside a convex shape (plane, sphere, capsule), the next one or two within
/// [`PUSH_TOLERANCE`] of its offset surface; a shell's concave inside needs more.
const PUSH_STEPS: usize = 4;

/// How far past the offset surface (m) a push may end.
const PUSH_TOLERANCE: f32 = 1e-5;

impl Shape {
    /// `p` moved out of the offset surface (at distance `thickness`) of the shape along the
    /// line through `p` with unit direction `direction`, on the side the shape's normal at `p`
    /// points to (`direction` may point either way); `p` itself when it is not inside.
    ///
    /// A pure function of `(p, direction)`, so two copies of a point with the same direction
    /// land at the same place. The distance along the line is found by Newton's method on the
    /// signed distance (its slope along the line is the cosine between the line and the
    /// normal); for a convex shape the signed distance is convex, so the first step already
    /// ends on or outside the surface and the next ones come back towards it from outside.
    /// Where the line meets the surface at a grazing angle (cosine below 0.25), or after a
    /// few steps, what remains is removed along the shape's own normal, so the result is never
    /// inside.
    pub fn push_out_along(&self, thickness: f32, p: Vec3A, direction: Vec3A) -> Vec3A {
        let mut prox = self.proximity(p);
        if prox.distance >= thickness {
            return p;
        }
        let d = if direction.dot(prox.normal) < 0.0 {
            -direction
        } else {
            direction
        };
        let mut q = p;
        for _ in 0..PUSH_STEPS {
            let slope = d.dot(prox.normal);
            if slope.is_nan() || slope < MIN_PUSH_COSINE {
                break;
            }
            q += d * ((thickness - prox.distance) / slope);
            prox = self.proximity(q);
            if (thickness..=thickness + PUSH_TOLERANCE).contains(&prox.distance) {
                return q;
            }
        }
        if prox.distance >= thickness {
            return q;
        }
        q + prox.normal * (thickness - prox.distance)
    }
}

/// Colliders, in coordinates whose zero lies at `origin` of the caller's (a world stores its
/// colliders relative to its own origin: [`crate::world::World::collider_set`]).
#[derive(Clone, Copy, Debug)]
pub struct ColliderSet<'c> {
    pub colliders: &'c [Collider],
    pub origin: Vec3A,
}

impl<'c> ColliderSet<'c> {
    /// Colliders given in the caller's coordinates.
    pub fn new(colliders: &'c [Collider]) -> Self {
        ColliderSet {
            colliders,
            origin: Vec3A::ZERO,
        }
    }

    /// True when `p` (caller's coordinates) is inside the offset surface of any collider: the
    /// cheap test before a push, which needs a direction.
    #[inline]
    pub fn holds(&self, p: Vec3A) -> bool {
        let local = p - self.origin;
        self.colliders
            .iter()
            .any(|c| c.shape.within(c.thickness, local))
    }

    /// `p` (caller's coordinates) pushed out of each collider in turn, along `direction`
    /// ([`Shape::push_out_along`], each collider's own thickness); `p` itself, bit for bit,
    /// when it is inside none. A point pushed out of one collider into an earlier one stays
    /// there (one pass, in order).
    pub fn push_out(&self, p: Vec3A, direction: Vec3A) -> Vec3A {
        let local = p - self.origin;
        let mut q = local;
        for c in self.colliders {
            q = c.shape.push_out_along(c.thickness, q, direction);
        }
        if q == local {
            p
        } else {
            q + self.origin
        }
    }
}

/// Which parts of the cloth a shape is tested against. A plane's or a shell's solid is the
/// outside of a convex set or a half-space, so an edge or a face whose corners are all clear of
/// it is clear too: vertices suffice. A sphere or a capsule can lie between the corners (a
/// pole under an edge, a fingertip under a face), so edges and faces are tested as well.
impl Shape {
    /// The core a sphere or capsule is the `radius`-neighbourhood of: a segment (a point for a
    /// sphere) and the radius; `None` for the shapes vertices suffice for.
    fn core(&self) -> Option<(Vec3A, Vec3A, f32)> {
        match *self {
            Shape::Sphere { center, radius } => Some((center, center, radius)),
            Shape::Capsule { a, b, radius } => Some((a, b, radius)),
            Shape::Plane { .. } | Shape::Shell { .. } => None,
        }
    }

    /// Whether the shape can touch the cloth between its vertices (a sphere or a capsule).
    pub fn between_vertices(&self) -> bool {
        self.core().is_some()
    }

    /// The shortest cloth edge that can cut into a sphere or capsule while both its ends stay
    /// outside its offset surface (`thickness` beyond it): a chord of length `L` between two
    /// points at `ρ = radius + thickness` from the core comes within `√(ρ² − L²/4)` of it, which
    /// is inside the radius only when `L ≥ 2 √(thickness (2 radius + thickness))`. Shorter
    /// edges dip into the thickness at most, and the vertex contacts suffice. `None` for a
    /// plane or a shell (vertices always suffice).
    pub fn shortest_cutting_edge(&self, thickness: f32) -> Option<f32> {
        let (_, _, radius) = self.core()?;
        Some(2.0 * libm::sqrtf((thickness * (2.0 * radius + thickness)).max(0.0)))
    }

    /// The point of the cloth edge `p`–`q` nearest to a sphere or capsule: its parameter `s`
    /// (the point is `p + s (q − p)`) and the proximity there. `None` for a plane or a shell
    /// (see above).
    pub fn segment_proximity(&self, p: Vec3A, q: Vec3A) -> Option<(f32, Proximity)> {
        let (a, b, radius) = self.core()?;
        let (s, t) = closest_between_segments(p, q, a, b);
        Some((s, sphere_proximity(a.lerp(b, t), radius, p.lerp(q, s))))
    }

    /// The point of the cloth triangle `p` nearest to a sphere or capsule: its barycentric
    /// weights and the proximity there. `None` for a plane or a shell (see above). For a
    /// capsule the nearest pair is found by alternating projections between the triangle and
    /// the axis (both convex, so it converges; a few rounds place it well within a thickness for
    /// the contact test).
    pub fn triangle_proximity(&self, p: [Vec3A; 3]) -> Option<([f32; 3], Proximity)> {
        let (a, b, radius) = self.core()?;
        let [p0, p1, p2] = p;
        let at = |w: [f32; 3]| p0 * w[0] + p1 * w[1] + p2 * w[2];
        let mut c = a.lerp(b, 0.5);
        let mut w = closest_on_triangle(p, c);
        if a != b {
            for _ in 0..3 {
                c = a.lerp(b, closest_on_segment(a, b, at(w)));
                w = closest_on_triangle(p, c);
            }
        }
        Some((w, sphere_proximity(c, radius, at(w))))
    }
}

/// The unit direction of `d` (a point minus a sphere's centre or the nearest point of a
/// capsule's axis); at the centre itself any direction is outward: `+Z`, deterministically.
fn outward(d: Vec3A) -> Vec3A {
    let len = d.length();
    if len > 0.0 {
        d / len
    } else {
        Vec3A::Z
    }
}

/// Parameter in [0, 1] of the point of segment `a`–`b` nearest to `p`.
fn closest_on_segment(a: Vec3A, b: Vec3A, p: Vec3A) -> f32 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Parameters `(s, t)` of the nearest points of segments `p`–`q` and `a`–`b` (Ericson,
/// Real-Time Collision Detection, 5.1.9).
fn closest_between_segments(p: Vec3A, q: Vec3A, a: Vec3A, b: Vec3A) -> (f32, f32) {
    let (d1, d2, r) = (q - p, b - a, p - a);
    let (aa, ee, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    if aa <= f32::EPSILON * ee.max(1.0) {
        return (0.0, closest_on_segment(a, b, p));
    }
    let c = d1.dot(r);
    if ee <= f32::EPSILON * aa {
        return (closest_on_segment(p, q, a), 0.0);
    }
    let bb = d1.dot(d2);
    let denom = aa * ee - bb * bb;
    // parallel segments: any s works; 0, then t follows
    let mut s = if denom > f32::EPSILON * aa * ee {
        ((bb * f - c * ee) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = (bb * s + f) / ee;
    if t < 0.0 {
        t = 0.0;
        s = (-c / aa).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((bb - c) / aa).clamp(0.0, 1.0);
    }
    (s, t)
}

/// Barycentric weights of the point of triangle `t` nearest to `x` (Ericson, 5.1.5).
fn closest_on_triangle(t: [Vec3A; 3], x: Vec3A) -> [f32; 3] {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, x - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = x - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = x - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let sum = va + vb + vc;
    if sum.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
        // a degenerate triangle: its first corner
        return [1.0, 0.0, 0.0];
    }
    let (v, w) = (vb / sum, vc / sum);
    [1.0 - v - w, v, w]
}

#[inline]
fn sphere_proximity(center: Vec3A, radius: f32, p: Vec3A) -> Proximity {
    let d = p - center;
    Proximity {
        distance: d.length() - radius,
        normal: outward(d),
    }
}

/// A kinematic collider as the world stores it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collider {
    /// Where the collider is now (set by the engine before a step).
    pub shape: Shape,
    /// Where it was at the end of the previous step (the sweep starts here).
    pub previous: Shape,
    /// Coulomb friction coefficient (≥ 0).
    pub friction: f32,
    /// Distance (m) the cloth keeps from the surface: the cloth's half thickness plus skin.
    pub thickness: f32,
}

impl Collider {
    pub fn new(shape: Shape, friction: f32, thickness: f32) -> Self {
        Collider {
            shape,
            previous: shape,
            friction,
            thickness,
        }
    }

    pub fn is_valid(&self) -> bool {
        self.shape.is_valid()
            && self.previous.is_valid()
            && self.friction.is_finite()
            && self.friction >= 0.0
            && self.thickness.is_finite()
            && self.thickness >= 0.0
    }
}

/// Pushes `x` out to the offset surface of `shape` and corrects `v`: the inward normal
/// relative velocity is removed and Coulomb friction (coefficient `mu`) reduces the tangential
/// relative velocity by `mu` times the normal velocity change. `surface_v` is the collider's
/// surface velocity. Returns true when the vertex was in contact.
pub fn resolve(
    shape: &Shape,
    surface_v: Vec3A,
    thickness: f32,
    mu: f32,
    x: &mut Vec3A,
    v: &mut Vec3A,
) -> bool {
    let prox = shape.proximity(*x);
    if prox.distance >= thickness {
        return false;
    }
    let n = prox.normal;
    *x += n * (thickness - prox.distance);
    let rel = *v - surface_v;
    let vn = rel.dot(n);
    if vn < 0.0 {
        let vt = rel - n * vn;
        let vt_len = vt.length();
        // Coulomb: the tangential change is bounded by mu times the normal change |vn|.
        let scale = if vt_len > 0.0 {
            (1.0 - mu * (-vn) / vt_len).max(0.0)
        } else {
            0.0
        };
        *v = surface_v + vt * scale;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proximities() {
        let plane = Shape::Plane {
            normal: Vec3A::Y,
            offset: 1.0,
        };
        let p = plane.proximity(Vec3A::new(3.0, 0.5, 2.0));
        assert_eq!(p.distance, -0.5);
        assert_eq!(p.normal, Vec3A::Y);
        let s = Shape::Sphere {
            center: Vec3A::ZERO,
            radius: 1.0,
        };
        let p = s.proximity(Vec3A::new(0.0, 0.0, 3.0));
        assert_eq!(p.distance, 2.0);
        assert_eq!(s.proximity(Vec3A::ZERO).normal, Vec3A::Z);
        let c = Shape::Capsule {
            a: Vec3A::ZERO,
            b: Vec3A::X * 2.0,
            radius: 0.5,
        };
        let p = c.proximity(Vec3A::new(1.0, 1.0, 0.0));
        assert!((p.distance - 0.5).abs() < 1e-6 && (p.normal - Vec3A::Y).length() < 1e-6);
        let p = c.proximity(Vec3A::new(3.0, 0.0, 0.0));
        assert!((p.distance - 0.5).abs() < 1e-6 && (p.normal - Vec3A::X).length() < 1e-6);
    }

    /// What `rounding` promises: a point `resolve` put on a shape's offset surface is on it
    /// to within the rounding (above as well as below), for every kind of shape, near the
    /// origin and away from it (the contact slop relies on it).
    #[test]
    fn a_projected_point_is_on_the_surface_within_the_rounding() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut draw = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let (mut above, mut below) = (0, 0);
        for scale in [0.01f32, 1.0, 30.0] {
            for _ in 0..2000 {
                let v3 = |draw: &mut dyn FnMut() -> f32| Vec3A::new(draw(), draw(), draw()) * scale;
                let (c, d) = (v3(&mut draw), v3(&mut draw));
                let radius = scale * (0.1 + draw().abs());
                let normal = Vec3A::new(draw(), draw(), draw() + 2.0).normalize();
                let shapes = [
                    Shape::Plane {
                        normal,
                        offset: c.x,
                    },
                    Shape::Sphere { center: c, radius },
                    Shape::Shell { center: c, radius },
                    Shape::Capsule { a: c, b: d, radius },
                ];
                let thickness = [0.0, 1e-3 * scale][usize::from(draw() > 0.0)];
                for shape in shapes {
                    // a point a little inside the offset surface
                    let mut x = c + v3(&mut draw) * 0.5;
                    let prox = shape.proximity(x);
                    x -= prox.normal * (prox.distance - thickness + 0.01 * scale * draw().abs());
                    let mut v = Vec3A::ZERO;
                    if !resolve(&shape, Vec3A::ZERO, thickness, 0.0, &mut x, &mut v) {
                        continue;
                    }
                    let off = shape.proximity(x).distance - thickness;
                    assert!(
                        off.abs() <= shape.rounding(x),
                        "{shape:?}: {off:e} off the surface, rounding {:e}",
                        shape.rounding(x)
                    );
                    above += usize::from(off > 0.0);
                    below += usize::from(off < 0.0);
                }
            }
        }
        assert!(above > 100 && below > 100, "{above} above, {below} below");
    }

    #[test]
    fn resolve_projects_and_applies_friction() {
        let plane = Shape::Plane {
            normal: Vec3A::Z,
            offset: 0.0,
        };
        // sliding into the floor: pushed to the thickness, normal velocity removed
        let mut x = Vec3A::new(0.0, 0.0, -0.1);
        let mut v = Vec3A::new(1.0, 0.0, -2.0);
        assert!(resolve(&plane, Vec3A::ZERO, 0.01, 0.25, &mut x, &mut v));
        assert!((x.z - 0.01).abs() < 1e-7);
        assert_eq!(v.z, 0.0);
        assert!(
            (v.x - 0.5).abs() < 1e-6,
            "friction 0.25·2 = 0.5 removed: {}",
            v.x
        );
        // high friction stops sliding entirely, never reverses it
        let mut x = Vec3A::new(0.0, 0.0, -0.1);
        let mut v = Vec3A::new(1.0, 0.0, -2.0);
        resolve(&plane, Vec3A::ZERO, 0.01, 10.0, &mut x, &mut v);
        assert_eq!(v.x, 0.0);
        // away from the surface: untouched
        let mut x = Vec3A::new(0.0, 0.0, 0.5);
        let mut v = Vec3A::new(1.0, 0.0, -2.0);
        assert!(!resolve(&plane, Vec3A::ZERO, 0.01, 0.25, &mut x, &mut v));
        assert_eq!(v, Vec3A::new(1.0, 0.0, -2.0));
    }

    #[test]
    fn push_out_along_a_direction() {
        let t = 0.01;
        let floor = Shape::Plane {
            normal: Vec3A::Z,
            offset: 0.0,
        };
        // along a slanted direction, either sign: exactly onto the offset plane, along it
        let d = Vec3A::new(1.0, 0.0, 1.0).normalize();
        let p = Vec3A::new(0.0, 0.0, -0.1);
        for dir in [d, -d] {
            let q = floor.push_out_along(t, p, dir);
            assert!((q.z - t).abs() < 1e-6, "{q}");
            assert!((q - p).normalize().cross(d).length() < 1e-6);
        }
        // grazing: straight out along the plane's normal instead
        let q = floor.push_out_along(t, p, Vec3A::new(1.0, 0.0, 0.1).normalize());
        assert!((q - Vec3A::new(0.0, 0.0, t)).length() < 1e-6, "{q}");
        // outside: the same point, bit for bit
        let above = Vec3A::new(0.3, 0.2, 0.5);
        assert_eq!(floor.push_out_along(t, above, d), above);

        // a sphere, along a line off its centre: outside, along the line
        let ball = Shape::Sphere {
            center: Vec3A::ZERO,
            radius: 1.0,
        };
        let p = Vec3A::new(0.2, 0.0, 0.8);
        let q = ball.push_out_along(t, p, Vec3A::Z);
        let dist = ball.proximity(q).distance;
        assert!(dist >= t - 1e-6 && dist <= t + PUSH_TOLERANCE, "{dist}");
        assert!((q - p).normalize().cross(Vec3A::Z).length() < 1e-6);
        // a shell: pulled back inside along the line
        let shell = Shape::Shell {
            center: Vec3A::ZERO,
            radius: 1.0,
        };
        let q = shell.push_out_along(t, Vec3A::new(0.3, 0.0, 1.2), Vec3A::Z);
        assert!(shell.proximity(q).distance >= t - 1e-6, "{q}");
        assert!(q.x == 0.3 && q.y == 0.0, "{q}");

        // the cheap inside test agrees with the distance
        let pole = Shape::Capsule {
            a: Vec3A::ZERO,
            b: Vec3A::X,
            radius: 0.2,
        };
        for shape in [floor, ball, shell, pole] {
            for i in 0..200 {
                let f = i as f32;
                let p = Vec3A::new((f * 0.37).sin(), (f * 0.71).cos(), (f * 0.13).sin() * 1.3);
                let inside = shape.proximity(p).distance < t;
                assert_eq!(shape.within(t, p), inside, "{shape:?} {p}");
            }
        }

        // a set of colliders given relative to an origin: the same push, moved
        let far = Vec3A::new(1000.0, 0.0, 0.0);
        let colliders = [Collider::new(ball, 0.0, t)];
        let set = ColliderSet {
            colliders: &colliders,
            origin: far,
        };
        let q = set.push_out(p + far, Vec3A::Z) - far;
        assert!(
            (q - ball.push_out_along(t, p, Vec3A::Z)).length() < 1e-4,
            "{q}"
        );
    }

    #[test]
    fn sweep_and_surface_velocity() {
        let a = Shape::Sphere {
            center: Vec3A::ZERO,
            radius: 1.0,
        };
        let b = Shape::Sphere {
            center: Vec3A::X * 2.0,
            radius: 1.0,
        };
        assert_eq!(
            a.lerp(&b, 0.5),
            Shape::Sphere {
                center: Vec3A::X,
                radius: 1.0
            }
        );
        assert_eq!(b.surface_velocity(&a, Vec3A::Y * 5.0, 0.5), Vec3A::X * 4.0);
        assert!(!Shape::Sphere {
            center: Vec3A::ZERO,
            radius: -1.0
        }
        .is_valid());
    }

    /// The velocity computed once per collider is the one of every point.
    #[test]
    fn uniform_surface_velocity_is_every_points() {
        let plane = |offset| Shape::Plane {
            normal: Vec3A::new(0.0, 0.6, 0.8),
            offset,
        };
        let sphere = |x| Shape::Sphere {
            center: Vec3A::new(x, 0.2, 0.1),
            radius: 0.3,
        };
        let points = [Vec3A::ZERO, Vec3A::new(0.3, -2.0, 5.0), Vec3A::splat(1e3)];
        for (from, to) in [
            (plane(0.1), plane(0.35)),
            (sphere(0.0), sphere(0.7)),
            (sphere(0.0), plane(0.2)),
        ] {
            let v = to.uniform_surface_velocity(&from, 0.01).unwrap();
            for p in points {
                assert_eq!(v, to.surface_velocity(&from, p, 0.01));
            }
            assert_eq!(to.uniform_surface_velocity(&from, 0.0), Some(Vec3A::ZERO));
        }
        let pole = |x| Shape::Capsule {
            a: Vec3A::new(x, 0.0, 0.0),
            b: Vec3A::ONE,
            radius: 0.1,
        };
        let shell = |r| Shape::Shell {
            center: Vec3A::ZERO,
            radius: r,
        };
        assert!(pole(1.0)
            .uniform_surface_velocity(&pole(0.0), 0.01)
            .is_none());
        assert!(shell(1.0)
            .uniform_surface_velocity(&shell(2.0), 0.01)
            .is_none());
        let ball = |r| Shape::Sphere {
            center: Vec3A::ZERO,
            radius: r,
        };
        assert!(ball(1.0)
            .uniform_surface_velocity(&ball(2.0), 0.01)
            .is_none());
    }

    /// A sphere, shell or capsule whose radius changes moves its surface along the normal at
    /// the rate of change (besides its centre's or axis's motion).
    #[test]
    fn a_growing_radius_moves_the_surface_along_the_normal() {
        let p = Vec3A::new(0.0, 3.0, 4.0); // 5 from the origin, normal (0, 0.6, 0.8)
        let n = Vec3A::new(0.0, 0.6, 0.8);
        let ball = |c: Vec3A, r| Shape::Sphere {
            center: c,
            radius: r,
        };
        let shell = |c: Vec3A, r| Shape::Shell {
            center: c,
            radius: r,
        };
        let dc = Vec3A::new(0.1, 0.0, 0.0);
        for (from, to) in [
            (ball(Vec3A::ZERO, 1.0), ball(dc, 1.5)),
            (shell(Vec3A::ZERO, 1.0), shell(dc, 1.5)),
        ] {
            // the normal at p of the shape where it ends
            let n = (p - dc).normalize();
            let v = to.surface_velocity(&from, p, 0.5);
            assert!((v - (dc + 0.5 * n) / 0.5).length() < 1e-5, "{to:?}: {v}");
        }
        // a pole along x: the normal at p is its distance from the axis, (0, 0.6, 0.8)
        let pole = |r| Shape::Capsule {
            a: Vec3A::new(-1.0, 0.0, 0.0),
            b: Vec3A::new(1.0, 0.0, 0.0),
            radius: r,
        };
        let v = pole(0.3).surface_velocity(&pole(0.1), p, 0.1);
        assert!((v - 2.0 * n).length() < 1e-5, "{v}");
    }

    #[test]
    fn edges_and_faces_between_vertices() {
        let pole = Shape::Capsule {
            a: Vec3A::new(-1.0, 0.0, 0.0),
            b: Vec3A::new(1.0, 0.0, 0.0),
            radius: 0.02,
        };
        // an edge crossing over the pole, 5 cm above its axis, a quarter of the way along
        let (p, q) = (Vec3A::new(0.3, -0.1, 0.05), Vec3A::new(0.3, 0.3, 0.05));
        let (s, prox) = pole.segment_proximity(p, q).unwrap();
        assert!((s - 0.25).abs() < 1e-5, "s = {s}");
        assert!((prox.distance - 0.03).abs() < 1e-5 && (prox.normal - Vec3A::Z).length() < 1e-5);
        // skew edges: the nearest pair of two crossing lines, then clamped to an end
        let (s, prox) = pole
            .segment_proximity(Vec3A::new(0.5, 0.0, 0.1), Vec3A::new(0.5, 0.0, 0.5))
            .unwrap();
        assert_eq!(s, 0.0);
        assert!((prox.distance - 0.08).abs() < 1e-5);
        // a sphere under the middle of a triangle: its vertices and edges are far, the face
        // is 1 cm above the surface
        let ball = Shape::Sphere {
            center: Vec3A::ZERO,
            radius: 0.03,
        };
        let tri = [
            Vec3A::new(-0.1, -0.1, 0.04),
            Vec3A::new(0.1, -0.1, 0.04),
            Vec3A::new(0.0, 0.1, 0.04),
        ];
        let (w, prox) = ball.triangle_proximity(tri).unwrap();
        let at = tri[0] * w[0] + tri[1] * w[1] + tri[2] * w[2];
        assert!((at - Vec3A::new(0.0, 0.0, 0.04)).length() < 1e-5, "{at}");
        assert!((prox.distance - 0.01).abs() < 1e-5);
        // a capsule's end under the face: the nearest pair between the face and the axis
        let finger = Shape::Capsule {
            a: Vec3A::new(0.0, 0.0, -0.5),
            b: Vec3A::ZERO,
            radius: 0.03,
        };
        let (_, prox) = finger.triangle_proximity(tri).unwrap();
        assert!((prox.distance - 0.01).abs() < 1e-5, "{}", prox.distance);
        // beside a corner, the corner is nearest
        let (w, _) = ball
            .triangle_proximity(tri.map(|p| p + Vec3A::new(0.2, 0.2, 0.0)))
            .unwrap();
        assert_eq!(w, [1.0, 0.0, 0.0]);
        // planes and shells are tested at vertices only
        let floor = Shape::Plane {
            normal: Vec3A::Z,
            offset: 0.0,
        };
        assert!(floor.segment_proximity(p, q).is_none() && !floor.between_vertices());
        assert!(pole.between_vertices() && ball.between_vertices());
        // a chord of that length with its ends on the offset surface just touches the sphere
        let cut = ball.shortest_cutting_edge(0.005).unwrap();
        let rho = 0.035f32;
        assert!(((rho * rho - cut * cut / 4.0).sqrt() - 0.03).abs() < 1e-6);
        assert!(floor.shortest_cutting_edge(0.005).is_none());
    }
}
