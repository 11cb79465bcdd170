//! The fuzz harness, shared by the cargo-fuzz targets (`fuzz/fuzz_targets/*.rs` include this file
//! by path), the seed generator (`examples/fuzz_seeds.rs`) and the regression tests
//! (`tests/fuzz_regressions.rs`), so that every input the fuzzer found replays in `cargo test`
//! exactly as the fuzzer ran it.
//!
//! * [`blob`]: raw bytes to `Blob::parse`, as they are, at a misaligned address, and re-sealed
//!   (total size and CRC fixed up so mutations reach the structural and content checks). An
//!   accepted blob must re-encode to the same bytes (the format's encoding is unique), every
//!   cell must be reachable, and its cells must build a world.
//! * [`world`]: bytes decoded (by [`Input`], a forgiving reader that yields zeros when the input
//!   runs out) into a mesh, materials, capacity, memory and settings for `World::new`, then a
//!   sequence of edits and steps. Every call must return `Ok` or `Err`; positions and velocities
//!   must stay finite; a failed step or edit must leave the state as it was.
//!
//! Panics here are the findings: the harness asserts what the library promises.
#![allow(dead_code)] // each includer uses a subset

use std::sync::OnceLock;

use weft::blob::{self, AlignedBytes, Blob, CellRecord};
use weft::collide::{Collider, Shape};
use weft::world::{
    effects, Capacity, ClothDef, EditError, InitError, Material, Materials, Settings, StepError,
    World,
};

// ---------------------------------------------------------------------------------------------
// Blob
// ---------------------------------------------------------------------------------------------

const H_TOTAL_SIZE: usize = 16;
const H_CHECKSUM: usize = 40;

/// `bytes` with the header's total size and checksum made consistent with the rest (what a
/// corruption must survive to reach the checks behind the CRC). Shorter than a header: as is.
pub fn reseal(bytes: &[u8]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    if b.len() >= blob::HEADER_SIZE {
        let total = b.len() as u64;
        b[H_TOTAL_SIZE..H_TOTAL_SIZE + 8].copy_from_slice(&total.to_le_bytes());
        let crc = blob::crc32(&b[blob::HEADER_SIZE..]);
        b[H_CHECKSUM..H_CHECKSUM + 4].copy_from_slice(&crc.to_le_bytes());
    }
    b
}

/// What the blob target checks on one input; returns how many of the two aligned parses
/// (as is, resealed) accepted it.
pub fn blob(data: &[u8]) -> usize {
    let mut accepted = 0;
    let raw = AlignedBytes::copy_from(data);
    let first = Blob::parse(&raw);
    if let Ok(b) = &first {
        check_accepted(b);
        accepted += 1;
    }

    // The same bytes one byte past an aligned address: never accepted. Header problems are
    // reported first (docs/BLOB.md, "Validation"), then the alignment.
    let mut shifted = AlignedBytes::zeroed(data.len() + 1);
    shifted[1..].copy_from_slice(data);
    let misaligned = Blob::parse(&shifted[1..]);
    match first {
        Ok(_) => assert_eq!(misaligned.err(), Some(blob::BlobError::Misaligned)),
        Err(e) => assert!(
            misaligned.is_err(),
            "misaligned blob accepted ({e:?} aligned)"
        ),
    }

    let sealed = AlignedBytes::copy_from(&reseal(data));
    if let Ok(b) = Blob::parse(&sealed) {
        check_accepted(&b);
        accepted += 1;
    }
    accepted
}

/// Everything an accepted blob promises (docs/BLOB.md).
fn check_accepted(b: &Blob<'_>) {
    let records: Vec<CellRecord> = b.cells().map(|c| c.to_record()).collect();
    assert_eq!(
        records.len(),
        b.cell_count(),
        "a cell of a parsed blob is missing"
    );
    for (i, rec) in records.iter().enumerate() {
        let c = b.cell(i).expect("cell(i) of a parsed blob");
        assert_eq!(b.find(&rec.name).map(|f| f.name), Some(c.name));
        let (nu, nv) = (c.nu() as usize, c.nv() as usize);
        assert_eq!(c.nodes.len(), nu * nv);
        assert_eq!(c.triangles.len(), 2 * nu * nv);
        assert_eq!(c.tri_material.len(), c.triangles.len());
        assert_eq!(c.chi.len(), c.nodes.len());
        assert!(c.height().is_finite() && c.height() > 0.0);
        for t in c.triangles {
            assert!(t.iter().all(|&v| (v as usize) < c.nodes.len()));
        }
        for &m in c.tri_material {
            assert!((m as usize) < c.materials.len());
        }
    }
    assert!(b.cell(b.cell_count()).is_none());
    // A valid blob has exactly one encoding: the writer reproduces it byte for byte.
    let again = blob::write(&records).expect("the writer accepts what the reader accepted");
    assert!(again == b.as_bytes(), "re-encoding changed the bytes");
    // Its cells are usable materials.
    if b.cell_count() > 0 {
        cells_build_a_world(b);
    }
}

/// A 4×4 sheet whose triangles use every cell of `b` in turn: builds, and steps finitely (or
/// fails cleanly).
fn cells_build_a_world(b: &Blob<'_>) {
    let sheet = Grid::new(4, 4, 0.3, 0.3);
    let materials: Vec<u32> = (0..sheet.triangles.len())
        .map(|t| (t % b.cell_count()) as u32)
        .collect();
    let def = ClothDef {
        positions: &sheet.positions,
        uvs: &sheet.uvs,
        triangles: &sheet.triangles,
        materials: &materials,
    };
    let cap = sheet.capacity();
    let mut mem = vec![0u8; cap.world_bytes()];
    match World::new(&mut mem, cap, &def, Materials::Blob(b), Settings::default()) {
        Ok(mut w) => {
            check_world(&w);
            for _ in 0..2 {
                let before = snapshot(&w);
                if w.step().is_err() {
                    assert_unchanged(&w, &before, "failed step");
                }
                check_world(&w);
            }
        }
        // Validated cells can still be unusable at run time (e.g. a density whose lumped mass
        // overflows f32); that must be an init error, nothing else.
        Err(e) => assert!(
            matches!(e, InitError::InvalidMaterial { .. }),
            "a validated blob's cell was refused: {e:?}"
        ),
    }
}

// ---------------------------------------------------------------------------------------------
// Decoding fuzz bytes
// ---------------------------------------------------------------------------------------------

/// A forgiving byte reader: every read succeeds, yielding zeros once the data runs out, so every
/// byte string is a valid input and a zero byte always means "the ordinary choice".
pub struct Input<'a> {
    data: &'a [u8],
}

/// Special floats a fuzzer would take long to hit by flipping bits.
const SPECIAL: [f32; 20] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e-3,
    1e-7,
    1e-30,
    1e30,
    -1e30,
    1e20,
    f32::MAX,
    f32::MIN,
    f32::MIN_POSITIVE,
    1e-45, // subnormal
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    3.0e38,
    -1e-30,
];

impl<'a> Input<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Input { data }
    }

    pub fn byte(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }

    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.byte(), self.byte()])
    }

    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.byte(), self.byte(), self.byte(), self.byte()])
    }

    /// `default` most of the time (tag < 128), else a special value, a small fraction or raw bits.
    pub fn f32_or(&mut self, default: f32) -> f32 {
        let tag = self.byte();
        match tag {
            0..=127 => default,
            128..=175 => SPECIAL[usize::from(tag - 128) % SPECIAL.len()],
            176..=239 => f32::from(self.u16() as i16) / 256.0,
            _ => f32::from_bits(self.u32()),
        }
    }

    /// `default` plus a small offset (tag < 128: unchanged), or a replacement as [`f32_or`].
    pub fn nudge(&mut self, default: f32) -> f32 {
        let tag = self.byte();
        match tag {
            0..=127 => default,
            128..=191 => default + f32::from(self.byte() as i8) / 512.0,
            _ => self.f32_or(default),
        }
    }

    pub fn f64_or(&mut self, default: f64) -> f64 {
        let tag = self.byte();
        match tag {
            0..=127 => default,
            128..=175 => f64::from(SPECIAL[usize::from(tag - 128) % SPECIAL.len()]),
            176..=191 => [1e300, -1e300, f64::MAX, 1e-300, 5e-324][usize::from(tag - 176) % 5],
            192..=239 => f64::from(self.u16() as i16) * 10.0,
            _ => f64::from_bits(u64::from(self.u32()) << 32 | u64::from(self.u32())),
        }
    }

    /// An index below `n + 2` (so sometimes just out of range), or rarely any u32.
    pub fn index(&mut self, n: usize) -> u32 {
        let tag = self.byte();
        if tag == 255 {
            self.u32()
        } else {
            (usize::from(tag) % (n + 2)) as u32
        }
    }

    pub fn vec3_or(&mut self, d: [f32; 3]) -> [f32; 3] {
        [self.f32_or(d[0]), self.f32_or(d[1]), self.f32_or(d[2])]
    }
}

// ---------------------------------------------------------------------------------------------
// World
// ---------------------------------------------------------------------------------------------

/// An owned grid sheet (positions = (u, v, 0)).
pub struct Grid {
    pub positions: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
}

impl Grid {
    pub fn new(nx: usize, ny: usize, width: f32, height: f32) -> Grid {
        let mut positions = vec![[0.0; 3]; nx * ny];
        let mut uvs = vec![[0.0; 2]; nx * ny];
        let mut triangles = vec![[0; 3]; 2 * (nx - 1) * (ny - 1)];
        // Sizes decoded from fuzz bytes may be anything; the grid itself only fails on nx < 2.
        let _ = weft::mesh::grid(
            nx,
            ny,
            width,
            height,
            &mut positions,
            &mut uvs,
            &mut triangles,
        );
        Grid {
            positions,
            uvs,
            triangles,
        }
    }

    pub fn capacity(&self) -> Capacity {
        Capacity {
            vertices: self.positions.len() as u32,
            triangles: self.triangles.len() as u32,
            edges: (3 * self.triangles.len() as u32).max(16),
            colliders: 4,
            pins: 16,
        }
    }
}

/// The cell blob the world target draws `Materials::Blob` from: two small homogenized cells
/// (the bundled stripes pattern, shrunk, and a homogeneous one), built once.
pub fn material_blob() -> Blob<'static> {
    static BYTES: OnceLock<AlignedBytes> = OnceLock::new();
    let bytes = BYTES.get_or_init(|| AlignedBytes::copy_from(&small_blob_bytes()));
    Blob::parse(bytes).expect("the harness blob is valid")
}

/// Two tiny cells homogenized by the library itself, written with `blob::write`.
pub fn small_blob_bytes() -> Vec<u8> {
    let stripes = r###"
name = "stripes4"
size = 0.01
pattern = ["##", "..", "##", ".."]
[materials."#"]
stiffness = 2000.0
poisson = 0.3
density = 0.2
bending = 2.0e-5
[materials."."]
stiffness = 200.0
poisson = 0.3
density = 0.1
bending = 5.0e-6
"###;
    let plain = r###"
name = "plain"
size = 0.004
pattern = ["x"]
[materials."x"]
tensor = [[600.0, 60.0, 0.0], [60.0, 150.0, 0.0], [0.0, 0.0, 50.0]]
density = 0.15
"###;
    let records: Vec<CellRecord> = [(stripes, 1), (plain, 2)]
        .iter()
        .map(|(text, refine)| homogenized(text, *refine))
        .collect();
    blob::write(&records).expect("valid cells")
}

/// Parses a cell description and homogenizes it at `refine`.
pub fn homogenized(text: &str, refine: usize) -> CellRecord {
    let desc = weft::cell::parse(text, "fuzz.toml", std::path::Path::new(".")).expect("cell");
    let mesh = weft::cell::mesh_cell(&desc, refine);
    let h = weft::homogenize::homogenize(&desc, &mesh, &mut |_| {}).expect("homogenize");
    weft::homogenize::record(&desc, &mesh, refine, &h)
}

fn material(input: &mut Input<'_>) -> Material {
    let base = match input.byte() % 3 {
        0 => Material {
            stiffness: weft::membrane::isotropic(1000.0, 0.3),
            density: 0.2,
            bending: 1e-4,
        },
        1 => Material {
            stiffness: [[600.0, 60.0, 0.0], [60.0, 150.0, 0.0], [0.0, 0.0, 50.0]],
            density: 0.15,
            bending: 1e-5,
        },
        _ => Material {
            stiffness: weft::membrane::isotropic(input.f64_or(500.0), input.f64_or(0.25)),
            density: input.f64_or(0.1),
            bending: input.f64_or(1e-6),
        },
    };
    let mut m = base;
    for _ in 0..input.byte() % 4 {
        let k = usize::from(input.byte() % 11);
        match k {
            0..=8 => m.stiffness[k / 3][k % 3] = input.f64_or(m.stiffness[k / 3][k % 3]),
            9 => m.density = input.f64_or(m.density),
            _ => m.bending = input.f64_or(m.bending),
        }
    }
    m
}

fn edit_settings(input: &mut Input<'_>, mut s: Settings) -> Settings {
    for _ in 0..input.byte() % 5 {
        match input.byte() % 16 {
            0 => {
                s.effects = match input.byte() % 4 {
                    0 => effects::ALL,
                    1 => input.u32(),
                    _ => u32::from(input.u16()) & effects::ALL,
                }
            }
            1 => s.time_step = input.f32_or(1.0 / 30.0),
            2 => {
                s.substeps = match input.byte() % 8 {
                    0 => 0,
                    1 => 1000,
                    2 => 1001,
                    3 => u32::MAX,
                    k => u32::from(k) - 2,
                }
            }
            3 => s.gravity = input.vec3_or(s.gravity),
            4 => s.damping_mass = input.f32_or(1.0),
            5 => s.damping_stiffness = input.f32_or(0.01),
            6 => s.wind = input.vec3_or([3.0, 0.0, 0.0]),
            7 => s.drag = input.f32_or(0.5),
            8 => s.tolerance = input.f32_or(1e-6),
            // A caller asking for 4 billion iterations gets them; the harness stays quick.
            9 => s.max_iterations = [0, 1, 5, 50, 1000][usize::from(input.byte() % 5)],
            // Per-node warping is a research option: without the feature the byte still
            // counts (the corpus keeps its meaning) but the world stays per-element.
            10 => s.per_node_warping = input.byte() % 2 == 1 && cfg!(feature = "research"),
            11 => s.rotation_iterations = u32::from(input.byte() % 32),
            12 => s.sleep_velocity = input.f32_or(0.5),
            13 => s.sleep_frames = [0, 1, 2, u32::MAX][usize::from(input.byte() % 4)],
            14 => s.effects ^= 1 << (input.byte() % 12),
            _ => s = Settings::default(),
        }
    }
    s
}

fn shape(input: &mut Input<'_>) -> Shape {
    match input.byte() % 3 {
        0 => {
            let n = input.vec3_or([0.0, 0.0, 1.0]);
            Shape::Plane {
                normal: n.into(),
                offset: input.f32_or(-0.05),
            }
        }
        1 => Shape::Sphere {
            center: input.vec3_or([0.2, 0.2, -0.1]).into(),
            radius: input.f32_or(0.15),
        },
        _ => Shape::Capsule {
            a: input.vec3_or([0.0, 0.1, -0.05]).into(),
            b: input.vec3_or([0.4, 0.1, -0.05]).into(),
            radius: input.f32_or(0.05),
        },
    }
}

/// The cloth a world input describes.
struct Cloth {
    positions: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    triangles: Vec<[u32; 3]>,
}

fn cloth(input: &mut Input<'_>) -> Cloth {
    let mode = input.byte() % 4;
    let mut c = if mode < 3 {
        let (nx, ny) = (
            2 + usize::from(input.byte() % 6),
            2 + usize::from(input.byte() % 6),
        );
        let (w, h) = (input.f32_or(0.4), input.f32_or(0.3));
        let g = Grid::new(nx, ny, w, h);
        Cloth {
            positions: g.positions,
            uvs: g.uvs,
            triangles: g.triangles,
        }
    } else {
        // Random triangles over random vertices.
        let n = usize::from(input.byte() % 12);
        let mut positions = Vec::with_capacity(n);
        let mut uvs = Vec::with_capacity(n);
        for _ in 0..n {
            let (u, v) = (
                f32::from(input.byte()) / 256.0,
                f32::from(input.byte()) / 256.0,
            );
            uvs.push([input.f32_or(u), input.f32_or(v)]);
            positions.push(input.vec3_or([u, v, 0.0]));
        }
        let nt = usize::from(input.byte() % 16);
        let triangles = (0..nt)
            .map(|_| [input.index(n), input.index(n), input.index(n)])
            .collect();
        Cloth {
            positions,
            uvs,
            triangles,
        }
    };
    // Edits: perturbed, degenerate, repeated, out-of-range, flipped, duplicated triangles.
    let (n, nt) = (c.positions.len(), c.triangles.len());
    for _ in 0..input.byte() % 8 {
        let kind = input.byte() % 6;
        let v = usize::from(input.u16()) % n.max(1);
        let t = usize::from(input.u16()) % nt.max(1);
        let k = usize::from(input.byte() % 3);
        match kind {
            0 if n > 0 => c.positions[v][k] = input.f32_or(c.positions[v][k]),
            1 if n > 0 => c.positions[v][k] = input.nudge(c.positions[v][k]),
            2 if n > 0 => c.uvs[v][k % 2] = input.nudge(c.uvs[v][k % 2]),
            3 if nt > 0 => c.triangles[t][k] = input.index(n),
            4 if nt > 0 => c.triangles[t].swap(k, (k + 1) % 3),
            5 if nt > 0 => {
                let other = usize::from(input.u16()) % nt;
                c.triangles[t] = c.triangles[other];
            }
            _ => {}
        }
    }
    c
}

/// Decodes `data` into a world and drives it. Returns `World::new`'s error, if it refused.
pub fn world(data: &[u8]) -> Result<(), InitError> {
    let mut input = Input::new(data);
    let cloth = cloth(&mut input);
    let (n, nt) = (cloth.positions.len(), cloth.triangles.len());

    // Materials: a table, the harness blob, or nothing.
    let blob = material_blob();
    let table: Vec<Material> = (0..1 + input.byte() % 3)
        .map(|_| material(&mut input))
        .collect();
    let source = input.byte() % 4;
    let n_materials = match source {
        0 | 1 => table.len(),
        2 => blob.cell_count(),
        _ => 0,
    };
    let materials = match source {
        0 | 1 => Materials::Table(&table),
        2 => Materials::Blob(&blob),
        _ => Materials::Table(&[]),
    };
    let mut tri_materials: Vec<u32> = (0..nt).map(|t| (t % n_materials.max(1)) as u32).collect();
    for _ in 0..input.byte() % 4 {
        match input.byte() % 4 {
            0 => {
                tri_materials.pop();
            }
            1 => tri_materials.push(0),
            _ => {
                if let Some(len) = core::num::NonZeroUsize::new(tri_materials.len()) {
                    let t = usize::from(input.u16()) % len.get();
                    tri_materials[t] = input.index(n_materials);
                }
            }
        }
    }

    // Capacity and memory: exact, short by one here and there, or absurd.
    let mut cap = Capacity {
        vertices: n as u32,
        triangles: nt as u32,
        edges: (3 * nt as u32).max(4),
        colliders: u32::from(input.byte() % 5),
        pins: u32::from(input.byte() % 9),
    };
    match input.byte() % 12 {
        1 => cap.vertices = cap.vertices.saturating_sub(1),
        2 => cap.triangles = cap.triangles.saturating_sub(1),
        3 => cap.edges = u32::from(input.byte() % 16),
        4 => cap.vertices = u32::MAX,
        5 => cap.edges = u32::MAX,
        6 => cap.vertices += 7,
        _ => {}
    }
    // Absurd capacities get a small block (and MemoryTooSmall): no need to page in gigabytes.
    const MAX_MEMORY: usize = 1 << 20;
    let needed = cap.world_bytes();
    let mut len = needed.min(MAX_MEMORY);
    let mut offset = 0;
    match input.byte() % 8 {
        1 => len = len.saturating_sub(1),
        2 => offset = 1 + usize::from(input.byte() % 15),
        _ => {}
    }
    let mut block = vec![0u8; len + offset];
    // Fill with garbage: World::new must initialize every byte it reads.
    block.fill(0xA5);
    let memory = &mut block[offset..];

    let settings = edit_settings(&mut input, Settings::default());
    let def = ClothDef {
        positions: &cloth.positions,
        uvs: &cloth.uvs,
        triangles: &cloth.triangles,
        materials: &tri_materials,
    };
    let valid_settings = settings.validate().is_ok();
    let mut w = match World::new(memory, cap, &def, materials, settings) {
        Ok(w) => w,
        Err(e) => {
            if !valid_settings {
                assert!(matches!(e, InitError::InvalidSetting { .. }), "{e:?}");
            }
            if len < needed {
                assert!(
                    !valid_settings
                        || matches!(
                            e,
                            InitError::MemoryTooSmall
                                | InitError::VertexCapacity { .. }
                                | InitError::TriangleCapacity { .. }
                                | InitError::MaterialCount
                                | InitError::Mesh(_)
                        ),
                    "short memory gave {e:?}"
                );
            }
            return Err(e);
        }
    };
    assert!(valid_settings, "World::new accepted invalid settings");
    assert!(len >= needed, "World::new accepted too little memory");
    assert_eq!(w.vertex_count(), n);
    assert_eq!(w.triangle_count(), nt);
    check_world(&w);

    // Edits and steps.
    for _ in 0..input.byte() % 16 {
        let before = snapshot(&w);
        let op = input.byte() % 12;
        match op {
            0 | 1 => {
                let r = if op == 0 {
                    w.step()
                } else {
                    w.step_dt(input.f32_or(1.0 / 60.0))
                };
                if let Err(e) = r {
                    assert_unchanged(&w, &before, "failed step");
                    if let StepError::NonFinitePin { vertex } = e {
                        assert!((vertex as usize) < n);
                    }
                }
            }
            2 => {
                let v = input.index(n);
                let at = w
                    .positions()
                    .get(v as usize)
                    .map_or([0.0; 3], |p| p.to_array());
                let target = [
                    input.nudge(at[0]),
                    input.nudge(at[1]),
                    input.nudge(at[2] + 0.01),
                ];
                let r = w.set_pin(v, target);
                if (v as usize) >= n {
                    assert_eq!(r, Err(EditError::VertexOutOfRange));
                }
                assert_unchanged(&w, &before, "set_pin");
            }
            3 => {
                let v = input.index(n);
                let pins = w.pin_count();
                let r = w.remove_pin(v);
                assert!(r.is_ok() || (v as usize) >= n);
                assert!(w.pin_count() <= pins);
                assert_unchanged(&w, &before, "remove_pin");
            }
            4 => {
                let s = shape(&mut input);
                let c = Collider::new(s, input.f32_or(0.3), input.f32_or(0.005));
                let count = w.collider_count();
                match w.add_collider(c) {
                    Ok(i) => assert_eq!(i as usize, count),
                    Err(_) => assert_eq!(w.collider_count(), count),
                }
                assert_unchanged(&w, &before, "add_collider");
            }
            5 => {
                let i = u32::from(input.byte() % 5);
                let s = shape(&mut input);
                let old = w.collider(i).copied();
                if w.set_collider_shape(i, s).is_err() {
                    assert_eq!(w.collider(i).copied(), old);
                }
                assert_unchanged(&w, &before, "set_collider_shape");
            }
            6 => w.clear_colliders(),
            7 | 8 => {
                let mut values: Vec<[f32; 3]> = if op == 7 {
                    w.positions().iter().map(|p| p.to_array()).collect()
                } else {
                    w.velocities().iter().map(|p| p.to_array()).collect()
                };
                if input.byte().is_multiple_of(8) {
                    values.pop();
                }
                for _ in 0..input.byte() % 3 {
                    if let Some(len) = core::num::NonZeroUsize::new(values.len()) {
                        let v = usize::from(input.u16()) % len.get();
                        let k = usize::from(input.byte() % 3);
                        values[v][k] = input.nudge(values[v][k]);
                    }
                }
                let r = if op == 7 {
                    w.set_positions(&values)
                } else {
                    w.set_velocities(&values)
                };
                if r.is_err() {
                    assert_unchanged(&w, &before, "set_positions/velocities");
                }
            }
            9 => {
                let old = *w.settings();
                let s = edit_settings(&mut input, old);
                match w.set_settings(s) {
                    Ok(()) => assert_eq!(*w.settings(), s),
                    Err(_) => assert_eq!(*w.settings(), old),
                }
            }
            10 => {
                let short = input.byte().is_multiple_of(4);
                let mut out = vec![glam::Vec3A::ZERO; n.saturating_sub(usize::from(short))];
                let ok = w.elastic_forces(&mut out);
                if short && n > 0 {
                    assert!(!ok);
                }
            }
            _ => w.wake(),
        }
        check_world(&w);
    }
    Ok(())
}

/// Positions and velocities, to compare across a call that failed.
pub struct Snapshot {
    x: Vec<glam::Vec3A>,
    v: Vec<glam::Vec3A>,
}

pub fn snapshot(w: &World<'_>) -> Snapshot {
    Snapshot {
        x: w.positions().to_vec(),
        v: w.velocities().to_vec(),
    }
}

/// Bit-for-bit the same state (a failed call must not move anything; NaN cannot be there).
pub fn assert_unchanged(w: &World<'_>, s: &Snapshot, what: &str) {
    assert!(
        w.positions() == s.x.as_slice() && w.velocities() == s.v.as_slice(),
        "{what} changed the state"
    );
}

/// The world's invariants: finite state, finite non-negative masses, finite total mass.
pub fn check_world(w: &World<'_>) {
    assert!(
        w.positions().iter().all(|p| p.is_finite()),
        "non-finite position"
    );
    assert!(
        w.velocities().iter().all(|v| v.is_finite()),
        "non-finite velocity"
    );
    assert!(
        w.masses().iter().all(|m| m.is_finite() && *m >= 0.0),
        "non-finite mass"
    );
    assert!(w.total_mass().is_finite(), "non-finite total mass");
}

// ---------------------------------------------------------------------------------------------
// Seeds
// ---------------------------------------------------------------------------------------------

/// Small valid blobs: the bundled cells homogenized by the library at refine 1 (when
/// `cells_dir` holds them), the harness blob, an empty blob, and a one-pixel cell.
pub fn blob_seeds(cells_dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut seeds = vec![
        ("empty".to_string(), blob::write(&[]).expect("empty blob")),
        ("two-small-cells".to_string(), small_blob_bytes()),
    ];
    let one = r###"
name = "one"
size = 0.002
pattern = ["o"]
[materials."o"]
stiffness = 800.0
poisson = 0.2
density = 0.3
"###;
    seeds.push((
        "one-pixel".to_string(),
        blob::write(&[homogenized(one, 1)]).expect("one pixel"),
    ));
    for name in ["stripes", "three"] {
        let path = cells_dir.join(format!("{name}.toml"));
        if path.exists() {
            let b = weft::homogenize::build_blob(&[path], 1, &mut |_, _| {}).expect("bundled");
            seeds.push((format!("{name}-refine1"), b));
        }
    }
    seeds
}

/// World inputs in the [`world`] encoding (see [`cloth`], [`material`], [`edit_settings`]).
pub fn world_seeds() -> Vec<(String, Vec<u8>)> {
    vec![
        // All defaults: a 2×2 grid, table material, 16 zero-ops.
        ("defaults".into(), vec![]),
        // 7×7 grid (mode 0, nx 5+2, ny 5+2), one material, 8 pins capacity,
        // then 8 ops: pin vertex 0, pin vertex 6, add a sphere, step ×5.
        (
            "grid7-pins-sphere-steps".into(),
            vec![
                0, 5, 5, 0, 0, // cloth: grid 7×7, default size
                0, // no edits
                0, 0, 0, // one material, kind 0, no edits
                0, // table
                0, // no material edits
                4, 8, 0, 0, // colliders 4, pins 8, capacity and memory as needed
                0, // settings unchanged
                8, // 8 ops
                2, 0, 0, 0, 0, // pin vertex 0 at its place (+0.01 z)
                2, 6, 0, 0, 0, // pin vertex 6
                4, 1, 0, 0, 0, 0, 0, 0, // sphere, default centre/radius/friction/thickness
                0, 0, 0, 0, 0, // five steps
            ],
        ),
        // Random triangles over random vertices (mode 3): 5 vertices, 3 triangles (CCW in uv).
        (
            "raw-triangles".into(),
            vec![
                3, 5, // mode raw, 5 vertices
                10, 20, 0, 0, 0, 0, 0, //
                200, 30, 0, 0, 0, 0, 0, //
                100, 200, 0, 0, 0, 0, 0, //
                30, 150, 0, 0, 0, 0, 0, //
                250, 250, 0, 0, 0, 0, 0, //
                3, 0, 1, 2, 1, 4, 2, 0, 2, 3, // 3 triangles
                0, // no edits
                0, 0, 0, 0, 0, // one table material, no per-triangle edits
                2, 2, 0, 0, // capacity and memory as needed
                0, // default settings
                4, 0, 0, 0, 0, // four steps
            ],
        ),
        // Per-node warping, wind, blob materials, a few steps.
        (
            "grid-blob-wind-per-node".into(),
            vec![
                1, 3, 2, 0, 0, 0, // grid 5×4
                0, 0, 0, // material
                2, // blob materials
                0, // no material edits
                2, 2, 0, 0, // capacity and memory as needed
                3, 10, 1, 6, 0, 0, 0, 14, 5, // per-node warping, wind [3,0,0], WIND on
                4, 0, 0, 0, 0, // four steps
            ],
        ),
        // NaN pin target then steps, then the pin removed.
        (
            "nan-pin".into(),
            vec![
                0, 2, 2, 0, 0, 0, // grid 4×4
                0, 0, 0, 0, 0, // one table material
                3, 4, 0, 0, // capacity and memory as needed
                0, // default settings
                4, // four ops:
                2, 3, 0, 0, 192, 143, // pin vertex 3 with z = NaN
                0,   // step (refused: NonFinitePin)
                3, 3, // remove the pin
                0, // step
            ],
        ),
    ]
}
