//! An animated glTF 2.0 binary (.glb) of a mesh whose vertices move: one mesh per frame, shown
//! one at a time by a STEP animation of the frame nodes' scale (0 hides a node). Blender's and
//! the web viewers' glTF importers all play that; morph targets would need one weight per frame
//! in every vertex shader. Static meshes (the colliders) ride along.
//!
//! Layout (glTF 2.0 §4.4 "GLB File Format Specification"): a 12-byte header (magic, version,
//! total length), a JSON chunk padded with spaces and a BIN chunk padded with zeros, every
//! chunk and every buffer view 4-byte aligned. Weft is z-up; glTF is y-up, so every position and
//! normal is rotated by −90° about x: `(x, y, z) → (x, z, −y)`.

use serde_json::{json, Value};

pub const MAGIC: u32 = 0x4654_6C67; // "glTF"
pub const CHUNK_JSON: u32 = 0x4E4F_534A; // "JSON"
pub const CHUNK_BIN: u32 = 0x004E_4942; // "BIN\0"
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// One frame of the animated mesh: the time it shows from, positions and normals (z-up).
pub struct Frame {
    pub time: f32,
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
}

/// The animated mesh: topology shared by every frame, one material (an sRGB colour) per
/// triangle.
pub struct Animated<'a> {
    pub name: &'a str,
    /// Texture coordinates, (0, 0) at the lower left of the sheet (flipped to glTF's top left).
    pub uvs: &'a [[f32; 2]],
    pub triangles: &'a [[u32; 3]],
    pub materials: &'a [u32],
    pub colour: &'a dyn Fn(u32) -> [u8; 3],
    pub frames: &'a [Frame],
}

/// A mesh that does not move, in one sRGB colour (normals optional: flat without).
pub struct Static<'a> {
    pub name: &'a str,
    pub positions: &'a [[f32; 3]],
    pub normals: Option<&'a [[f32; 3]]>,
    pub triangles: &'a [[u32; 3]],
    pub colour: [u8; 3],
}

/// The .glb bytes of `mesh` and `statics`.
pub fn write(mesh: &Animated<'_>, statics: &[Static<'_>]) -> Vec<u8> {
    let mut b = Builder::default();
    let mut materials = Vec::new();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();

    // Per material: its triangles' indices, shared by every frame's primitive.
    let mut used: Vec<u32> = mesh.materials.to_vec();
    used.sort_unstable();
    used.dedup();
    let uv = b.vec2(
        &mesh
            .uvs
            .iter()
            .map(|t| [t[0], 1.0 - t[1]])
            .collect::<Vec<_>>(),
    );
    let parts: Vec<(usize, usize)> = used
        .iter()
        .map(|&m| {
            let tris: Vec<[u32; 3]> = mesh
                .triangles
                .iter()
                .zip(mesh.materials)
                .filter(|(_, tm)| **tm == m)
                .map(|(t, _)| *t)
                .collect();
            materials.push(material(&format!("m{m}"), (mesh.colour)(m)));
            (b.indices(&tris), materials.len() - 1)
        })
        .collect();
    for (k, f) in mesh.frames.iter().enumerate() {
        let p = b.vec3(&y_up(&f.positions), true);
        let n = b.vec3(&y_up(&f.normals), false);
        let primitives: Vec<Value> = parts
            .iter()
            .map(|&(indices, material)| {
                json!({"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": uv},
                       "indices": indices, "material": material, "mode": 4})
            })
            .collect();
        meshes.push(json!({"name": format!("{} {k}", mesh.name), "primitives": primitives}));
        let scale = if k == 0 { 1.0 } else { 0.0 };
        nodes.push(json!({"name": format!("{} t={:.3}", mesh.name, f.time),
                          "mesh": meshes.len() - 1, "scale": [scale, scale, scale]}));
    }

    // Node k is scaled 1 from frame k's time until frame k+1's and 0 otherwise.
    let times: Vec<f32> = mesh.frames.iter().map(|f| f.time).collect();
    let input = b.scalars(&times);
    let (mut samplers, mut channels) = (Vec::new(), Vec::new());
    for k in 0..mesh.frames.len() {
        let scales: Vec<[f32; 3]> = (0..times.len())
            .map(|i| [if i == k { 1.0 } else { 0.0 }; 3])
            .collect();
        let output = b.vec3(&scales, false);
        samplers.push(json!({"input": input, "output": output, "interpolation": "STEP"}));
        channels.push(json!({"sampler": k, "target": {"node": k, "path": "scale"}}));
    }

    for s in statics {
        let p = b.vec3(&y_up(s.positions), true);
        let mut attributes = json!({ "POSITION": p });
        if let Some(n) = s.normals {
            attributes["NORMAL"] = json!(b.vec3(&y_up(n), false));
        }
        let indices = b.indices(s.triangles);
        materials.push(material(s.name, s.colour));
        meshes.push(
            json!({"name": s.name, "primitives": [{"attributes": attributes,
            "indices": indices, "material": materials.len() - 1, "mode": 4}]}),
        );
        nodes.push(json!({"name": s.name, "mesh": meshes.len() - 1}));
    }

    let scene_nodes: Vec<usize> = (0..nodes.len()).collect();
    let doc = json!({
        "asset": {"version": "2.0", "generator": "weft-demo"},
        "scene": 0,
        "scenes": [{"nodes": scene_nodes}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "animations": [{"name": "drape", "samplers": samplers, "channels": channels}],
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{"byteLength": b.bin.len()}],
    });
    container(&doc.to_string(), &b.bin)
}

/// Header, JSON chunk (space-padded), BIN chunk (zero-padded).
fn container(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    for word in [MAGIC, 2, total as u32, json.len() as u32, CHUNK_JSON] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.extend_from_slice(&json);
    for word in [bin.len() as u32, CHUNK_BIN] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.extend_from_slice(&bin);
    out
}

fn y_up(v: &[[f32; 3]]) -> Vec<[f32; 3]> {
    v.iter().map(|p| [p[0], p[2], -p[1]]).collect()
}

/// A glTF material from an sRGB colour (glTF factors are linear).
fn material(name: &str, srgb: [u8; 3]) -> Value {
    let linear = srgb.map(|c| {
        let c = f32::from(c) / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    });
    json!({"name": name, "doubleSided": true,
           "pbrMetallicRoughness": {"baseColorFactor": [linear[0], linear[1], linear[2], 1.0],
                                    "metallicFactor": 0.0, "roughnessFactor": 0.8}})
}

/// The BIN chunk and the views and accessors into it.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// A 4-byte aligned buffer view of `bytes`; its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// Float VEC3 vertex data (or animation output); with its bounds when `bounds` (required
    /// for POSITION).
    fn vec3(&mut self, v: &[[f32; 3]], bounds: bool) -> usize {
        let view = self.view(bytemuck::cast_slice(v), Some(ARRAY_BUFFER));
        let mut a = json!({"bufferView": view, "componentType": FLOAT, "count": v.len(),
                           "type": "VEC3"});
        if bounds {
            let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
            for p in v {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessor(a)
    }

    fn vec2(&mut self, v: &[[f32; 2]]) -> usize {
        let view = self.view(bytemuck::cast_slice(v), Some(ARRAY_BUFFER));
        self.accessor(
            json!({"bufferView": view, "componentType": FLOAT, "count": v.len(),
                             "type": "VEC2"}),
        )
    }

    /// Float scalars with their bounds (animation input: times, bounds required).
    fn scalars(&mut self, v: &[f32]) -> usize {
        let view = self.view(bytemuck::cast_slice(v), None);
        let lo = v.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        self.accessor(
            json!({"bufferView": view, "componentType": FLOAT, "count": v.len(),
                             "type": "SCALAR", "min": [lo], "max": [hi]}),
        )
    }

    fn indices(&mut self, t: &[[u32; 3]]) -> usize {
        let view = self.view(bytemuck::cast_slice(t), Some(ELEMENT_ARRAY_BUFFER));
        self.accessor(json!({"bufferView": view, "componentType": UNSIGNED_INT,
                             "count": 3 * t.len(), "type": "SCALAR"}))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u32_at(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    fn floats(bin: &[u8], doc: &Value, accessor: usize) -> Vec<f32> {
        let a = &doc["accessors"][accessor];
        assert_eq!(a["componentType"], FLOAT);
        let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let start = view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        bin[start..start + len]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    /// A 3×2-vertex sheet in two materials over two frames, and a static triangle.
    fn sample() -> Vec<u8> {
        let grid = |z: f32| -> Vec<[f32; 3]> {
            (0..6)
                .map(|i| [(i % 3) as f32, (i / 3) as f32, z + 0.5 * (i % 3) as f32])
                .collect()
        };
        let up = vec![[0.0, 0.0, 1.0]; 6];
        let frames = [
            Frame {
                time: 0.0,
                positions: grid(1.0),
                normals: up.clone(),
            },
            Frame {
                time: 0.5,
                positions: grid(-2.0),
                normals: up,
            },
        ];
        let uvs: Vec<[f32; 2]> = grid(0.0).iter().map(|p| [p[0], p[1]]).collect();
        let colour = |m: u32| [m as u8 * 100, 50, 200];
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        write(
            &Animated {
                name: "sheet",
                uvs: &uvs,
                triangles: &[[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]],
                materials: &[0, 0, 1, 1],
                colour: &colour,
                frames: &frames,
            },
            &[Static {
                name: "floor",
                positions: &tri,
                normals: None,
                triangles: &[[0, 1, 2]],
                colour: [9, 9, 9],
            }],
        )
    }

    /// The container: header, two chunks, lengths that add up, 4-byte alignment.
    #[test]
    fn container_follows_the_glb_layout() {
        let glb = sample();
        assert_eq!(u32_at(&glb, 0), MAGIC);
        assert_eq!(u32_at(&glb, 4), 2);
        assert_eq!(u32_at(&glb, 8) as usize, glb.len());
        let json_len = u32_at(&glb, 12) as usize;
        assert_eq!(u32_at(&glb, 16), CHUNK_JSON);
        assert_eq!(json_len % 4, 0);
        let bin_at = 20 + json_len;
        let bin_len = u32_at(&glb, bin_at) as usize;
        assert_eq!(u32_at(&glb, bin_at + 4), CHUNK_BIN);
        assert_eq!(bin_len % 4, 0);
        assert_eq!(bin_at + 8 + bin_len, glb.len());
        let doc: Value = serde_json::from_slice(&glb[20..bin_at]).unwrap();
        let declared = doc["buffers"][0]["byteLength"].as_u64().unwrap() as usize;
        assert!(declared <= bin_len && bin_len - declared < 4);
    }

    /// Every reference resolves, every accessor fits its view and every view the buffer,
    /// POSITION bounds are the data's, indices address existing vertices, and at every key time
    /// exactly one frame node is visible.
    #[test]
    fn accessors_and_animation_are_consistent() {
        let glb = sample();
        let json_len = u32_at(&glb, 12) as usize;
        let doc: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
        let bin = &glb[20 + json_len + 8..];
        let buffer_len = doc["buffers"][0]["byteLength"].as_u64().unwrap();
        let size = |a: &Value| {
            let n = match a["type"].as_str().unwrap() {
                "SCALAR" => 1,
                "VEC2" => 2,
                "VEC3" => 3,
                t => panic!("{t}"),
            };
            n * 4 * a["count"].as_u64().unwrap()
        };
        for a in doc["accessors"].as_array().unwrap() {
            let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
            assert_eq!(view["byteOffset"].as_u64().unwrap() % 4, 0);
            assert_eq!(view["byteLength"].as_u64().unwrap(), size(a));
            let end = view["byteOffset"].as_u64().unwrap() + view["byteLength"].as_u64().unwrap();
            assert!(end <= buffer_len);
        }
        let meshes = doc["meshes"].as_array().unwrap();
        assert_eq!(meshes.len(), 3, "two frames and the floor");
        for m in meshes {
            for p in m["primitives"].as_array().unwrap() {
                let pos = p["attributes"]["POSITION"].as_u64().unwrap() as usize;
                let a = &doc["accessors"][pos];
                let x = floats(bin, &doc, pos);
                for k in 0..3 {
                    let lo = x
                        .iter()
                        .skip(k)
                        .step_by(3)
                        .copied()
                        .fold(f32::MAX, f32::min);
                    let hi = x
                        .iter()
                        .skip(k)
                        .step_by(3)
                        .copied()
                        .fold(f32::MIN, f32::max);
                    assert_eq!(a["min"][k].as_f64().unwrap(), f64::from(lo));
                    assert_eq!(a["max"][k].as_f64().unwrap(), f64::from(hi));
                }
                let idx = &doc["accessors"][p["indices"].as_u64().unwrap() as usize];
                assert_eq!(idx["componentType"], UNSIGNED_INT);
                let view = &doc["bufferViews"][idx["bufferView"].as_u64().unwrap() as usize];
                let start = view["byteOffset"].as_u64().unwrap() as usize;
                let count = a["count"].as_u64().unwrap() as u32;
                for c in
                    bin[start..start + 4 * idx["count"].as_u64().unwrap() as usize].chunks_exact(4)
                {
                    assert!(u32::from_le_bytes(c.try_into().unwrap()) < count);
                }
                assert!(
                    p["material"].as_u64().unwrap()
                        < doc["materials"].as_array().unwrap().len() as u64
                );
            }
        }
        // z-up → y-up: frame 0's heights (z from 1 to 2) are the y bounds.
        let p0 = &doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .unwrap() as usize];
        assert_eq!(p0["min"][1], 1.0);
        assert_eq!(p0["max"][1], 2.0);
        assert_eq!(p0["max"][2], 0.0);

        let anim = &doc["animations"][0];
        let channels = anim["channels"].as_array().unwrap();
        assert_eq!(channels.len(), 2);
        let mut visible = [[0.0f32; 2]; 2];
        for c in channels {
            let node = c["target"]["node"].as_u64().unwrap() as usize;
            assert!(doc["nodes"][node]["mesh"].as_u64().unwrap() < 2);
            assert_eq!(c["target"]["path"], "scale");
            let s = &anim["samplers"][c["sampler"].as_u64().unwrap() as usize];
            let input = s["input"].as_u64().unwrap() as usize;
            assert_eq!(floats(bin, &doc, input), [0.0, 0.5]);
            assert!(doc["accessors"][input]["min"].is_array());
            let out = floats(bin, &doc, s["output"].as_u64().unwrap() as usize);
            visible[node] = [out[0], out[3]];
        }
        assert_eq!(visible, [[1.0, 0.0], [0.0, 1.0]]);
    }
}
