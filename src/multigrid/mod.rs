//! An algebraic multilevel preconditioner for the filtered PCG of [`crate::pcg`]: unsmoothed
//! aggregation, Galerkin coarse operators recomputed every solve, a K-cycle (a V-cycle whose
//! coarse corrections are each improved by two inner CG steps) with damped block-Jacobi
//! smoothing and a dense Cholesky solve on the coarsest level.
//!
//! Why: block-Jacobi PCG needs a number of iterations that grows with the mesh (the implicit
//! step's `A = c_m M + c_k K` gets stiffer relative to the mass as the triangles shrink:
//! ~160 iterations at 21×21 vertices, past a 200 cap from 41×41 on at tolerance 1e-5). A
//! multilevel preconditioner removes the smooth error that Jacobi cannot, so the count stays
//! bounded as the mesh is refined.
//!
//! # Hierarchy (built once, [`build`])
//!
//! From the block pattern alone (any triangle mesh; nothing grid-specific): level 0 is the
//! caller's matrix; level `ℓ + 1` has one vertex per *aggregate* of level `ℓ`. Aggregation is
//! greedy over the symmetric coupling graph, in ascending vertex order (deterministic):
//! 1. a vertex whose neighbours are all unaggregated becomes a root: it and all its
//!    neighbours form a new aggregate;
//! 2. every vertex left over (it has an aggregated neighbour, else it would have been a root)
//!    joins the aggregate of its first neighbour aggregated in step 1.
//!
//! Levels are added until the coarsest has at most [`MAX_DENSE`] vertices, [`MAX_LEVELS`] are
//! reached, coarsening stalls (fewer than 10% fewer vertices, e.g. a mesh of isolated vertices)
//! or the caller's pools are full; a coarsest level above [`MAX_DENSE`] vertices is smoothed
//! instead of solved ([`Options::coarse_sweeps`]). The coarse patterns live in the pools; so
//! does everything else, see [`Memory`], including where each fine coupling lands in level 1's
//! operator (a `u32` per coupling), so that no solve searches the coarse pattern for it: the
//! binary search per fine coupling was a fifth of every setup's instructions.
//!
//! # Operators (every solve, [`Multigrid::new`])
//!
//! The prolongation `P` of level `ℓ` copies an aggregate's value to its members (3×3 identity
//! blocks). The constraint filter `S` of the PCG (pins `0`, contacts `I − n nᵀ`) is folded in
//! as in Tamstorf, Jones & McCormick 2015 ("Smoothed aggregation multigrid for cloth
//! simulation"): the hierarchy approximates the filtered operator `Â = S A S + τ (I − S)`
//! (constrained directions decoupled; `τ_i = tr(A_ii)/3` only keeps the diagonal blocks well
//! scaled), and the first prolongation is filtered, `P̂ = S P`, so that coarse corrections
//! never move a constrained direction. The coarse operators are Galerkin,
//! `A₁ = P̂ᵀ Â P̂ = Pᵀ (S A S) P` and `A_{ℓ+1} = Pᵀ A_ℓ P`: for piecewise-constant `P` a coarse
//! block is the sum of the fine blocks between two aggregates, accumulated through the coarse
//! pattern (one pass over the fine blocks). A fully constrained aggregate direction gives a
//! zero coarse row; the block inverses and the Cholesky treat it as decoupled (zero output).
//! When only a few vertices' filters changed since the last setup (contacts let go, and the
//! solve goes on), [`Multigrid::renew`] recomputes only their inverses and the level-1 blocks
//! of their aggregates, in the same order of sums, so the operators are `new`'s bit for bit
//! (measured: a quarter of a full setup; 3.0 / 3.5 % of the step at 81 / 161 per side).
//!
//! # Cycle ([`Preconditioner::apply`])
//!
//! One cycle with `ν` = [`Options::sweeps`] smoothing sweeps before and after the coarse
//! correction on every level, the first from `z = 0`. The default smoother is damped block
//! Jacobi (`z += ω D⁻¹ (r − A z)`, [`Smoother::Jacobi`]); the finest level can be smoothed
//! along lines of dominant couplings instead ([`Smoother::Lines`], `lines.rs`); block Gauss–Seidel
//! ([`Smoother::GaussSeidel`]) is an option: forward sweeps (ascending vertices) before,
//! backward sweeps after, so the post-smoother is the adjoint of the pre-smoother; with the
//! strictly-upper storage a forward sweep scatters `t_j −= A_ijᵀ δ_i` and a backward one
//! gathers. Either way the
//! cycle is a symmetric operator, positive definite when every level's smoother converges
//! (Gauss–Seidel: always, for SPD levels; Jacobi: `ω λ_max(D⁻¹ A) < 2`). Each coarse level is
//! visited `γ` = [`Options::cycle`] times per visit of its parent (default `1`, a V-cycle; `2` a W-cycle):
//! `γ` stationary steps of the coarse cycle, a fixed linear SPD operator (no flexible outer
//! iteration), saving the coarse iterate in the parent's scratch (no extra memory). The input is
//! filtered first and the output lies in `range(S)`, so the operator applied is `S B S` with `B`
//! the cycle on `Â`.
//!
//! # K-cycle (the default, [`Options::krylov`])
//!
//! Unsmoothed aggregation's coarse corrections are piecewise constant: right in direction,
//! wrong in size, and the error compounds with every level, so a V-cycle's CG count grows
//! with the mesh (measured 23/33/53/63 at 21/41/81/161 per side on the growth test). The K-cycle of Notay & Vassilevski (2008) replaces each coarse level's
//! correction by up to two steps of CG on that level, preconditioned by the level's own
//! cycle: the inner CG picks the best size and mix of the two corrections, on every level.
//! Measured: 17/17/20/17 on the growth test; on weft-bench 18/23/27/33 at 21/41/81/161 (the
//! V-cycle: 20/28/43/58), and the step 1.00×/0.94×/0.76×/0.69× the V-cycle's time in the same
//! run (with the flexible outer CG, below). The second inner step is skipped when the first
//! has already reduced the level's residual to a quarter. Cost: one more vector per coarse vertex, and coarse levels
//! are visited up to twice per visit of their parent (levels shrink ~8× each, so this adds
//! ~30% to a cycle).
//!
//! The inner CG makes the cycle a nonlinear map of its input (its step sizes depend on it),
//! so the outer CG must be the flexible one ([`crate::pcg`]'s Polak–Ribière `β`). Measured
//! with the plain `β`: the same iteration counts, but the demo's second drape gained energy
//! and was redone at every step from step 25 on; with the flexible `β`, twice in 120 steps.
//! Each application is deterministic, positive (`rᵀ B(r) > 0`: two CG steps from zero on SPD
//! levels) and filtered.
//!
//! Measured before the K-cycle, on the World's step (tolerance 1e-3, `examples/bench_solver.rs`, pinned+contact,
//! CG iterations per solve at 21/41/81 per side): Jacobi V-cycle 22/38/67, Jacobi W 18/38/58,
//! Gauss–Seidel V 15/30/51, Gauss–Seidel W 14/29/46 ([`Options::FEWEST_ITERATIONS`]),
//! Gauss–Seidel `ν = 2` W 11/21/33, over-correction 1.4 did not help. On weft-bench's scene the
//! step with the Jacobi V-cycle was the fastest per step at 21, 41 and 81 per side in the same
//! run (1.1–1.3× faster than Gauss–Seidel W despite more iterations): the default.
//!
//! # Lumped scalar couplings (the default, [`Options::lumped`])
//!
//! The world's matrix holds half its couplings as scalars (`sparse::Scalars`: hinge bending
//! between the two vertices opposite an edge, which share no edge), and they cost ~30 % of a
//! product (`examples/bench_kernels.rs`: 5.5 µs with them, 3.9 µs without at 21×21) although
//! they are ~1e-4 of the diagonal. The finest level's Jacobi smoother, which multiplies by the
//! matrix twice per cycle, leaves them out of its residuals and adds their magnitudes to the
//! diagonal instead (`w_i = Σ_j |s_ij|`, one float per vertex in [`Memory::blocks`]): it
//! smooths `Ã = A + (|H| − H)` with `H` those couplings, and `|H| − H` is positive
//! semidefinite, so `Ã ≥ A` is SPD and the cycle stays symmetric and positive. The outer CG
//! multiplies by `A` itself and the coarse levels are the Galerkin operators of `A`: only the
//! preconditioner changes, never the system solved. Where a weight exceeds 5 % of its diagonal
//! (`LUMP_LIMIT`: strong bending on a fine mesh), the solve smooths exactly. Measured against
//! smoothing exactly: see `docs/PERFORMANCE.md` ("Lumped hinge couplings in the fine
//! smoother").
//!
//! Numerics: `f32` vectors and blocks, block inverses and the coarsest Cholesky in `f64`;
//! every loop runs in a fixed serial order, so a cycle is bit-reproducible.
//!
//! Memory: everything lives in the caller's [`Memory`] (lengths from `const fn`s of the
//! fine vertex and coupling counts), plus, at solve time, `n` blocks for the finest level's
//! smoother (the block-Jacobi array a caller already has) and the PCG's dead `q` vector as the
//! finest level's scratch. Nothing allocates and nothing panics.
#![deny(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::unreachable
)]

use crate::pcg::{Filter, Free, Preconditioner};
use crate::sparse::{BlockMatrix, Pattern};
use glam::{Mat3A, Vec3A};

/// Most levels in a hierarchy (the finest included).
pub const MAX_LEVELS: usize = 8;
/// Largest coarsest level (vertices) that is solved by a dense Cholesky factorization.
pub const MAX_DENSE: usize = 8;
const DENSE_DOF: usize = 3 * MAX_DENSE;
const DENSE_LEN: usize = DENSE_DOF * (DENSE_DOF + 1) / 2;

const MAGIC: u32 = 0x4d47_0001;
/// Per level: n, nnz, agg, rs, cols, blk, vec (see [`Level`]).
const LEVEL_WORDS: usize = 7;
/// magic, levels, dense flag, the finest level's scalar couplings, then the levels.
const HEADER: usize = 4 + LEVEL_WORDS * MAX_LEVELS;
const NONE: u32 = u32::MAX;
/// In the finest level's coupling map ([`index_len`]): both vertices lie in one aggregate, so
/// the coupling lands in its diagonal block.
const SAME: u32 = u32::MAX;
/// In the finest level's coupling map: the coupling lands in the coarse block `(J, I)`,
/// transposed (its aggregates are in the other order).
const TRANSPOSED: u32 = 1 << 31;
const PASS2: u32 = 1 << 31;
/// Relative ridge added to a coarse diagonal block before inverting it (bounds its condition
/// number by ~1e6 so that the `f32` inverse stays SPD; zero for all practical blocks).
const RIDGE: f64 = 1e-6;
/// Largest lumped weight of a vertex's scalar couplings, relative to its diagonal block's mean
/// entry, at which the finest level smooths with them lumped ([`Options::lumped`]): beyond,
/// the lumped cycle loses iterations. Measured on a 17×17 cloth with couplings of alternating
/// sign (`cycle.rs`, `lumped_scalar_couplings_keep_the_cycle_symmetric_and_positive`, CG
/// iterations to 1e-5, lumped against exact): weights up to 1 %, 2.5 %, 4.8 % of the diagonal
/// 18 / 18, 15 / 14, 14 / 14; 7.6 % 14 / 13, 14 % 15 / 12, 20 % 16 / 11. The world's hinge
/// bending weighs 7e-5 on weft-bench's cloth and 1e-7 on the stiff fabric of
/// `tests/hard_cases.rs`.
const LUMP_LIMIT: f32 = 0.05;
/// The line smoother's damping on the finest level ([`Smoother::Lines`]; the coarse levels and a
/// vertex alone on its line keep [`Options::omega`]): an exact solve along lines over-corrects
/// less than a block-Jacobi sweep, so it is damped less. weft-bench's CG iterations per step at
/// ω = 0.6 / 0.8 / 0.9 / 1.0 (tolerance 1e-3, the first build of the lines): 10.6 / 9.3 / 9.5 /
/// 11.6 at 21×21 (300 steps), 16.9 / 15.3 / 14.4 / 16.1 at 41×41 (100 steps), and with the
/// `ribbed` cell at 41×41 19.4 / 17.7 / 16.3 / 16.7.
const LINE_OMEGA: f32 = 0.9;

/// The growth of the line smoother's power step (`Multigrid::new_probed`) from which the
/// finest level is smoothed by block Jacobi instead: the cycle stops being positive at 2, and
/// the estimate, a power iteration one step per setup, approaches `λ_max` from below, so the
/// limit keeps a margin. On weft-bench's scene the estimate settles at 1.69–1.72 (`stripes`,
/// `ribbed`, 41×41); in adversarial scene 12001 it reaches 35, later 2.3–2.4.
const LINE_LIMIT: f32 = 1.9;

/// Relative pivot below which the coarsest Cholesky treats a direction as decoupled.
const PIVOT: f64 = 1e-9;

/// Budget of all coarse levels together, in vertices: measured coarsening on triangle meshes
/// is ~8–9× per level on the mesh edges (so the coarse levels sum to ~n/8; measured 819 at
/// 81×81 = 6561 vertices); `n/7` leaves some room for irregular meshes. A mesh that coarsens worse gets fewer levels, not an error.
const fn coarse_vertices(vertices: usize) -> usize {
    (vertices / 7).saturating_add(MAX_LEVELS)
}

/// Budget of all coarse levels together, in couplings (measured ~nnz/17 in total: 2304 at
/// 81×81 with 38,400 fine couplings, 9524 at 161×161 with 153,600).
const fn coarse_couplings(couplings: usize) -> usize {
    (couplings / 16).saturating_add(2 * MAX_LEVELS)
}

/// `u32` entries of [`Memory::index`] for a fine level of `vertices` vertices and
/// `couplings` off-diagonal blocks (the strictly-upper pattern entries of the block and the
/// scalar patterns): the header; where each fine coupling lands in level 1's operator (its
/// coarse block, transposed or not, or its aggregate's diagonal block: every solve's Galerkin
/// sum then looks nothing up); the coarse levels' aggregate maps and the coarse patterns. (The
/// finest level's aggregate map, `vertices` entries, is [`Memory::agg`].)
pub const fn index_len(vertices: usize, couplings: usize) -> usize {
    let cv = coarse_vertices(vertices);
    HEADER
        .saturating_add(couplings)
        .saturating_add(cv.saturating_mul(2))
        .saturating_add(MAX_LEVELS)
        .saturating_add(coarse_couplings(couplings))
}

/// `f32` entries of [`Memory::blocks`] per finest-level vertex: its inverse diagonal block (6
/// floats, symmetric), the weight of its lumped scalar couplings ([`Options::lumped`]) and
/// whether its filter block is the identity (a `u32` 0 or 1: the cycle's passes skip the
/// filter's 3×3 product on free vertices, most of them).
const FINE_FLOATS: usize = 8;

/// `f32` entries of [`Memory::blocks`] of the finest level's lines ([`Smoother::Lines`]), after
/// its [`FINE_FLOATS`]: per vertex the line factor's coupling block `C` (a [`Mat3A`], 12
/// floats, from a `Mat3A` boundary), and four `u32`: the vertices in line order, the coupling
/// of each to the next on its line, each vertex's line, and the lines' starts (`+ 1`).
const LINE_FLOATS: usize = 16;

/// `f32` entries of [`Memory::blocks`] the finest level takes (its [`FINE_FLOATS`] and
/// [`LINE_FLOATS`] per vertex, the lines' last start and their count, and the alignment of the
/// line blocks);
/// the coarse levels start after it, on a `Mat3A` boundary.
const fn fine_floats(vertices: usize) -> usize {
    vertices
        .saturating_mul(FINE_FLOATS + LINE_FLOATS)
        .saturating_add(2 + ALIGN_SKIP)
}

/// `f32` entries of [`Memory::blocks`]: the finest level's 24 per vertex (its inverse
/// diagonal block, lumped weight, free-vertex flag; its lines and their factor), and the coarse operators (a
/// symmetric diagonal block and its inverse per coarse vertex; a `Mat3A`, 12 floats, per
/// coarse coupling), and 6 floats of slack for aligning them to `Mat3A`.
/// Rewritten by every [`Multigrid::new`], so a caller may lend memory that is free during the
/// solve (the World lends its block-Jacobi array).
pub const fn blocks_len(vertices: usize, couplings: usize) -> usize {
    fine_floats(vertices)
        .saturating_add(ALIGN_SLACK)
        .saturating_add(
            coarse_vertices(vertices)
                .saturating_mul(12)
                .saturating_add(coarse_couplings(couplings).saturating_mul(COUPLING_FLOATS)),
        )
}

/// `f32` entries of a coarse coupling block: a [`Mat3A`], read with three aligned loads. (Nine
/// packed floats took nine loads and as many shuffles per block in every coarse product: its
/// inner loop was 40 instructions a block, now 33.)
const COUPLING_FLOATS: usize = core::mem::size_of::<Mat3A>() / core::mem::size_of::<f32>();

/// Floats of [`Memory::blocks`] that may go to alignment: up to [`ALIGN_SKIP`] before the
/// pool's first `Mat3A` boundary (the caller's slice need only be `f32`-aligned), and as many
/// after the finest level's floats, where the coarse levels start on a boundary.
const ALIGN_SLACK: usize = 2 * ALIGN_SKIP;

/// Most `f32`s before an `f32`-aligned slice's first `Mat3A` boundary (3).
const ALIGN_SKIP: usize = core::mem::align_of::<Mat3A>() / core::mem::size_of::<f32>() - 1;

/// `u32` entries of [`build`]'s scratch (only used during the build).
pub const fn scratch_len(vertices: usize, couplings: usize) -> usize {
    vertices
        .saturating_mul(4)
        .saturating_add(couplings)
        .saturating_add(2)
}

/// `f64` entries of [`Memory::dense`]: the packed Cholesky factor of a coarsest level of up
/// to [`MAX_DENSE`] vertices (independent of the mesh).
pub const fn dense_len(_vertices: usize, _couplings: usize) -> usize {
    DENSE_LEN
}

/// `Vec3A` entries of [`Memory::vectors`]: residual, correction, scratch and the K-cycle's
/// saved direction per coarse vertex (rewritten by every cycle: may be lent, like `blocks`).
pub const fn vectors_len(vertices: usize, _couplings: usize) -> usize {
    coarse_vertices(vertices).saturating_mul(VECTORS_PER_LEVEL)
}

/// `Vec3A` vectors per coarse vertex: the cycle's residual, correction and scratch, and the
/// K-cycle's first search direction ([`Options::krylov`]).
const VECTORS_PER_LEVEL: usize = 4;

/// Bytes of the four pools together (without alignment padding).
pub const fn bytes(vertices: usize, couplings: usize) -> usize {
    index_len(vertices, couplings)
        .saturating_mul(4)
        .saturating_add(blocks_len(vertices, couplings).saturating_mul(4))
        .saturating_add(dense_len(vertices, couplings).saturating_mul(8))
        .saturating_add(vectors_len(vertices, couplings).saturating_mul(16))
}

/// The caller's memory for one solve: `index` is the hierarchy written by [`build`] (read
/// only); `blocks`, `dense` and `vectors` are rewritten by every [`Multigrid::new`] / cycle,
/// so they need to persist only for the solve. Each slice must hold at least the
/// corresponding `*_len(vertices, couplings)` entries.
pub struct Memory<'a> {
    /// The finest level's aggregate map (`vertices` entries), written by [`build`].
    pub agg: &'a [u32],
    pub index: &'a [u32],
    pub blocks: &'a mut [f32],
    pub dense: &'a mut [f64],
    pub vectors: &'a mut [Vec3A],
}

/// The line smoother's positivity probe ([`Multigrid::new_probed`]): `x`, which the caller
/// keeps from one solve to the next (a power iterate of the smoother, `vertices` entries; any
/// contents at first), and `t`, scratch (`vertices` entries).
pub struct Probe<'p> {
    pub x: &'p mut [Vec3A],
    pub t: &'p mut [Vec3A],
}

/// Errors of [`build`] and [`Multigrid::new`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MgError {
    /// A [`Memory`] slice is shorter than its `*_len`.
    MemoryTooSmall,
    /// The fine pattern is not a valid strictly-upper CSR pattern.
    InvalidPattern,
    /// `index` holds no hierarchy, or one for another pattern size.
    NotBuilt,
    /// The matrix, filter or finest-level blocks do not have the hierarchy's sizes.
    LengthMismatch,
    /// An internal inconsistency (a bug if it happens; never a panic).
    Internal,
}

impl core::fmt::Display for MgError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            MgError::MemoryTooSmall => "a memory slice is shorter than the hierarchy needs",
            MgError::InvalidPattern => "not a valid strictly-upper CSR pattern",
            MgError::NotBuilt => "no hierarchy built for this pattern",
            MgError::LengthMismatch => "matrix, filter or blocks do not match the hierarchy",
            MgError::Internal => "internal consistency check failed",
        })
    }
}

/// The shape of a built hierarchy.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Info {
    /// Levels, the finest included (1 means no coarse level: plain Jacobi smoothing).
    pub levels: usize,
    /// Vertices per level.
    pub vertices: [u32; MAX_LEVELS],
    /// Off-diagonal blocks (strictly-upper pattern entries) per level.
    pub couplings: [u32; MAX_LEVELS],
    /// The coarsest level is solved exactly (dense Cholesky) rather than smoothed.
    pub dense: bool,
}

/// Cycle parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Jacobi damping `ω`.
    pub omega: f32,
    /// Pre- and post-smoothing sweeps per level (`ν`, at least 1).
    pub sweeps: u32,
    /// Jacobi sweeps on a coarsest level too large for the dense solve.
    pub coarse_sweeps: u32,
    /// Scale of the coarse-grid correction (over-correction; `1` is plain Galerkin).
    pub correction: f32,
    /// The smoother of every level.
    pub smoother: Smoother,
    /// Cycle index `γ`: visits of each coarse level per visit of its parent (`1`: V-cycle,
    /// `2`: W-cycle; at least 1). Ignored with [`Options::krylov`].
    pub cycle: u32,
    /// K-cycle (Notay & Vassilevski 2008): each coarse level's correction is two steps of
    /// conjugate gradients on that level, preconditioned by its own cycle, instead of `γ`
    /// stationary visits. It scales each coarse correction optimally, which unsmoothed
    /// aggregation's piecewise-constant corrections need; the preconditioner is then a
    /// (mildly) nonlinear map, see the module docs.
    pub krylov: bool,
    /// With the Jacobi smoother, the finest level's smoothing leaves the matrix's scalar
    /// couplings (`sparse::Scalars`: the World's hinge bending between vertices that share no
    /// edge) out of its residuals and adds their magnitudes to the diagonal instead: it
    /// smooths `Ã = A − H + |H|`, where `H` holds those couplings and `|H|` is the diagonal of
    /// their absolute row sums. `Ã − A = |H| − H` is positive semidefinite (a sum of
    /// `|h| [[1, ∓1], [∓1, 1]]` per coupling), so `Ã` is SPD whenever `A` is and the cycle
    /// stays symmetric and positive; the coarse levels keep the Galerkin operators of `A` and
    /// the outer CG multiplies by `A` itself, so only the preconditioner changes. See the
    /// module docs for what it saves. Ignored by Gauss–Seidel and without scalar couplings.
    pub lumped: bool,
}

/// A level's smoother; both keep the cycle symmetric (the post-smoother is the adjoint of
/// the pre-smoother).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Smoother {
    /// Damped block Jacobi, `z += ω D⁻¹ (r − A z)` (the same before and after).
    Jacobi,
    /// Damped line Jacobi on the finest level, `z += ω_L T⁻¹ (r − Ã z)` (`ω_L` = 0.9): `T`
    /// is the block-tridiagonal part of `Ã` (the matrix with its scalar couplings' weights on
    /// the diagonal, [`Options::lumped`]) along lines of vertices whose couplings dominate
    /// their others, solved exactly (block Thomas), so that a coupling much stronger along one
    /// direction than across it (an anisotropic fabric's stiff direction) is smoothed along it
    /// at once. A vertex on no line keeps block Jacobi, and a matrix with no line at all is
    /// smoothed by block Jacobi itself, bit for bit; the coarse levels smooth with block
    /// Jacobi. The World's `Solver::MultigridLines`.
    Lines,
    /// Block Gauss–Seidel: forward sweeps before the coarse correction, backward sweeps
    /// after (no damping; convergent for any SPD matrix).
    GaussSeidel,
}

impl Options {
    /// The plain V-cycle (damped block Jacobi, `ω = 0.6`, `ν = 1`): a fixed linear SPD
    /// operator, the default before the K-cycle.
    pub const V_CYCLE: Options = Options {
        omega: 0.6,
        sweeps: 1,
        coarse_sweeps: 4,
        correction: 1.0,
        smoother: Smoother::Jacobi,
        cycle: 1,
        krylov: false,
        lumped: true,
    };

    /// Block Gauss–Seidel, `ν = 1`, W-cycle: the fewest CG iterations per solve measured
    /// among the linear cycles (not the fastest step; see [`Options::default`]).
    pub const FEWEST_ITERATIONS: Options = Options {
        smoother: Smoother::GaussSeidel,
        cycle: 2,
        ..Self::V_CYCLE
    };
}

impl Default for Options {
    /// [`Options::V_CYCLE`] with the K-cycle's inner CG on every coarse level: its CG count
    /// does not grow with the mesh (see the module docs). Before the K-cycle, the V-cycle was
    /// chosen by time per step: on
    /// weft-bench's scene (pins, a sphere contact, wind; tolerance 1e-3) block Gauss–Seidel
    /// with a W-cycle ([`Options::FEWEST_ITERATIONS`]) needs fewer CG iterations (15 / 20 / 29
    /// instead of 20 / 28 / 44 at 21 / 41 / 81 per side) but each costs more, and the step
    /// took 1.1–1.3× as long in the same run.
    fn default() -> Self {
        Self {
            krylov: true,
            ..Self::V_CYCLE
        }
    }
}

/// Offsets of one level: `agg` (index pool) maps its vertices to the next level's; `rs`,
/// `cols` (index pool) are its pattern and `blk` (blocks pool) its operator: `6 n` floats of
/// diagonal blocks, `6 n` of their inverses, `9 nnz` of off-diagonal blocks; `vec` (vectors
/// pool) its residual, correction, scratch and the K-cycle's saved direction, `n` each.
/// Level 0 uses only `agg`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Level {
    n: usize,
    nnz: usize,
    agg: usize,
    rs: usize,
    cols: usize,
    blk: usize,
    vec: usize,
}

impl Level {
    /// Floats of its operator in [`Memory::blocks`]: diagonal blocks and their inverses (6
    /// floats each, symmetric) and its coupling blocks ([`COUPLING_FLOATS`] each).
    fn floats(&self) -> usize {
        12 * self.n + COUPLING_FLOATS * self.nnz
    }
    fn to_words(self) -> [u32; LEVEL_WORDS] {
        [
            self.n, self.nnz, self.agg, self.rs, self.cols, self.blk, self.vec,
        ]
        .map(|v| v as u32)
    }
    fn from_words(w: &[u32]) -> Option<Level> {
        let &[n, nnz, agg, rs, cols, blk, vec] = w else {
            return None;
        };
        Some(Level {
            n: n as usize,
            nnz: nnz as usize,
            agg: agg as usize,
            rs: rs as usize,
            cols: cols as usize,
            blk: blk as usize,
            vec: vec as usize,
        })
    }
}

struct Header {
    levels: [Level; MAX_LEVELS],
    count: usize,
    dense: bool,
    /// The finest level's scalar couplings at the build: its coupling map holds the block
    /// pattern's `levels[0].nnz` entries, then these, from [`HEADER`] on.
    scalars: usize,
}

fn read_header(index: &[u32]) -> Option<Header> {
    let head = index.get(..HEADER)?;
    if *head.first()? != MAGIC {
        return None;
    }
    let count = *head.get(1)? as usize;
    if count == 0 || count > MAX_LEVELS {
        return None;
    }
    let dense = *head.get(2)? != 0;
    let scalars = *head.get(3)? as usize;
    let mut levels = [Level::default(); MAX_LEVELS];
    for (l, lv) in levels.iter_mut().enumerate().take(count) {
        let at = 4 + l * LEVEL_WORDS;
        *lv = Level::from_words(head.get(at..at + LEVEL_WORDS)?)?;
    }
    Some(Header {
        levels,
        count,
        dense,
        scalars,
    })
}

fn info_of(levels: &[Level; MAX_LEVELS], count: usize, dense: bool) -> Info {
    let mut info = Info {
        levels: count,
        dense,
        ..Info::default()
    };
    for (l, lv) in levels.iter().enumerate().take(count) {
        if let (Some(v), Some(c)) = (info.vertices.get_mut(l), info.couplings.get_mut(l)) {
            *v = lv.n as u32;
            *c = lv.nnz as u32;
        }
    }
    info
}

/// The shape of the hierarchy in `index`, if one was built there.
pub fn info(index: &[u32]) -> Option<Info> {
    read_header(index).map(|h| info_of(&h.levels, h.count, h.dense))
}

/// Where a fine coupling between aggregates `i` and `j` lands in the coarse operator of
/// pattern `coarse`: [`SAME`] (the diagonal block of `i = j`), the coarse block `(i, j)`, or
/// `(j, i)` flagged [`TRANSPOSED`].
fn coupling_code(coarse: &Pattern<'_>, i: usize, j: usize) -> Result<u32, MgError> {
    let (slot, flag) = match i.cmp(&j) {
        core::cmp::Ordering::Equal => return Ok(SAME),
        core::cmp::Ordering::Less => (coarse.find(i, j), 0),
        core::cmp::Ordering::Greater => (coarse.find(j, i), TRANSPOSED),
    };
    match slot {
        Some(k) if k < TRANSPOSED as usize => Ok(k as u32 | flag),
        _ => Err(MgError::Internal),
    }
}

/// The coupling pattern of coarse level `lv` (strictly upper CSR), at its offsets in `pool`.
fn coarse_pattern<'b>(pool: &'b [u32], lv: &Level) -> Result<Pattern<'b>, MgError> {
    Ok(Pattern {
        row_start: part(pool, lv.rs, lv.n + 1)?,
        cols: part(pool, lv.cols, lv.nnz)?,
    })
}

/// `pool[at..at + len]`.
#[inline]
fn part<T>(pool: &[T], at: usize, len: usize) -> Result<&[T], MgError> {
    pool.get(at..at.checked_add(len).ok_or(MgError::Internal)?)
        .ok_or(MgError::Internal)
}

#[inline]
fn part_mut<T>(pool: &mut [T], at: usize, len: usize) -> Result<&mut [T], MgError> {
    pool.get_mut(at..at.checked_add(len).ok_or(MgError::Internal)?)
        .ok_or(MgError::Internal)
}

mod cycle;
mod hierarchy;
mod lines;

pub use cycle::Multigrid;
pub(crate) use cycle::{factor_packed, solve_packed, tri};
pub use hierarchy::{build, Graph};
