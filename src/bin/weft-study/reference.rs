//! The fine reference and the coarse cloth of a study sheet, as owned meshes.
//!
//! The fine reference is the cells' own micro meshes tiled over the whole sheet
//! ([`weft::cell::mesh_sheet`]), each fine triangle with its pixel's material `C` (not `C^H`),
//! stepped by the very same [`World`](weft::world::World) as the coarse cloth:
//! `Materials::Table` over the cell's materials instead of `Materials::Blob`. There is no
//! second copy of the physics; this module only owns the arrays (`Vec`s) and says how big a
//! world they need.

use weft::cell::{mesh_sheet, CellDesc};
use weft::world::{Capacity, ClothDef, Material};

/// An owned cloth: rest (u, v), triangles, per-triangle material, and a placement in 3D.
pub struct Sheet {
    pub uvs: Vec<[f32; 2]>,
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
    pub materials: Vec<u32>,
    /// Vertices along u and v (both meshes are structured grids, node `(i, j)` = `j·nx + i`).
    pub nx: usize,
    pub ny: usize,
    /// Size in (u, v), metres.
    pub width: f64,
    pub height: f64,
}

impl Sheet {
    pub fn def(&self) -> ClothDef<'_> {
        ClothDef {
            positions: &self.positions,
            uvs: &self.uvs,
            triangles: &self.triangles,
            materials: &self.materials,
        }
    }

    /// Capacity for this sheet with `pins` pins and a few colliders.
    pub fn capacity(&self, pins: usize) -> Capacity {
        let (qx, qy) = ((self.nx - 1) as u32, (self.ny - 1) as u32);
        Capacity {
            vertices: self.uvs.len() as u32,
            triangles: self.triangles.len() as u32,
            // a structured grid: 3 per square plus the top row and right column
            edges: 3 * qx * qy + qx + qy,
            colliders: 4,
            pins: pins.max(1) as u32,
        }
    }

    /// Puts every vertex at `place(u, v)`.
    pub fn place(&mut self, place: impl Fn([f32; 2]) -> [f32; 3]) {
        self.positions = self.uvs.iter().map(|&uv| place(uv)).collect();
    }

    /// Indices of the vertices whose (u, v) satisfy `pred`.
    pub fn select(&self, pred: impl Fn([f64; 2]) -> bool) -> Vec<u32> {
        self.uvs
            .iter()
            .enumerate()
            .filter(|(_, uv)| pred([f64::from(uv[0]), f64::from(uv[1])]))
            .map(|(i, _)| i as u32)
            .collect()
    }
}

/// The fine heterogeneous sheet: `tiles × tiles` copies of `desc` at `refine`, every triangle
/// with its pixel's material; the table is the cell's materials in order (the material index
/// of a triangle indexes it).
pub fn fine_sheet(desc: &CellDesc, refine: usize, tiles: usize) -> (Sheet, Vec<Material>) {
    let mesh = mesh_sheet(desc, refine, tiles, tiles);
    let table = desc
        .materials
        .iter()
        .map(|m| Material {
            stiffness: m.c,
            density: m.density,
            bending: m.bending,
        })
        .collect();
    let uvs: Vec<[f32; 2]> = mesh
        .nodes
        .iter()
        .map(|p| [p[0] as f32, p[1] as f32])
        .collect();
    let sheet = Sheet {
        positions: uvs.iter().map(|uv| [uv[0], uv[1], 0.0]).collect(),
        uvs,
        triangles: mesh.triangles,
        materials: mesh.tri_material,
        nx: mesh.nu + 1,
        ny: mesh.nv + 1,
        width: desc.width() * tiles as f64,
        height: desc.height() * tiles as f64,
    };
    (sheet, table)
}

/// A coarse grid of `quads × quads` squares over a `width × height` sheet, split like the
/// pixels (lower-left to upper-right), every triangle of material `material`.
pub fn coarse_sheet(width: f64, height: f64, quads: usize, material: u32) -> Sheet {
    let n = quads + 1;
    let mut positions = vec![[0.0f32; 3]; n * n];
    let mut uvs = vec![[0.0f32; 2]; n * n];
    let mut triangles = vec![[0u32; 3]; 2 * quads * quads];
    // mesh::grid only fails for fewer than 2×2 vertices or short buffers, neither possible here
    let _ = weft::mesh::grid(
        n,
        n,
        width as f32,
        height as f32,
        &mut positions,
        &mut uvs,
        &mut triangles,
    );
    Sheet {
        materials: vec![material; triangles.len()],
        positions,
        uvs,
        triangles,
        nx: n,
        ny: n,
        width,
        height,
    }
}
