//! The runtime `World`: a coarse cloth and everything needed to step it, in a caller-owned
//! memory block (paper §5).
//!
//! Memory is the caller's: [`Capacity::world_bytes`] says how many bytes a world of a given
//! capacity needs (a `const fn`, so it can size a `static`), and [`World::new`] carves every
//! array out of that block (`memory.rs`) and builds the cloth in it (`build.rs`). Nothing
//! allocates, nothing panics; init either builds the whole world or returns an error and leaves
//! nothing behind.
//!
//! A step is linearized implicit Euler on the per-element corotated membrane (`membrane.rs`),
//! hinge bending, gravity, wind and Rayleigh damping, with pins and contacts in the filter of
//! the modified PCG; its stages live in `crate::step` (`src/step/`), in order, and every step's energy
//! balance is checked at its end (`step/monitor.rs`).
//!
//! **Coordinates.** The world simulates relative to its [`origin`](World::origin) (an `f64`
//! point of the caller's coordinates, near the cloth: `origin.rs` says why and how it is
//! chosen). Every input is in the caller's coordinates and converted on the way in:
//! [`ClothDef`] positions, [`World::set_positions`] and [`World::set_positions_range`],
//! [`World::set_pin`] and [`World::set_pin_axes`] (the plane's or line's point),
//! [`World::add_collider`], [`World::set_collider_shape`], and [`World::transform`]
//! (`x ← R x + t` in the caller's coordinates, computed in `f64`, after which the origin is
//! chosen again for where the cloth lands). Velocities, forces, impulses, pin axes and strains are
//! differences and are not converted. The accessors that lend the world's
//! own arrays, [`World::positions`] and [`World::collider`], are in local coordinates;
//! [`World::to_world`] turns a local point into the caller's (the C API's getters do), and
//! localization's frames ([`crate::localize::prepare`]) are in the caller's coordinates. For a
//! cloth created within `ORIGIN_GRID / 2` (2 m) of the caller's zero the origin is zero and the
//! two coordinates are the same, bit for bit, until the cloth travels more than `ORIGIN_GRID`
//! (4 m) from it: then a step moves the origin after it (`World::follow_cloth`), so a caller
//! that reads local positions reads `origin()` with them.

mod build;
pub(crate) mod error;
pub(crate) mod memory;
mod origin;
pub(crate) mod settings;

pub use error::{EditError, Energy, InitError, StepError, StepStats};
pub use memory::Capacity;
pub(crate) use memory::{Arrays, Counts};
pub use origin::ORIGIN_GRID;
pub use settings::{effects, Settings, Solver};

use glam::{DVec3, Mat3A, Quat, Vec3A};

use crate::blob::Blob;
use crate::collide::{Collider, ColliderSet, Shape};
use crate::membrane;
use crate::mesh;
use crate::multigrid;
use crate::normals;
use crate::step::{self, monitor};
use crate::strided::{Strided, StridedMut};

/// A material as the world uses it: stiffness (C^H for a coarse cloth, the pixel's own C for
/// the fine reference), areal density and bending stiffness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Membrane stiffness, N/m, Voigt `[11, 22, 12]`, engineering shear.
    pub stiffness: [[f64; 3]; 3],
    /// kg/m².
    pub density: f64,
    /// N·m.
    pub bending: f64,
}

/// Where triangle materials come from: the cells of a blob (index = cell index) or a table.
#[derive(Clone, Copy)]
pub enum Materials<'a> {
    Blob(&'a Blob<'a>),
    Table(&'a [Material]),
}

impl Materials<'_> {
    pub fn get(&self, i: u32) -> Option<Material> {
        match self {
            Materials::Blob(b) => b.cell(i as usize).map(|c| Material {
                stiffness: c.stiffness,
                density: c.density,
                bending: c.bending,
            }),
            Materials::Table(t) => t.get(i as usize).copied(),
        }
    }
}

/// The cloth handed to [`World::new`]. Borrowed; nothing is kept.
#[derive(Clone, Copy)]
pub struct ClothDef<'a> {
    /// Initial positions (m).
    pub positions: &'a [[f32; 3]],
    /// Material coordinates (u, v) in metres: the rest shape.
    pub uvs: &'a [[f32; 2]],
    pub triangles: &'a [[u32; 3]],
    /// Per triangle, its material (the cell index in a blob).
    pub materials: &'a [u32],
}

impl<'a> ClothDef<'a> {
    /// The same cloth as a [`StridedClothDef`].
    pub fn strided(&self) -> StridedClothDef<'a> {
        StridedClothDef {
            positions: Strided::from_slice(self.positions),
            uvs: Strided::from_slice(self.uvs),
            triangles: self.triangles,
            materials: TriangleMaterials::PerTriangle(self.materials),
        }
    }
}

/// The cloth handed to [`World::new_strided`]: a [`ClothDef`] whose positions and (u, v) are
/// read in place from (interleaved) vertex buffers and whose triangles may share one material,
/// so nothing has to be gathered into packed arrays first. Borrowed; nothing is kept.
#[derive(Clone, Copy)]
pub struct StridedClothDef<'a> {
    /// Initial positions (m).
    pub positions: Strided<'a, 3>,
    /// Material coordinates (u, v) in metres: the rest shape.
    pub uvs: Strided<'a, 2>,
    pub triangles: &'a [[u32; 3]],
    pub materials: TriangleMaterials<'a>,
}

/// Each triangle's material (the cell index in a blob).
#[derive(Clone, Copy, Debug)]
pub enum TriangleMaterials<'a> {
    /// One per triangle.
    PerTriangle(&'a [u32]),
    /// The same for every triangle.
    Uniform(u32),
}

impl TriangleMaterials<'_> {
    /// Triangle `t`'s material (`None` past the end of a per-triangle slice).
    fn get(&self, t: usize) -> Option<u32> {
        match self {
            TriangleMaterials::PerTriangle(m) => m.get(t).copied(),
            TriangleMaterials::Uniform(m) => Some(*m),
        }
    }
}

/// A whole-cloth vertex input of the edit functions: one entry per vertex, every value finite.
fn check_vertex_input(input: &Strided<'_, 3>, n: usize) -> Result<(), EditError> {
    if input.count() != n {
        return Err(EditError::VertexOutOfRange);
    }
    check_range_input(input, 0, n).map(|_| ())
}

/// A vertex-range input of the edit functions: entries for vertices `first..first + count`,
/// all below `n`, every value finite. Returns the range.
fn check_range_input<const N: usize>(
    input: &Strided<'_, N>,
    first: usize,
    n: usize,
) -> Result<core::ops::Range<usize>, EditError> {
    let end = first
        .checked_add(input.count())
        .filter(|&end| end <= n)
        .ok_or(EditError::VertexOutOfRange)?;
    let finite = |i| {
        input
            .get(i)
            .is_some_and(|p| p.iter().all(|c| c.is_finite()))
    };
    if !(0..input.count()).all(finite) {
        return Err(EditError::NonFinite);
    }
    Ok(first..end)
}

/// `array[first..first + input.count()] = convert(input)`, after [`check_range_input`]
/// (nothing is written on failure); `convert` takes positions to local coordinates.
fn write_range(
    array: &mut [Vec3A],
    first: usize,
    input: &Strided<'_, 3>,
    n: usize,
    convert: impl Fn([f32; 3]) -> Vec3A,
) -> Result<(), EditError> {
    let range = check_range_input(input, first, n)?;
    let to = array.get_mut(range).ok_or(EditError::VertexOutOfRange)?;
    for (k, x) in to.iter_mut().enumerate() {
        *x = convert(input.get(k).ok_or(EditError::VertexOutOfRange)?);
    }
    Ok(())
}

/// The live prefix `..n` for an accessor or an infallible helper: empty should `n` exceed the
/// array, which a world's counts never do.
fn prefix<T>(array: &[T], n: usize) -> &[T] {
    array.get(..n).unwrap_or_default()
}

/// [`prefix`] for an array that is written.
fn prefix_mut<T>(array: &mut [T], n: usize) -> &mut [T] {
    array.get_mut(..n).unwrap_or_default()
}

/// `to[..n] = from[..n]` (nothing, should `n` exceed either array, which it never does).
fn copy_live<T: Copy>(to: &mut [T], from: &[T], n: usize) {
    if let (Some(to), Some(from)) = (to.get_mut(..n), from.get(..n)) {
        to.copy_from_slice(from);
    }
}

/// The directions a pin holds ([`World::set_pin_axes`]); the others are free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PinAxes {
    /// Every direction: the vertex is on the target.
    Point,
    /// The direction `normal` only: the vertex slides freely in the plane through the target
    /// normal to it.
    Plane { normal: [f32; 3] },
    /// The two directions normal to `direction`: the vertex slides freely along the line
    /// through the target (a curtain ring on a rail).
    Line { direction: [f32; 3] },
}

impl PinAxes {
    /// The free directions as a projection `S` (the PCG filter of the pinned vertex), or
    /// `None` for an axis that is not finite and non-zero.
    fn free_directions(&self) -> Option<Mat3A> {
        let unit = |a: [f32; 3]| {
            let a = Vec3A::from(a);
            let unit = a.normalize_or_zero();
            (a.is_finite() && unit != Vec3A::ZERO).then_some(unit)
        };
        Some(match *self {
            PinAxes::Point => Mat3A::ZERO,
            PinAxes::Plane { normal } => {
                let n = unit(normal)?;
                Mat3A::IDENTITY - step::system::outer(n, n)
            }
            PinAxes::Line { direction } => {
                let d = unit(direction)?;
                step::system::outer(d, d)
            }
        })
    }
}

/// Whether targets `a` and `b` of a pin leaving the directions `free` free hold it to the
/// same line or plane, to the rounding of the three points involved: the step moves a target
/// along its free directions ([`World::anchor_pins_at_their_vertices`]), and an engine setting
/// the same target again each frame must not wake the world.
fn same_rail(free: Mat3A, a: Vec3A, b: Vec3A) -> bool {
    if free == Mat3A::ZERO {
        return a == b;
    }
    let (a, b) = (a.as_dvec3(), b.as_dvec3());
    let d = b - a;
    let held = d - free.as_dmat3() * d;
    let rounding = 4.0 * f64::from(f32::EPSILON) * (a.abs() + b.abs() + d.abs()).max_element();
    held.abs().max_element() <= rounding
}

/// A coarse cloth and everything needed to step it, living in a caller-owned block.
pub struct World<'a> {
    a: Arrays<'a>,
    capacity: Capacity,
    settings: Settings,
    n: usize,
    nt: usize,
    ne: usize,
    nh: usize,
    /// Entries of the block pattern (edges) and of the scalar pattern (hinge-only pairs).
    nnz: usize,
    nnz_h: usize,
    pins: usize,
    colliders: usize,
    /// The id the next collider gets (ids are not reused while their collider lives).
    next_collider_id: u32,
    /// Per-vertex lumped mass sum, kg.
    total_mass: f64,
    calm_frames: u32,
    /// The energy balance's level of the current state, when known (each step's end is the
    /// next one's start; every edit forgets it).
    level: Option<monitor::Level>,
    /// The balance since the lowest level reached (`monitor::Drift`); forgotten with `level`.
    drift: Option<monitor::Drift>,
    /// The work of external input in the last attempt at a step, and its round-off (J).
    last_input: (f64, f64),
    asleep: bool,
    last: StepStats,
    solver: Solver,
    /// The caller's coordinates of local zero (`origin.rs`).
    origin: DVec3,
}

impl<'a> World<'a> {
    // ----- accessors -----

    pub fn vertex_count(&self) -> usize {
        self.n
    }
    pub fn triangle_count(&self) -> usize {
        self.nt
    }
    pub fn edge_count(&self) -> usize {
        self.ne
    }
    pub fn hinge_count(&self) -> usize {
        self.nh
    }
    pub fn capacity(&self) -> Capacity {
        self.capacity
    }
    /// Vertex positions in local coordinates (module docs, "Coordinates"): `to_world` gives the
    /// caller's.
    pub fn positions(&self) -> &[Vec3A] {
        prefix(self.a.x, self.n)
    }
    pub fn velocities(&self) -> &[Vec3A] {
        prefix(self.a.v, self.n)
    }
    pub fn masses(&self) -> &[f32] {
        prefix(self.a.mass, self.n)
    }
    pub fn rest_positions(&self) -> &[Vec3A] {
        prefix(self.a.rest, self.n)
    }
    pub fn triangles(&self) -> &[[u32; 3]] {
        prefix(self.a.triangles, self.nt)
    }
    pub fn triangle_materials(&self) -> &[u32] {
        prefix(self.a.tri_material, self.nt)
    }
    /// Triangles incident to vertex `v` (empty for an out-of-range index).
    pub fn incident_triangles(&self, v: usize) -> &[u32] {
        let a = &self.a;
        match (a.vt_start.get(v), a.vt_start.get(v + 1)) {
            (Some(&s), Some(&e)) if v < self.n => a.vt.get(s as usize..e as usize).unwrap_or(&[]),
            _ => &[],
        }
    }
    /// Per-vertex rotations of the per-node warping mode (identity otherwise).
    #[cfg(feature = "research")]
    pub fn rotations(&self) -> &[Quat] {
        prefix(self.a.rot, self.n)
    }
    pub fn normals(&self) -> &[Vec3A] {
        prefix(self.a.normals, self.n)
    }
    pub fn settings(&self) -> &Settings {
        &self.settings
    }
    pub fn last_step(&self) -> StepStats {
        self.last
    }
    pub fn is_asleep(&self) -> bool {
        self.asleep
    }
    pub fn total_mass(&self) -> f64 {
        self.total_mass
    }

    /// The CG preconditioner of the step.
    pub fn solver(&self) -> Solver {
        self.solver
    }

    /// The multilevel hierarchy's shape (built at init for any solver).
    pub fn multigrid_info(&self) -> Option<multigrid::Info> {
        multigrid::info(self.a.scratch_a)
    }

    /// Chooses the CG preconditioner of the following steps.
    pub fn set_solver(&mut self, solver: Solver) {
        self.solver = solver;
    }

    /// Changes scene parameters; wakes the world when anything changed.
    pub fn set_settings(&mut self, settings: Settings) -> Result<(), InitError> {
        settings.validate()?;
        if settings != self.settings {
            let pins_on = |s: &Settings| s.effects & effects::PINS != 0;
            if pins_on(&settings) && !pins_on(&self.settings) {
                // Pins switched on start where their vertices are, as a new pin does
                // ([`World::set_pin_axes`]), and reach their targets over the next step as
                // moving pins (whose work the energy balance counts). From their old targets
                // they yanked a vertex that had moved away in one substep: an outside fuzzer
                // saw 0.09 J become 75 J, and every later step refused.
                self.start_pins_at_their_vertices(0..self.n);
            }
            self.settings = settings;
            self.wake();
        }
        Ok(())
    }

    /// Wakes a sleeping world.
    pub fn wake(&mut self) {
        self.asleep = false;
        self.calm_frames = 0;
        self.level = None;
    }

    /// Overwrites positions (caller's coordinates; zeroes nothing else); wakes the world. A
    /// pinned vertex keeps its pin: set away from the pin's target, it is carried back over the
    /// next step (to move the pin too, set its target with [`World::set_pin`]).
    pub fn set_positions(&mut self, positions: &[[f32; 3]]) -> Result<(), EditError> {
        self.set_positions_strided(&Strided::from_slice(positions))
    }

    /// [`World::set_positions`] from a strided (e.g. interleaved) vertex buffer.
    pub fn set_positions_strided(&mut self, positions: &Strided<'_, 3>) -> Result<(), EditError> {
        check_vertex_input(positions, self.n)?;
        self.set_positions_range(0, positions)
    }

    /// Overwrites the positions (caller's coordinates) of vertices
    /// `first..first + positions.count()` (the others keep theirs); checks every value first,
    /// nothing changes on failure. Wakes the world.
    pub fn set_positions_range(
        &mut self,
        first: usize,
        positions: &Strided<'_, 3>,
    ) -> Result<(), EditError> {
        let origin = self.origin;
        write_range(self.a.x, first, positions, self.n, |p| {
            origin::to_local(origin, p)
        })?;
        // A pinned vertex set away from its pin is carried back over the next step by its pin,
        // moving from the vertex to its target (work counted), as a new pin does: held at its
        // old target, the pin yanked it back in one substep (a cloth moved by 0.4 m gained
        // 4.2 J, was redone at 8× the substeps and had 3.2 J removed).
        self.start_pins_at_their_vertices(first..first + positions.count());
        self.wake();
        Ok(())
    }

    /// Starts the step's motion of the pins of the vertices in `range` where those vertices
    /// are (their `pin_previous`), so they reach their targets over the next step as moving
    /// pins whose work the energy balance counts.
    fn start_pins_at_their_vertices(&mut self, range: core::ops::Range<usize>) {
        let a = &mut self.a;
        let pinned = prefix_mut(a.pin_previous, self.pins)
            .iter_mut()
            .zip(prefix(a.pin_vertex, self.pins))
            .filter(|(_, &vertex)| range.contains(&(vertex as usize)));
        for (previous, &vertex) in pinned {
            if let Some(&x) = a.x.get(vertex as usize) {
                *previous = x;
            }
        }
    }

    /// Moves the target of every pin that leaves its vertex free along a line or a plane
    /// ([`PinAxes`]) to the point of that line or plane nearest the vertex, and likewise where
    /// the step's motion starts (`pin_previous`), in `f64`: the same pin. Where a vertex slid far
    /// along its rail, `target − x` is mostly along the free directions, and the `f32`
    /// projection onto the held ones (`place_pins`, the filter) is then neither exact nor
    /// idempotent: `(I − F)` is a projector only to `f32`, so each projection moved the vertex
    /// by ~1e-7 of that distance. Adversarial scene 18004, a stiff cloth that slid 2.4 km along
    /// its line pin: the pinned vertex was kicked 1.5 mm at every projection (0.11 J into a
    /// 0.04 J cloth), and every other step was held still. Anchored, `target − x` is the step's
    /// own motion.
    fn anchor_pins_at_their_vertices(&mut self) {
        let a = &mut self.a;
        let pins = prefix_mut(a.pin_target, self.pins)
            .iter_mut()
            .zip(prefix_mut(a.pin_previous, self.pins))
            .zip(
                prefix(a.pin_free, self.pins)
                    .iter()
                    .zip(prefix(a.pin_vertex, self.pins)),
            );
        for ((target, previous), (&free, &vertex)) in pins {
            if free == Mat3A::ZERO {
                continue;
            }
            let Some(&x) = a.x.get(vertex as usize) else {
                continue;
            };
            let free = free.as_dmat3();
            let near = |p: Vec3A| (p.as_dvec3() + free * (x.as_dvec3() - p.as_dvec3())).as_vec3a();
            let (t, p) = (near(*target), near(*previous));
            if t.is_finite() && p.is_finite() {
                (*target, *previous) = (t, p);
            }
        }
    }

    /// Overwrites velocities and forgets the solver's warm start (the last step's velocity
    /// change, meaningless for the new velocities); wakes the world.
    pub fn set_velocities(&mut self, velocities: &[[f32; 3]]) -> Result<(), EditError> {
        self.set_velocities_strided(&Strided::from_slice(velocities))
    }

    /// [`World::set_velocities`] from a strided (e.g. interleaved) vertex buffer.
    pub fn set_velocities_strided(&mut self, velocities: &Strided<'_, 3>) -> Result<(), EditError> {
        check_vertex_input(velocities, self.n)?;
        self.set_velocities_range(0, velocities)
    }

    /// Overwrites the velocities of vertices `first..first + velocities.count()` (the others
    /// keep theirs) and forgets the solver's warm start; checks every value first, nothing
    /// changes on failure. Wakes the world.
    pub fn set_velocities_range(
        &mut self,
        first: usize,
        velocities: &Strided<'_, 3>,
    ) -> Result<(), EditError> {
        write_range(self.a.v, first, velocities, self.n, Vec3A::from)?;
        prefix_mut(self.a.dv, self.n).fill(Vec3A::ZERO);
        self.wake();
        Ok(())
    }

    /// Moves the whole cloth rigidly, `x ← R x + t` in the caller's coordinates (so `R` turns
    /// about the caller's zero: to turn about a point `p`, pass `t = p − R p + the move`), a
    /// teleport with a character: its shape, and so its elastic and bending energy, is kept.
    /// With `keep_velocity` the velocities (and the solver's warm start) turn with it,
    /// `v ← R v`, so the motion goes on in the new frame; otherwise the cloth is at rest. Pin
    /// targets move with the cloth (set them again if they should not); contacts are
    /// forgotten, colliders stay. `rotation` must be finite and non-zero (it is normalized),
    /// `translation` finite; `NonFinite` (nothing changed) also when the cloth would land
    /// beyond `f32`. Wakes the world.
    ///
    /// The motion is computed in `f64` from the caller's coordinates, one rounding per
    /// position, and the [`World::origin`] is chosen again for where the cloth lands, as at
    /// creation: a cloth teleported 10 km keeps its edge lengths to the `f32` of a local
    /// coordinate and goes on being simulated near its origin.
    pub fn transform(
        &mut self,
        rotation: Quat,
        translation: [f32; 3],
        keep_velocity: bool,
    ) -> Result<(), EditError> {
        let t = Vec3A::from(translation);
        if !(rotation.is_finite() && t.is_finite()) {
            return Err(EditError::NonFinite);
        }
        if rotation.length_squared() < f32::MIN_POSITIVE {
            return Err(EditError::InvalidRotation);
        }
        let rotation = rotation.normalize();
        let motion = origin::Rigid::new(rotation, t);
        let from = self.origin;
        let landed = prefix(self.a.x, self.n)
            .iter()
            .map(|&x| motion.apply(from, x));
        let to = origin::origin_around(landed);
        self.reorigin(to, |x| origin::moved(from, to, &motion, x))?;
        let (n, pins) = (self.n, self.pins);
        let r = Mat3A::from_quat(rotation);
        let a = &mut self.a;
        for free in prefix_mut(a.pin_free, pins) {
            *free = r * *free * r.transpose();
        }
        for v in prefix_mut(a.v, n).iter_mut().chain(prefix_mut(a.dv, n)) {
            *v = if keep_velocity { r * *v } else { Vec3A::ZERO };
        }
        prefix_mut(a.contact, n).fill(mesh::NONE);
        self.refresh_frames(8);
        self.wake();
        Ok(())
    }

    // ----- read-back -----

    /// The Green strain `E = ½(FᵀF − I)` of triangles `first..first + out.count()`, in the
    /// triangle's material frame (the cloth's (u, v) axes), Voigt `[E11, E22, 2 E12]` with
    /// engineering shear: `F` maps the triangle's rest (u, v) to its current positions. Whatever
    /// the step's strain measure, this is the Green strain. The stretch along u is
    /// `sqrt(1 + 2 E11)` (along v likewise; 1 at rest), the thing to threshold for tearing.
    pub fn triangle_strains(
        &self,
        first: usize,
        out: &mut StridedMut<'_, 3>,
    ) -> Result<(), EditError> {
        let end = first
            .checked_add(out.count())
            .filter(|&end| end <= self.nt)
            .ok_or(EditError::TriangleOutOfRange)?;
        let (triangles, elements) = (
            self.a.triangles.get(first..end),
            self.a.elements.get(first..end),
        );
        let (Some(triangles), Some(elements)) = (triangles, elements) else {
            return Err(EditError::TriangleOutOfRange);
        };
        let x = self.positions();
        for (k, (tri, element)) in triangles.iter().zip(elements).enumerate() {
            let corner = |c: usize| {
                let i = tri.get(c).copied().unwrap_or(0) as usize;
                x.get(i).copied().unwrap_or(Vec3A::ZERO) // (corners are < n)
            };
            let (e, _, _) =
                element.measure([corner(0), corner(1), corner(2)], membrane::Strain::Green);
            out.set(k, e);
        }
        Ok(())
    }

    // ----- forces, impulses, masses -----

    /// Adds forces (N) to vertices `first..first + forces.count()` for the next step: constant
    /// over it, then cleared (apply them again each frame for a lasting force). The step's
    /// energy balance counts their work as input. Checks every value first; nothing changes
    /// on failure. Wakes the world when any is non-zero.
    pub fn add_forces(&mut self, first: usize, forces: &Strided<'_, 3>) -> Result<(), EditError> {
        let range = check_range_input(forces, first, self.n)?;
        let applied = self
            .a
            .applied_force
            .get_mut(range)
            .ok_or(EditError::VertexOutOfRange)?;
        let mut any = false;
        for (k, f) in applied.iter_mut().enumerate() {
            let add = Vec3A::from(forces.get(k).ok_or(EditError::VertexOutOfRange)?);
            *f = (Vec3A::from(*f) + add).to_array();
            any |= add != Vec3A::ZERO;
        }
        if any {
            self.wake();
        }
        Ok(())
    }

    /// The forces applied for the next step so far (N), per vertex.
    pub fn applied_forces(&self) -> &[[f32; 3]] {
        prefix(self.a.applied_force, self.n)
    }

    /// Applies impulses (N·s) to vertices `first..first + impulses.count()`: each vertex's
    /// velocity changes by `impulse / mass` at once, so the next step starts from it (a pinned
    /// vertex stays held). Checks every value first; nothing changes on failure. Wakes the
    /// world when any is non-zero.
    pub fn add_impulses(
        &mut self,
        first: usize,
        impulses: &Strided<'_, 3>,
    ) -> Result<(), EditError> {
        let range = check_range_input(impulses, first, self.n)?;
        let (Some(v), Some(mass)) = (
            self.a.v.get_mut(range.clone()),
            self.a.mass.get(range.clone()),
        ) else {
            return Err(EditError::VertexOutOfRange);
        };
        let mut any = false;
        for (k, (v, &m)) in v.iter_mut().zip(mass).enumerate() {
            let impulse = Vec3A::from(impulses.get(k).ok_or(EditError::VertexOutOfRange)?);
            *v += impulse / m;
            any |= impulse != Vec3A::ZERO;
        }
        if any {
            self.wake();
        }
        Ok(())
    }

    /// Sets the mass scale of vertices `first..first + scales.count()`: each one's mass
    /// becomes its lumped mass from the materials' density times the scale (heavier hems,
    /// weighted attachment points). A scale must be finite and positive, and the mass it gives
    /// a normal positive `f32` (`EditError::InvalidMassScale` names the first that is not).
    /// The step uses these masses for inertia, gravity and damping. Checks every value first;
    /// nothing changes on failure. Wakes the world.
    pub fn set_mass_scales(
        &mut self,
        first: usize,
        scales: &Strided<'_, 1>,
    ) -> Result<(), EditError> {
        let range = check_range_input(scales, first, self.n)?;
        let (Some(mass), Some(rest)) = (
            self.a.mass.get_mut(range.clone()),
            self.a.rest_mass.get(range.clone()),
        ) else {
            return Err(EditError::VertexOutOfRange);
        };
        let scaled = |k: usize, &rest: &f32| {
            let s = scales.get(k).map_or(f32::NAN, |[s]| s);
            let m = rest * s;
            (s > 0.0 && m.is_normal()).then_some(m)
        };
        if let Some(k) = rest
            .iter()
            .enumerate()
            .position(|(k, r)| scaled(k, r).is_none())
        {
            return Err(EditError::InvalidMassScale {
                vertex: (first + k) as u32,
            });
        }
        for (k, (m, r)) in mass.iter_mut().zip(rest).enumerate() {
            *m = scaled(k, r).unwrap_or(*m);
        }
        self.total_mass = prefix(self.a.mass, self.n)
            .iter()
            .map(|&m| f64::from(m))
            .sum();
        self.wake();
        Ok(())
    }

    // ----- pins -----

    /// Pins `vertex` to `target` (m, caller's coordinates) in every direction. A pin that
    /// already exists gets the new target; the vertex moves there over the next step (linearly
    /// across substeps). Wakes the world when the target changed. Targets are checked at step
    /// time too, so a NaN target set through a raw pointer in C is still caught.
    pub fn set_pin(&mut self, vertex: u32, target: [f32; 3]) -> Result<(), EditError> {
        self.set_pin_axes(vertex, target, PinAxes::Point)
    }

    /// Pins `vertex` to `target` (m, caller's coordinates) in the directions `axes` holds and leaves it free in the
    /// others (a ring on a rail: [`PinAxes::Line`]); otherwise as [`World::set_pin`]. The held
    /// directions are the solver's constraint filter, so the free ones feel no friction. Only
    /// the line or plane through `target` matters: another target on it is the same pin (it
    /// does not wake the world), and the step keeps the point of it nearest the vertex.
    pub fn set_pin_axes(
        &mut self,
        vertex: u32,
        target: [f32; 3],
        axes: PinAxes,
    ) -> Result<(), EditError> {
        let vi = vertex as usize;
        if vi >= self.n {
            return Err(EditError::VertexOutOfRange);
        }
        let free = axes.free_directions().ok_or(EditError::InvalidAxis)?;
        let target = origin::to_local(self.origin, target);
        // (`pin_of` and `x` are capacity-long, and a pin index is below the pin count: the
        // `VertexOutOfRange` and `PinCapacity` below cannot happen)
        let p = *self.a.pin_of.get(vi).ok_or(EditError::VertexOutOfRange)?;
        if p != mesh::NONE {
            let a = &mut self.a;
            let (Some(slot), Some(slot_free)) = (
                prefix_mut(a.pin_target, self.pins).get_mut(p as usize),
                prefix_mut(a.pin_free, self.pins).get_mut(p as usize),
            ) else {
                return Err(EditError::PinCapacity);
            };
            if *slot_free != free || !same_rail(free, *slot, target) {
                *slot = target;
                *slot_free = free;
                self.wake();
            }
            return Ok(());
        }
        if self.pins >= self.capacity.p() {
            return Err(EditError::PinCapacity);
        }
        let p = self.pins;
        let a = &mut self.a;
        let (Some(pin_vertex), Some(pin_target), Some(pin_previous), Some(pin_free)) = (
            a.pin_vertex.get_mut(p),
            a.pin_target.get_mut(p),
            a.pin_previous.get_mut(p),
            a.pin_free.get_mut(p),
        ) else {
            return Err(EditError::PinCapacity);
        };
        let (Some(&x), Some(pin_of)) = (a.x.get(vi), a.pin_of.get_mut(vi)) else {
            return Err(EditError::VertexOutOfRange);
        };
        *pin_vertex = vertex;
        *pin_target = target;
        *pin_free = free;
        // A new pin starts where the vertex is, so it is not yanked in one substep.
        *pin_previous = x;
        *pin_of = p as u32;
        self.pins += 1;
        self.wake();
        Ok(())
    }

    /// Releases the pin of `vertex` (no error if it had none).
    pub fn remove_pin(&mut self, vertex: u32) -> Result<(), EditError> {
        let vi = vertex as usize;
        if vi >= self.n {
            return Err(EditError::VertexOutOfRange);
        }
        // (as in `set_pin`, the errors below cannot happen; nothing is written before them)
        let p = *self.a.pin_of.get(vi).ok_or(EditError::VertexOutOfRange)?;
        if p == mesh::NONE {
            return Ok(());
        }
        // Swap-remove, keeping pin_of consistent.
        let last = self.pins - 1;
        let p = p as usize;
        let a = &mut self.a;
        let (Some(&last_vertex), Some(&last_target), Some(&last_previous), Some(&last_free)) = (
            a.pin_vertex.get(last),
            a.pin_target.get(last),
            a.pin_previous.get(last),
            a.pin_free.get(last),
        ) else {
            return Err(EditError::PinCapacity);
        };
        let (Some(pin_vertex), Some(pin_target), Some(pin_previous), Some(pin_free)) = (
            a.pin_vertex.get_mut(p),
            a.pin_target.get_mut(p),
            a.pin_previous.get_mut(p),
            a.pin_free.get_mut(p),
        ) else {
            return Err(EditError::PinCapacity);
        };
        if a.pin_of.get(last_vertex as usize).is_none() {
            return Err(EditError::VertexOutOfRange);
        }
        *pin_vertex = last_vertex;
        *pin_target = last_target;
        *pin_previous = last_previous;
        *pin_free = last_free;
        // (in this order: when `p` is the last pin, `last_vertex` is `vertex`)
        if let Some(moved) = a.pin_of.get_mut(last_vertex as usize) {
            *moved = p as u32;
        }
        if let Some(removed) = a.pin_of.get_mut(vi) {
            *removed = mesh::NONE;
        }
        self.pins = last;
        self.wake();
        Ok(())
    }

    pub fn pin_count(&self) -> usize {
        self.pins
    }

    // ----- colliders -----

    /// Adds a collider (its shapes in the caller's coordinates); returns its id, which names it
    /// until it is removed, whatever else is added or removed (0, 1, 2 ... in order of
    /// addition; a removed collider's id is not given again until the 32-bit counter wraps).
    pub fn add_collider(&mut self, collider: Collider) -> Result<u32, EditError> {
        if !collider.is_valid() {
            return Err(EditError::InvalidCollider);
        }
        let collider = Collider {
            shape: origin::shape_to_local(self.origin, collider.shape),
            previous: origin::shape_to_local(self.origin, collider.previous),
            ..collider
        };
        // (a contact state keeps its flags above the collider index)
        if self.colliders >= self.capacity.c().min(step::contacts::MAX_COLLIDERS) {
            return Err(EditError::ColliderCapacity);
        }
        // (after a wrap of the counter, skip the ids still in use)
        let mut id = self.next_collider_id;
        while id == mesh::NONE || self.collider_slot(id).is_some() {
            id = id.wrapping_add(1);
        }
        let k = self.colliders;
        let (Some(slot), Some(slot_id)) =
            (self.a.colliders.get_mut(k), self.a.collider_id.get_mut(k))
        else {
            return Err(EditError::ColliderCapacity);
        };
        *slot = collider;
        *slot_id = id;
        self.colliders += 1;
        self.next_collider_id = id.wrapping_add(1);
        self.wake();
        Ok(id)
    }

    /// The slot of the collider `id` (colliders are packed in slots `..colliders`).
    fn collider_slot(&self, id: u32) -> Option<usize> {
        prefix(self.a.collider_id, self.colliders)
            .iter()
            .position(|&c| c == id)
    }

    /// Moves collider `id` to `shape` (caller's coordinates); the next step sweeps it from
    /// where it was: its centre, axis, plane offset and radius (a growing sphere, capsule or
    /// shell pushes the cloth at the speed its surface moves).
    pub fn set_collider_shape(&mut self, id: u32, shape: Shape) -> Result<(), EditError> {
        let shape = origin::shape_to_local(self.origin, shape);
        let k = self.collider_slot(id).ok_or(EditError::UnknownCollider)?;
        let c = self
            .a
            .colliders
            .get_mut(k)
            .ok_or(EditError::UnknownCollider)?;
        if !shape.is_valid() {
            return Err(EditError::InvalidCollider);
        }
        if c.shape != shape {
            c.shape = shape;
            self.wake();
        }
        Ok(())
    }

    /// Collider `id`, if it exists, in local coordinates (module docs, "Coordinates").
    pub fn collider(&self, id: u32) -> Option<&Collider> {
        self.a.colliders.get(self.collider_slot(id)?)
    }

    /// The ids of the colliders, in slot order.
    pub fn collider_ids(&self) -> &[u32] {
        prefix(self.a.collider_id, self.colliders)
    }

    pub fn collider_count(&self) -> usize {
        self.colliders
    }

    /// The colliders, for [`crate::localize::localize_colliding`] (whose frames are in the
    /// caller's coordinates).
    pub fn collider_set(&self) -> ColliderSet<'_> {
        ColliderSet {
            colliders: prefix(self.a.colliders, self.colliders),
            origin: self.origin.as_vec3a(),
        }
    }

    /// Removes collider `id`; the other colliders keep their ids. An id that names no
    /// collider (never added, or removed already) is [`EditError::UnknownCollider`]. Wakes
    /// the world.
    pub fn remove_collider(&mut self, id: u32) -> Result<(), EditError> {
        let k = self.collider_slot(id).ok_or(EditError::UnknownCollider)?;
        let last = self.colliders - 1;
        let a = &mut self.a;
        if last >= a.colliders.len().min(a.collider_id.len()) {
            return Err(EditError::UnknownCollider); // (slots below the count always exist)
        }
        // the last slot moves into the hole, and the contacts follow their collider
        a.colliders.swap(k, last);
        a.collider_id.swap(k, last);
        let (k, last) = (k as u32, last as u32);
        let contacts = prefix_mut(a.contact, self.n)
            .iter_mut()
            .chain(prefix_mut(a.contact_start, self.n));
        for c in contacts {
            *c = step::contacts::collider_removed(*c, k, last);
        }
        self.colliders -= 1;
        self.wake();
        Ok(())
    }

    /// Removes all colliders (their ids are not given again).
    pub fn clear_colliders(&mut self) {
        self.colliders = 0;
        prefix_mut(self.a.contact, self.n).fill(mesh::NONE);
        self.wake();
    }

    // ----- origin -----

    /// The caller's coordinates of the world's local zero (module docs, "Coordinates").
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// A point of the caller's coordinates in local ones (what every input goes through).
    pub fn to_local(&self, p: [f32; 3]) -> Vec3A {
        origin::to_local(self.origin, p)
    }

    /// A local point (e.g. of [`World::positions`]) in the caller's coordinates (what every
    /// output goes through).
    pub fn to_world(&self, x: Vec3A) -> [f32; 3] {
        origin::to_world(self.origin, x)
    }

    /// Moves the local zero to `origin` (caller's coordinates), e.g. when the cloth travelled
    /// far from where it was created: positions, pin targets and colliders are re-expressed
    /// relative to it, one rounding each, and stay where they are in the caller's coordinates.
    /// Does not wake the world. `NonFinite` (nothing changed) for a non-finite origin or one so
    /// far that a local coordinate would not be finite.
    pub fn set_origin(&mut self, origin: DVec3) -> Result<(), EditError> {
        let from = self.origin;
        self.reorigin(origin, |x| origin::rebase(from, origin, x))
    }

    /// Makes `to` the origin: positions and pin targets become `place(x)` (their local
    /// coordinates relative to `to`), colliders are re-expressed relative to `to`, where they
    /// are in the caller's coordinates. `NonFinite` (nothing changed) when `to` or a placed
    /// position is not finite.
    fn reorigin(&mut self, to: DVec3, place: impl Fn(Vec3A) -> Vec3A) -> Result<(), EditError> {
        let from = self.origin;
        if !(to.is_finite()
            && prefix(self.a.x, self.n)
                .iter()
                .all(|&x| place(x).is_finite()))
        {
            return Err(EditError::NonFinite);
        }
        let a = &mut self.a;
        let targets = prefix_mut(a.pin_target, self.pins).iter_mut();
        for x in prefix_mut(a.x, self.n)
            .iter_mut()
            .chain(targets)
            .chain(prefix_mut(a.pin_previous, self.pins))
        {
            *x = place(*x);
        }
        for c in prefix_mut(a.colliders, self.colliders) {
            c.shape = c.shape.translated(from - to);
            c.previous = c.previous.translated(from - to);
        }
        self.origin = to;
        // the gravitational energy is measured from the origin's height
        self.level = None;
        Ok(())
    }

    /// After a step: a cloth whose bounding box's centre has travelled more than
    /// [`ORIGIN_GRID`] (4 m, along any axis) from local zero gets the origin creation would
    /// give it there (the centre rounded to the grid: within 2 m). An `f32` position 2 km away
    /// is resolved to 1.2e-4 m, and a 5 cm triangle's strain to 2e-3: noise of which the
    /// elastic forces and the energy balance's floor are made (an adversarial scene's cloth
    /// that had drifted 180 m read 0.7 J of round-off in a 1 J state, and its balance was
    /// blind). The move is by a multiple of the grid, so a position that comes nearer to zero
    /// is not rounded; the caller's coordinates do not change, and `origin()` tells the new one.
    fn follow_cloth(&mut self) {
        let (lo, hi) = prefix(self.a.x, self.n)
            .iter()
            .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
        let centre = (lo + hi) * 0.5;
        if centre.abs().max_element() as f64 > ORIGIN_GRID {
            let to = origin::on_grid(self.origin + centre.as_dvec3());
            // (positions are finite after a step; a refusal would leave the origin as it is)
            let _ = self.set_origin(to);
        }
    }

    /// Follows a recentering of the caller's coordinates (Jolt's and PhysX's "shift origin"):
    /// what was at `shift` is now at zero, so every later input and output is relative to the
    /// new coordinates. Nothing in the world moves or is rounded (only the origin changes by
    /// `-shift`). `NonFinite` (nothing changed) when the new origin would not be finite.
    pub fn shift_origin(&mut self, shift: DVec3) -> Result<(), EditError> {
        let origin = self.origin - shift;
        if !origin.is_finite() {
            return Err(EditError::NonFinite);
        }
        self.origin = origin;
        Ok(())
    }

    // ----- stepping -----

    /// Advances by `settings.time_step`.
    pub fn step(&mut self) -> Result<StepStats, StepError> {
        self.step_dt(self.settings.time_step)
    }

    /// Advances by `dt` seconds in `settings.substeps` substeps (the stages of
    /// `crate::step` (`src/step/`)), then checks the step's energy balance: a step whose end state holds
    /// more energy than its start plus the work of external input is redone with twice the
    /// substeps, and a tenth of a CG tolerance looser than the default when its solves had
    /// converged (three times: ×2, ×4, ×8, and twice more, to ×32, while each doubling at least
    /// halves the gain; with the multilevel preconditioner if its block-Jacobi solves did not
    /// converge), and what it still gains is taken out of its kinetic energy
    /// (see [`StepStats::redone`], [`StepStats::energy_removed`]); when that cannot cover it,
    /// the step is done once more with each substep's end energy-limited
    /// ([`StepStats::limited`]), and only if that fails too is the cloth held still for the
    /// step ([`StepStats::stopped`]). The gains each step's round-off forgives do not add up:
    /// one within its own round-off whose sum with those since the lowest level the cloth has
    /// been at exceeds the round-off of the two has that excess taken out of its kinetic
    /// energy, as far as that goes, without a redo. A substep whose solve
    /// breaks down or whose state overflows is redone the same way, and after the last redo
    /// the cloth is held still too; the step fails only when that hold overflows as well
    /// (pins on targets beyond `f32`). On error the world keeps the state it had before the
    /// call.
    pub fn step_dt(&mut self, dt: f32) -> Result<StepStats, StepError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidTimeStep);
        }
        let eff = self.settings.effects;
        let pins_on = eff & effects::PINS != 0;
        if pins_on {
            let pins = step::live(self.a.pin_target, self.pins)?
                .iter()
                .zip(step::live(self.a.pin_vertex, self.pins)?);
            for (target, &vertex) in pins {
                if !target.is_finite() {
                    return Err(StepError::NonFinitePin { vertex });
                }
            }
        }
        if self.asleep && eff & effects::SLEEP != 0 {
            self.last = StepStats {
                asleep: true,
                converged: true,
                ..StepStats::default()
            };
            return Ok(self.last);
        }
        if pins_on {
            self.anchor_pins_at_their_vertices();
        }
        let n = self.n;
        copy_live(self.a.x_start, self.a.x, n);
        copy_live(self.a.v_start, self.a.v, n);
        copy_live(self.a.contact_start, self.a.contact, n);
        let counts = self.counts();
        let start = match self.level {
            Some(level) => level,
            None => {
                self.drift = None;
                monitor::level(&self.a, &counts, &self.settings)?
            }
        };
        let stats = match self.attempts(dt, start, pins_on) {
            Ok(stats) => stats,
            Err(e) => {
                self.restore_start(false);
                return Err(e);
            }
        };
        // The sweep of colliders and pins ends where the engine put them.
        for c in prefix_mut(self.a.colliders, self.colliders) {
            c.previous = c.shape;
        }
        copy_live(self.a.pin_previous, self.a.pin_target, self.pins);
        self.follow_cloth();
        prefix_mut(self.a.applied_force, n).fill([0.0; 3]);
        if eff & effects::SLEEP != 0 {
            let limit = self.settings.sleep_velocity * self.settings.sleep_velocity;
            let v = prefix_mut(self.a.v, n);
            let calm = v.iter().all(|v| v.length_squared() <= limit);
            self.calm_frames = if calm { self.calm_frames + 1 } else { 0 };
            if self.calm_frames >= self.settings.sleep_frames.max(1) {
                self.asleep = true;
                v.fill(Vec3A::ZERO);
                self.level = None;
            }
        }
        self.last = stats;
        Ok(stats)
    }

    /// The attempts at a step from the energy level `start`, redone with more substeps while
    /// they gain energy (see [`World::step_dt`]). On error the caller restores the start.
    fn attempts(
        &mut self,
        dt: f32,
        start: monitor::Level,
        pins_on: bool,
    ) -> Result<StepStats, StepError> {
        let counts = self.counts();
        let mut substeps = self.settings.substeps.max(1);
        let mut redone = 0;
        let mut solver = self.solver;
        let mut tolerance = self.settings.tolerance;
        let mut previous_gain = None;
        // Once the step is energy-limited: the stats of the attempt before it, what a hold
        // keeps should the limited attempt break down.
        let mut limiting: Option<StepStats> = None;
        let stats = loop {
            // An end state whose energy overflows (its positions finite, its elastic terms
            // beyond `f32`) is an overflowed state too: its balance reads `∞ ≤ ∞` (the
            // energy's round-off is infinite as well), and from it every later step fails.
            // Measured: adversarial scene 5079 (a cloth crushed by a moving shell) accepted
            // such a step and then broke down at every call.
            // The end's round-off is taken no farther out than a sound step reaches
            // (`monitor::reach_bound`): one that threw the cloth far is not forgiven the
            // resolution of where it landed.
            let attempt = self
                .run_substeps(dt, substeps, solver, tolerance, limiting.is_some())
                .and_then(|stats| {
                    let (input, input_noise) = self.last_input;
                    let (a, st) = (&self.a, &self.settings);
                    let reach = monitor::reach_bound(
                        a,
                        &counts,
                        st,
                        dt,
                        &start,
                        input.abs() + input_noise,
                    )?;
                    let end = monitor::level_within(a, &counts, st, reach)?;
                    if end.is_finite() {
                        Ok((stats, end))
                    } else {
                        Err(StepError::NonFiniteState)
                    }
                });
            let room = substeps <= Settings::MAX_SUBSTEPS / 2;
            let redo = redone < monitor::MAX_REDOS && room;
            let (mut stats, end) = match attempt {
                Ok(attempt) => attempt,
                // A solve that broke down or a state that overflowed is the substep's size as
                // much as a gain below is: redone with twice the substeps, whose system is
                // better conditioned (the stiffness against the mass shrinks as h²), without
                // the failed Δv as a warm start. Failing at once kept the start, from which
                // every later call failed the same way (an outside fuzzer's cloth of 700×
                // vertex-mass contrast, 180 m from its origin: refused at every step from step
                // 94 on; it steps at 4 substeps). After the last redo the cloth is held still
                // for the step ([`World::stop_after`]).
                Err(e @ (StepError::SolverBreakdown | StepError::NonFiniteState)) => {
                    if let Some(stats) = limiting {
                        let tried = StepStats {
                            limited: true,
                            redone,
                            ..stats
                        };
                        break self.stop(pins_on, tried)?;
                    }
                    if !redo {
                        return self.stop_after(pins_on, e, redone, substeps);
                    }
                    self.restore_start(false);
                    substeps *= 2;
                    redone += 1;
                    solver = Solver::Multigrid;
                    // a later gain is compared with a gain of the attempt just before it
                    previous_gain = None;
                    continue;
                }
                Err(e) => return Err(e),
            };
            let (input, input_noise) = self.last_input;
            let (gravity, gravity_noise) =
                monitor::constant_force_work(&self.a, &counts, &self.settings)?;
            // the balance of a state `level` ending the attempt: its energy beyond the start's
            // and the input's
            let balance = |level: &monitor::Level| level.energy - start.energy - gravity - input;
            let gain = balance(&end);
            let floor = start.noise + end.excess + gravity_noise + input_noise;
            let drift = self.drift.unwrap_or_else(|| monitor::Drift::since(&start));
            stats.redone = redone;
            stats.energy_gain = gain as f32;
            stats.limited = limiting.is_some();
            let step_noise = gravity_noise + input_noise;
            if gain <= floor {
                // Within the step's own round-off; beyond that of the lowest level since, the
                // sum is a drift of many steps (`monitor::Drift`), which more substeps for this
                // one would not undo: what of it the kinetic energy holds is taken out. The rest
                // (the drift of a cloth at rest lies in its elastic energy, at the resolution of
                // `f32` positions) is left: a redo or a hold for it held a taut cloth at rest
                // still (adversarial scene 18074, its elastic energy rising ~5e-7 of itself a
                // step).
                let (drifted, drift_floor) = drift.with(gain, &end, step_noise);
                let end = if drifted > drift_floor {
                    let excess = drifted - drift_floor;
                    let removed = monitor::remove_kinetic(&mut self.a, &counts, pins_on, excess)?;
                    stats.energy_removed += removed as f32;
                    monitor::Level {
                        energy: end.energy - removed,
                        ..end
                    }
                } else {
                    end
                };
                let gain = balance(&end);
                self.level = Some(end);
                self.drift = Some(drift.after(gain, &end, step_noise));
                break stats;
            }
            let converging = room && monitor::converging(redone, gain, previous_gain);
            if limiting.is_none() && (redo || converging) {
                previous_gain = Some(gain);
                // Redo from the start with half the substep, and after converged solves at a
                // loose tolerance a tighter one: the linearization, the contacts' one-substep
                // prediction and the solves' error are the usual sources of a gain
                // (`monitor::redo_tolerance`). The attempt's last Δv warm-starts the redo.
                self.restore_start(true);
                substeps *= 2;
                redone += 1;
                // A tighter solve only after solves that reached their tolerance: one that
                // stopped short of it (its cap, the divergence guard) cannot reach a tighter
                // one, and pushed on it ends capped and dropped (`pcg`'s do-no-harm rule).
                if stats.converged {
                    tolerance = monitor::redo_tolerance(tolerance);
                }
                // Block Jacobi that did not converge (its iteration count grows with the
                // mesh and the stiffness, and on stiff slivers it breaks down in `f32` far
                // below its cap) is what most likely gained: the redos use the multilevel
                // preconditioner, which every world has. So do the redos of a step solved
                // along lines: their smoothing is checked only where a line is made, and a
                // cycle that is not positive everywhere can gain where it does not break down.
                if (!stats.converged && solver == Solver::BlockJacobi)
                    || solver == Solver::MultigridLines
                {
                    solver = Solver::Multigrid;
                }
                continue;
            }
            if !gain.is_finite() {
                return Err(StepError::Unstable);
            }
            let excess = gain - floor;
            let removed = monitor::remove_kinetic(&mut self.a, &counts, pins_on, excess)?;
            if removed < excess {
                if limiting.is_some() {
                    break self.stop(pins_on, stats)?;
                }
                // Once more, at the settings' substeps (the redos' last solver and tolerance),
                // each substep's end energy-limited (`step::system::limit`): from rest, or near
                // it, a gain its kinetic energy cannot cover is the Newton step's overshoot, and
                // a fraction of it goes on downhill where holding the cloth still stopped it at
                // every step. (At the last attempt's substeps instead: as few steps held, at up
                // to 8× the cost of such a step.)
                self.restore_start(true);
                redone += 1;
                limiting = Some(stats);
                substeps = self.settings.substeps.max(1);
                continue;
            }
            stats.energy_removed += removed as f32;
            let end = monitor::level(&self.a, &counts, &self.settings)?;
            let gain = balance(&end);
            self.level = Some(end);
            self.drift = Some(drift.after(gain, &end, step_noise));
            break stats;
        };
        Ok(stats)
    }

    /// The step's last resort, when even its redos and its energy-limited attempt gain more
    /// than their kinetic energy can give back (the limited substeps balance by themselves but
    /// for what they do not scale: the pins' motion and the pushes out of colliders): the cloth
    /// is held still for this step, where it started, with no velocity, but with what holds
    /// it done: its pinned vertices are put on their targets, and every other vertex out of
    /// the colliders, where they are at the end of the step, as each substep's projection
    /// does (what pins and colliders do is input, the rest stands still). That state holds
    /// less energy than the start plus that input by the kinetic energy, so it always
    /// balances, and the next step starts from rest. Refusing the step instead kept the start
    /// state, from which the next call failed the same way: an outside fuzzer saw such cloths
    /// refused at every later step, frozen. Leaving the pins behind made the next step's pin
    /// motion, and its failure, grow at every step; leaving a vertex inside a collider (the
    /// engine put it there, or a collider moved or appeared around it) left the next step the
    /// same push out of it to fail on, from the same state: a stiff strip pinned at a vertex
    /// inside a sphere was held still at every step, its other vertices inside for good
    /// (adversarial scene 16049: all 300 of its steps; `tests/hard_cases.rs`). A hold whose
    /// pins put the state beyond what `f32` energies hold fails as an overflowed substep does
    /// ([`StepError::NonFiniteState`]).
    fn stop(&mut self, pins_on: bool, stats: StepStats) -> Result<StepStats, StepError> {
        self.restore_start(false);
        let counts = self.counts();
        let v = prefix_mut(self.a.v, self.n);
        let kinetic = monitor::kinetic(prefix(self.a.mass, self.n), v);
        v.fill(Vec3A::ZERO);
        let outside = step::contacts::place_outside(&mut self.a, &counts, &self.settings)?;
        if pins_on {
            step::contacts::place_pins(&mut self.a, &counts, 1.0)?;
        }
        if pins_on || outside {
            self.refresh_frames(8);
        }
        // Pins put on targets far beyond what `f32` energies hold (a pin moved 1e9 m in one
        // step, whose attempts all gained without breaking down) overflow the state as a
        // substep can: the step fails with its start kept (the caller restores it), as for a
        // substep's overflow. Returned as a hold, the world stepped on from an infinite energy.
        let level = monitor::level(&self.a, &counts, &self.settings)?;
        if !level.is_finite() {
            return Err(StepError::NonFiniteState);
        }
        self.level = Some(level);
        // held still at rest: the balance since starts here
        self.drift = None;
        Ok(StepStats {
            stopped: true,
            energy_removed: kinetic as f32,
            ..stats
        })
    }

    /// The end of a step whose last redo broke down or overflowed (`e`, after `redone` redos,
    /// the last at `substeps`): the cloth is held still for the step ([`World::stop`]), and
    /// the next step starts from rest. Failing kept the start, velocities and all, from which
    /// every later call failed the same way: adversarial scene 16050 (a 7.7e5 N/m cloth of
    /// 1 g/m² that an unconverged solve had left with a vertex at 169 m/s) diverged at every
    /// substep count and failed at each of its last 25 calls. A hold that itself overflows
    /// (pins on targets beyond what `f32` energies hold, a pin at 1e30 m) fails with `e`,
    /// the start kept by the caller.
    fn stop_after(
        &mut self,
        pins_on: bool,
        e: StepError,
        redone: u32,
        substeps: u32,
    ) -> Result<StepStats, StepError> {
        let tried = StepStats {
            redone,
            substeps,
            ..StepStats::default()
        };
        self.stop(pins_on, tried).map_err(|_| e)
    }

    /// The substeps of one attempt at a step; `self.last_input` gets the work of external
    /// input (J) and its round-off.
    fn run_substeps(
        &mut self,
        dt: f32,
        substeps: u32,
        solver: Solver,
        tolerance: f32,
        limited: bool,
    ) -> Result<StepStats, StepError> {
        let settings = Settings {
            tolerance,
            ..self.settings
        };
        let counts = Counts {
            solver,
            ..self.counts()
        };
        let h = dt / substeps as f32;
        let mut stats = StepStats {
            converged: true,
            substeps,
            ..StepStats::default()
        };
        let (mut input, mut noise) = (0.0f64, 0.0f64);
        for s in 0..substeps {
            let sub = step::Substep {
                h,
                t0: s as f32 / substeps as f32,
                t: (s + 1) as f32 / substeps as f32,
            };
            let report = step::substep(&mut self.a, &counts, &settings, sub, limited)?;
            stats.energy_removed += report.removed as f32;
            stats.iterations += report.solve.iterations;
            stats.solves += report.solves;
            stats.first_iterations += report.first_iterations;
            stats.residual = stats.residual.max(report.solve.residual);
            stats.converged &= report.solve.converged;
            stats.contacts = report.contacts;
            input += report.input;
            // the estimate of the input is as good as the solve that gave its impulses, and no
            // worse than none: a relative residual measured against a near-zero right-hand side
            // can be any size (an outside fuzzer saw 2e3, which made the floor 1.9e8 J and let
            // a step gain 1e3 J)
            noise += report.input.abs() * f64::from(report.solve.residual.clamp(1e-3, 1.0));
        }
        self.last_input = (input, noise);
        Ok(stats)
    }

    /// Puts back the state saved at the start of the step. `keep_warm_start`: the next solve
    /// starts from the current Δv if it is finite (a redo), else from zero (after an error).
    fn restore_start(&mut self, keep_warm_start: bool) {
        let n = self.n;
        copy_live(self.a.x, self.a.x_start, n);
        copy_live(self.a.v, self.a.v_start, n);
        copy_live(self.a.contact, self.a.contact_start, n);
        // A failed solve's Δv (maybe huge or NaN) must not warm-start the next one, or one
        // bad input breaks every later solve. (The step's own warm start is not saved: its
        // memory is the flexible CG's vector.)
        let dv = prefix_mut(self.a.dv, n);
        if !(keep_warm_start && dv.iter().all(|d| d.is_finite())) {
            dv.fill(Vec3A::ZERO);
        }
        // Normals (and rotations) are warm starts; re-derive them from the restored state.
        self.refresh_frames(8);
    }

    /// The arrays, counts and settings the step's stages take, for the stages' own tests.
    #[cfg(test)]
    pub(crate) fn stage(&mut self) -> (&mut Arrays<'a>, Counts, Settings) {
        let (c, st) = (self.counts(), self.settings);
        (&mut self.a, c, st)
    }

    /// The counts the step's stages slice the arrays to.
    fn counts(&self) -> Counts {
        Counts {
            n: self.n,
            nt: self.nt,
            nnz: self.nnz,
            nnz_h: self.nnz_h,
            pins: self.pins,
            colliders: self.colliders,
            solver: self.solver,
            total_mass: self.total_mass,
        }
    }

    /// The cloth's mechanical energy (J): kinetic, elastic (as the step's own forces see it),
    /// bending and gravitational (if on; measured from the height of the [`World::origin`]).
    pub fn energy(&mut self) -> Energy {
        // The same sums the step's energy balance uses; a world's counts always fit its
        // arrays, so the fallback (no energy) is never taken.
        let (a, c, st) = (&self.a, self.counts(), &self.settings);
        let parts = || -> Result<Energy, StepError> {
            let (elastic, bending, _) = monitor::shape_energy(a, &c, st, f32::INFINITY)?;
            Ok(Energy {
                kinetic: monitor::kinetic(prefix(a.mass, c.n), prefix(a.v, c.n)),
                elastic,
                bending,
                gravity: monitor::gravity_potential(a, &c, st)?,
            })
        };
        parts().unwrap_or_default()
    }

    /// Vertex normals (and, for per-node warping, the rotations) of the current positions.
    #[cfg_attr(not(feature = "research"), allow(unused_variables))]
    fn refresh_frames(&mut self, iterations: u32) {
        let n = self.n;
        #[cfg(feature = "research")]
        if step::forces::per_node_warping(&self.settings) {
            let counts = self.counts();
            crate::research::per_node::update_rotations(&mut self.a, &counts, iterations);
            return;
        }
        let a = &mut self.a;
        // Only fails on inconsistent lengths, which the world never has; the previous
        // normals then stay, which is what a normal's fallback is anyway.
        if normals::vertex_normals(
            prefix(a.triangles, self.nt),
            prefix(a.tri_sign, self.nt),
            prefix(a.x, n),
            prefix_mut(a.normals, n),
        )
        .is_err()
        {
            prefix_mut(a.normals, n).fill(normals::REST_NORMAL);
        }
    }

    /// The elastic forces (N) on the current state, exactly as the next substep computes
    /// them; for tests and diagnostics. Returns false when `out` is too short.
    pub fn elastic_forces(&mut self, out: &mut [Vec3A]) -> bool {
        self.assemble_elastic(out).is_some()
    }

    /// [`World::elastic_forces`], with the membrane's elastic energy (J) it assembled them
    /// with (that of per-node warping's unrotated membrane, for that research option).
    pub(crate) fn assemble_elastic(&mut self, out: &mut [Vec3A]) -> Option<f64> {
        let n = self.n;
        if out.len() < n {
            return None;
        }
        self.refresh_frames(16);
        let a = &mut self.a;
        let energy = membrane::assemble(
            prefix(a.triangles, self.nt),
            prefix(a.elements, self.nt),
            prefix(a.slots, self.nt),
            prefix(a.x, n),
            step::forces::assembly_strain(&self.settings),
            prefix_mut(a.k_diag, n),
            prefix_mut(a.k_off, self.nnz),
            prefix_mut(out, n),
        )
        .ok()?;
        #[cfg(feature = "research")]
        if step::forces::per_node_warping(&self.settings) {
            let counts = self.counts();
            crate::research::per_node::warped_force(&mut self.a, &counts, prefix_mut(out, n))
                .ok()?;
        }
        Some(energy)
    }
}

/// A flat `nx × nx` grid cloth of side `size` (m) in the tests' anisotropic material, owned,
/// for the step stages' own tests ([`World::stage`]).
#[cfg(test)]
pub(crate) struct TestGrid {
    pub positions: std::vec::Vec<[f32; 3]>,
    pub uvs: std::vec::Vec<[f32; 2]>,
    pub triangles: std::vec::Vec<[u32; 3]>,
    pub materials: std::vec::Vec<u32>,
    pub capacity: Capacity,
}

#[cfg(test)]
impl TestGrid {
    pub fn new(nx: usize, size: f32) -> Self {
        let n = nx * nx;
        let mut positions = std::vec![[0.0f32; 3]; n];
        let mut uvs = std::vec![[0.0f32; 2]; n];
        let mut triangles = std::vec![[0u32; 3]; 2 * (nx - 1) * (nx - 1)];
        mesh::grid(nx, nx, size, size, &mut positions, &mut uvs, &mut triangles).unwrap();
        let materials = std::vec![0u32; triangles.len()];
        let capacity = Capacity::grid(nx as u32);
        TestGrid {
            positions,
            uvs,
            triangles,
            materials,
            capacity,
        }
    }

    /// Memory for its world.
    pub fn memory(&self) -> std::vec::Vec<u8> {
        std::vec![0u8; self.capacity.world_bytes()]
    }

    /// Its world in `mem`, default settings.
    pub fn world<'m>(&self, mem: &'m mut [u8]) -> World<'m> {
        let def = ClothDef {
            positions: &self.positions,
            uvs: &self.uvs,
            triangles: &self.triangles,
            materials: &self.materials,
        };
        let mats = [Material {
            stiffness: [[600.0, 60.0, 0.0], [60.0, 150.0, 0.0], [0.0, 0.0, 50.0]],
            density: 0.15,
            bending: 1e-4,
        }];
        World::new(
            mem,
            self.capacity,
            &def,
            Materials::Table(&mats),
            Settings::default(),
        )
        .unwrap()
    }
}
