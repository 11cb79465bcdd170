//! Building a [`World`]: [`World::new`] and [`World::new_strided`] check the input against the
//! capacity and carve the arrays out of the caller's block; `build` then validates the mesh and
//! the materials, places the vertices, builds the topology (edges, hinges, one-rings) and the
//! block pattern, the elements, lumped masses and their places in the pattern, the hinges'
//! bending Hessians and the multigrid hierarchy. Either the whole world is built or an error is
//! returned.

use glam::{Mat3A, Vec3A};

use super::{copy_live, Solver, StridedClothDef, TriangleMaterials, World};
use super::{memory, origin, Capacity, ClothDef, InitError, Materials, Settings, StepStats};
use crate::bending;
use crate::membrane::{self, Element};
use crate::mesh::{self, MeshError, Topology};
use crate::multigrid;
use crate::sparse::{self, Pattern};

/// The live prefix `..n` of one of the world's capacity-long arrays, at init. The counts never
/// exceed the capacity (checked first thing in [`World::new_strided`]), so the error cannot
/// happen; it stands in for the index that is not made.
fn live<T>(array: &[T], n: usize) -> Result<&[T], InitError> {
    array.get(..n).ok_or(InitError::Internal)
}

/// [`live`] for an array init writes.
fn live_mut<T>(array: &mut [T], n: usize) -> Result<&mut [T], InitError> {
    array.get_mut(..n).ok_or(InitError::Internal)
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
        Self::new_strided(memory, capacity, &cloth.strided(), materials, settings)
    }

    /// [`World::new`] reading the cloth in place from strided buffers.
    pub fn new_strided(
        memory: &'a mut [u8],
        capacity: Capacity,
        cloth: &StridedClothDef<'_>,
        materials: Materials<'_>,
        settings: Settings,
    ) -> Result<World<'a>, InitError> {
        settings.validate()?;
        let (n, nt) = (cloth.positions.count(), cloth.triangles.len());
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
        if cloth.uvs.count() != n {
            return Err(InitError::Mesh(MeshError::BufferTooSmall));
        }
        if let TriangleMaterials::PerTriangle(m) = cloth.materials {
            if m.len() != nt {
                return Err(InitError::MaterialCount);
            }
        }
        if memory.len() < capacity.world_bytes() {
            return Err(InitError::MemoryTooSmall);
        }
        let mut carver = memory::Carver {
            rest: memory,
            needed: 0,
        };
        let a = memory::carve(&capacity, &mut carver)?;
        let mut w = World {
            a,
            capacity,
            settings,
            n,
            nt,
            ne: 0,
            nh: 0,
            nnz: 0,
            nnz_h: 0,
            pins: 0,
            colliders: 0,
            next_collider_id: 0,
            total_mass: 0.0,
            calm_frames: 0,
            level: None,
            drift: None,
            last_input: (0.0, 0.0),
            asleep: false,
            last: StepStats::default(),
            solver: Solver::default(),
            origin: origin::origin_for(&cloth.positions),
        };
        w.build(cloth, materials)?;
        Ok(w)
    }

    fn build(
        &mut self,
        cloth: &StridedClothDef<'_>,
        materials: Materials<'_>,
    ) -> Result<(), InitError> {
        let (n, nt, origin) = (self.n, self.nt, self.origin);
        let a = &mut self.a;
        mesh::validate_strided(
            &cloth.positions,
            &cloth.uvs,
            cloth.triangles,
            live_mut(a.tri_sign, nt)?,
        )?;
        // Materials: every triangle's must exist and be usable.
        for t in 0..nt {
            let m = cloth.materials.get(t).ok_or(InitError::MaterialCount)?;
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
        // (`nt` is `cloth.triangles.len()`)
        live_mut(a.triangles, nt)?.copy_from_slice(cloth.triangles);
        for (t, m) in live_mut(a.tri_material, nt)?.iter_mut().enumerate() {
            *m = cloth.materials.get(t).ok_or(InitError::MaterialCount)?;
        }
        let placed = live_mut(a.x, n)?.iter_mut().zip(live_mut(a.rest, n)?);
        for (i, (x, rest)) in placed.enumerate() {
            let p = cloth.positions.get(i).ok_or(InitError::Internal)?;
            let uv = cloth.uvs.get(i).ok_or(InitError::Internal)?;
            *x = origin::to_local(origin, p);
            *rest = Vec3A::new(uv[0], uv[1], 0.0);
        }
        // Edges, hinges and the hinge couplings are needed only here, before the stiffness
        // blocks are first assembled: they borrow the blocks' bytes (E blocks of 48 bytes hold
        // E edges, E edge-triangle pairs, E hinges and E hinge couplings).
        let e_cap = self.capacity.e();
        let scratch: &mut [u8] = bytemuck::cast_slice_mut(&mut *a.k_off);
        let (edges, scratch) = scratch.split_at_mut(8 * e_cap);
        let (edge_tris, scratch) = scratch.split_at_mut(8 * e_cap);
        let (hinges, scratch) = scratch.split_at_mut(16 * e_cap);
        let (couplings, _) = scratch.split_at_mut(8 * e_cap);
        let edges: &mut [[u32; 2]] = bytemuck::cast_slice_mut(edges);
        let edge_tris: &mut [[u32; 2]] = bytemuck::cast_slice_mut(edge_tris);
        let hinges: &mut [[u32; 4]] = bytemuck::cast_slice_mut(hinges);
        let couplings: &mut [[u32; 2]] = bytemuck::cast_slice_mut(couplings);
        let counts = mesh::build(
            n,
            live(a.triangles, nt)?,
            live(a.tri_sign, nt)?,
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
        let hinges = live(hinges, self.nh)?;
        let capacity_error = |_| InitError::EdgeCapacity {
            capacity: self.capacity.edges,
        };
        // Two patterns: the edges carry 3×3 blocks (membrane and bending), the pairs opposite
        // a hinge that share no edge only bending's scalar (`mesh::couplings`).
        self.nnz = sparse::build_pattern(n, live(edges, self.ne)?, a.row_start, a.cols)
            .map_err(capacity_error)?;
        let pattern = Pattern {
            row_start: live(a.row_start, n + 1)?,
            cols: live(a.cols, self.nnz)?,
        };
        let nc = mesh::couplings(&pattern, hinges, couplings)?;
        self.nnz_h = sparse::build_pattern(n, live(couplings, nc)?, a.hinge_start, a.hinge_cols)
            .map_err(capacity_error)?;
        let hinge_pattern = Pattern {
            row_start: live(a.hinge_start, n + 1)?,
            cols: live(a.hinge_cols, self.nnz_h)?,
        };

        // Element stiffness K_e = A Bᵀ C^H B (Eq. 10–11 on the coarse mesh with the cell's C^H),
        // lumped masses, and each element's place in the block pattern.
        let (triangles, tri_material) = (live(a.triangles, nt)?, live(a.tri_material, nt)?);
        let rest = live(a.rest, n)?;
        // the (u, v) of vertices `ids` (validated above: every vertex of a triangle is < n)
        fn uvs<const K: usize>(rest: &[Vec3A], ids: [u32; K]) -> Result<[[f64; 2]; K], InitError> {
            let mut uv = [[0.0; 2]; K];
            for (uv, &i) in uv.iter_mut().zip(&ids) {
                let r = rest.get(i as usize).ok_or(InitError::Internal)?;
                *uv = [r.x as f64, r.y as f64];
            }
            Ok(uv)
        }
        let (mass, area) = (live_mut(a.mass, n)?, live_mut(a.area, n)?);
        let per_triangle = triangles
            .iter()
            .zip(tri_material)
            .zip(live_mut(a.elements, nt)?.iter_mut())
            .zip(live_mut(a.slots, nt)?.iter_mut());
        let mut total_mass = 0.0f64;
        for (t, (((&tri, &material), element), slots)) in per_triangle.enumerate() {
            let mat = materials.get(material).ok_or(InitError::Internal)?;
            let uv = uvs(rest, tri)?;
            let degenerate = InitError::Mesh(MeshError::DegenerateUv { triangle: t as u32 });
            let g = membrane::gradients(uv).ok_or(degenerate)?;
            *element = Element::new(uv, &mat.stiffness).ok_or(degenerate)?;
            // Stiffness, lumped area and mass are f32: a value beyond its range is refused here
            // rather than becoming an infinite (or zero) mass or force.
            let e = &*element;
            let bad_material = InitError::InvalidMaterial { material };
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
                let (Some(mass_i), Some(area_i)) = (mass.get_mut(i), area.get_mut(i)) else {
                    return Err(InitError::Internal); // validated: < n
                };
                *mass_i += m as f32;
                *area_i += area3 as f32;
                total_mass += m;
                if !area_i.is_finite() {
                    return Err(bad_uv);
                }
                if !mass_i.is_finite() {
                    return Err(bad_material);
                }
            }
            let pairs = [(tri[0], tri[1]), (tri[0], tri[2]), (tri[1], tri[2])];
            for (slot, (i, j)) in slots.iter_mut().zip(pairs) {
                let (i, j) = (i as usize, j as usize);
                let (lo, hi, flag) = if i < j {
                    (i, j, 0)
                } else {
                    (j, i, membrane::TRANSPOSED)
                };
                let k = pattern.find(lo, hi).ok_or(InitError::Internal)?;
                *slot = k as u32 | flag;
            }
        }
        self.total_mass = total_mass;
        copy_live(a.rest_mass, a.mass, n);

        // Bending: the constant isometric Hessian of every hinge, scaled by the mean bending
        // stiffness of its two triangles.
        let (q_diag, q_off) = (live_mut(a.q_diag, n)?, live_mut(a.q_off, self.nnz)?);
        let q_hinge = live_mut(a.q_hinge, self.nnz_h)?;
        let bending_of = |t: usize| {
            tri_material
                .get(t)
                .and_then(|&m| materials.get(m))
                .map(|m| m.bending)
        };
        for &hinge in hinges {
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
            let b0 = bending_of(t0).unwrap_or(0.0);
            let b1 = bending_of(t1).unwrap_or(0.0);
            let uv = uvs(rest, hinge)?;
            let Some(q) = bending::hinge_hessian(uv, bending::CONTINUUM_SCALE * 0.5 * (b0 + b1))
            else {
                continue; // a degenerate hinge bends freely rather than blowing up
            };
            for (&i, qa) in hinge.iter().zip(&q) {
                for (&j, &qab) in hinge.iter().zip(qa) {
                    if i > j {
                        continue;
                    }
                    let (i, j, q) = (i as usize, j as usize, qab as f32);
                    // On an edge (or the diagonal), else a hinge-only pair.
                    if i == j || pattern.find(i.min(j), i.max(j)).is_some() {
                        sparse::add_scalar(&pattern, q_diag, q_off, i, j, q)
                    } else {
                        sparse::add_scalar(&hinge_pattern, q_diag, q_hinge, i, j, q)
                    }
                    .map_err(|_| InitError::Internal)?;
                }
            }
        }

        // The multilevel hierarchy, aggregated over the mesh edges; its scratch is the
        // stiffness blocks, not assembled yet. A mesh it cannot be built for (scratch too
        // small: far more isolated vertices than edges) steps with block Jacobi: its index
        // then holds no hierarchy and `Multigrid::new` refuses it.
        let a = &mut self.a;
        let scratch: &mut [u32] = bytemuck::cast_slice_mut(&mut *a.k_off);
        let vectors = crate::step::system::multigrid_vectors(a.force.len(), n, self.nnz);
        let built = multigrid::build(
            &Pattern {
                row_start: live(a.row_start, n + 1)?,
                cols: live(a.cols, self.nnz)?,
            },
            &Pattern {
                row_start: live(a.hinge_start, n + 1)?,
                cols: live(a.hinge_cols, self.nnz_h)?,
            },
            Some(multigrid::Graph {
                start: live(a.ring_start, n + 1)?,
                adjacency: live(a.ring, 2 * self.ne)?,
            }),
            live_mut(a.scratch_b, n)?,
            a.scratch_a,
            scratch,
            vectors,
        );
        if built.is_err() {
            a.scratch_a.fill(0);
        }
        // Normals (and, for per-node warping, warm-started rotations) of the initial placement.
        self.refresh_frames(8);
        self.check_initial_forces()
    }

    /// Refuses a cloth that can never step: every step first evaluates the elastic forces,
    /// stiffness and energy of its state, per triangle in `f32`, and fails when they overflow
    /// (the solve breaks down, or the energy balance reads an infinite energy), and a failed
    /// step keeps its state, so a cloth whose initial elastic terms do not fit `f32` fails
    /// every step. That happens when the positions stretch the rest (u, v) beyond anything a
    /// membrane takes (e.g. (u, v) scaled by 1e-15 against positions in metres: a stretch of
    /// 1e15). The error names the first triangle whose own terms overflow (triangle 0 if only
    /// their sums do).
    fn check_initial_forces(&mut self) -> Result<(), InitError> {
        let (n, nt, nnz) = (self.n, self.nt, self.nnz);
        let force = core::mem::take(&mut self.a.force);
        let energy = self.assemble_elastic(force);
        self.a.force = force;
        let a = &self.a;
        let finite = energy.is_some_and(f64::is_finite)
            && live(a.force, n)?.iter().all(|f| f.is_finite())
            && live(a.k_diag, n)?.iter().all(|k| k.is_finite())
            && live(a.k_off, nnz)?.iter().all(|k| k.is_finite());
        if finite {
            return Ok(());
        }
        // The same assembly, one triangle at a time on its own three corners.
        let strain = crate::step::forces::assembly_strain(&self.settings);
        let x = live(a.x, n)?;
        let corner = |i: u32| x.get(i as usize).copied().unwrap_or(Vec3A::ZERO); // (< n)
        let overflows = |(tri, element): (&[u32; 3], &Element)| {
            let (mut diag, mut off, mut force) =
                ([Mat3A::ZERO; 3], [Mat3A::ZERO; 3], [Vec3A::ZERO; 3]);
            let own = membrane::assemble(
                &[[0, 1, 2]],
                core::slice::from_ref(element),
                &[[0, 1, 2]],
                &tri.map(corner),
                strain,
                &mut diag,
                &mut off,
                &mut force,
            );
            !(own.is_ok_and(f64::is_finite)
                && force.iter().all(|f| f.is_finite())
                && diag.iter().chain(&off).all(|k| k.is_finite()))
        };
        let mut triangles = live(a.triangles, nt)?.iter().zip(live(a.elements, nt)?);
        let triangle = triangles.position(overflows).unwrap_or(0) as u32;
        Err(InitError::StrainOutOfRange { triangle })
    }
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
