//! A world's memory: its [`Capacity`], and the one list of arrays from which the struct, the
//! byte count ([`Capacity::world_bytes`], a `const fn`) and the carving of the caller's block
//! all come, so they cannot disagree.

use glam::{Mat3A, Quat, Vec3A};

use super::settings::Solver;
use super::InitError;
use crate::collide::{Collider, Shape};
use crate::membrane::Element;
use crate::mesh;

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

    pub(crate) const fn v(&self) -> usize {
        self.vertices as usize
    }
    pub(crate) const fn t(&self) -> usize {
        self.triangles as usize
    }
    pub(crate) const fn e(&self) -> usize {
        self.edges as usize
    }
    pub(crate) const fn c(&self) -> usize {
        self.colliders as usize
    }
    pub(crate) const fn p(&self) -> usize {
        self.pins as usize
    }
    /// Couplings the multilevel hierarchy is sized for: the block pattern (one per edge) and
    /// the hinge-only scalar pattern (at most one per edge).
    const fn couplings(&self) -> usize {
        self.e().saturating_mul(2)
    }
    /// `scratch_a`, which holds the multilevel hierarchy: a vertex's worth of `u32`, and at
    /// least the hierarchy's index. The multilevel pools borrow arrays the world has anyway,
    /// and below a few hundred vertices those are shorter than a hierarchy's fixed part (its
    /// header, the coarsest level's dense factor): such meshes stepped with block Jacobi,
    /// which on a 126-vertex fan of a stiff fabric (κ ≈ 1e7) stopped at its iteration cap
    /// with Δv 24–194 % off and gained energy at every substep count (outside fuzzer).
    /// Lengthened, they cost a few KB at most, and every mesh gets a hierarchy.
    const fn multigrid_index(&self) -> usize {
        at_least(
            self.v(),
            crate::multigrid::index_len(self.v(), self.couplings()),
        )
    }
    /// `precond`, lent to the multilevel operators as `f32` (see [`Capacity::multigrid_index`]).
    const fn multigrid_blocks(&self) -> usize {
        let floats = crate::multigrid::blocks_len(self.v(), self.couplings());
        let per_block = core::mem::size_of::<Mat3A>() / core::mem::size_of::<f32>();
        at_least(self.v(), floats.div_ceil(per_block))
    }
    /// `force`, lent to the coarsest factor and the multilevel vectors (see
    /// [`Capacity::multigrid_index`]).
    const fn multigrid_vectors(&self) -> usize {
        let dense = crate::step::system::dense_vectors(self.v(), self.couplings());
        let vectors = crate::multigrid::vectors_len(self.v(), self.couplings());
        at_least(self.v(), dense.saturating_add(vectors))
    }
    /// Per-node rotations exist only for the research path (per-node warping, Eq. 14–17);
    /// the default world carries none.
    const fn r(&self) -> usize {
        if cfg!(feature = "research") {
            self.v()
        } else {
            0
        }
    }
}

/// Declares the world's arrays once: the struct, the byte count and the carving all come from
/// this one list, so they cannot disagree.
macro_rules! arrays {
    ($cap:ident; $( $(#[$doc:meta])* $field:ident : $ty:ty = [$count:expr; $init:expr] ),* $(,)?) => {
        /// Every array of a world, carved from the caller's block. The step's stages
        /// (`crate::step`) work on these slices.
        pub(crate) struct Arrays<'a> { $( $(#[$doc])* pub(crate) $field: &'a mut [$ty], )* }

        impl Capacity {
            /// Bytes a world of this capacity needs (including worst-case alignment padding).
            pub const fn world_bytes(&self) -> usize {
                let $cap = self;
                let mut total = 0usize;
                $( total = total.saturating_add(slot_bytes::<$ty>($count)); )*
                total
            }

            /// [`Capacity::world_bytes`] with every product and sum checked: `None` when the
            /// count does not fit a `usize` (then no memory block can hold the world).
            pub const fn checked_world_bytes(&self) -> Option<usize> {
                let $cap = self;
                let mut total = 0usize;
                $(
                    let Some(bytes) = ($count).checked_mul(core::mem::size_of::<$ty>()) else {
                        return None;
                    };
                    let Some(slot) = bytes.checked_add(core::mem::align_of::<$ty>() - 1) else {
                        return None;
                    };
                    let Some(sum) = total.checked_add(slot) else {
                        return None;
                    };
                    total = sum;
                )*
                Some(total)
            }
        }

        pub(super) fn carve<'a>($cap: &Capacity, carver: &mut Carver<'a>) -> Result<Arrays<'a>, InitError> {
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
    /// Lumped masses (kg): the step's, `rest_mass` times the vertex's mass scale.
    mass: f32 = [cap.v(); 0.0],
    /// Lumped masses from the materials' densities at init (kg), what a mass scale scales.
    rest_mass: f32 = [cap.v(); 0.0],
    /// Forces the engine applied for the next step (N), constant over it, cleared after it
    /// (packed: the 64×64 default world stays within 4 MB).
    applied_force: [f32; 3] = [cap.v(); [0.0; 3]],
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
    /// per-solve memory is lent by `precond` and `force` (see `step/system.rs`). So the
    /// multilevel solver adds no memory to a mesh of more than a few hundred vertices; a
    /// smaller one's arrays are lengthened to a hierarchy's fixed part
    /// ([`Capacity::multigrid_index`] and its two siblings).
    scratch_a: u32 = [cap.multigrid_index(); 0],
    scratch_b: u32 = [cap.v(); 0],
    /// Block pattern (strictly upper CSR): the mesh edges, which the membrane stiffness and
    /// the bending Hessian share.
    row_start: u32 = [cap.v().saturating_add(1); 0],
    cols: u32 = [cap.e(); 0],
    /// Scalar pattern (strictly upper CSR): the pairs of vertices opposite a hinge that share
    /// no edge, which only bending couples (a scalar times I3, `sparse::Scalars`); at most
    /// one per hinge, so per edge.
    hinge_start: u32 = [cap.v().saturating_add(1); 0],
    hinge_cols: u32 = [cap.e(); 0],
    /// Per triangle: its constant element stiffness and gradients, and where its three
    /// vertex pairs sit in the block pattern.
    elements: Element = [cap.t(); Element::ZERO],
    slots: [u32; 3] = [cap.t(); [0; 3]],
    /// Rotated membrane stiffness `K_w = Σ_e R_e K_e R_eᵀ` (N/m), re-assembled every substep.
    k_diag: Mat3A = [cap.v(); Mat3A::ZERO],
    k_off: Mat3A = [cap.e(); Mat3A::ZERO],
    /// Elastic forces of the current substep (N); during the solve, the multilevel vectors
    /// and coarsest factor.
    force: Vec3A = [cap.multigrid_vectors(); Vec3A::ZERO],
    /// Bending Hessian `B Q` (N/m per unit displacement), a scalar per block times I3: on
    /// the diagonal, on the block pattern (`q_off`) and on the scalar pattern (`q_hinge`).
    q_diag: f32 = [cap.v(); 0.0],
    q_off: f32 = [cap.e(); 0.0],
    q_hinge: f32 = [cap.e(); 0.0],
    /// Per-node rotations (feature `research` only; empty otherwise).
    #[cfg_attr(not(feature = "research"), allow(dead_code))]
    rot: Quat = [cap.r(); Quat::IDENTITY],
    normals: Vec3A = [cap.v(); Vec3A::Z],
    /// Right-hand side, solution (warm start) and PCG work vectors (`w_c` and `w_p` then hold
    /// the projection's marks of each vertex, see `contacts::resolve`, until the next solve).
    rhs: Vec3A = [cap.v(); Vec3A::ZERO],
    dv: Vec3A = [cap.v(); Vec3A::ZERO],
    w_r: Vec3A = [cap.v(); Vec3A::ZERO],
    w_c: Vec3A = [cap.v(); Vec3A::ZERO],
    w_q: Vec3A = [cap.v(); Vec3A::ZERO],
    w_s: Vec3A = [cap.v(); Vec3A::ZERO],
    /// The flexible CG's `S q` (`pcg::Work::p`). Its memory was the warm start saved at the
    /// start of each step: a redone step now warm-starts from the failed attempt's last `Δv`,
    /// a failed step's next solve from zero.
    w_p: Vec3A = [cap.v(); Vec3A::ZERO],
    /// The line smoother's positivity probe, kept from one solve to the next (a power
    /// iterate, `multigrid::Probe`): used only by `Solver::MultigridLines`.
    line_probe: Vec3A = [cap.v(); Vec3A::ZERO],
    /// Block-Jacobi inverses, or (lent as f32) the multilevel operators of the solve.
    precond: Mat3A = [cap.multigrid_blocks(); Mat3A::IDENTITY],
    filter: Mat3A = [cap.v(); Mat3A::IDENTITY],
    /// Contacts: the collider a vertex is held against in this substep (or `mesh::NONE`),
    /// with the flags of `step::contacts::FLAGS` (static friction holds it; it was let go
    /// because its contact pulled); and the same at the start of the step (a redone step
    /// starts from it again).
    contact: u32 = [cap.v(); mesh::NONE],
    contact_start: u32 = [cap.v(); mesh::NONE],
    /// The contacts of each vertex let go in this substep because they pulled, by their order
    /// in the vertex's contact tests (bit `k`: the `k`-th; see `step::contacts::release`).
    contact_dropped: u32 = [cap.v(); 0],
    /// Pin index of each vertex, or `mesh::NONE`.
    pin_of: u32 = [cap.v(); mesh::NONE],
    pin_vertex: u32 = [cap.p(); 0],
    pin_target: Vec3A = [cap.p(); Vec3A::ZERO],
    pin_previous: Vec3A = [cap.p(); Vec3A::ZERO],
    /// The directions each pin leaves free, as the PCG filter `S` of its vertex: 0 for a
    /// point, `I − n nᵀ` for a plane, `d dᵀ` for a line (see `PinAxes`).
    pin_free: Mat3A = [cap.p(); Mat3A::ZERO],
    /// The id of the collider in each slot (ids stay with their collider when another is
    /// removed; the slots stay packed).
    collider_id: u32 = [cap.c(); mesh::NONE],
    colliders: Collider = [cap.c(); Collider::new(Shape::Plane { normal: Vec3A::Z, offset: 0.0 }, 0.0, 0.0)],
}

const fn at_least(n: usize, floor: usize) -> usize {
    if n > floor {
        n
    } else {
        floor
    }
}

/// Saturating, so that a capacity too large for a 32-bit `usize` asks for `usize::MAX` bytes
/// (which no block satisfies: init reports `MemoryTooSmall`) instead of overflowing.
const fn slot_bytes<T>(n: usize) -> usize {
    n.saturating_mul(core::mem::size_of::<T>())
        .saturating_add(core::mem::align_of::<T>() - 1)
}

/// Hands out typed, initialized slices from a caller's byte block.
pub(super) struct Carver<'a> {
    pub(super) rest: &'a mut [u8],
    pub(super) needed: usize,
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

/// How many of each thing a built world holds: the lengths the step's stages slice its
/// arrays to.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Counts {
    pub n: usize,
    pub nt: usize,
    pub nnz: usize,
    /// Entries of the scalar (hinge-only) pattern.
    pub nnz_h: usize,
    pub pins: usize,
    pub colliders: usize,
    /// The CG preconditioner.
    pub solver: Solver,
    /// Σ lumped masses (kg): the scale of the solve's absolute floor.
    pub total_mass: f64,
}
