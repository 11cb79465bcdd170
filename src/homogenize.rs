//! The periodic cell problem (§4): characteristic displacements `chi` (Eq. 10) and the
//! homogenized membrane stiffness `C^H` (Eq. 12–13), with the Voigt and Reuss bounds.
//!
//! For each unit macro strain `E^k` (`[1,0,0]`, `[0,1,0]`, `[0,0,1]`, engineering shear) the
//! periodic `chi^k` solves (Eq. 10, docs/CONVENTIONS.md)
//!
//! ```text
//! Σ_e A_e B_eᵀ C_e B_e chi^k = Σ_e A_e B_eᵀ C_e E^k        (K chi^k = f^k)
//! ```
//!
//! which is the stationarity condition of the cell energy `½ Σ_e A_e (E^k - B_e chi)ᵀ C_e
//! (E^k - B_e chi)` over periodic `chi`. Periodicity is built into the mesh (the right and top
//! nodes *are* the left and bottom ones, [`crate::cell::mesh_cell`]); each element is
//! evaluated on its unwrapped corners so its shape is right where its node indices wrap.
//! Then (Eq. 13)
//!
//! ```text
//! C^H[:, k] = 1/|Y| Σ_e A_e C_e (E^k - B_e chi^k).
//! ```

// Index loops over 3×3 tensors and 2-vectors read like the formulas they implement.
#![allow(clippy::needless_range_loop)]
// The crate denies indexing (src/lib.rs). This module is the offline cell solve only (feature
// `std`, never in the shipped no_std library): its ~70 index expressions are the assembly and
// post-processing formulas of Eq. 10–13 over a mesh it builds itself (`cell::mesh`), and are
// kept as indices so they read like the equations. A bad index here is a bug in the offline
// tool, reported by its panic, not an abort inside a game.
#![allow(clippy::indexing_slicing)]

use std::fmt;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::cell::{CellDesc, Material, MicroMesh};
use crate::membrane;
use crate::Voigt;

/// The homogenized cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Homogenized {
    /// `C^H` (Eq. 13), N/m, symmetric positive definite.
    pub stiffness: Voigt,
    /// Per mesh node, per unit strain `k = 0..3`: the characteristic displacement `chi^k`
    /// `(u, v)` in metres per unit strain, periodic, with zero nodal mean (which on the uniform
    /// periodic pixel grid is also the zero area mean: every node carries the same area `h²`).
    /// The micro displacement under a macro strain `Ê` is `-Σ_k chi^k Ê_k` (docs/CONVENTIONS.md).
    pub chi: Vec<[[f64; 2]; 3]>,
    /// Upper (Voigt) bound: area mean of `C`.
    pub voigt_bound: Voigt,
    /// Lower (Reuss) bound: inverse of the area mean of `C⁻¹`.
    pub reuss_bound: Voigt,
    /// Area-averaged areal density, kg/m² (exact: mass is additive).
    pub density: f64,
    /// Area-averaged bending stiffness, N·m. An approximation: the cell problem here is
    /// in-plane only (§4), and the true effective bending stiffness of a heterogeneous plate
    /// lies between the harmonic and arithmetic means depending on the layout; the
    /// arithmetic mean overestimates it for patterns with soft hinges across the bending axis.
    pub bending: f64,
}

/// Why a cell could not be homogenized.
#[derive(Clone, Debug, PartialEq)]
pub enum HomogenizeError {
    /// The mesh is a non-periodic sheet ([`crate::cell::mesh_sheet`]); the cell problem needs
    /// the periodic cell mesh.
    NotPeriodic,
    /// The mesh has no nodes or no triangles.
    EmptyMesh,
    /// The mesh's arrays disagree with each other or with the description (lengths, node
    /// indices, total area).
    InconsistentMesh(String),
    /// A triangle names a material the description does not have.
    MaterialIndex { triangle: usize, material: u32 },
    /// A material whose `C` is not symmetric positive definite, or whose density or bending
    /// is not finite and non-negative (descriptions built in code skip the file checks).
    InvalidMaterial { key: String },
    /// A zero-area or non-finite triangle.
    DegenerateTriangle { triangle: usize },
    /// Memory for the sparse factorization could not be had.
    OutOfMemory,
    /// The sparse Cholesky factorization failed: the periodic stiffness with one node fixed
    /// was not numerically positive definite (extreme contrast, or a broken mesh).
    Factorization(String),
    /// `C^H` came out asymmetric beyond solver round-off (relative asymmetry given).
    Asymmetric { relative: f64 },
    /// NaN or infinity in the result.
    NonFinite,
}

impl fmt::Display for HomogenizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotPeriodic => write!(f, "the cell problem needs a periodic cell mesh"),
            Self::EmptyMesh => write!(f, "the cell mesh is empty"),
            Self::InconsistentMesh(what) => write!(f, "inconsistent cell mesh: {what}"),
            Self::MaterialIndex { triangle, material } => write!(
                f,
                "triangle {triangle} has material index {material}, which the cell does not have"
            ),
            Self::InvalidMaterial { key } => write!(
                f,
                "material {key:?}: stiffness not symmetric positive definite, or bad density or bending"
            ),
            Self::DegenerateTriangle { triangle } => {
                write!(f, "triangle {triangle} is degenerate")
            }
            Self::OutOfMemory => write!(f, "out of memory in the sparse factorization"),
            Self::Factorization(e) => write!(
                f,
                "the periodic cell stiffness is not numerically positive definite: {e}"
            ),
            Self::Asymmetric { relative } => write!(
                f,
                "the homogenized stiffness is asymmetric (relative {relative:.3e}): solver failure"
            ),
            Self::NonFinite => write!(f, "the homogenized result is not finite"),
        }
    }
}

impl std::error::Error for HomogenizeError {}

/// Relative asymmetry of `C^H` accepted as solver round-off for a cell of moderate contrast.
/// `C^H` is symmetric for the exact discrete solution (`C^H_jk = 1/|Y| Σ A (E^j - B chi^j)ᵀ C
/// (E^k - B chi^k)` once `K chi = f` holds), so anything larger means the solve went wrong.
/// Round-off grows with the conditioning of `K`, i.e. with the stiffness contrast of the cell's
/// materials, so [`symmetry_tolerance`] adds `1e-15 × contrast` (measured: 3.8e-10 at 1:10⁸).
pub const SYMMETRY_TOLERANCE: f64 = 1e-10;

/// The accepted relative asymmetry of `C^H` for materials of stiffness contrast `contrast`
/// (largest over smallest of the materials' largest tensor entries).
pub fn symmetry_tolerance(contrast: f64) -> f64 {
    SYMMETRY_TOLERANCE + 1e-15 * contrast.max(1.0)
}

/// The unit strains `E^k` (engineering shear).
const UNIT_STRAINS: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

fn material_ok(m: &Material) -> bool {
    membrane::is_spd(&m.c)
        && m.density.is_finite()
        && m.density >= 0.0
        && m.bending.is_finite()
        && m.bending >= 0.0
}

/// Upper-triangular CSC pattern of the periodic stiffness with node 0's dofs removed.
/// Node `n ≥ 1` owns dofs `2(n-1)` (u) and `2(n-1)+1` (v).
struct Pattern {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// The same at node level (node `n ≥ 1` is index `n-1`), for the fill-reducing ordering.
    node_col_ptr: Vec<usize>,
    node_row_idx: Vec<usize>,
}

impl Pattern {
    /// Position of entry `(row, col)`, `row ≤ col`, in the value array.
    #[inline]
    fn find(&self, row: usize, col: usize) -> Option<usize> {
        let (a, b) = (self.col_ptr[col], self.col_ptr[col + 1]);
        self.row_idx[a..b].binary_search(&row).ok().map(|p| a + p)
    }
}

/// Builds the pattern from node adjacency (two nodes couple when they share a triangle).
fn pattern(n_nodes: usize, triangles: &[[u32; 3]]) -> Pattern {
    // Node adjacency in CSR, 3 entries per (triangle, corner), then sorted and deduplicated.
    let mut count = vec![0usize; n_nodes + 1];
    for t in triangles {
        for &a in t {
            count[a as usize + 1] += 3;
        }
    }
    for n in 0..n_nodes {
        count[n + 1] += count[n];
    }
    let mut fill = count.clone();
    let mut adj = vec![0u32; count[n_nodes]];
    for t in triangles {
        for &a in t {
            for &b in t {
                adj[fill[a as usize]] = b;
                fill[a as usize] += 1;
            }
        }
    }
    let ndof = 2 * (n_nodes - 1);
    let mut col_ptr = Vec::with_capacity(ndof + 1);
    let mut row_idx = Vec::with_capacity(7 * 2 * ndof);
    let mut node_col_ptr = Vec::with_capacity(n_nodes);
    let mut node_row_idx = Vec::with_capacity(4 * n_nodes);
    col_ptr.push(0);
    node_col_ptr.push(0);
    for n in 1..n_nodes {
        let list = &mut adj[count[n]..count[n + 1]];
        list.sort_unstable();
        let mut last = u32::MAX;
        for &m in list.iter() {
            if m != last && m != 0 && m as usize <= n {
                node_row_idx.push(m as usize - 1);
            }
            last = m;
        }
        node_col_ptr.push(node_row_idx.len());
        for r in 0..2 {
            let col = 2 * (n - 1) + r;
            let mut last = u32::MAX;
            for &m in list.iter() {
                if m == last || m == 0 || m as usize > n {
                    continue;
                }
                last = m;
                for s in 0..2 {
                    let row = 2 * (m as usize - 1) + s;
                    if row <= col {
                        row_idx.push(row);
                    }
                }
            }
            col_ptr.push(row_idx.len());
        }
    }
    Pattern {
        col_ptr,
        row_idx,
        node_col_ptr,
        node_row_idx,
    }
}

/// Fill-reducing ordering of the dofs: AMD on the node graph, each node's two dofs kept
/// together. Ordering the node graph is 4× smaller than the dof graph, and the 2×2 blocks
/// stay contiguous, which gives the supernodal factorization wider supernodes.
/// Returns (forward, inverse) dof permutations.
fn node_block_ordering(pat: &Pattern) -> Result<(Vec<usize>, Vec<usize>), HomogenizeError> {
    let n = pat.node_col_ptr.len() - 1;
    let sym =
        SymbolicSparseColMatRef::new_checked(n, n, &pat.node_col_ptr, None, &pat.node_row_idx);
    let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
    let mut buffer = MemBuffer::try_new(amd::order_scratch::<usize>(n, pat.node_row_idx.len()))
        .map_err(|_| HomogenizeError::OutOfMemory)?;
    amd::order(
        &mut fwd,
        &mut inv,
        sym,
        amd::Control::default(),
        MemStack::new(&mut buffer),
    )
    .map_err(|e| HomogenizeError::Factorization(format!("{e:?}")))?;
    let expand = |p: &[usize]| {
        p.iter()
            .flat_map(|&q| [2 * q, 2 * q + 1])
            .collect::<Vec<_>>()
    };
    Ok((expand(&fwd), expand(&inv)))
}

/// Solves the periodic cell problem of `desc` on `mesh` (from [`crate::cell::mesh_cell`]).
///
/// `progress` is called with the fraction done (0 to 1): 0 at the start, 0.25 after assembly,
/// 0.35 after the ordering, 0.8 after the factorization, 0.9 after the solves, 1 at the end.
/// The linear solver is faer's sparse Cholesky (AMD on the node graph), single-threaded,
/// factored once for the three unit-strain right-hand sides.
pub fn homogenize(
    desc: &CellDesc,
    mesh: &MicroMesh,
    progress: &mut dyn FnMut(f64),
) -> Result<Homogenized, HomogenizeError> {
    progress(0.0);
    if !mesh.periodic {
        return Err(HomogenizeError::NotPeriodic);
    }
    let n_nodes = mesh.nodes.len();
    let n_tris = mesh.triangles.len();
    if n_nodes == 0 || n_tris == 0 {
        return Err(HomogenizeError::EmptyMesh);
    }
    // A periodic pixel mesh has nu·nv nodes and 2·nu·nv triangles; a sheet relabelled as
    // periodic would not, and its pinned stiffness would keep the rotation mode.
    if n_nodes != mesh.nu * mesh.nv || n_tris != 2 * n_nodes {
        return Err(HomogenizeError::InconsistentMesh(format!(
            "{n_nodes} nodes and {n_tris} triangles for a periodic {}×{} grid",
            mesh.nu, mesh.nv
        )));
    }
    if mesh.tri_material.len() != n_tris || mesh.tri_corners.len() != n_tris {
        return Err(HomogenizeError::InconsistentMesh(format!(
            "{n_tris} triangles, {} materials, {} corner triples",
            mesh.tri_material.len(),
            mesh.tri_corners.len()
        )));
    }
    if let Some(t) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&a| a as usize >= n_nodes))
    {
        return Err(HomogenizeError::InconsistentMesh(format!(
            "triangle {t} names a node beyond {n_nodes}"
        )));
    }
    for (triangle, &material) in mesh.tri_material.iter().enumerate() {
        if material as usize >= desc.materials.len() {
            return Err(HomogenizeError::MaterialIndex { triangle, material });
        }
    }
    let mut compliance = Vec::with_capacity(desc.materials.len());
    for m in &desc.materials {
        match membrane::inverse3(&m.c) {
            Some(s) if material_ok(m) => compliance.push(s),
            _ => return Err(HomogenizeError::InvalidMaterial { key: m.key.clone() }),
        }
    }

    // Element geometry and the area means (bounds, density, bending). Every triangle of a
    // pixel mesh has the same area, but the sums are weighted anyway so any periodic mesh works.
    let mut grads = Vec::with_capacity(n_tris);
    let mut area = 0.0;
    let (mut mean_c, mut mean_s) = ([[0.0; 3]; 3], [[0.0; 3]; 3]);
    let (mut density, mut bending) = (0.0, 0.0);
    for (t, corners) in mesh.tri_corners.iter().enumerate() {
        let g = membrane::gradients(*corners)
            .ok_or(HomogenizeError::DegenerateTriangle { triangle: t })?;
        let mi = mesh.tri_material[t] as usize;
        let m = &desc.materials[mi];
        area += g.area;
        for i in 0..3 {
            for j in 0..3 {
                mean_c[i][j] += g.area * m.c[i][j];
                mean_s[i][j] += g.area * compliance[mi][i][j];
            }
        }
        density += g.area * m.density;
        bending += g.area * m.bending;
        grads.push(g);
    }
    // The triangles must tile the cell exactly once: a mesh from another description (or a
    // sheet with `periodic` set by hand) would homogenize the wrong domain.
    let cell_area = desc.width() * desc.height();
    let covers = (area - cell_area).abs() <= 1e-9 * cell_area; // false for NaN
    if !covers {
        return Err(HomogenizeError::InconsistentMesh(format!(
            "triangles cover {area:e} m², the cell is {cell_area:e} m²"
        )));
    }
    for i in 0..3 {
        for j in 0..3 {
            mean_c[i][j] /= area;
            mean_s[i][j] /= area;
        }
    }
    let reuss = membrane::inverse3(&mean_s).ok_or(HomogenizeError::NonFinite)?;

    // Assembly of K and f^k (Eq. 10) with node 0 removed. K is singular on periodic fields
    // only by the two translations; pinning one node removes them, and the zero-mean
    // normalization afterwards makes chi unique.
    let ndof = 2 * (n_nodes - 1);
    let mut x = vec![0.0f64; 3 * ndof]; // right-hand sides, then solutions, column-major
    let dof = |n: u32, r: usize| 2 * (n as usize - 1) + r;
    if ndof > 0 {
        let pat = pattern(n_nodes, &mesh.triangles);
        let mut values = vec![0.0f64; pat.row_idx.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let g = &grads[t];
            let c = &desc.materials[mesh.tri_material[t] as usize].c;
            let ke = membrane::element_stiffness(g, c);
            // A node appearing twice in a triangle (a 1-square-wide cell) is handled by the
            // plain sum: the upper part of a sum is the sum of upper parts.
            for a in 0..3 {
                if tri[a] == 0 {
                    continue;
                }
                for b in 0..3 {
                    if tri[b] == 0 {
                        continue;
                    }
                    for r in 0..2 {
                        for s in 0..2 {
                            let (row, col) = (dof(tri[a], r), dof(tri[b], s));
                            if row <= col {
                                let p = pat.find(row, col).ok_or_else(|| {
                                    HomogenizeError::InconsistentMesh(
                                        "stiffness pattern".to_string(),
                                    )
                                })?;
                                values[p] += ke[a][b][r][s];
                            }
                        }
                    }
                }
            }
            for (k, e) in UNIT_STRAINS.iter().enumerate() {
                let f = membrane::stress_forces(g, membrane::stress(c, *e));
                for a in 0..3 {
                    if tri[a] != 0 {
                        for r in 0..2 {
                            x[k * ndof + dof(tri[a], r)] += f[a][r];
                        }
                    }
                }
            }
        }
        progress(0.25);

        let sym =
            SymbolicSparseColMatRef::new_checked(ndof, ndof, &pat.col_ptr, None, &pat.row_idx);
        let kmat = SparseColMatRef::new(sym, &values);
        let (fwd, inv) = node_block_ordering(&pat)?;
        let perm = PermRef::new_checked(&fwd, &inv, ndof);
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            SymmetricOrdering::Custom(perm),
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| HomogenizeError::Factorization(format!("{e:?}")))?;
        progress(0.35);
        let par = Par::Seq;
        let mut l_values = Vec::new();
        l_values
            .try_reserve_exact(symbolic.len_val())
            .map_err(|_| HomogenizeError::OutOfMemory)?;
        l_values.resize(symbolic.len_val(), 0.0f64);
        let scratch = symbolic
            .factorize_numeric_llt_scratch::<f64>(par, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(3, par));
        let mut buffer = MemBuffer::try_new(scratch).map_err(|_| HomogenizeError::OutOfMemory)?;
        let llt = symbolic
            .factorize_numeric_llt::<f64>(
                &mut l_values,
                kmat,
                Side::Upper,
                LltRegularization::default(),
                par,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| HomogenizeError::Factorization(e.to_string()))?;
        progress(0.8);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut x, ndof, 3),
            par,
            MemStack::new(&mut buffer),
        );
        progress(0.9);
    }

    // chi per node (node 0 pinned at zero), then shifted to zero nodal mean.
    let mut chi = vec![[[0.0f64; 2]; 3]; n_nodes];
    for (n, c) in chi.iter_mut().enumerate().skip(1) {
        for (k, ck) in c.iter_mut().enumerate() {
            for (r, v) in ck.iter_mut().enumerate() {
                *v = x[k * ndof + dof(n as u32, r)];
            }
        }
    }
    for k in 0..3 {
        for r in 0..2 {
            let mean = chi.iter().map(|c| c[k][r]).sum::<f64>() / n_nodes as f64;
            for c in chi.iter_mut() {
                c[k][r] -= mean;
            }
        }
    }

    // Eq. 13: C^H[:, k] = 1/|Y| Σ_e A_e C_e (E^k - B_e chi^k).
    let mut ch = [[0.0f64; 3]; 3];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let g = &grads[t];
        let c = &desc.materials[mesh.tri_material[t] as usize].c;
        for (k, e) in UNIT_STRAINS.iter().enumerate() {
            let d = [0, 1, 2].map(|a| chi[tri[a] as usize][k]);
            let b_chi = membrane::strain(g, d);
            let s = membrane::stress(c, [e[0] - b_chi[0], e[1] - b_chi[1], e[2] - b_chi[2]]);
            for i in 0..3 {
                ch[i][k] += g.area * s[i];
            }
        }
    }
    for row in ch.iter_mut() {
        for v in row.iter_mut() {
            *v /= area;
        }
    }
    if ch.iter().flatten().any(|v| !v.is_finite())
        || chi.iter().flatten().flatten().any(|v| !v.is_finite())
    {
        return Err(HomogenizeError::NonFinite);
    }
    let scale = ch.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut asym = 0.0f64;
    for i in 0..3 {
        for j in 0..i {
            asym = asym.max((ch[i][j] - ch[j][i]).abs());
        }
    }
    let relative = asym / scale;
    let sizes = desc
        .materials
        .iter()
        .map(|m| m.c.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs())));
    let (hi, lo) = sizes.fold((0.0f64, f64::INFINITY), |(h, l), v| (h.max(v), l.min(v)));
    let symmetric = relative <= symmetry_tolerance(hi / lo); // false for NaN
    if !symmetric {
        return Err(HomogenizeError::Asymmetric { relative });
    }
    for i in 0..3 {
        for j in 0..i {
            let s = 0.5 * (ch[i][j] + ch[j][i]);
            ch[i][j] = s;
            ch[j][i] = s;
        }
    }
    progress(1.0);
    Ok(Homogenized {
        stiffness: ch,
        chi,
        voigt_bound: mean_c,
        reuss_bound: reuss,
        density: density / area,
        bending: bending / area,
    })
}

/// Direction of the layer normal of a laminate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayerNormal {
    /// Layers stacked along u: vertical stripes, pattern columns alternate.
    U,
    /// Layers stacked along v: horizontal stripes, pattern rows alternate.
    V,
}

/// Closed-form `C^H` of a laminate: layers `(fraction, C)` (fractions are normalized by their
/// sum) stacked along the normal `n`.
///
/// Derivation. In a laminate of homogeneous layers the cell solution has uniform strain `e` and
/// stress `s` in each layer (a piecewise-affine displacement). Write `t` for the in-plane
/// direction along the layers. Across an interface (a line along `t`):
/// * the displacement is continuous, so its derivative along `t` is: the tangential strain
///   `e_tt` is the same in every layer, hence equal to its mean, the macro `E_tt`;
/// * equilibrium makes the traction `s·n` continuous: `s_nn` and `s_nt` are the same in every
///   layer, hence equal to the macro `S_nn`, `S_nt` (the macro stress is the mean stress, Eq. 12).
///
/// The other three, `s_tt`, `e_nn`, `γ_nt`, vary from layer to layer. Split the Voigt indices
/// into `a = {tt}` (strain-continuous) and `b = {nn, nt}` (stress-continuous). From
/// `s_a = C_aa e_a + C_ab e_b`, `s_b = C_ba e_a + C_bb e_b`, eliminate `e_b`:
///
/// ```text
/// [ s_a ]       [ e_a ]        M = [ C_aa - C_ab C_bb⁻¹ C_ba    C_ab C_bb⁻¹ ]
/// [ e_b ]  =  M [ s_b ],           [ -C_bb⁻¹ C_ba               C_bb⁻¹      ]
/// ```
///
/// (the principal pivot transform of `C` on `b`). The right-hand side is the same in all
/// layers, so averaging gives `[S_a; E_b] = <M> [E_a; S_b]` with `<·>` the
/// fraction-weighted mean, and `C^H` is the pivot transform of `<M>` back on `b` (the
/// transform is an involution: applying the same formula to `M` returns `C`).
///
/// Normal `v` (horizontal stripes): `a = {11}`, `b = {22, 12}`. Normal `u` (vertical
/// stripes): `a = {22}`, `b = {11, 12}`. For isotropic layers with a common Poisson ratio `ν`
/// and normal `v` this reduces to the textbook rules (`Y` the membrane stiffness,
/// `c = Y/(1-ν²)`, `G = Y/(2(1+ν))`, `H(x) = <1/x>⁻¹` the harmonic mean):
/// `C^H_22 = H(c)`, `C^H_33 = H(G)`, `C^H_12 = ν H(c)`, `C^H_11 = <Y> + ν² H(c)`, rest 0 —
/// stiffness along the layers by the rule of mixtures, across and in shear by the inverse rule.
///
/// Returns `None` if a block `C_bb` or `<M>_bb` is singular, or no layers or a non-positive
/// total fraction are given.
pub fn laminate(layers: &[(f64, Voigt)], normal: LayerNormal) -> Option<Voigt> {
    let (a, b) = match normal {
        LayerNormal::V => (0usize, [1usize, 2]),
        LayerNormal::U => (1usize, [0usize, 2]),
    };
    let total: f64 = layers.iter().map(|l| l.0).sum();
    let positive = total > 0.0; // false for NaN
    if layers.is_empty() || !positive {
        return None;
    }
    let mut mean = [[0.0; 3]; 3];
    for (w, c) in layers {
        let m = pivot(c, a, b)?;
        for i in 0..3 {
            for j in 0..3 {
                mean[i][j] += w / total * m[i][j];
            }
        }
    }
    pivot(&mean, a, b)
}

/// Principal pivot transform of `c` on the index pair `b` (`a` the remaining index), in place
/// of the original index positions.
fn pivot(c: &Voigt, a: usize, b: [usize; 2]) -> Option<Voigt> {
    let bb = [
        [c[b[0]][b[0]], c[b[0]][b[1]]],
        [c[b[1]][b[0]], c[b[1]][b[1]]],
    ];
    let det = bb[0][0] * bb[1][1] - bb[0][1] * bb[1][0];
    if !det.is_finite() || det == 0.0 {
        return None;
    }
    let inv = [
        [bb[1][1] / det, -bb[0][1] / det],
        [-bb[1][0] / det, bb[0][0] / det],
    ];
    let ab = [c[a][b[0]], c[a][b[1]]];
    let ba = [c[b[0]][a], c[b[1]][a]];
    let mut m = [[0.0; 3]; 3];
    // C_ab C_bb⁻¹ (row) and C_bb⁻¹ C_ba (column)
    let ab_inv = [
        ab[0] * inv[0][0] + ab[1] * inv[1][0],
        ab[0] * inv[0][1] + ab[1] * inv[1][1],
    ];
    let inv_ba = [
        inv[0][0] * ba[0] + inv[0][1] * ba[1],
        inv[1][0] * ba[0] + inv[1][1] * ba[1],
    ];
    m[a][a] = c[a][a] - (ab_inv[0] * ba[0] + ab_inv[1] * ba[1]);
    for p in 0..2 {
        m[a][b[p]] = ab_inv[p];
        m[b[p]][a] = -inv_ba[p];
        for q in 0..2 {
            m[b[p]][b[q]] = inv[p][q];
        }
    }
    Some(m)
}

/// A deterministic `n × n` three-material cell for benchmarks: an isotropic soft matrix, an
/// isotropic stiff yarn, and an anisotropic coating, laid out by a small LCG (no `rand`).
pub fn bench_cell(n: usize) -> CellDesc {
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut pixels = Vec::with_capacity(n * n);
    for _ in 0..n * n {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        pixels.push(((state >> 33) % 3) as u32);
    }
    let material = |key: &str, c: Voigt, density: f64| Material {
        key: key.to_string(),
        c,
        density,
        bending: crate::cell::DEFAULT_BENDING,
    };
    CellDesc {
        name: format!("bench{n}"),
        size: 0.01,
        cols: n,
        rows: n,
        pixels,
        materials: vec![
            material("a", membrane::isotropic(100.0, 0.3), 0.1),
            material("b", membrane::isotropic(2000.0, 0.2), 0.3),
            material(
                "c",
                [
                    [600.0, 80.0, 30.0],
                    [80.0, 200.0, -20.0],
                    [30.0, -20.0, 70.0],
                ],
                0.2,
            ),
        ],
    }
}

/// Why building a blob from cell files failed; names the file.
#[derive(Debug)]
pub enum BuildError {
    Cell(crate::cell::CellError),
    Homogenize {
        file: String,
        error: HomogenizeError,
    },
    Blob(crate::blob::BlobError),
    NoCells,
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::Cell(e) => write!(f, "{e}"),
            BuildError::Homogenize { file, error } => {
                write!(f, "{file}: homogenization failed: {error}")
            }
            BuildError::Blob(e) => write!(f, "the blob would be invalid: {e}"),
            BuildError::NoCells => write!(f, "no cell files given"),
        }
    }
}

impl std::error::Error for BuildError {}

/// The blob record of a homogenized cell: the runtime's arrays in f32, the tensors in f64.
pub fn record(
    desc: &CellDesc,
    mesh: &MicroMesh,
    refine: usize,
    h: &Homogenized,
) -> crate::blob::CellRecord {
    crate::blob::CellRecord {
        name: desc.name.clone(),
        size: desc.size,
        cols: desc.cols as u32,
        rows: desc.rows as u32,
        refine: refine.max(1) as u32,
        stiffness: h.stiffness,
        density: h.density,
        bending: h.bending,
        voigt_bound: h.voigt_bound,
        reuss_bound: h.reuss_bound,
        materials: desc
            .materials
            .iter()
            .map(|m| crate::blob::MaterialRecord {
                c: m.c,
                density: m.density,
                bending: m.bending,
            })
            .collect(),
        nodes: mesh
            .nodes
            .iter()
            .map(|p| [p[0] as f32, p[1] as f32])
            .collect(),
        triangles: mesh.triangles.clone(),
        tri_material: mesh.tri_material.clone(),
        chi: h
            .chi
            .iter()
            .map(|c| [c[0][0], c[0][1], c[1][0], c[1][1], c[2][0], c[2][1]].map(|v| v as f32))
            .collect(),
    }
}

/// Reads each cell file, homogenizes it at `refine`, and writes one blob holding them all in
/// order (a cell's index is its position in `paths`). `progress(cell, fraction)` reports.
pub fn build_blob(
    paths: &[std::path::PathBuf],
    refine: usize,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<Vec<u8>, BuildError> {
    if paths.is_empty() {
        return Err(BuildError::NoCells);
    }
    let mut records = Vec::with_capacity(paths.len());
    for (i, path) in paths.iter().enumerate() {
        let desc = crate::cell::load(path).map_err(BuildError::Cell)?;
        let mesh = crate::cell::mesh_cell(&desc, refine);
        let h = homogenize(&desc, &mesh, &mut |f| progress(i, f)).map_err(|error| {
            BuildError::Homogenize {
                file: path.display().to_string(),
                error,
            }
        })?;
        records.push(record(&desc, &mesh, refine, &h));
    }
    crate::blob::write(&records).map_err(BuildError::Blob)
}
