//! Coarse mesh validation and topology: vertex→triangle incidence, unique edges, interior
//! hinges (for bending), one-rings (for the rotations of Eq. 14) and the couplings of the block
//! matrix. Everything is written into caller slices; nothing allocates.
//!
//! The rest configuration of the coarse cloth is its material space lifted to 3D,
//! `x0 = (u, v, 0)`: a flat sheet, so hinges are flat at rest and the rest normal is `+z`.

use crate::membrane;
use crate::strided::Strided;

/// Marks a missing second triangle on a boundary edge.
pub const NONE: u32 = u32::MAX;

/// Why a mesh was rejected. Indices name the offending element so a tool can point at it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshError {
    /// No vertices or no triangles.
    Empty,
    /// More vertices, triangles or edges than the storage holds.
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
    /// A triangle names a vertex that does not exist.
    IndexOutOfRange {
        triangle: u32,
    },
    /// A triangle uses the same vertex twice.
    RepeatedVertex {
        triangle: u32,
    },
    /// A triangle has (near) zero area in material (u,v) space.
    DegenerateUv {
        triangle: u32,
    },
    /// A triangle has (near) zero area in its initial 3D placement.
    Degenerate3d {
        triangle: u32,
    },
    /// An edge is shared by more than two triangles.
    NonManifoldEdge {
        a: u32,
        b: u32,
    },
    /// A position or (u,v) coordinate is NaN or infinite.
    NonFinite {
        vertex: u32,
    },
    /// Two triangles on one edge disagree on orientation in (u,v) (the sheet folds over
    /// itself in material space).
    FoldedUv {
        a: u32,
        b: u32,
    },
    /// A slice handed in is shorter than the counts require.
    BufferTooSmall,
    /// A vertex belongs to no triangle: it would have no mass, no stiffness and no one-ring.
    UnusedVertex {
        vertex: u32,
    },
    /// A triangle's (u,v) area is beyond `f32`: its lumped area overflows (a sheet some 1e19 m
    /// across) or rounds to zero.
    UvOutOfRange {
        triangle: u32,
    },
}

/// Relative area below which a 3D triangle is degenerate (area / longest edge²).
pub const DEGENERATE_3D_RATIO: f32 = 1e-7;

/// Checks vertices and triangles; returns the orientation sign of each triangle in (u,v)
/// (+1 counter-clockwise) in `tri_sign`.
pub fn validate(
    positions: &[[f32; 3]],
    uvs: &[[f32; 2]],
    triangles: &[[u32; 3]],
    tri_sign: &mut [f32],
) -> Result<(), MeshError> {
    validate_strided(
        &Strided::from_slice(positions),
        &Strided::from_slice(uvs),
        triangles,
        tri_sign,
    )
}

/// [`validate`] with positions and (u, v) read in place from strided vertex buffers.
pub fn validate_strided(
    positions: &Strided<'_, 3>,
    uvs: &Strided<'_, 2>,
    triangles: &[[u32; 3]],
    tri_sign: &mut [f32],
) -> Result<(), MeshError> {
    if positions.is_empty() || triangles.is_empty() {
        return Err(MeshError::Empty);
    }
    if uvs.count() != positions.count() || tri_sign.len() < triangles.len() {
        return Err(MeshError::BufferTooSmall);
    }
    let n = positions.count();
    for v in 0..n {
        let (p, uv) = (positions.get(v), uvs.get(v));
        let finite = |c: &f32| c.is_finite();
        if !(p.is_some_and(|p| p.iter().all(finite)) && uv.is_some_and(|uv| uv.iter().all(finite)))
        {
            return Err(MeshError::NonFinite { vertex: v as u32 });
        }
    }
    for (t, (tri, sign)) in triangles.iter().zip(tri_sign.iter_mut()).enumerate() {
        let triangle = t as u32;
        if tri.iter().any(|&i| i as usize >= n) {
            return Err(MeshError::IndexOutOfRange { triangle });
        }
        let [a, b, c] = *tri;
        if a == b || b == c || a == c {
            return Err(MeshError::RepeatedVertex { triangle });
        }
        let corner = |i: u32| {
            let out = MeshError::IndexOutOfRange { triangle };
            Ok::<_, MeshError>((
                uvs.get(i as usize).ok_or(out)?,
                positions.get(i as usize).ok_or(out)?,
            ))
        };
        let ((ua, pa), (ub, pb), (uc, pc)) = (corner(a)?, corner(b)?, corner(c)?);
        let f = |p: [f32; 2]| [p[0] as f64, p[1] as f64];
        if membrane::gradients([f(ua), f(ub), f(uc)]).is_none() {
            return Err(MeshError::DegenerateUv { triangle });
        }
        let area2 = (ub[0] - ua[0]) * (uc[1] - ua[1]) - (uc[0] - ua[0]) * (ub[1] - ua[1]);
        *sign = if area2 > 0.0 { 1.0 } else { -1.0 };
        let (pa, pb, pc) = (
            glam::Vec3A::from(pa),
            glam::Vec3A::from(pb),
            glam::Vec3A::from(pc),
        );
        let cross = (pb - pa).cross(pc - pa).length();
        let longest = (pb - pa)
            .length_squared()
            .max((pc - pb).length_squared())
            .max((pa - pc).length_squared());
        // written so that NaN also counts as degenerate
        if cross.partial_cmp(&(DEGENERATE_3D_RATIO * longest)) != Some(core::cmp::Ordering::Greater)
        {
            return Err(MeshError::Degenerate3d { triangle });
        }
    }
    Ok(())
}

/// Topology of a validated mesh, on caller storage.
pub struct Topology<'a> {
    /// Vertex → incident triangles (CSR): `vt[vt_start[v]..vt_start[v+1]]`.
    pub vt_start: &'a mut [u32],
    pub vt: &'a mut [u32],
    /// Unique edges `[a, b]` with `a < b`, and their one or two triangles.
    pub edges: &'a mut [[u32; 2]],
    pub edge_tris: &'a mut [[u32; 2]],
    /// Interior edges as hinges `[x0, x1, x2, x3]`: shared edge (x0, x1), opposite vertices x2
    /// (in the first triangle) and x3 (in the second).
    pub hinges: &'a mut [[u32; 4]],
    /// One-ring neighbours of each vertex (CSR, excluding the vertex itself).
    pub ring_start: &'a mut [u32],
    pub ring: &'a mut [u32],
    /// Scratch, one per vertex.
    pub scratch_a: &'a mut [u32],
    pub scratch_b: &'a mut [u32],
}

/// Counts of what [`build`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    pub edges: usize,
    pub hinges: usize,
}

/// Builds incidence, edges, hinges and one-rings. `n` vertices; `triangles` already validated.
/// Capacities are the lengths of the slices in `topo`.
pub fn build(
    n: usize,
    triangles: &[[u32; 3]],
    tri_sign: &[f32],
    topo: &mut Topology<'_>,
) -> Result<Counts, MeshError> {
    let nt = triangles.len();
    if topo.vt_start.len() < n + 1
        || topo.vt.len() < 3 * nt
        || topo.ring_start.len() < n + 1
        || topo.scratch_a.len() < n
        || topo.scratch_b.len() < n
        || tri_sign.len() < nt
    {
        return Err(MeshError::BufferTooSmall);
    }
    // Vertex → triangle incidence by counting sort (deterministic: triangles in index order).
    let vt_start = &mut topo.vt_start[..n + 1];
    vt_start.fill(0);
    for tri in triangles {
        for &v in tri {
            let slot = vt_start
                .get_mut(v as usize + 1)
                .ok_or(MeshError::IndexOutOfRange { triangle: 0 })?;
            *slot += 1;
        }
    }
    for v in 0..n {
        vt_start[v + 1] += vt_start[v];
    }
    if let Some(v) = (0..n).find(|&v| vt_start[v] == vt_start[v + 1]) {
        return Err(MeshError::UnusedVertex { vertex: v as u32 });
    }
    let fill = &mut topo.scratch_a[..n];
    fill.copy_from_slice(&vt_start[..n]);
    for (t, tri) in triangles.iter().enumerate() {
        for &v in tri {
            let at = &mut fill[v as usize];
            topo.vt[*at as usize] = t as u32;
            *at += 1;
        }
    }

    // Unique edges: for each vertex a, visit its triangles and their corners b > a. `stamp[b]`
    // remembers the last `a` that saw b, `slot[b]` the edge index, so no hashing is needed.
    let (stamp, slot) = (&mut topo.scratch_a[..n], &mut topo.scratch_b[..n]);
    stamp.fill(NONE);
    let mut ne = 0usize;
    let mut nh = 0usize;
    for a in 0..n {
        let (s, e) = (vt_start[a] as usize, vt_start[a + 1] as usize);
        for &t in &topo.vt[s..e] {
            let tri = triangles[t as usize];
            for &b in &tri {
                if b as usize <= a {
                    continue;
                }
                let b_us = b as usize;
                if stamp[b_us] != a as u32 {
                    if ne >= topo.edges.len() || ne >= topo.edge_tris.len() {
                        return Err(MeshError::EdgeCapacity {
                            capacity: topo.edges.len().min(topo.edge_tris.len()) as u32,
                        });
                    }
                    stamp[b_us] = a as u32;
                    slot[b_us] = ne as u32;
                    topo.edges[ne] = [a as u32, b];
                    topo.edge_tris[ne] = [t, NONE];
                    ne += 1;
                } else {
                    let et = &mut topo.edge_tris[slot[b_us] as usize];
                    if et[1] != NONE {
                        return Err(MeshError::NonManifoldEdge { a: a as u32, b });
                    }
                    et[1] = t;
                }
            }
        }
    }

    // Hinges on interior edges, and a consistency check: two triangles sharing an edge
    // traverse it in opposite directions iff they have the same (u,v) orientation.
    for e in 0..ne {
        let [a, b] = topo.edges[e];
        let [t0, t1] = topo.edge_tris[e];
        if t1 == NONE {
            continue;
        }
        let (tri0, tri1) = (triangles[t0 as usize], triangles[t1 as usize]);
        let same_dir = directed(tri0, a, b) == directed(tri1, a, b);
        let same_sign = tri_sign[t0 as usize] == tri_sign[t1 as usize];
        if same_dir == same_sign {
            return Err(MeshError::FoldedUv { a, b });
        }
        if nh >= topo.hinges.len() {
            return Err(MeshError::EdgeCapacity {
                capacity: topo.hinges.len() as u32,
            });
        }
        topo.hinges[nh] = [a, b, opposite(tri0, a, b), opposite(tri1, a, b)];
        nh += 1;
    }

    // One-rings from the edge list.
    let ring_start = &mut topo.ring_start[..n + 1];
    ring_start.fill(0);
    for &[a, b] in &topo.edges[..ne] {
        ring_start[a as usize + 1] += 1;
        ring_start[b as usize + 1] += 1;
    }
    for v in 0..n {
        ring_start[v + 1] += ring_start[v];
    }
    if topo.ring.len() < 2 * ne {
        return Err(MeshError::EdgeCapacity {
            capacity: (topo.ring.len() / 2) as u32,
        });
    }
    let fill = &mut topo.scratch_a[..n];
    fill.copy_from_slice(&ring_start[..n]);
    for &[a, b] in &topo.edges[..ne] {
        topo.ring[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
        topo.ring[fill[b as usize] as usize] = a;
        fill[b as usize] += 1;
    }
    Ok(Counts {
        edges: ne,
        hinges: nh,
    })
}

/// True when the triangle traverses a→b (rather than b→a).
fn directed(tri: [u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|k| tri[k] == a && tri[(k + 1) % 3] == b)
}

/// The corner of `tri` that is neither a nor b.
fn opposite(tri: [u32; 3], a: u32, b: u32) -> u32 {
    tri.iter().copied().find(|&v| v != a && v != b).unwrap_or(a)
}

/// The couplings of the block matrix: every edge, plus the two opposite vertices of every hinge
/// (the bending stencil couples them although they share no edge). Returns how many were written.
pub fn couplings(
    edges: &[[u32; 2]],
    hinges: &[[u32; 4]],
    out: &mut [[u32; 2]],
) -> Result<usize, MeshError> {
    let needed = edges.len() + hinges.len();
    if out.len() < needed {
        return Err(MeshError::EdgeCapacity {
            capacity: out.len() as u32,
        });
    }
    for (o, e) in out.iter_mut().zip(edges) {
        *o = *e;
    }
    for (o, h) in out[edges.len()..].iter_mut().zip(hinges) {
        *o = [h[2], h[3]];
    }
    Ok(needed)
}

/// A regular grid sheet of `nx × ny` vertices spanning `width × height` in (u,v), each square
/// split along its lower-left→upper-right diagonal (the pixel convention of docs/CONVENTIONS.md).
/// Positions are `(u, v, 0)`. Used by tests, benchmarks and the demo; writes into the slices and
/// returns `(vertices, triangles)`.
pub fn grid(
    nx: usize,
    ny: usize,
    width: f32,
    height: f32,
    positions: &mut [[f32; 3]],
    uvs: &mut [[f32; 2]],
    triangles: &mut [[u32; 3]],
) -> Result<(usize, usize), MeshError> {
    if nx < 2 || ny < 2 {
        return Err(MeshError::Empty);
    }
    let nv = nx * ny;
    let nt = 2 * (nx - 1) * (ny - 1);
    if positions.len() < nv || uvs.len() < nv || triangles.len() < nt {
        return Err(MeshError::BufferTooSmall);
    }
    for j in 0..ny {
        for i in 0..nx {
            let u = width * i as f32 / (nx - 1) as f32;
            let v = height * j as f32 / (ny - 1) as f32;
            positions[j * nx + i] = [u, v, 0.0];
            uvs[j * nx + i] = [u, v];
        }
    }
    let mut t = 0;
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let ll = (j * nx + i) as u32;
            let lr = ll + 1;
            let ul = ll + nx as u32;
            let ur = ul + 1;
            triangles[t] = [ll, lr, ur];
            triangles[t + 1] = [ll, ur, ul];
            t += 2;
        }
    }
    Ok((nv, nt))
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Owned {
        vt_start: Vec<u32>,
        vt: Vec<u32>,
        edges: Vec<[u32; 2]>,
        edge_tris: Vec<[u32; 2]>,
        hinges: Vec<[u32; 4]>,
        ring_start: Vec<u32>,
        ring: Vec<u32>,
        a: Vec<u32>,
        b: Vec<u32>,
    }
    impl Owned {
        fn new(n: usize, nt: usize, ne: usize) -> Self {
            Owned {
                vt_start: vec![0; n + 1],
                vt: vec![0; 3 * nt],
                edges: vec![[0; 2]; ne],
                edge_tris: vec![[0; 2]; ne],
                hinges: vec![[0; 4]; ne],
                ring_start: vec![0; n + 1],
                ring: vec![0; 2 * ne],
                a: vec![0; n],
                b: vec![0; n],
            }
        }
        fn topo(&mut self) -> Topology<'_> {
            Topology {
                vt_start: &mut self.vt_start,
                vt: &mut self.vt,
                edges: &mut self.edges,
                edge_tris: &mut self.edge_tris,
                hinges: &mut self.hinges,
                ring_start: &mut self.ring_start,
                ring: &mut self.ring,
                scratch_a: &mut self.a,
                scratch_b: &mut self.b,
            }
        }
    }

    type GridMesh = (Vec<[f32; 3]>, Vec<[f32; 2]>, Vec<[u32; 3]>);

    fn grid_mesh(nx: usize, ny: usize) -> GridMesh {
        let mut p = vec![[0.0; 3]; nx * ny];
        let mut uv = vec![[0.0; 2]; nx * ny];
        let mut t = vec![[0; 3]; 2 * (nx - 1) * (ny - 1)];
        grid(nx, ny, 1.0, 1.0, &mut p, &mut uv, &mut t).unwrap();
        (p, uv, t)
    }

    #[test]
    fn grid_topology_counts() {
        let (p, uv, t) = grid_mesh(4, 3);
        let mut sign = vec![0.0; t.len()];
        validate(&p, &uv, &t, &mut sign).unwrap();
        assert!(sign.iter().all(|&s| s == 1.0));
        let mut o = Owned::new(p.len(), t.len(), 40);
        let c = build(p.len(), &t, &sign, &mut o.topo()).unwrap();
        // 4×3 grid: 3·2 squares: horizontal 3·3 + vertical 4·2 + diagonals 6 = 23 edges
        assert_eq!(c.edges, 23);
        // interior edges = edges − boundary edges (2·3 + 2·2 = 10)
        assert_eq!(c.hinges, 13);
        // corner vertex 0 neighbours: 1, 4, 5
        let r = &o.ring[o.ring_start[0] as usize..o.ring_start[1] as usize];
        let mut r = r.to_vec();
        r.sort();
        assert_eq!(r, vec![1, 4, 5]);
        // every hinge: x2, x3 are on opposite sides of the edge in uv
        for h in &o.hinges[..c.hinges] {
            let side = |v: u32| {
                let (a, b, q) = (uv[h[0] as usize], uv[h[1] as usize], uv[v as usize]);
                (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])
            };
            assert!(side(h[2]) * side(h[3]) < 0.0);
        }
    }

    #[test]
    fn validation_errors_name_the_element() {
        let (p, uv, t) = grid_mesh(3, 3);
        let mut sign = vec![0.0; t.len()];
        let mut bad = t.clone();
        bad[5] = [0, 1, 99];
        assert_eq!(
            validate(&p, &uv, &bad, &mut sign),
            Err(MeshError::IndexOutOfRange { triangle: 5 })
        );
        bad[5] = [2, 2, 3];
        assert_eq!(
            validate(&p, &uv, &bad, &mut sign),
            Err(MeshError::RepeatedVertex { triangle: 5 })
        );
        let mut puv = uv.clone();
        puv[4] = puv[0];
        assert!(matches!(
            validate(&p, &puv, &t, &mut sign),
            Err(MeshError::DegenerateUv { .. })
        ));
        let mut pp = p.clone();
        pp[4] = pp[0];
        assert!(matches!(
            validate(&pp, &uv, &t, &mut sign),
            Err(MeshError::Degenerate3d { .. })
        ));
        pp = p.clone();
        pp[7][1] = f32::NAN;
        assert_eq!(
            validate(&pp, &uv, &t, &mut sign),
            Err(MeshError::NonFinite { vertex: 7 })
        );
    }

    #[test]
    fn non_manifold_and_capacity_errors() {
        // three triangles on edge (0,1)
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],
            [0.5, -1.0, 0.0],
            [0.5, 0.5, 1.0],
        ];
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.5, 1.0], [0.5, -1.0], [0.6, 0.4]];
        let t = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        let mut sign = vec![0.0; 3];
        validate(&p, &uv, &t, &mut sign).unwrap();
        let mut o = Owned::new(5, 3, 20);
        assert_eq!(
            build(5, &t, &sign, &mut o.topo()),
            Err(MeshError::NonManifoldEdge { a: 0, b: 1 })
        );
        let (p, uv, t) = grid_mesh(3, 3);
        let mut sign = vec![0.0; t.len()];
        validate(&p, &uv, &t, &mut sign).unwrap();
        let mut o = Owned::new(p.len(), t.len(), 5);
        assert!(matches!(
            build(p.len(), &t, &sign, &mut o.topo()),
            Err(MeshError::EdgeCapacity { .. })
        ));
    }

    #[test]
    fn folded_uv_is_rejected() {
        // two triangles on edge (0,1) on the same side of it in uv
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],
            [0.5, 1.0, 1.0],
        ];
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [0.5, 1.0], [0.4, 0.5]];
        let t = vec![[0, 1, 2], [1, 0, 3]];
        let mut sign = vec![0.0; 2];
        validate(&p, &uv, &t, &mut sign).unwrap();
        let mut o = Owned::new(4, 2, 10);
        assert_eq!(
            build(4, &t, &sign, &mut o.topo()),
            Err(MeshError::FoldedUv { a: 0, b: 1 })
        );
    }
}
