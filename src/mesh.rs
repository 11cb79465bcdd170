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

impl core::fmt::Display for MeshError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            MeshError::Empty => f.write_str("no vertices or no triangles"),
            MeshError::VertexCapacity { needed, capacity } => {
                write!(f, "{needed} vertices exceed the capacity of {capacity}")
            }
            MeshError::TriangleCapacity { needed, capacity } => {
                write!(f, "{needed} triangles exceed the capacity of {capacity}")
            }
            MeshError::EdgeCapacity { capacity } => {
                write!(f, "more edges than the capacity of {capacity}")
            }
            MeshError::IndexOutOfRange { triangle } => {
                write!(f, "triangle {triangle} names a vertex that does not exist")
            }
            MeshError::RepeatedVertex { triangle } => {
                write!(f, "triangle {triangle} uses a vertex twice")
            }
            MeshError::DegenerateUv { triangle } => {
                write!(f, "triangle {triangle} has (near) zero area in (u, v)")
            }
            MeshError::Degenerate3d { triangle } => {
                write!(
                    f,
                    "triangle {triangle} has (near) zero area in its initial placement"
                )
            }
            MeshError::NonManifoldEdge { a, b } => {
                write!(f, "edge {a}-{b} is shared by more than two triangles")
            }
            MeshError::NonFinite { vertex } => {
                write!(
                    f,
                    "vertex {vertex} has a NaN or infinite position or (u, v)"
                )
            }
            MeshError::FoldedUv { a, b } => {
                write!(
                    f,
                    "the triangles on edge {a}-{b} disagree on orientation in (u, v)"
                )
            }
            MeshError::BufferTooSmall => f.write_str("a buffer is shorter than the counts need"),
            MeshError::UnusedVertex { vertex } => {
                write!(f, "vertex {vertex} belongs to no triangle")
            }
            MeshError::UvOutOfRange { triangle } => {
                write!(f, "triangle {triangle}'s (u, v) area is beyond f32")
            }
        }
    }
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
    // (every slice below was checked long enough above: `BufferTooSmall` cannot happen)
    let (Some(vt_start), Some(fill)) =
        (topo.vt_start.get_mut(..n + 1), topo.scratch_a.get_mut(..n))
    else {
        return Err(MeshError::BufferTooSmall);
    };
    // Vertex → triangle incidence by counting sort (deterministic: triangles in index order).
    vt_start.fill(0);
    for tri in triangles {
        for &v in tri {
            let slot = vt_start
                .get_mut(v as usize + 1)
                .ok_or(MeshError::IndexOutOfRange { triangle: 0 })?;
            *slot += 1;
        }
    }
    running_sum(vt_start);
    if let Some(v) = vt_start
        .windows(2)
        .position(|w| matches!(w, [s, e] if s == e))
    {
        return Err(MeshError::UnusedVertex { vertex: v as u32 });
    }
    fill.copy_from_slice(vt_start.get(..n).ok_or(MeshError::BufferTooSmall)?);
    for (t, tri) in triangles.iter().enumerate() {
        for &v in tri {
            // (every vertex is < n: counted above)
            let at = fill.get_mut(v as usize).ok_or(MeshError::BufferTooSmall)?;
            let incident = topo
                .vt
                .get_mut(*at as usize)
                .ok_or(MeshError::BufferTooSmall)?;
            *incident = t as u32;
            *at += 1;
        }
    }

    // Unique edges: for each vertex a, visit its triangles and their corners b > a. `stamp[b]`
    // remembers the last `a` that saw b, `slot[b]` the edge index, so no hashing is needed.
    let (Some(stamp), Some(slot)) = (topo.scratch_a.get_mut(..n), topo.scratch_b.get_mut(..n))
    else {
        return Err(MeshError::BufferTooSmall);
    };
    stamp.fill(NONE);
    let edge_capacity = topo.edges.len().min(topo.edge_tris.len()) as u32;
    let mut ne = 0usize;
    let mut nh = 0usize;
    for (a, range) in vt_start.windows(2).enumerate() {
        let &[s, e] = range else {
            return Err(MeshError::BufferTooSmall);
        };
        let incident = topo
            .vt
            .get(s as usize..e as usize)
            .ok_or(MeshError::BufferTooSmall)?;
        for &t in incident {
            let tri = *triangles.get(t as usize).ok_or(MeshError::BufferTooSmall)?;
            for &b in &tri {
                if b as usize <= a {
                    continue;
                }
                let b_us = b as usize;
                let (Some(stamp_b), Some(slot_b)) = (stamp.get_mut(b_us), slot.get_mut(b_us))
                else {
                    return Err(MeshError::BufferTooSmall);
                };
                if *stamp_b != a as u32 {
                    let (Some(edge), Some(edge_tris)) =
                        (topo.edges.get_mut(ne), topo.edge_tris.get_mut(ne))
                    else {
                        return Err(MeshError::EdgeCapacity {
                            capacity: edge_capacity,
                        });
                    };
                    *stamp_b = a as u32;
                    *slot_b = ne as u32;
                    *edge = [a as u32, b];
                    *edge_tris = [t, NONE];
                    ne += 1;
                } else {
                    let et = topo
                        .edge_tris
                        .get_mut(*slot_b as usize)
                        .ok_or(MeshError::BufferTooSmall)?;
                    if et[1] != NONE {
                        return Err(MeshError::NonManifoldEdge { a: a as u32, b });
                    }
                    et[1] = t;
                }
            }
        }
    }
    let (Some(edges), Some(edge_tris)) = (topo.edges.get(..ne), topo.edge_tris.get(..ne)) else {
        return Err(MeshError::BufferTooSmall);
    };

    // Hinges on interior edges, and a consistency check: two triangles sharing an edge
    // traverse it in opposite directions iff they have the same (u,v) orientation.
    let hinge_capacity = topo.hinges.len() as u32;
    for (&[a, b], &[t0, t1]) in edges.iter().zip(edge_tris) {
        if t1 == NONE {
            continue;
        }
        let (t0, t1) = (t0 as usize, t1 as usize);
        let (Some(&tri0), Some(&tri1), Some(sign0), Some(sign1)) = (
            triangles.get(t0),
            triangles.get(t1),
            tri_sign.get(t0),
            tri_sign.get(t1),
        ) else {
            return Err(MeshError::BufferTooSmall);
        };
        let same_dir = directed(tri0, a, b) == directed(tri1, a, b);
        let same_sign = sign0 == sign1;
        if same_dir == same_sign {
            return Err(MeshError::FoldedUv { a, b });
        }
        let hinge = topo.hinges.get_mut(nh).ok_or(MeshError::EdgeCapacity {
            capacity: hinge_capacity,
        })?;
        *hinge = [a, b, opposite(tri0, a, b), opposite(tri1, a, b)];
        nh += 1;
    }

    // One-rings from the edge list.
    let ring_start = topo
        .ring_start
        .get_mut(..n + 1)
        .ok_or(MeshError::BufferTooSmall)?;
    ring_start.fill(0);
    for &[a, b] in edges {
        for v in [a, b] {
            // (edge ends are vertices, < n)
            let count = ring_start
                .get_mut(v as usize + 1)
                .ok_or(MeshError::BufferTooSmall)?;
            *count += 1;
        }
    }
    running_sum(ring_start);
    if topo.ring.len() < 2 * ne {
        return Err(MeshError::EdgeCapacity {
            capacity: (topo.ring.len() / 2) as u32,
        });
    }
    let fill = topo
        .scratch_a
        .get_mut(..n)
        .ok_or(MeshError::BufferTooSmall)?;
    fill.copy_from_slice(ring_start.get(..n).ok_or(MeshError::BufferTooSmall)?);
    for &[a, b] in edges {
        for (v, other) in [(a, b), (b, a)] {
            let at = fill.get_mut(v as usize).ok_or(MeshError::BufferTooSmall)?;
            let entry = topo
                .ring
                .get_mut(*at as usize)
                .ok_or(MeshError::BufferTooSmall)?;
            *entry = other;
            *at += 1;
        }
    }
    Ok(Counts {
        edges: ne,
        hinges: nh,
    })
}

/// `s[v + 1] += s[v]` for every `v`, in order: counts become start offsets.
fn running_sum(s: &mut [u32]) {
    let mut sum = 0;
    for x in s.iter_mut() {
        *x += sum;
        sum = *x;
    }
}

/// True when the triangle traverses a→b (rather than b→a).
fn directed(tri: [u32; 3], a: u32, b: u32) -> bool {
    let [p, q, r] = tri;
    (p == a && q == b) || (q == a && r == b) || (r == a && p == b)
}

/// The corner of `tri` that is neither a nor b.
fn opposite(tri: [u32; 3], a: u32, b: u32) -> u32 {
    tri.iter().copied().find(|&v| v != a && v != b).unwrap_or(a)
}

/// The couplings that only bending makes: the two vertices opposite each hinge, where they
/// share no edge of `edges` (the block pattern of the mesh edges; on a coarse or closed mesh
/// they may). Their stiffness is a scalar times I3 (`sparse::Scalars`). Returns how many were
/// written (duplicates included).
pub fn couplings(
    edges: &crate::sparse::Pattern<'_>,
    hinges: &[[u32; 4]],
    out: &mut [[u32; 2]],
) -> Result<usize, MeshError> {
    let mut written = 0;
    for h in hinges {
        let (a, b) = (h[2].min(h[3]) as usize, h[2].max(h[3]) as usize);
        if a == b || edges.find(a, b).is_some() {
            continue;
        }
        let capacity = out.len() as u32;
        let slot = out
            .get_mut(written)
            .ok_or(MeshError::EdgeCapacity { capacity })?;
        *slot = [h[2], h[3]];
        written += 1;
    }
    Ok(written)
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
    // vertex k = j nx + i, row by row
    for (k, (p, uv)) in positions
        .iter_mut()
        .zip(uvs.iter_mut())
        .take(nv)
        .enumerate()
    {
        let (i, j) = (k % nx, k / nx);
        let u = width * i as f32 / (nx - 1) as f32;
        let v = height * j as f32 / (ny - 1) as f32;
        *p = [u, v, 0.0];
        *uv = [u, v];
    }
    let mut out = triangles.iter_mut();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let id = |i: usize, j: usize| crate::lattice::node(i, j, nx) as u32;
            let (Some(lower), Some(upper)) = (out.next(), out.next()) else {
                return Err(MeshError::BufferTooSmall); // checked above
            };
            [*lower, *upper] = crate::lattice::square_triangles(
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j + 1),
            );
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
