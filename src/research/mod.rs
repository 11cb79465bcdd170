//! Research options, behind the cargo feature `research`: kept to show why the defaults are
//! what they are, never part of the C ABI or the default world's memory.
//!
//! * [`per_node`]: the paper's per-node warping (Eq. 14–17). Measured in this project, it
//!   diverges for cloth hanging in 3D, and its force `−R_i Σ_j K_ij (R_iᵀ x_j − x0_j)` is not
//!   the gradient of any energy; the runtime warps per element instead (`membrane.rs`).
//!
//! The crate denies indexing (src/lib.rs); these research modules keep their index loops
//! (scoped allow below) because they are out of the shipped C ABI and the default world, and
//! exist to document a rejected method, not to run in a game.
#![allow(clippy::indexing_slicing)]

pub mod per_node;
pub mod rotation;
