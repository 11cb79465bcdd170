//! The runtime `World`: a coarse cloth stepped with linear FEM + warped stiffness, hinge bending,
//! linearized implicit Euler and a filtered block-Jacobi PCG (paper §5, DESIGN.md).
//!
//! Memory is the caller's: [`Capacity::world_bytes`] says how many bytes a world of a given
//! capacity needs (a `const fn`, so it can size a `static`), and [`World::new`] carves every
//! array out of that block. Nothing allocates, nothing panics; init either builds the whole
//! world or returns an error and leaves nothing behind.
//!
//! One step (per substep of length `h`):
//! 1. per-node rotations `R_i` from the oriented-particles moment matrix (Eq. 14–16);
//! 2. forces: warped elasticity `f_i = -R_i Σ_j K_ij (R_iᵀ x_j - x0_j)` (Eq. 17) on the constant
//!    rest stiffness `K` assembled once from each triangle's `C^H`; bending `-B Q x` with the
//!    constant isometric Hessian `Q`; gravity, wind, Rayleigh damping `D = αM + β K_w`;
//! 3. the linearized implicit Euler system of Baraff & Witkin (Eq. 18 discretized):
//!    `[(1+hα) M + (hβ + h²) K_w] Δv = h (f - (β + h) K_w v)` with `K_w = R K Rᵀ + B Q`,
//!    symmetric, applied as `R (K (Rᵀ p))` on the constant `K` (no re-assembly);
//! 4. pins and contacts as the per-vertex filter of the modified PCG;
//! 5. `v += Δv`, `x += h v`, projection out of colliders with Coulomb friction.

use glam::{Mat3A, Quat, Vec3A};

use crate::bending;
use crate::blob::Blob;
use crate::collide::{self, Collider, Shape};
use crate::membrane::{self, Element};
use crate::mesh::{self, MeshError, Topology};
use crate::multigrid;
use crate::pcg::{self, Operator};
use crate::rotation;
use crate::sparse::{self, Pattern};

/// Scene effects, a bit set. An effect that is off costs nothing in the step.
pub mod effects {
    pub const GRAVITY: u32 = 1 << 0;
    pub const BENDING: u32 = 1 << 1;
    /// Rayleigh damping `αM + βK`.
    pub const DAMPING: u32 = 1 << 2;
    pub const PINS: u32 = 1 << 3;
    pub const COLLISION: u32 = 1 << 4;
    /// Wind and air drag.
    pub const WIND: u32 = 1 << 5;
    /// Per-node rotations (warped stiffness). Off: plain linear FEM (for the accuracy study).
    pub const WARPING: u32 = 1 << 6;
    /// A cloth at rest goes to sleep and costs nothing until something wakes it.
    pub const SLEEP: u32 = 1 << 7;
    /// Localization and recomputed normals are the caller's to run; the bits are carried here
    /// so one effect set describes a scene.
    pub const LOCALIZE: u32 = 1 << 8;
    pub const NORMALS: u32 = 1 << 9;
    pub const ALL: u32 = (1 << 10) - 1;
}

/// How much a world holds. Fixed at init; memory is [`Capacity::world_bytes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capacity {
    pub vertices: u32,
    pub triangles: u32,
    /// Unique edges (a grid of n×n vertices has 3(n-1)² + 2(n-1)).
    pub edges: u32,
    pub colliders: u32,
    pub pins: u32,
}

impl Capacity {
    /// The default C build: a 64×64-vertex cloth and 8 colliders.
    pub const DEFAULT: Capacity = Capacity {
        vertices: 4096,
        triangles: 8064,
        edges: 12160,
        colliders: 8,
        pins: 64,
    };

    /// Capacity for an `n × n`-vertex grid sheet (benchmarks, tests). Saturates at `u32::MAX`
    /// (which no memory block satisfies) instead of overflowing.
    pub const fn grid(n: u32) -> Capacity {
        let s = n.saturating_sub(1);
        let s2 = s.saturating_mul(s);
        Capacity {
            vertices: n.saturating_mul(n),
            triangles: s2.saturating_mul(2),
            edges: s2.saturating_mul(3).saturating_add(s.saturating_mul(2)),
            colliders: 8,
            pins: 64,
        }
    }

    const fn v(&self) -> usize {
        self.vertices as usize
    }
    const fn t(&self) -> usize {
        self.triangles as usize
    }
    const fn e(&self) -> usize {
        self.edges as usize
    }
    /// Couplings of the block matrix: edges plus hinges (at most one per edge).
    const fn b(&self) -> usize {
        (self.edges as usize).saturating_mul(2)
    }
    const fn c(&self) -> usize {
        self.colliders as usize
    }
    const fn p(&self) -> usize {
        self.pins as usize
    }
}

/// Declares the world's arrays once: the struct, the byte count and the carving all come from
/// this one list, so they cannot disagree.
macro_rules! arrays {
    ($cap:ident; $( $(#[$doc:meta])* $field:ident : $ty:ty = [$count:expr; $init:expr] ),* $(,)?) => {
        struct Arrays<'a> { $( $(#[$doc])* $field: &'a mut [$ty], )* }

        impl Capacity {
            /// Bytes a world of this capacity needs (including worst-case alignment padding).
            pub const fn world_bytes(&self) -> usize {
                let $cap = self;
                let mut total = 0usize;
                $( total = total.saturating_add(slot_bytes::<$ty>($count)); )*
                total
            }
        }

        fn carve<'a>($cap: &Capacity, carver: &mut Carver<'a>) -> Result<Arrays<'a>, InitError> {
            Ok(Arrays { $( $field: carver.take::<$ty>($count, $init)?, )* })
        }
    };
}

arrays! { cap;
    /// Positions, velocities and the state at the start of the step (restored on failure).
    x: Vec3A = [cap.v(); Vec3A::ZERO],
    v: Vec3A = [cap.v(); Vec3A::ZERO],
    x_start: Vec3A = [cap.v(); Vec3A::ZERO],
    v_start: Vec3A = [cap.v(); Vec3A::ZERO],
    /// Rest positions `(u, v, 0)`.
    rest: Vec3A = [cap.v(); Vec3A::ZERO],
    /// Lumped masses (kg).
    mass: f32 = [cap.v(); 0.0],
    /// Lumped area (m²), for wind.
    area: f32 = [cap.v(); 0.0],
    triangles: [u32; 3] = [cap.t(); [0; 3]],
    tri_sign: f32 = [cap.t(); 0.0],
    tri_material: u32 = [cap.t(); 0],
    vt_start: u32 = [cap.v().saturating_add(1); 0],
    vt: u32 = [cap.t().saturating_mul(3); 0],
    ring_start: u32 = [cap.v().saturating_add(1); 0],
    ring: u32 = [cap.e().saturating_mul(2); 0],
    /// Topology scratch during init, then the multilevel hierarchy (`multigrid::build`):
    /// `scratch_a` its coarse levels, `scratch_b` the finest level's aggregate map; its
    /// per-solve memory is lent by `precond` and `force` (see `substep`). So the multilevel
    /// solver adds no memory (and `world_bytes` stays affine in the capacity, as the FFI
    /// assumes); a mesh too small for these budgets (~300 vertices) steps with block Jacobi.
    scratch_a: u32 = [cap.v(); 0],
    scratch_b: u32 = [cap.v(); 0],
    /// Block pattern (strictly upper CSR) shared by the stiffness and the bending Hessian.
    row_start: u32 = [cap.v().saturating_add(1); 0],
    cols: u32 = [cap.b(); 0],
    /// Per triangle: its constant element stiffness and gradients, and where its three
    /// vertex pairs sit in the block pattern.
    elements: Element = [cap.t(); Element::ZERO],
    slots: [u32; 3] = [cap.t(); [0; 3]],
    /// Rotated membrane stiffness `K_w = Σ_e R_e K_e R_eᵀ` (N/m), re-assembled every substep.
    k_diag: Mat3A = [cap.v(); Mat3A::ZERO],
    k_off: Mat3A = [cap.b(); Mat3A::ZERO],
    /// Elastic forces of the current substep (N); during the solve, the multilevel vectors
    /// and coarsest factor.
    force: Vec3A = [cap.v(); Vec3A::ZERO],
    /// Bending Hessian `B Q` (N/m per unit displacement), a scalar per block times I3.
    q_diag: f32 = [cap.v(); 0.0],
    q_off: f32 = [cap.b(); 0.0],
    rot: Quat = [cap.v(); Quat::IDENTITY],
    normals: Vec3A = [cap.v(); Vec3A::Z],
    /// Right-hand side, solution (warm start) and PCG work vectors.
    rhs: Vec3A = [cap.v(); Vec3A::ZERO],
    dv: Vec3A = [cap.v(); Vec3A::ZERO],
    w_r: Vec3A = [cap.v(); Vec3A::ZERO],
    w_c: Vec3A = [cap.v(); Vec3A::ZERO],
    w_q: Vec3A = [cap.v(); Vec3A::ZERO],
    w_s: Vec3A = [cap.v(); Vec3A::ZERO],
    /// Block-Jacobi inverses, or (lent as f32) the multilevel operators of the solve.
    precond: Mat3A = [cap.v(); Mat3A::IDENTITY],
    filter: Mat3A = [cap.v(); Mat3A::IDENTITY],
    /// Contacts of the substep: the collider a vertex is held against (or `mesh::NONE`) and
    /// the normal impulse per unit mass the contact supplies (along the outward normal, m/s),
    /// which bounds Coulomb friction.
    contact_collider: u32 = [cap.v(); mesh::NONE],
    contact_push: Vec3A = [cap.v(); Vec3A::ZERO],
    /// Pin index of each vertex, or `mesh::NONE`.
    pin_of: u32 = [cap.v(); mesh::NONE],
    pin_vertex: u32 = [cap.p(); 0],
    pin_target: Vec3A = [cap.p(); Vec3A::ZERO],
    pin_previous: Vec3A = [cap.p(); Vec3A::ZERO],
    colliders: Collider = [cap.c(); Collider::new(Shape::Plane { normal: Vec3A::Z, offset: 0.0 }, 0.0, 0.0)],
}

/// Saturating, so that a capacity too large for a 32-bit `usize` asks for `usize::MAX` bytes
/// (which no block satisfies: init reports `MemoryTooSmall`) instead of overflowing.
const fn slot_bytes<T>(n: usize) -> usize {
    n.saturating_mul(core::mem::size_of::<T>())
        .saturating_add(core::mem::align_of::<T>() - 1)
}

/// Hands out typed, initialized slices from a caller's byte block.
struct Carver<'a> {
    rest: &'a mut [u8],
    needed: usize,
}

impl<'a> Carver<'a> {
    fn take<T: Copy>(&mut self, n: usize, init: T) -> Result<&'a mut [T], InitError> {
        let size = core::mem::size_of::<T>();
        let align = core::mem::align_of::<T>();
        let addr = self.rest.as_ptr() as usize;
        let pad = (align - addr % align) % align;
        let bytes = n.checked_mul(size).ok_or(InitError::CapacityTooLarge)?;
        self.needed = self.needed.saturating_add(pad + bytes);
        if self.rest.len() < pad + bytes {
            return Err(InitError::MemoryTooSmall);
        }
        let rest = core::mem::take(&mut self.rest);
        let (_, rest) = rest.split_at_mut(pad);
        let (head, tail) = rest.split_at_mut(bytes);
        self.rest = tail;
        let ptr = head.as_mut_ptr().cast::<T>();
        // SAFETY: `head` is an exclusive borrow of `n * size_of::<T>()` bytes for 'a, and `pad`
        // made its start aligned for T. Every element is written with `init` before the slice
        // is formed, so no byte pattern of the caller's memory is ever read as a T. T: Copy has
        // no destructor, so forgetting the values when the block is reused is fine.
        unsafe {
            for i in 0..n {
                ptr.add(i).write(init);
            }
            Ok(core::slice::from_raw_parts_mut(ptr, n))
        }
    }
}

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

/// Scene parameters. Can change between steps ([`World::set_settings`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Bit set of [`effects`].
    pub effects: u32,
    /// Frame time step (s) used by [`World::step`].
    pub time_step: f32,
    /// Substeps per step (≥ 1).
    pub substeps: u32,
    /// m/s².
    pub gravity: [f32; 3],
    /// Rayleigh damping: mass factor α (1/s) and stiffness factor β (s).
    pub damping_mass: f32,
    pub damping_stiffness: f32,
    /// Wind velocity (m/s) and drag coefficient (kg/(m²·s)): the force on a vertex is
    /// `drag · area · ((wind - v)·n) n`.
    pub wind: [f32; 3],
    pub drag: f32,
    /// PCG relative residual and iteration cap (1..=[`Settings::MAX_ITERATIONS`]).
    pub tolerance: f32,
    pub max_iterations: u32,
    /// Warp with the paper's per-node rotations (Eq. 14–17) instead of per-element frames.
    /// Kept for comparison: it is unstable for cloth hanging in 3D (see README, "Limits").
    pub per_node_warping: bool,
    /// Rotation extraction iterations per node per substep (warm started), per-node warping
    /// (0..=[`Settings::MAX_ROTATION_ITERATIONS`]).
    pub rotation_iterations: u32,
    /// Sleep when every vertex is slower than this (m/s) for `sleep_frames` steps.
    pub sleep_velocity: f32,
    pub sleep_frames: u32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            effects: effects::GRAVITY
                | effects::BENDING
                | effects::DAMPING
                | effects::PINS
                | effects::COLLISION
                | effects::WARPING,
            time_step: 1.0 / 60.0,
            substeps: 1,
            gravity: [0.0, 0.0, -9.81],
            damping_mass: 0.1,
            damping_stiffness: 0.001,
            wind: [0.0; 3],
            drag: 0.0,
            tolerance: 1e-4,
            max_iterations: 200,
            per_node_warping: false,
            rotation_iterations: 4,
            sleep_velocity: 1e-3,
            sleep_frames: 30,
        }
    }
}

impl Settings {
    /// Largest accepted `max_iterations`: far beyond where block-Jacobi PCG stops gaining in
    /// f32, and it bounds the cost of one step (a caller's `u32::MAX` would mean a step that
    /// never ends on a system that does not converge).
    pub const MAX_ITERATIONS: u32 = 10_000;
    /// Largest accepted `rotation_iterations` (the extraction is warm started; a few suffice).
    pub const MAX_ROTATION_ITERATIONS: u32 = 100;

    /// Checks every field; `Err` names the first bad one.
    pub fn validate(&self) -> Result<(), InitError> {
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        let bad = |field| Err(InitError::InvalidSetting { field });
        if !(self.time_step.is_finite() && self.time_step > 0.0) {
            return bad("time_step");
        }
        if self.substeps == 0 || self.substeps > 1000 {
            return bad("substeps");
        }
        if !finite(&self.gravity) {
            return bad("gravity");
        }
        if !(self.damping_mass.is_finite() && self.damping_mass >= 0.0) {
            return bad("damping_mass");
        }
        if !(self.damping_stiffness.is_finite() && self.damping_stiffness >= 0.0) {
            return bad("damping_stiffness");
        }
        if !finite(&self.wind) {
            return bad("wind");
        }
        if !(self.drag.is_finite() && self.drag >= 0.0) {
            return bad("drag");
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad("tolerance");
        }
        if self.max_iterations == 0 || self.max_iterations > Self::MAX_ITERATIONS {
            return bad("max_iterations");
        }
        if self.rotation_iterations > Self::MAX_ROTATION_ITERATIONS {
            return bad("rotation_iterations");
        }
        if !(self.sleep_velocity.is_finite() && self.sleep_velocity >= 0.0) {
            return bad("sleep_velocity");
        }
        if self.effects & !effects::ALL != 0 {
            return bad("effects");
        }
        Ok(())
    }
}

/// The preconditioner of the step's CG ([`World::set_solver`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Solver {
    /// The inverse 3×3 diagonal blocks: cheap per iteration, but the iteration count grows
    /// with the mesh resolution.
    BlockJacobi,
    /// The multilevel preconditioner of [`crate::multigrid`]: a V-cycle per iteration, an
    /// iteration count that does not grow with the mesh. Per-node warping
    /// ([`Settings::per_node_warping`]) always uses block Jacobi.
    #[default]
    Multigrid,
}

/// Absolute floor of the step's CG (`pcg::Settings::floor`) as a velocity: the solve stops
/// once the remaining error of `Δv` is below this RMS velocity (m/s) in the energy norm, so a
/// cloth at rest (right-hand side = round-off) costs no iterations.
const FLOOR_VELOCITY: f64 = 1e-6;

/// Why [`World::new`] refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InitError {
    /// The memory block is smaller than `Capacity::world_bytes()`.
    MemoryTooSmall,
    CapacityTooLarge,
    /// The cloth does not fit: which capacity, how much was needed.
    VertexCapacity {
        needed: u32,
        capacity: u32,
    },
    TriangleCapacity {
        needed: u32,
        capacity: u32,
    },
    EdgeCapacity {
        capacity: u32,
    },
    Mesh(MeshError),
    /// `materials` has a different length than `triangles`.
    MaterialCount,
    /// A triangle names a material (cell) that does not exist.
    MaterialOutOfRange {
        triangle: u32,
        material: u32,
    },
    /// A material's numbers are unusable (non-finite, non-positive density, not SPD), or beyond
    /// `f32` on this mesh (a lumped mass or an element stiffness overflows or underflows).
    InvalidMaterial {
        material: u32,
    },
    InvalidSetting {
        field: &'static str,
    },
    /// An internal consistency check failed (a bug if it happens; never a panic).
    Internal,
}

impl From<MeshError> for InitError {
    fn from(e: MeshError) -> Self {
        match e {
            MeshError::EdgeCapacity { capacity } => InitError::EdgeCapacity { capacity },
            e => InitError::Mesh(e),
        }
    }
}

/// Why a step failed. The world keeps the state it had before the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepError {
    InvalidTimeStep,
    /// A pin target is NaN or infinite.
    NonFinitePin {
        vertex: u32,
    },
    /// The solver broke down (indefinite or non-finite system).
    SolverBreakdown,
    /// The step produced NaN or infinite positions or velocities.
    NonFiniteState,
    /// The cloth created mechanical energy where nothing could supply it (pins and colliders
    /// at rest, no wind, no contact) — over a quarter of its movable energy within
    /// [`MONITOR_WINDOW`] steps: numerically unstable, e.g. sliver triangles beyond f32
    /// resolution. The state is the one before this step.
    Unstable,
}

/// What a step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// PCG iterations summed over substeps.
    pub iterations: u32,
    /// Largest final relative residual over substeps.
    pub residual: f32,
    /// Every substep's solve reached the tolerance.
    pub converged: bool,
    pub substeps: u32,
    /// The world was asleep and did nothing.
    pub asleep: bool,
    /// Vertices in contact with a collider at the end of the step.
    pub contacts: u32,
}

/// A cloth's mechanical energy by kind (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    pub kinetic: f64,
    pub elastic: f64,
    pub bending: f64,
    /// Gravitational potential `-Σ m g·x` (zero when gravity is off).
    pub gravity: f64,
}

impl Energy {
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.bending + self.gravity
    }
}

/// Steps in one window of the energy monitor ([`StepError::Unstable`]).
pub const MONITOR_WINDOW: u32 = 16;

/// Errors of the pin and collider setters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EditError {
    VertexOutOfRange,
    NonFinite,
    PinCapacity,
    ColliderCapacity,
    ColliderOutOfRange,
    InvalidCollider,
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
    nnz: usize,
    pins: usize,
    colliders: usize,
    /// Per-vertex lumped mass sum, kg.
    total_mass: f64,
    calm_frames: u32,
    /// The energy monitor: nothing drives the cloth in this step; the steps since the window
    /// opened were all quiet; the window's age, start energy and movable energy (J).
    monitor_now: bool,
    monitor_valid: bool,
    window_age: u32,
    window_energy: f64,
    window_scale: f64,
    asleep: bool,
    last: StepStats,
    solver: Solver,
}

impl<'a> World<'a> {
    /// Builds a world for `cloth` in `memory` (at least `capacity.world_bytes()` bytes).
    pub fn new(
        memory: &'a mut [u8],
        capacity: Capacity,
        cloth: &ClothDef<'_>,
        materials: Materials<'_>,
        settings: Settings,
    ) -> Result<World<'a>, InitError> {
        settings.validate()?;
        let (n, nt) = (cloth.positions.len(), cloth.triangles.len());
        if n > capacity.v() {
            return Err(InitError::VertexCapacity {
                needed: n as u32,
                capacity: capacity.vertices,
            });
        }
        if nt > capacity.t() {
            return Err(InitError::TriangleCapacity {
                needed: nt as u32,
                capacity: capacity.triangles,
            });
        }
        if cloth.uvs.len() != n {
            return Err(InitError::Mesh(MeshError::BufferTooSmall));
        }
        if cloth.materials.len() != nt {
            return Err(InitError::MaterialCount);
        }
        if memory.len() < capacity.world_bytes() {
            return Err(InitError::MemoryTooSmall);
        }
        let mut carver = Carver {
            rest: memory,
            needed: 0,
        };
        let a = carve(&capacity, &mut carver)?;
        let mut w = World {
            a,
            capacity,
            settings,
            n,
            nt,
            ne: 0,
            nh: 0,
            nnz: 0,
            pins: 0,
            colliders: 0,
            total_mass: 0.0,
            calm_frames: 0,
            monitor_now: false,
            monitor_valid: false,
            window_age: 0,
            window_energy: 0.0,
            window_scale: 0.0,
            asleep: false,
            last: StepStats::default(),
            solver: Solver::default(),
        };
        w.build(cloth, materials)?;
        Ok(w)
    }

    fn build(&mut self, cloth: &ClothDef<'_>, materials: Materials<'_>) -> Result<(), InitError> {
        let (n, nt) = (self.n, self.nt);
        let a = &mut self.a;
        mesh::validate(
            cloth.positions,
            cloth.uvs,
            cloth.triangles,
            &mut a.tri_sign[..nt],
        )?;
        // Materials: every triangle's must exist and be usable.
        for (t, &m) in cloth.materials.iter().enumerate() {
            let mat = materials.get(m).ok_or(InitError::MaterialOutOfRange {
                triangle: t as u32,
                material: m,
            })?;
            let ok = membrane::is_spd(&mat.stiffness)
                && mat.density.is_finite()
                && mat.density > 0.0
                && mat.bending.is_finite()
                && mat.bending >= 0.0;
            if !ok {
                return Err(InitError::InvalidMaterial { material: m });
            }
        }
        a.triangles[..nt].copy_from_slice(cloth.triangles);
        a.tri_material[..nt].copy_from_slice(cloth.materials);
        for i in 0..n {
            let p = cloth.positions[i];
            let uv = cloth.uvs[i];
            a.x[i] = Vec3A::from(p);
            a.rest[i] = Vec3A::new(uv[0], uv[1], 0.0);
        }
        // Edges, hinges and the block couplings are needed only here, before the stiffness
        // blocks are first assembled: they borrow the blocks' bytes (2E blocks of 48 bytes hold
        // E edges, E edge-triangle pairs, E hinges and 2E couplings with room to spare).
        let e_cap = self.capacity.e();
        let scratch: &mut [u8] = bytemuck::cast_slice_mut(&mut a.k_off[..]);
        let (edges, scratch) = scratch.split_at_mut(8 * e_cap);
        let (edge_tris, scratch) = scratch.split_at_mut(8 * e_cap);
        let (hinges, scratch) = scratch.split_at_mut(16 * e_cap);
        let (couplings, _) = scratch.split_at_mut(16 * e_cap);
        let edges: &mut [[u32; 2]] = bytemuck::cast_slice_mut(edges);
        let edge_tris: &mut [[u32; 2]] = bytemuck::cast_slice_mut(edge_tris);
        let hinges: &mut [[u32; 4]] = bytemuck::cast_slice_mut(hinges);
        let couplings: &mut [[u32; 2]] = bytemuck::cast_slice_mut(couplings);
        let counts = mesh::build(
            n,
            &a.triangles[..nt],
            &a.tri_sign[..nt],
            &mut Topology {
                vt_start: a.vt_start,
                vt: a.vt,
                edges,
                edge_tris,
                hinges,
                ring_start: a.ring_start,
                ring: a.ring,
                scratch_a: a.scratch_a,
                scratch_b: a.scratch_b,
            },
        )?;
        self.ne = counts.edges;
        self.nh = counts.hinges;
        let nc = mesh::couplings(&edges[..self.ne], &hinges[..self.nh], couplings)?;
        self.nnz =
            sparse::build_pattern(n, &couplings[..nc], a.row_start, a.cols).map_err(|_| {
                InitError::EdgeCapacity {
                    capacity: self.capacity.edges,
                }
            })?;

        // Element stiffness K_e = A Bᵀ C^H B (Eq. 10–11 on the coarse mesh with the cell's C^H),
        // lumped masses, and each element's place in the block pattern.
        let pattern = Pattern {
            row_start: &a.row_start[..n + 1],
            cols: &a.cols[..self.nnz],
        };
        let mut total_mass = 0.0f64;
        for t in 0..nt {
            let tri = a.triangles[t];
            let mat = materials
                .get(a.tri_material[t])
                .ok_or(InitError::Internal)?;
            let uv = tri.map(|i| {
                let r = a.rest[i as usize];
                [r.x as f64, r.y as f64]
            });
            let degenerate = InitError::Mesh(MeshError::DegenerateUv { triangle: t as u32 });
            let g = membrane::gradients(uv).ok_or(degenerate)?;
            a.elements[t] = Element::new(uv, &mat.stiffness).ok_or(degenerate)?;
            // Stiffness, lumped area and mass are f32: a value beyond its range is refused here
            // rather than becoming an infinite (or zero) mass or force.
            let e = &a.elements[t];
            let bad_material = InitError::InvalidMaterial {
                material: a.tri_material[t],
            };
            let bad_uv = InitError::Mesh(MeshError::UvOutOfRange { triangle: t as u32 });
            if !e.c.iter().all(|v| v.is_finite()) {
                return Err(bad_material);
            }
            let (area3, m) = (g.area / 3.0, mat.density * g.area / 3.0);
            let grad_ok = e.grad.iter().all(|v| v.is_finite());
            if !(grad_ok && e.area.is_finite() && (area3 as f32).is_finite() && area3 as f32 > 0.0)
            {
                return Err(bad_uv);
            }
            if !((m as f32).is_finite() && m as f32 > 0.0) {
                return Err(bad_material);
            }
            for &i in &tri {
                let i = i as usize;
                a.mass[i] += m as f32;
                a.area[i] += area3 as f32;
                total_mass += m;
                if !a.area[i].is_finite() {
                    return Err(bad_uv);
                }
                if !a.mass[i].is_finite() {
                    return Err(bad_material);
                }
            }
            for (p, (ai, bi)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
                let (i, j) = (tri[ai] as usize, tri[bi] as usize);
                let (lo, hi, flag) = if i < j {
                    (i, j, 0)
                } else {
                    (j, i, membrane::TRANSPOSED)
                };
                let k = pattern.find(lo, hi).ok_or(InitError::Internal)?;
                a.slots[t][p] = k as u32 | flag;
            }
        }
        self.total_mass = total_mass;

        // Bending: the constant isometric Hessian of every hinge, scaled by the mean bending
        // stiffness of its two triangles.
        for &hinge in &hinges[..self.nh] {
            let t0 = triangle_of(
                a.vt_start,
                a.vt,
                a.triangles,
                [hinge[0], hinge[1], hinge[2]],
            )
            .ok_or(InitError::Internal)?;
            let t1 = triangle_of(
                a.vt_start,
                a.vt,
                a.triangles,
                [hinge[0], hinge[1], hinge[3]],
            )
            .ok_or(InitError::Internal)?;
            let b0 = materials
                .get(a.tri_material[t0])
                .map(|m| m.bending)
                .unwrap_or(0.0);
            let b1 = materials
                .get(a.tri_material[t1])
                .map(|m| m.bending)
                .unwrap_or(0.0);
            let uv = hinge.map(|i| {
                let r = a.rest[i as usize];
                [r.x as f64, r.y as f64]
            });
            let Some(q) = bending::hinge_hessian(uv, bending::CONTINUUM_SCALE * 0.5 * (b0 + b1))
            else {
                continue; // a degenerate hinge bends freely rather than blowing up
            };
            for (ai, &i) in hinge.iter().enumerate() {
                for (bi, &j) in hinge.iter().enumerate() {
                    if i > j {
                        continue;
                    }
                    sparse::add_scalar(
                        &pattern,
                        &mut a.q_diag[..n],
                        &mut a.q_off[..self.nnz],
                        i as usize,
                        j as usize,
                        q[ai][bi] as f32,
                    )
                    .map_err(|_| InitError::Internal)?;
                }
            }
        }

        // The multilevel hierarchy, aggregated over the mesh edges; its scratch is the
        // stiffness blocks, not assembled yet. A mesh it cannot be built for (scratch too
        // small: far more isolated vertices than edges) steps with block Jacobi.
        let a = &mut self.a;
        let scratch: &mut [u32] = bytemuck::cast_slice_mut(&mut a.k_off[..]);
        let _ = multigrid::build(
            &Pattern {
                row_start: &a.row_start[..n + 1],
                cols: &a.cols[..self.nnz],
            },
            Some(multigrid::Graph {
                start: &a.ring_start[..n + 1],
                adjacency: &a.ring[..2 * self.ne],
            }),
            &mut a.scratch_b[..n],
            a.scratch_a,
            scratch,
        );
        // Warm start the rotations from the initial placement.
        self.update_rotations(8);
        Ok(())
    }

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
    pub fn positions(&self) -> &[Vec3A] {
        &self.a.x[..self.n]
    }
    pub fn velocities(&self) -> &[Vec3A] {
        &self.a.v[..self.n]
    }
    pub fn masses(&self) -> &[f32] {
        &self.a.mass[..self.n]
    }
    pub fn rest_positions(&self) -> &[Vec3A] {
        &self.a.rest[..self.n]
    }
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.a.triangles[..self.nt]
    }
    pub fn triangle_materials(&self) -> &[u32] {
        &self.a.tri_material[..self.nt]
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
    pub fn rotations(&self) -> &[Quat] {
        &self.a.rot[..self.n]
    }
    pub fn normals(&self) -> &[Vec3A] {
        &self.a.normals[..self.n]
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
            self.settings = settings;
            self.wake();
        }
        Ok(())
    }

    /// Wakes a sleeping world.
    pub fn wake(&mut self) {
        self.asleep = false;
        self.calm_frames = 0;
        self.monitor_valid = false;
    }

    /// Overwrites positions (and zeroes nothing else); wakes the world.
    pub fn set_positions(&mut self, positions: &[[f32; 3]]) -> Result<(), EditError> {
        if positions.len() != self.n {
            return Err(EditError::VertexOutOfRange);
        }
        if positions.iter().flatten().any(|c| !c.is_finite()) {
            return Err(EditError::NonFinite);
        }
        for (x, p) in self.a.x.iter_mut().zip(positions) {
            *x = Vec3A::from(*p);
        }
        self.wake();
        Ok(())
    }

    /// Overwrites velocities and forgets the solver's warm start (the last step's velocity
    /// change, meaningless for the new velocities); wakes the world.
    pub fn set_velocities(&mut self, velocities: &[[f32; 3]]) -> Result<(), EditError> {
        if velocities.len() != self.n {
            return Err(EditError::VertexOutOfRange);
        }
        if velocities.iter().flatten().any(|c| !c.is_finite()) {
            return Err(EditError::NonFinite);
        }
        for (v, p) in self.a.v.iter_mut().zip(velocities) {
            *v = Vec3A::from(*p);
        }
        self.a.dv[..self.n].fill(Vec3A::ZERO);
        self.wake();
        Ok(())
    }

    // ----- pins -----

    /// Pins `vertex` to `target` (m). A pin that already exists gets the new target; the vertex
    /// moves there over the next step (linearly across substeps). Wakes the world when the
    /// target changed. Targets are checked at step time too, so a NaN target set through a
    /// raw pointer in C is still caught.
    pub fn set_pin(&mut self, vertex: u32, target: [f32; 3]) -> Result<(), EditError> {
        let vi = vertex as usize;
        if vi >= self.n {
            return Err(EditError::VertexOutOfRange);
        }
        let target = Vec3A::from(target);
        let p = self.a.pin_of[vi];
        if p != mesh::NONE {
            let slot = &mut self.a.pin_target[p as usize];
            if *slot != target {
                *slot = target;
                self.wake();
            }
            return Ok(());
        }
        if self.pins >= self.capacity.p() {
            return Err(EditError::PinCapacity);
        }
        let p = self.pins;
        self.a.pin_vertex[p] = vertex;
        self.a.pin_target[p] = target;
        // A new pin starts where the vertex is, so it is not yanked in one substep.
        self.a.pin_previous[p] = self.a.x[vi];
        self.a.pin_of[vi] = p as u32;
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
        let p = self.a.pin_of[vi];
        if p == mesh::NONE {
            return Ok(());
        }
        // Swap-remove, keeping pin_of consistent.
        let last = self.pins - 1;
        let p = p as usize;
        self.a.pin_vertex[p] = self.a.pin_vertex[last];
        self.a.pin_target[p] = self.a.pin_target[last];
        self.a.pin_previous[p] = self.a.pin_previous[last];
        self.a.pin_of[self.a.pin_vertex[p] as usize] = p as u32;
        self.a.pin_of[vi] = mesh::NONE;
        self.pins = last;
        self.wake();
        Ok(())
    }

    pub fn pin_count(&self) -> usize {
        self.pins
    }

    // ----- colliders -----

    /// Adds a collider; returns its index.
    pub fn add_collider(&mut self, collider: Collider) -> Result<u32, EditError> {
        if !collider.is_valid() {
            return Err(EditError::InvalidCollider);
        }
        if self.colliders >= self.capacity.c() {
            return Err(EditError::ColliderCapacity);
        }
        self.a.colliders[self.colliders] = collider;
        self.colliders += 1;
        self.wake();
        Ok(self.colliders as u32 - 1)
    }

    /// Moves collider `index` to `shape`; the next step sweeps it from where it was.
    pub fn set_collider_shape(&mut self, index: u32, shape: Shape) -> Result<(), EditError> {
        let c = self
            .a
            .colliders
            .get_mut(..self.colliders)
            .and_then(|c| c.get_mut(index as usize))
            .ok_or(EditError::ColliderOutOfRange)?;
        if !shape.is_valid() {
            return Err(EditError::InvalidCollider);
        }
        if c.shape != shape {
            c.shape = shape;
            self.wake();
        }
        Ok(())
    }

    pub fn collider(&self, index: u32) -> Option<&Collider> {
        self.a.colliders[..self.colliders].get(index as usize)
    }

    pub fn collider_count(&self) -> usize {
        self.colliders
    }

    /// Removes all colliders.
    pub fn clear_colliders(&mut self) {
        self.colliders = 0;
        self.wake();
    }

    // ----- stepping -----

    /// Advances by `settings.time_step`.
    pub fn step(&mut self) -> Result<StepStats, StepError> {
        self.step_dt(self.settings.time_step)
    }

    /// Advances by `dt` seconds in `settings.substeps` substeps. On error the world keeps the
    /// state it had before the call.
    pub fn step_dt(&mut self, dt: f32) -> Result<StepStats, StepError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidTimeStep);
        }
        let eff = self.settings.effects;
        let pins_on = eff & effects::PINS != 0;
        if pins_on {
            for p in 0..self.pins {
                if !self.a.pin_target[p].is_finite() {
                    return Err(StepError::NonFinitePin {
                        vertex: self.a.pin_vertex[p],
                    });
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
        let n = self.n;
        self.a.x_start[..n].copy_from_slice(&self.a.x[..n]);
        self.a.v_start[..n].copy_from_slice(&self.a.v[..n]);
        // Energy monitor: with nothing moving the cloth from outside, a damped implicit step
        // can only lose energy. Checked only then, so it costs nothing in driven scenes.
        let drivers_still = (!pins_on
            || self.a.pin_previous[..self.pins] == self.a.pin_target[..self.pins])
            && self.a.colliders[..self.colliders]
                .iter()
                .all(|c| c.previous == c.shape)
            && eff & effects::WIND == 0;
        // Compared at the start of consecutive steps (the first substep's assembly computes
        // the elastic energy anyway), so the monitor costs two passes over the vertices.
        self.monitor_now = drivers_still;
        let substeps = self.settings.substeps.max(1);
        let h = dt / substeps as f32;
        let mut stats = StepStats {
            converged: true,
            substeps,
            ..StepStats::default()
        };
        for s in 0..substeps {
            let t0 = s as f32 / substeps as f32;
            let t = (s + 1) as f32 / substeps as f32;
            match self.substep(h, t0, t) {
                Ok((sub, contacts)) => {
                    stats.iterations += sub.iterations;
                    stats.residual = stats.residual.max(sub.residual);
                    stats.converged &= sub.converged;
                    stats.contacts = contacts;
                }
                Err(e) => {
                    self.restore_start();
                    return Err(e);
                }
            }
        }
        // The next step may compare its starting energy with this one's only if nothing
        // drove the cloth during this step.
        self.monitor_valid = drivers_still && stats.contacts == 0;
        // The sweep of colliders and pins ends where the engine put them.
        for c in &mut self.a.colliders[..self.colliders] {
            c.previous = c.shape;
        }
        for p in 0..self.pins {
            self.a.pin_previous[p] = self.a.pin_target[p];
        }
        if eff & effects::SLEEP != 0 {
            let limit = self.settings.sleep_velocity * self.settings.sleep_velocity;
            let calm = self.a.v[..n].iter().all(|v| v.length_squared() <= limit);
            self.calm_frames = if calm { self.calm_frames + 1 } else { 0 };
            if self.calm_frames >= self.settings.sleep_frames.max(1) {
                self.asleep = true;
                self.a.v[..n].fill(Vec3A::ZERO);
            }
        }
        self.last = stats;
        Ok(stats)
    }

    /// Puts back the state saved at the start of the step.
    fn restore_start(&mut self) {
        let n = self.n;
        self.a.x[..n].copy_from_slice(&self.a.x_start[..n]);
        self.a.v[..n].copy_from_slice(&self.a.v_start[..n]);
        // The failed solve's Δv (maybe huge or NaN) must not warm-start the next step, or one
        // bad input breaks every later solve.
        self.a.dv[..n].fill(Vec3A::ZERO);
        // Rotations are only warm starts; re-derive them from the restored state.
        self.update_rotations(8);
    }

    /// The cloth's mechanical energy (J): kinetic, corotated elastic (per element, as the
    /// step's own forces see it), bending and gravitational (if on).
    pub fn energy(&mut self) -> Energy {
        let n = self.n;
        let eff = self.settings.effects;
        let warping = eff & effects::WARPING != 0;
        let a = &mut self.a;
        let elastic = membrane::elastic_energy(
            &a.triangles[..self.nt],
            &a.elements[..self.nt],
            &a.rest[..n],
            &a.x[..n],
            &a.normals[..n],
            warping,
        )
        .unwrap_or(0.0);
        let bending = if eff & effects::BENDING != 0 {
            let pattern = Pattern {
                row_start: &a.row_start[..n + 1],
                cols: &a.cols[..self.nnz],
            };
            bending::energy(&pattern, &a.q_off[..self.nnz], &a.x[..n])
        } else {
            0.0
        };
        let (kinetic, gravity) = motion_energy(
            &a.mass[..n],
            &a.x[..n],
            &a.v[..n],
            eff & effects::GRAVITY != 0,
            self.settings.gravity,
        );
        Energy {
            kinetic,
            elastic,
            bending,
            gravity,
        }
    }

    fn update_rotations(&mut self, iterations: u32) {
        let n = self.n;
        let a = &mut self.a;
        if rotation::vertex_normals(
            &a.triangles[..self.nt],
            &a.tri_sign[..self.nt],
            &a.x[..n],
            &mut a.normals[..n],
        )
        .is_err()
        {
            return;
        }
        let _ = rotation::update_rotations(
            &a.ring_start[..n + 1],
            &a.ring[..2 * self.ne],
            &a.mass[..n],
            &a.rest[..n],
            &a.x[..n],
            &a.normals[..n],
            &mut a.rot[..n],
            iterations,
        );
    }

    /// One linearized implicit Euler substep of length `h`; `t` ∈ (0, 1] is how far through the
    /// frame it ends (for sweeping pins and colliders).
    fn substep(&mut self, h: f32, t0: f32, t: f32) -> Result<(pcg::Stats, u32), StepError> {
        let n = self.n;
        let st = self.settings;
        let eff = st.effects;
        let warping = eff & effects::WARPING != 0;
        let per_node = warping && st.per_node_warping;
        let bending_on = eff & effects::BENDING != 0;
        let damping_on = eff & effects::DAMPING != 0;
        let (alpha, beta) = if damping_on {
            (st.damping_mass, st.damping_stiffness)
        } else {
            (0.0, 0.0)
        };
        if per_node {
            // also refreshes the vertex normals
            self.update_rotations(st.rotation_iterations);
        } else if warping || eff & effects::WIND != 0 {
            let a = &mut self.a;
            let _ = rotation::vertex_normals(
                &a.triangles[..self.nt],
                &a.tri_sign[..self.nt],
                &a.x[..n],
                &mut a.normals[..n],
            );
        }
        let a = &mut self.a;
        let pattern = Pattern {
            row_start: &a.row_start[..n + 1],
            cols: &a.cols[..self.nnz],
        };
        let (x, v) = (&a.x[..n], &a.v[..n]);

        // --- forces, accumulated into rhs ---
        // Membrane: corotated elements (or plain linear FEM; or, for per-node warping, the
        // unrotated K that Eq. 17 rotates node by node).
        let elastic = membrane::assemble_corotated(
            &a.triangles[..self.nt],
            &a.elements[..self.nt],
            &a.slots[..self.nt],
            &a.rest[..n],
            x,
            &a.normals[..n],
            warping && !per_node,
            &mut a.k_diag[..n],
            &mut a.k_off[..self.nnz],
            &mut a.force[..n],
        )
        .map_err(|_| StepError::SolverBreakdown)?;
        if t0 == 0.0 && self.monitor_now {
            // Energy monitor (see StepError::Unstable): with nothing driving the cloth, damped
            // implicit steps cannot gain energy. A capped solve may gain a little now and then,
            // so the start energy is compared with the one at the start of a window of up to
            // MONITOR_WINDOW quiet steps, and only a clear gain (a quarter of the energy that
            // can move between kinds) is refused.
            let pattern = Pattern {
                row_start: &a.row_start[..n + 1],
                cols: &a.cols[..self.nnz],
            };
            let bending = if bending_on {
                bending::energy(&pattern, &a.q_off[..self.nnz], x)
            } else {
                0.0
            };
            let (kinetic, gravity) =
                motion_energy(&a.mass[..n], x, v, eff & effects::GRAVITY != 0, st.gravity);
            let now = elastic + bending + kinetic + gravity;
            // what can legitimately move between kinds, and the f32 round-off of the
            // potential's absolute value (positions carry ~1e-7 relative error)
            let scale = elastic + bending + kinetic + 1e-6 * gravity.abs();
            if self.monitor_valid && self.window_age < MONITOR_WINDOW {
                self.window_age += 1;
                if now - self.window_energy > 0.25 * self.window_scale.max(scale) + 1e-12 {
                    return Err(StepError::Unstable);
                }
            } else {
                self.window_age = 0;
                self.window_energy = now;
                self.window_scale = scale;
            }
        }
        let rot = if per_node { Some(&a.rot[..n]) } else { None };
        if let Some(rot) = rot {
            membrane::node_warped_force(
                &pattern,
                &a.k_off[..self.nnz],
                rot,
                &a.rest[..n],
                x,
                &mut a.force[..n],
            )
            .map_err(|_| StepError::SolverBreakdown)?;
        }
        let rhs = &mut a.rhs[..n];
        rhs.copy_from_slice(&a.force[..n]);
        // Implicit and Rayleigh terms: -(β + h) K_w v  (K_w = R K Rᵀ + B Q).
        let c_kv = beta + h;
        stiffness_apply(
            &pattern,
            &a.k_diag[..n],
            &a.k_off[..self.nnz],
            &a.q_diag[..n],
            &a.q_off[..self.nnz],
            rot,
            bending_on,
            v,
            &mut a.force[..n],
            &mut a.w_r[..n],
        );
        for (f, kv) in rhs.iter_mut().zip(&a.w_r[..n]) {
            *f -= *kv * c_kv;
        }
        if bending_on {
            // Bending force -B Q x (Q annihilates the flat rest shape, so no rest term).
            let _ = bending::add_forces(&pattern, &a.q_off[..self.nnz], x, rhs);
        }
        let gravity = Vec3A::from(st.gravity);
        let wind = Vec3A::from(st.wind);
        for i in 0..n {
            let m = a.mass[i];
            let mut f = rhs[i];
            if eff & effects::GRAVITY != 0 {
                f += gravity * m;
            }
            if alpha > 0.0 {
                f -= v[i] * (alpha * m);
            }
            if eff & effects::WIND != 0 && st.drag > 0.0 {
                let nrm = a.normals[i];
                f += nrm * (st.drag * a.area[i] * (wind - v[i]).dot(nrm));
            }
            rhs[i] = f * h;
        }

        // --- constraints: the PCG filter and the prescribed velocity changes ---
        let mut constrained = false;
        let dv = &mut a.dv[..n];
        let filter = &mut a.filter[..n];
        let collide_on = eff & effects::COLLISION != 0 && self.colliders > 0;
        let pins_on = eff & effects::PINS != 0 && self.pins > 0;
        if collide_on || pins_on {
            filter.fill(Mat3A::IDENTITY);
        }
        if collide_on {
            for i in 0..n {
                a.contact_collider[i] = mesh::NONE;
                let mut deepest = f32::INFINITY;
                for (k, c) in a.colliders[..self.colliders].iter().enumerate() {
                    let shape = c.previous.lerp(&c.shape, t);
                    let before = c.previous.lerp(&c.shape, t0);
                    let prox = shape.proximity(x[i]);
                    let vs = shape.surface_velocity(&before, x[i], h);
                    let vn_rel = (v[i] - vs).dot(prox.normal);
                    // predicted distance at the end of the substep
                    let predicted = prox.distance + h * vn_rel;
                    if predicted < c.thickness && prox.distance - c.thickness < deepest {
                        deepest = prox.distance - c.thickness;
                        let nrm = prox.normal;
                        // end the substep on the offset surface, moving with the collider
                        let target_vn = vs.dot(nrm) + (c.thickness - prox.distance) / h;
                        let dvn = target_vn - v[i].dot(nrm);
                        filter[i] = Mat3A::IDENTITY - outer(nrm, nrm);
                        dv[i] = filter[i] * dv[i] + nrm * dvn;
                        // the push the contact supplies beyond what the forces alone would do
                        let free_dvn = rhs[i].dot(nrm) / a.mass[i].max(f32::MIN_POSITIVE);
                        a.contact_push[i] = nrm * (dvn - free_dvn).max(0.0);
                        a.contact_collider[i] = k as u32;
                        constrained = true;
                    }
                }
            }
        }
        if pins_on {
            for p in 0..self.pins {
                let i = a.pin_vertex[p] as usize;
                let target = a.pin_previous[p].lerp(a.pin_target[p], t);
                // land exactly on the target at the end of the substep
                dv[i] = (target - x[i]) / h - v[i];
                filter[i] = Mat3A::ZERO;
                constrained = true;
            }
        }

        // --- the system matrix A = c_m M + c_k K_w and its block-Jacobi preconditioner ---
        let c_m = 1.0 + h * alpha;
        let c_k = h * beta + h * h;
        let settings = pcg::Settings {
            tolerance: st.tolerance,
            max_iterations: st.max_iterations,
            floor: (self.total_mass * FLOOR_VELOCITY * FLOOR_VELOCITY) as f32,
        };
        let work = pcg::Work {
            r: &mut a.w_r[..n],
            c: &mut a.w_c[..n],
            q: &mut a.w_q[..n],
            s: &mut a.w_s[..n],
        };
        let filter_arg = if constrained { Some(&filter[..]) } else { None };
        let stats = match rot {
            None => {
                // K_w was assembled this substep anyway: fold bending and mass into the same
                // blocks, so a CG iteration is one block-sparse product.
                for (k, q) in a.k_off[..self.nnz].iter_mut().zip(&a.q_off[..self.nnz]) {
                    let b = if bending_on { *q } else { 0.0 };
                    *k = (*k + Mat3A::from_diagonal(glam::Vec3::splat(b))) * c_k;
                }
                for i in 0..n {
                    let b = if bending_on { a.q_diag[i] } else { 0.0 };
                    let d = &mut a.k_diag[i];
                    *d = *d * c_k
                        + Mat3A::from_diagonal(glam::Vec3::splat(b * c_k + c_m * a.mass[i]));
                }
                let op = sparse::BlockMatrix {
                    diag: &a.k_diag[..n],
                    pattern,
                    off: &a.k_off[..self.nnz],
                };
                let mut result = Err(pcg::PcgError::Breakdown);
                if self.solver == Solver::Multigrid {
                    // Lent for the solve: the block-Jacobi array and the force vector (read
                    // into rhs above).
                    let (vectors, dense) = a
                        .force
                        .split_at_mut(multigrid::vectors_len(n, self.nnz).min(n));
                    let mem = multigrid::Memory {
                        agg: &a.scratch_b[..n],
                        index: a.scratch_a,
                        blocks: bytemuck::cast_slice_mut(&mut a.precond[..]),
                        dense: bytemuck::cast_slice_mut(dense),
                        vectors,
                    };
                    let options = multigrid::Options::default();
                    if let Ok(mut mg) = multigrid::Multigrid::new(mem, op, filter_arg, options) {
                        result =
                            pcg::solve_with(&op, &mut mg, filter_arg, rhs, dv, &settings, work);
                    }
                }
                match result {
                    Ok(stats) => Ok(stats),
                    Err(_) => {
                        // Block Jacobi, also the fallback should the multilevel cycle ever
                        // break down (not positive): it restarts from the partial iterate,
                        // whose constrained components the solve has kept.
                        for (p, d) in a.precond[..n].iter_mut().zip(&a.k_diag[..n]) {
                            *p = pcg::invert_block(*d);
                        }
                        let work = pcg::Work {
                            r: &mut a.w_r[..n],
                            c: &mut a.w_c[..n],
                            q: &mut a.w_q[..n],
                            s: &mut a.w_s[..n],
                        };
                        pcg::solve(&op, &a.precond[..n], filter_arg, rhs, dv, &settings, work)
                    }
                }
            }
            Some(rot) => {
                for (i, (p, q)) in a.precond[..n].iter_mut().zip(rot).enumerate() {
                    let r = Mat3A::from_quat(*q);
                    let mut d = r * a.k_diag[i] * r.transpose();
                    if bending_on {
                        d += Mat3A::from_diagonal(glam::Vec3::splat(a.q_diag[i]));
                    }
                    let block = Mat3A::from_diagonal(glam::Vec3::splat(c_m * a.mass[i])) + d * c_k;
                    *p = pcg::invert_block(block);
                }
                let op = SystemOperator {
                    pattern: &pattern,
                    k_diag: &a.k_diag[..n],
                    k_off: &a.k_off[..self.nnz],
                    q_diag: &a.q_diag[..n],
                    q_off: &a.q_off[..self.nnz],
                    rot: Some(rot),
                    mass: &a.mass[..n],
                    bending: bending_on,
                    c_m,
                    c_k,
                    tmp: core::cell::RefCell::new(&mut a.force[..n]),
                };
                pcg::solve(&op, &a.precond[..n], filter_arg, rhs, dv, &settings, work)
            }
        }
        .map_err(|_| StepError::SolverBreakdown)?;

        // --- integrate ---
        for ((x, v), d) in a.x[..n].iter_mut().zip(&mut a.v[..n]).zip(dv.iter()) {
            *v += *d;
            *x += *v * h;
        }
        let mut contacts = 0;
        if collide_on {
            for i in 0..n {
                if a.pin_of[i] != mesh::NONE && pins_on {
                    continue;
                }
                let mut touched = false;
                // Coulomb friction for the contacts the solve held: the tangential velocity
                // relative to the surface shrinks by at most μ times the normal impulse.
                let k = a.contact_collider[i];
                if let Some(c) = a.colliders[..self.colliders].get(k as usize) {
                    let shape = c.previous.lerp(&c.shape, t);
                    let before = c.previous.lerp(&c.shape, t0);
                    let vs = shape.surface_velocity(&before, a.x[i], h);
                    let push = a.contact_push[i];
                    let nrm = shape.proximity(a.x[i]).normal;
                    let rel = a.v[i] - vs;
                    let vt = rel - nrm * rel.dot(nrm);
                    let vt_len = vt.length();
                    if vt_len > 0.0 {
                        let scale = (1.0 - c.friction * push.length() / vt_len).max(0.0);
                        a.v[i] -= vt * (1.0 - scale);
                    }
                    touched = true;
                }
                // Projection: nothing ends the substep deeper than `thickness`.
                for c in &a.colliders[..self.colliders] {
                    let shape = c.previous.lerp(&c.shape, t);
                    let before = c.previous.lerp(&c.shape, t0);
                    let vs = shape.surface_velocity(&before, a.x[i], h);
                    touched |= collide::resolve(
                        &shape,
                        vs,
                        c.thickness,
                        c.friction,
                        &mut a.x[i],
                        &mut a.v[i],
                    );
                }
                contacts += touched as u32;
            }
        }
        if pins_on {
            for p in 0..self.pins {
                let i = a.pin_vertex[p] as usize;
                a.x[i] = a.pin_previous[p].lerp(a.pin_target[p], t);
            }
        }
        if !a.x[..n].iter().chain(&a.v[..n]).all(|p| p.is_finite()) {
            return Err(StepError::NonFiniteState);
        }
        Ok((stats, contacts))
    }

    /// The elastic forces (N) on the current state, exactly as the next substep computes
    /// them; for tests and diagnostics. Returns false when `out` is too short.
    pub fn elastic_forces(&mut self, out: &mut [Vec3A]) -> bool {
        let n = self.n;
        if out.len() < n {
            return false;
        }
        let warping = self.settings.effects & effects::WARPING != 0;
        let per_node = warping && self.settings.per_node_warping;
        self.update_rotations(16);
        let a = &mut self.a;
        let ok = membrane::assemble_corotated(
            &a.triangles[..self.nt],
            &a.elements[..self.nt],
            &a.slots[..self.nt],
            &a.rest[..n],
            &a.x[..n],
            &a.normals[..n],
            warping && !per_node,
            &mut a.k_diag[..n],
            &mut a.k_off[..self.nnz],
            &mut out[..n],
        )
        .is_ok();
        if ok && per_node {
            let pattern = Pattern {
                row_start: &a.row_start[..n + 1],
                cols: &a.cols[..self.nnz],
            };
            return membrane::node_warped_force(
                &pattern,
                &a.k_off[..self.nnz],
                &a.rot[..n],
                &a.rest[..n],
                &a.x[..n],
                &mut out[..n],
            )
            .is_ok();
        }
        ok
    }
}

/// Kinetic energy and gravitational potential `-Σ m g·x` (zero without gravity), J.
fn motion_energy(
    mass: &[f32],
    x: &[Vec3A],
    v: &[Vec3A],
    gravity_on: bool,
    g: [f32; 3],
) -> (f64, f64) {
    let g = Vec3A::from(g);
    let mut kinetic = 0.0f64;
    let mut potential = 0.0f64;
    for ((&m, xi), vi) in mass.iter().zip(x).zip(v) {
        kinetic += 0.5 * f64::from(m) * f64::from(vi.length_squared());
        if gravity_on {
            potential -= f64::from(m) * f64::from(g.dot(*xi));
        }
    }
    (kinetic, potential)
}

/// The triangle whose corners are exactly `corners` (in any order), found through the
/// incidence list of the first corner.
fn triangle_of(
    vt_start: &[u32],
    vt: &[u32],
    triangles: &[[u32; 3]],
    corners: [u32; 3],
) -> Option<usize> {
    let v = corners[0] as usize;
    let range = (*vt_start.get(v)? as usize)..(*vt_start.get(v + 1)? as usize);
    vt.get(range)?.iter().map(|&t| t as usize).find(|&t| {
        triangles
            .get(t)
            .is_some_and(|tri| corners.iter().all(|c| tri.contains(c)))
    })
}

fn outer(a: Vec3A, b: Vec3A) -> Mat3A {
    Mat3A::from_cols(a * b.x, a * b.y, a * b.z)
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
        let _ = sparse::mul(k_diag, p, k_off, tmp, y);
        for (yi, r) in y.iter_mut().zip(rot) {
            *yi = *r * *yi;
        }
    } else {
        let _ = sparse::mul(k_diag, p, k_off, x, y);
    }
    if bending {
        let _ = sparse::mul_scalar_add(q_diag, p, q_off, 1.0, x, y);
    }
}

/// `A p = c_m M p + c_k K_w p`, the matrix of the linearized implicit Euler step.
struct SystemOperator<'s, 't> {
    pattern: &'s Pattern<'s>,
    k_diag: &'s [Mat3A],
    k_off: &'s [Mat3A],
    q_diag: &'s [f32],
    q_off: &'s [f32],
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
