//! Research options, behind the cargo feature `research`: kept to show why the defaults are
//! what they are, never part of the C ABI or the default world's memory.
//!
//! * [`per_node`]: the paper's per-node warping (Eq. 14–17). Measured in this project, it
//!   diverges for cloth hanging in 3D, and its force `−R_i Σ_j K_ij (R_iᵀ x_j − x0_j)` is not
//!   the gradient of any energy; the runtime warps per element instead (`membrane.rs`).
pub mod per_node;
pub mod rotation;
