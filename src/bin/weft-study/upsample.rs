//! Fine positions from a coarse cloth, with `weft::localize` (§6).
//!
//! * localization on: [`localize::bind`] once, then per frame [`localize::prepare`] and
//!   [`localize::localize`] (`x = Σ b_k p_k + T w`, `w = −χ Ê`), normals blended from the
//!   coarse vertices or recomputed on the fine mesh ([`localize::recompute_normals`]);
//! * localization off: the same bindings with `χ = 0`, i.e. the barycentric embedding of each
//!   fine vertex in its coarse triangle (Eq. 23 without `w`), same code and cost.

use glam::Vec3A;
use weft::blob::Blob;
use weft::localize::{self, Binding, NormalTarget, StrainMeasure, VertexFrame};
use weft::strided::{Strided, StridedMut};
use weft::world::World;

/// How fine positions (and normals) are made from the coarse cloth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Barycentric embedding, blended normals.
    Off,
    /// Localization; normals blended from the coarse cloth or recomputed on the fine mesh.
    On { recompute_normals: bool },
    /// Localization with the paper's verbatim strain and frame (Green strain, `T = F`),
    /// blended normals.
    Green,
}

impl Mode {
    pub fn localization(self) -> &'static str {
        match self {
            Mode::Off => "off",
            Mode::On { .. } => "on",
            Mode::Green => "on-green",
        }
    }
    pub fn normals(self) -> &'static str {
        match self {
            Mode::On {
                recompute_normals: true,
            } => "recomputed",
            _ => "blended",
        }
    }
    pub fn is_on(self) -> bool {
        self != Mode::Off
    }
}

/// The bindings of a fine mesh to one coarse world and the per-frame work buffers.
pub struct Upsampler {
    bindings: Vec<Binding>,
    /// The same with `χ = 0`.
    embedding: Vec<Binding>,
    frames: Vec<VertexFrame>,
    fine_triangles: Vec<[u32; 3]>,
}

impl Upsampler {
    /// Binds every fine vertex `(u, v)` to `world` (whose triangle materials are cells of
    /// `blob`).
    pub fn new(
        world: &World<'_>,
        blob: &Blob<'_>,
        fine_uv: &[[f32; 2]],
        fine_triangles: &[[u32; 3]],
    ) -> Result<Upsampler, String> {
        let uv = Strided::from_slice(fine_uv);
        let mut bindings = vec![Binding::ZERO; localize::bindings_needed(&uv)];
        localize::bind(world, blob, &uv, &mut bindings).map_err(|e| format!("bind: {e}"))?;
        let embedding = bindings
            .iter()
            .map(|b| Binding {
                chi: [0.0; 6],
                ..*b
            })
            .collect();
        Ok(Upsampler {
            bindings,
            embedding,
            frames: vec![VertexFrame::REST; world.vertex_count()],
            fine_triangles: fine_triangles.to_vec(),
        })
    }

    /// Writes the fine positions and normals of `world`'s current state.
    pub fn run(
        &mut self,
        world: &World<'_>,
        mode: Mode,
        positions: &mut [[f32; 3]],
        normals: &mut [[f32; 3]],
    ) -> Result<(), String> {
        let measure = if mode == Mode::Green {
            StrainMeasure::Green
        } else {
            StrainMeasure::Corotated
        };
        localize::prepare(world, measure, &mut self.frames).map_err(|e| format!("prepare: {e}"))?;
        let bindings = if mode == Mode::Off {
            &self.embedding
        } else {
            &self.bindings
        };
        let mut pos = StridedMut::from_slice(positions);
        let mut nrm = StridedMut::from_slice(normals);
        let recompute = mode
            == Mode::On {
                recompute_normals: true,
            };
        if recompute {
            localize::localize(&self.frames, world.triangles(), bindings, 0, &mut pos, None)
                .map_err(|e| format!("localize: {e}"))?;
            localize::recompute_normals(
                &self.fine_triangles,
                &mut pos,
                NormalTarget::Buffer(&mut nrm),
            )
            .map_err(|e| format!("normals: {e}"))?;
        } else {
            localize::localize(
                &self.frames,
                world.triangles(),
                bindings,
                0,
                &mut pos,
                Some(NormalTarget::Buffer(&mut nrm)),
            )
            .map_err(|e| format!("localize: {e}"))?;
        }
        Ok(())
    }
}

/// Area-weighted vertex normals of a triangle mesh (unit length; zero where undefined).
pub fn area_normals(triangles: &[[u32; 3]], x: &[Vec3A], out: &mut [Vec3A]) {
    out.iter_mut().for_each(|n| *n = Vec3A::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| x[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            out[i as usize] += n;
        }
    }
    for n in out.iter_mut() {
        *n = n.normalize_or_zero();
    }
}

/// `[f32; 3]` buffer as `Vec3A`s.
pub fn to_vec3a(v: &[[f32; 3]]) -> Vec<Vec3A> {
    v.iter().map(|p| Vec3A::from(*p)).collect()
}
