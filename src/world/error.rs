//! What a world reports: why init, a step or an edit refused, what a step did, its energy.

use core::fmt;

use crate::mesh::MeshError;

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
    /// The initial positions stretch triangle `triangle`'s rest (u, v) so far that its elastic
    /// force, stiffness or energy does not fit `f32`: every step would fail. Usually (u, v)
    /// and positions in different units.
    StrainOutOfRange {
        triangle: u32,
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
    /// The solver broke down (indefinite or non-finite system) at every substep count the
    /// step tried (up to 8× the setting's, as for a gain of energy), and holding the cloth
    /// still instead ([`StepStats::stopped`], what such a step does otherwise) overflowed too:
    /// its pins' targets lie beyond what `f32` energies hold. The world kept the state it had
    /// before.
    SolverBreakdown,
    /// The step produced NaN or infinite positions or velocities, or a state whose energy
    /// overflows `f32`, at every substep count the step tried, and so did holding the cloth
    /// still (e.g. a pin moved 1e9 m in one step); the world kept the state it had before.
    NonFiniteState,
    /// The step's energy balance is not a number (its energies overflowed `f64`). The state
    /// is the one before this step. (A step that gains energy is redone, then energy-limited,
    /// and as a last resort the cloth is held still: [`StepStats::limited`],
    /// [`StepStats::stopped`].)
    Unstable,
}

/// What a step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// PCG iterations summed over substeps.
    pub iterations: u32,
    /// Linear solves summed over substeps: one per substep, plus one per round of contacts
    /// let go because they pulled or engaged because the solve carried a vertex into a
    /// collider (`iterations / solves` is the cost of a solve).
    pub solves: u32,
    /// The PCG iterations of each substep's first solve, summed over substeps; the rest
    /// (`iterations − first_iterations`) went to the solves after contacts were let go or
    /// engaged, which start from the first solve's answer and cost a few each.
    pub first_iterations: u32,
    /// Largest final relative residual over substeps, `sqrt(rᵀ P r / δ₀)` (`P` the
    /// preconditioner, `δ₀` the same measure of the substep's first right-hand side). A solve
    /// also stops at an absolute floor (a cloth near rest, whose right-hand side is tiny): there
    /// it is converged with a relative residual above the tolerance, even above 1.
    pub residual: f32,
    /// Every substep's solve reached the tolerance.
    pub converged: bool,
    pub substeps: u32,
    /// The world was asleep and did nothing.
    pub asleep: bool,
    /// Vertices in contact with a collider at the end of the step.
    pub contacts: u32,
    /// Times the step was redone with twice the substeps (and, when it gained after
    /// converged solves at a tolerance looser than the default, a tenth of it) because its end
    /// state had gained energy that nothing supplied (0 to 3, and up to 5 while each redo at
    /// least halved the gain; `substeps` is the count finally used), and once more when it
    /// was then energy-limited (`limited`).
    pub redone: u32,
    /// Energy (J) taken out because the step still gained it without input after its redos:
    /// out of the kinetic energy at the end, or by the energy-limited substeps (`limited`);
    /// or, with no redo, out of the kinetic energy of a step within its own round-off whose
    /// gains since the lowest level the cloth has been at add up to more than the round-off;
    /// 0 for a sound step.
    pub energy_removed: f32,
    /// The energy balance of the step (J): end energy − start energy − work of external
    /// input, before any removal. ≤ 0 for a step that dissipates.
    pub energy_gain: f32,
    /// Even redone with 8× the substeps (up to 32× while its gain kept halving), the step
    /// gained more energy than its kinetic energy could give back, so the world held the cloth
    /// still instead: positions as at the start of the step, but the pinned vertices on their
    /// targets and every other vertex put out of the colliders (as a substep's projection
    /// does, where the colliders are at the end of the step), velocities zero
    /// (`energy_removed` is the kinetic energy it had). The next step starts from rest.
    /// Only when the energy-limited attempt (`limited`) failed too, or when every attempt's
    /// solve broke down or its state overflowed (failing kept the start, from which every
    /// later call failed the same way).
    pub stopped: bool,
    /// Its redos gained more energy than the kinetic energy could give back, so the step was
    /// done once more with each substep's end energy-limited: the velocity the solve gave the
    /// vertices no pin holds scaled by the first of 1, ½, …, 1/64 (else 0) that leaves the
    /// substep with no more energy than it began with and the wind gave it (`energy_removed`
    /// counts what that took). The linearized step is one Newton step, and on a non-convex
    /// energy (a membrane squeezed to a fraction of its size) it can overshoot at every substep
    /// count; part of it still goes downhill.
    pub limited: bool,
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

/// Errors of the pin and collider setters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EditError {
    VertexOutOfRange,
    NonFinite,
    PinCapacity,
    ColliderCapacity,
    /// A triangle range reaches past the last triangle.
    TriangleOutOfRange,
    /// No collider has that id (never added, or removed).
    UnknownCollider,
    InvalidCollider,
    /// A pin's plane normal or line direction is zero or not finite.
    InvalidAxis,
    /// A rotation quaternion of zero length.
    InvalidRotation,
    /// A mass scale that is not finite and positive, or gives a mass beyond `f32`.
    InvalidMassScale {
        vertex: u32,
    },
}

impl fmt::Display for InitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InitError::MemoryTooSmall => {
                f.write_str("the memory block is smaller than the capacity needs")
            }
            InitError::CapacityTooLarge => {
                f.write_str("the capacity does not fit in memory addresses")
            }
            InitError::VertexCapacity { needed, capacity } => {
                write!(f, "{needed} vertices exceed the capacity of {capacity}")
            }
            InitError::TriangleCapacity { needed, capacity } => {
                write!(f, "{needed} triangles exceed the capacity of {capacity}")
            }
            InitError::EdgeCapacity { capacity } => {
                write!(f, "the mesh has more edges than the capacity of {capacity}")
            }
            InitError::Mesh(e) => write!(f, "invalid mesh: {e}"),
            InitError::MaterialCount => f.write_str("materials and triangles differ in count"),
            InitError::MaterialOutOfRange { triangle, material } => {
                write!(
                    f,
                    "triangle {triangle} names material {material}, which does not exist"
                )
            }
            InitError::InvalidMaterial { material } => {
                write!(
                    f,
                    "material {material} is unusable (non-finite, not SPD, or beyond f32)"
                )
            }
            InitError::InvalidSetting { field } => write!(f, "setting `{field}` is out of range"),
            InitError::StrainOutOfRange { triangle } => write!(
                f,
                "triangle {triangle} is stretched so far from its (u, v) that its elastic terms are \
                 beyond f32: the cloth could never step"
            ),
            InitError::Internal => f.write_str("internal consistency check failed"),
        }
    }
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StepError::InvalidTimeStep => f.write_str("the time step is not finite and positive"),
            StepError::NonFinitePin { vertex } => {
                write!(f, "the pin of vertex {vertex} has a non-finite target")
            }
            StepError::SolverBreakdown => f.write_str("the linear solver broke down"),
            StepError::NonFiniteState => f.write_str(
                "the step produced non-finite positions or velocities, or an energy beyond f32",
            ),
            StepError::Unstable => f.write_str("the step's energy balance is not a number"),
        }
    }
}

impl fmt::Display for EditError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let EditError::InvalidMassScale { vertex } = self {
            return write!(
                f,
                "the mass scale of vertex {vertex} is not positive, or its mass is beyond f32"
            );
        }
        f.write_str(match self {
            EditError::VertexOutOfRange => "vertex index or count out of range",
            EditError::NonFinite => "a value is NaN or infinite",
            EditError::PinCapacity => "no room for another pin",
            EditError::ColliderCapacity => "no room for another collider",
            EditError::UnknownCollider => "no collider has that id (never added, or removed)",
            EditError::InvalidCollider => "the collider's shape or parameters are invalid",
            EditError::InvalidMassScale { .. } => "invalid mass scale",
            EditError::InvalidAxis => "a pin's normal or direction is zero or not finite",
            EditError::TriangleOutOfRange => "triangle index or count out of range",
            EditError::InvalidRotation => "the rotation quaternion has zero length",
        })
    }
}
