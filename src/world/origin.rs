//! The world's origin: the point of the caller's coordinates, in f64, that is zero in the
//! world's own (local) `f32` coordinates.
//!
//! Why: a step does `x += v·h` in `f32`. At 10 km from zero an `f32` position is resolved to
//! ~1 mm, so a slow vertex's move is rounded away while its velocity stays: a cloth hanging there
//! never rests (a 2.9e-2 m/s "ghost" velocity with frozen positions) and never sleeps. The world
//! therefore keeps every position (vertices, pin targets, colliders) relative to an origin near
//! the cloth, and converts on the way in and out, here and nowhere else:
//!
//! * [`to_local`] / [`shape_to_local`]: caller → local, for every input (the cloth's initial
//!   positions, `set_positions` and its ranges, pin targets of every kind, collider shapes);
//! * [`to_world`]: local → caller, for every output in the caller's coordinates (positions read
//!   back, localization's frames and so its fine vertices);
//! * [`moved`]: a rigid motion given in the caller's coordinates (`World::transform`: a turn
//!   about the caller's zero, not the origin), from one origin to another.
//!
//! All go through `f64`, so a conversion rounds once, to the nearest `f32` of the result.
//! Velocities, strains, forces and energies other than gravity's are differences and do not
//! change; the gravitational energy is measured from the origin's height.
//!
//! At creation the origin is the centre of the cloth's bounding box rounded to a multiple of
//! [`ORIGIN_GRID`] m, so every cloth within half of that of zero keeps origin zero (local
//! coordinates are then the caller's, bit for bit) and any other is simulated within
//! `ORIGIN_GRID / 2` plus its own size of local zero. `World::transform` chooses it again by
//! the same rule for where the cloth lands (a teleport of kilometres would otherwise leave the
//! cloth kilometres from local zero), a step chooses it again once the cloth has travelled
//! more than `ORIGIN_GRID` from it (`World::follow_cloth`), `World::set_origin` moves it
//! where the caller likes, and `World::shift_origin` follows an engine that recenters its own
//! coordinates (as Jolt's and PhysX's "shift origin").

use glam::{DMat3, DVec3, Quat, Vec3A};

use crate::collide::Shape;
use crate::strided::Strided;

/// The origin chosen at creation is a multiple of this (m), and a step moves it once the cloth's
/// centre is farther than this from it: local coordinates stay within it plus half the cloth's
/// size. What an `f32` resolves there sets how finely the strain of an element is known (an
/// ulp of its corners over its size), and so the round-off of the elastic energy that the
/// step's energy balance must forgive, which grows as the square of the distance from local
/// zero. With a grid of 64 m a cloth could be simulated 60 m from local zero, where an `f32`
/// resolves 3.8e-6 m (a 2.5 cm edge's strain to 1.5e-4), and the balance was blind to gains
/// below that round-off (adversarial scene 13036, a 0.75 m cloth teleported 20 m off its
/// origin: its energy tripled in a step within the floor, and it was held still at 91 steps in
/// a row). Within a few metres of local zero an `f32` resolves 5e-7 m or better and the
/// round-off is some 200 times smaller; moving the origin costs a pass over the positions and
/// one energy evaluation, every 4 m of travel.
pub const ORIGIN_GRID: f64 = 4.0;

/// Caller's coordinates → local.
#[inline]
pub(crate) fn to_local(origin: DVec3, p: [f32; 3]) -> Vec3A {
    let [x, y, z] = p.map(f64::from);
    (DVec3::new(x, y, z) - origin).as_vec3a()
}

/// Local coordinates → caller's.
#[inline]
pub(crate) fn to_world(origin: DVec3, x: Vec3A) -> [f32; 3] {
    (x.as_dvec3() + origin).as_vec3().to_array()
}

/// A shape given in the caller's coordinates, in local ones.
pub(crate) fn shape_to_local(origin: DVec3, shape: Shape) -> Shape {
    shape.translated(-origin)
}

/// Local coordinates relative to `from` → relative to `to`.
#[inline]
pub(crate) fn rebase(from: DVec3, to: DVec3, x: Vec3A) -> Vec3A {
    (x.as_dvec3() + (from - to)).as_vec3a()
}

/// A rigid motion of the caller's coordinates, `p ← R p + t`, in `f64` (`World::transform`).
pub(crate) struct Rigid {
    rotation: DMat3,
    translation: DVec3,
}

impl Rigid {
    /// The motion of a unit `rotation` and a `translation`.
    pub(crate) fn new(rotation: Quat, translation: Vec3A) -> Rigid {
        Rigid {
            rotation: DMat3::from_quat(rotation.as_dquat()),
            translation: translation.as_dvec3(),
        }
    }

    /// Where the local point `x` (relative to `origin`) goes, in the caller's coordinates.
    #[inline]
    pub(crate) fn apply(&self, origin: DVec3, x: Vec3A) -> DVec3 {
        self.rotation * (x.as_dvec3() + origin) + self.translation
    }
}

/// The local point `x` relative to `from`, moved by `motion` (about the caller's zero, not
/// `from`), relative to `to`: one rounding however far `from` and `to` are from zero.
#[inline]
pub(crate) fn moved(from: DVec3, to: DVec3, motion: &Rigid, x: Vec3A) -> Vec3A {
    (motion.apply(from, x) - to).as_vec3a()
}

/// The origin for a cloth at `positions`: its bounding box's centre rounded to a multiple of
/// [`ORIGIN_GRID`] (zero for no vertices or non-finite ones, which init refuses anyway).
pub(crate) fn origin_for(positions: &Strided<'_, 3>) -> DVec3 {
    origin_around(
        (0..positions.count())
            .filter_map(|i| positions.get(i))
            .map(|p| DVec3::from(p.map(f64::from))),
    )
}

/// [`origin_for`] points of the caller's coordinates in `f64`.
pub(crate) fn origin_around(points: impl Iterator<Item = DVec3>) -> DVec3 {
    let (lo, hi) = points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    });
    on_grid((lo + hi) * 0.5)
}

/// The origin for a cloth centred at `centre` (caller's coordinates): the nearest multiple of
/// [`ORIGIN_GRID`], or zero when `centre` is not finite.
pub(crate) fn on_grid(centre: DVec3) -> DVec3 {
    let origin = (centre / ORIGIN_GRID).round() * ORIGIN_GRID;
    if origin.is_finite() {
        origin
    } else {
        DVec3::ZERO
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn conversions_round_once_and_keep_near_cloths_at_zero() {
        let far = DVec3::new(9984.0, -64.0, 0.0);
        let p = [10_000.5f32, -63.25, 1.5];
        let x = to_local(far, p);
        assert_eq!(x, Vec3A::new(16.5, 0.75, 1.5));
        assert_eq!(to_world(far, x), p);
        assert_eq!(rebase(far, DVec3::ZERO, x), Vec3A::from(p));
        // a half turn about the caller's z axis (not about `far`), then 1 m along x
        let half_turn = Rigid::new(Quat::from_xyzw(0.0, 0.0, 1.0, 0.0), Vec3A::X);
        let there = DVec3::new(-9984.0, 0.0, 0.0);
        assert_eq!(
            moved(far, there, &half_turn, x),
            Vec3A::new(-15.5, 63.25, 1.5)
        );

        let near = [[-1.0f32, 0.0, 1.0], [1.5, 3.0, 1.0]];
        assert_eq!(origin_for(&Strided::from_slice(&near)), DVec3::ZERO);
        let away = near.map(|p| [p[0] + 10_000.0, p[1], p[2] - 300.0]);
        // the centre (10000.25, 1.5, -299) to the 4 m grid
        let o = origin_for(&Strided::from_slice(&away));
        assert_eq!(o, DVec3::new(10_000.0, 0.0, -300.0));
        assert_eq!(origin_for(&Strided::from_slice(&[])), DVec3::ZERO);

        let sphere = Shape::Sphere {
            center: Vec3A::new(10_000.0, 1.0, 2.0),
            radius: 0.5,
        };
        let Shape::Sphere { center, radius } = shape_to_local(far, sphere) else {
            unreachable!()
        };
        assert_eq!((center, radius), (Vec3A::new(16.0, 65.0, 2.0), 0.5));
        let floor = Shape::Plane {
            normal: Vec3A::Z,
            offset: -310.0,
        };
        let Shape::Plane { offset, .. } = shape_to_local(o, floor) else {
            unreachable!()
        };
        assert_eq!(offset, -10.0);
    }
}
