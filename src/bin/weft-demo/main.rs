//! The demo: `cargo run --release`.
//!
//! 1. homogenizes the bundled cells (`cells/*.toml`) into `out/cells.weft`, prints what the blob
//!    holds and renders `out/cells.png` (the same code as `weft-cell build/inspect/preview`);
//! 2. for each cell, drops a 0.3 m × 0.3 m coarse cloth (31×31 vertices, one cell per coarse
//!    quad) onto a sphere and the floor, and every step localizes the cell's own micro mesh
//!    tiled over the whole cloth (§6) onto it; prints the per-step cost of the coarse step and
//!    of the localization;
//! 3. writes the fine (localized) mesh as one animated glTF binary, `out/drape-<cell>.glb`
//!    (a frame every 0.1 s with the sphere and the floor; Blender and web viewers play it), its
//!    last frame as `out/drape-<cell>.obj` (uv, normals, one material per cell material,
//!    `out/drape.mtl`), and renders the last frames as `out/drape.png`.

mod glb;
#[path = "../weft-cell/inspect.rs"]
mod inspect;
#[path = "../weft-cell/preview.rs"]
mod preview;
#[allow(dead_code)]
#[path = "../weft-study/render.rs"]
mod render;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3A;
use weft::blob::{load_aligned, Blob};
use weft::collide::{Collider, Shape};
use weft::localize::{self, Binding, NormalTarget, StrainMeasure, VertexFrame};
use weft::strided::{Strided, StridedMut};
use weft::world::{Capacity, ClothDef, Settings, World};

use preview::{material_colour, Image, INK};
use render::{Camera, Depth, Panel};

/// Coarse vertices per side, sheet size (m), steps of 1/60 s, an animation frame every this
/// many steps.
const N: usize = 31;
const SIZE: f32 = 0.3;
const STEPS: usize = 120;
const FRAME_EVERY: usize = 6;
const SPHERE_RADIUS: f32 = 0.09;
const FLOOR: f32 = -0.09;

fn main() {
    if let Err(e) = run() {
        eprintln!("weft-demo: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = root.join("out");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let cells: Vec<PathBuf> = ["stripes", "three"]
        .iter()
        .map(|n| root.join("cells").join(format!("{n}.toml")))
        .collect();

    // 1. precompute
    let t0 = Instant::now();
    let refine = 1;
    let bytes =
        weft::homogenize::build_blob(&cells, refine, &mut |_, _| {}).map_err(|e| e.to_string())?;
    let blob_path = out.join("cells.weft");
    std::fs::write(&blob_path, &bytes).map_err(|e| format!("{}: {e}", blob_path.display()))?;
    println!(
        "homogenized {} cells (refine {refine}) in {:.1} ms → {}",
        cells.len(),
        t0.elapsed().as_secs_f64() * 1e3,
        blob_path.display()
    );
    inspect::run(&blob_path, false)?;
    let cells_png = out.join("cells.png");
    preview::run(&blob_path, &cells_png)?;
    println!("preview → {}\n", cells_png.display());

    // 2. runtime
    let aligned = load_aligned(&blob_path).map_err(|e| format!("{}: {e}", blob_path.display()))?;
    let blob = Blob::parse(&aligned).map_err(|e| format!("blob: {e}"))?;
    write_mtl(&out)?;
    let mut shots = Vec::new();
    for cell in 0..blob.cell_count() {
        shots.push(drape(&blob, cell as u32, &out)?);
    }
    let png = out.join("drape.png");
    picture(&shots).save_png(&png)?;
    println!("\noutputs in {}:", out.display());
    let mut outputs = vec![
        (
            "cells.weft".to_string(),
            "the cell blob (weft-cell inspect reads it)",
        ),
        (
            "cells.png".into(),
            "the cells' materials and micro-deformations",
        ),
    ];
    for s in &shots {
        outputs.push((
            format!("drape-{}.glb", s.name),
            "the localized fine mesh, animated: open in Blender or a glTF viewer, press play",
        ));
        outputs.push((
            format!("drape-{}.obj", s.name),
            "its last frame (materials in drape.mtl)",
        ));
    }
    outputs.push(("drape.png".into(), "the last frames: fine, coarse, zoom"));
    for (file, what) in outputs {
        println!("  {file:<18} {what}");
    }
    Ok(())
}

/// The last frame of a drape, for the picture.
struct Shot {
    name: String,
    positions: Vec<Vec3A>,
    triangles: Vec<[u32; 3]>,
    materials: Vec<u32>,
    coarse: Vec<Vec3A>,
    coarse_triangles: Vec<[u32; 3]>,
}

/// A coarse cloth of cell `cell` dropped on a sphere, localized every step.
fn drape(blob: &Blob<'_>, cell: u32, out: &Path) -> Result<Shot, String> {
    let name = blob
        .cell(cell as usize)
        .map(|c| c.name.to_string())
        .unwrap_or_else(|| "cell".into());
    let mut positions = vec![[0.0f32; 3]; N * N];
    let mut uvs = vec![[0.0f32; 2]; N * N];
    let mut triangles = vec![[0u32; 3]; 2 * (N - 1) * (N - 1)];
    weft::mesh::grid(N, N, SIZE, SIZE, &mut positions, &mut uvs, &mut triangles)
        .map_err(|e| format!("{e:?}"))?;
    // just above the sphere, a little off centre so the drape is not symmetric
    for p in &mut positions {
        let (x, y) = (p[0] - 0.5 * SIZE, p[1] - 0.5 * SIZE);
        *p = [x, y, SPHERE_RADIUS + 0.01];
    }
    let materials = vec![cell; triangles.len()];
    let cap = Capacity::grid(N as u32);
    let mut memory = vec![0u8; cap.world_bytes()];
    let def = ClothDef {
        positions: &positions,
        uvs: &uvs,
        triangles: &triangles,
        materials: &materials,
    };
    let settings = Settings {
        substeps: 2,
        ..Settings::default()
    };
    let mut world = World::new(
        &mut memory,
        cap,
        &def,
        weft::world::Materials::Blob(blob),
        settings,
    )
    .map_err(|e| format!("{e:?}"))?;
    world
        .add_collider(Collider::new(
            Shape::Sphere {
                center: Vec3A::ZERO,
                radius: SPHERE_RADIUS,
            },
            0.9,
            0.002,
        ))
        .map_err(|e| format!("{e:?}"))?;
    world
        .add_collider(Collider::new(
            Shape::Plane {
                normal: Vec3A::Z,
                offset: FLOOR,
            },
            0.6,
            0.002,
        ))
        .map_err(|e| format!("{e:?}"))?;

    // The fine render mesh: the cell's micro mesh tiled over the cloth, bound once.
    let (nv, nt) = localize::tiled_mesh_counts(&world, blob, cell).map_err(|e| e.to_string())?;
    let mut fine_uv = vec![[0.0f32; 2]; nv];
    let mut fine_tris = vec![[0u32; 3]; nt];
    let mut fine_mats = vec![0u32; nt];
    localize::tiled_mesh(
        &world,
        blob,
        cell,
        &mut fine_uv,
        &mut fine_tris,
        Some(&mut fine_mats),
    )
    .map_err(|e| e.to_string())?;
    let t = Instant::now();
    let mut bindings = vec![Binding::ZERO; nv];
    localize::bind(&world, blob, &Strided::from_slice(&fine_uv), &mut bindings)
        .map_err(|e| e.to_string())?;
    let bind_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut frames = vec![VertexFrame::REST; world.vertex_count()];
    let mut fine_x = vec![[0.0f32; 3]; nv];
    let mut fine_n = vec![[0.0f32; 3]; nv];
    println!(
        "drape '{name}': {N}×{N} coarse vertices ({} triangles), fine mesh {nv} vertices / {nt} triangles (bound in {bind_ms:.1} ms)",
        world.triangle_count()
    );

    let (mut step_ms, mut loc_ms) = (Vec::new(), Vec::new());
    let mut iterations = 0u64;
    let mut frames_out = Vec::new();
    // Step 0 localizes the rest state: the animation's first frame.
    for s in 0..=STEPS {
        if s > 0 {
            let t = Instant::now();
            let stats = world.step().map_err(|e| format!("step {s}: {e:?}"))?;
            step_ms.push(t.elapsed().as_secs_f64() * 1e3);
            iterations += u64::from(stats.iterations);
        }
        let t = Instant::now();
        localize::prepare(&world, StrainMeasure::Corotated, &mut frames)
            .map_err(|e| e.to_string())?;
        localize::localize(
            &frames,
            world.triangles(),
            &bindings,
            0,
            &mut StridedMut::from_slice(&mut fine_x),
            Some(NormalTarget::Buffer(&mut StridedMut::from_slice(
                &mut fine_n,
            ))),
        )
        .map_err(|e| e.to_string())?;
        if s > 0 {
            loc_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        if s % FRAME_EVERY == 0 {
            frames_out.push(glb::Frame {
                time: s as f32 / 60.0,
                positions: fine_x.clone(),
                normals: fine_n.clone(),
            });
        }
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "  {STEPS} steps of 1/60 s (2 substeps): coarse step median {:.2} ms ({:.0} CG iterations/step), localization median {:.2} ms, total {:.2} ms/frame",
        med(&mut step_ms.clone()),
        iterations as f64 / STEPS as f64,
        med(&mut loc_ms.clone()),
        med(&mut step_ms) + med(&mut loc_ms),
    );
    let obj = out.join(format!("drape-{name}.obj"));
    write_obj(
        &obj, &name, &fine_x, &fine_n, &fine_uv, &fine_tris, &fine_mats,
    )?;
    let path = out.join(format!("drape-{name}.glb"));
    let scenery = Scenery::new();
    let xyz = |v: &[Vec3A]| v.iter().map(|p| p.to_array()).collect::<Vec<_>>();
    let sphere_n: Vec<[f32; 3]> = scenery
        .sphere_x
        .iter()
        .map(|p| (*p / SPHERE_RADIUS).to_array())
        .collect();
    let bytes = glb::write(
        &glb::Animated {
            name: &name,
            uvs: &fine_uv
                .iter()
                .map(|t| t.map(|c| c / SIZE))
                .collect::<Vec<_>>(),
            triangles: &fine_tris,
            materials: &fine_mats,
            colour: &material_colour,
            frames: &frames_out,
        },
        &[
            glb::Static {
                name: "sphere",
                positions: &xyz(&scenery.sphere_x),
                normals: Some(&sphere_n),
                triangles: &scenery.sphere_t,
                colour: SPHERE_COLOUR,
            },
            glb::Static {
                name: "floor",
                positions: &xyz(&scenery.floor_x),
                normals: None,
                triangles: &scenery.floor_t,
                colour: FLOOR_COLOUR,
            },
        ],
    );
    std::fs::write(&path, &bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    println!(
        "  {} frames → {} ({:.1} MB), last frame → {}",
        frames_out.len(),
        path.display(),
        bytes.len() as f64 / 1e6,
        obj.display()
    );
    Ok(Shot {
        name,
        positions: fine_x.iter().map(|p| Vec3A::from(*p)).collect(),
        triangles: fine_tris,
        materials: fine_mats,
        coarse: world.positions().to_vec(),
        coarse_triangles: world.triangles().to_vec(),
    })
}

/// One material per palette colour (`m0`, `m1`, ...), as the cells' material indices.
fn write_mtl(out: &Path) -> Result<(), String> {
    let mut text = String::new();
    for m in 0..10u32 {
        let c = material_colour(m).map(|v| f32::from(v) / 255.0);
        let _ = writeln!(
            text,
            "newmtl m{m}\nKd {:.3} {:.3} {:.3}\nKa 0 0 0\nKs 0.05 0.05 0.05\nNs 10\n",
            c[0], c[1], c[2]
        );
    }
    let path = out.join("drape.mtl");
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// A Wavefront OBJ with positions, uv, normals and a material group per cell material.
fn write_obj(
    path: &Path,
    name: &str,
    x: &[[f32; 3]],
    n: &[[f32; 3]],
    uv: &[[f32; 2]],
    tris: &[[u32; 3]],
    mats: &[u32],
) -> Result<(), String> {
    let mut text = String::with_capacity(x.len() * 90 + tris.len() * 40);
    let _ = writeln!(
        text,
        "# weft-demo: localized fine mesh of '{name}'\nmtllib drape.mtl\no {name}"
    );
    for p in x {
        let _ = writeln!(text, "v {:.6} {:.6} {:.6}", p[0], p[1], p[2]);
    }
    for t in uv {
        let _ = writeln!(text, "vt {:.6} {:.6}", t[0] / SIZE, t[1] / SIZE);
    }
    for v in n {
        let _ = writeln!(text, "vn {:.4} {:.4} {:.4}", v[0], v[1], v[2]);
    }
    let mut order: Vec<usize> = (0..tris.len()).collect();
    order.sort_by_key(|&t| mats[t]);
    let mut current = u32::MAX;
    for t in order {
        if mats[t] != current {
            current = mats[t];
            let _ = writeln!(text, "usemtl m{current}");
        }
        let [a, b, c] = tris[t].map(|i| i + 1);
        let _ = writeln!(text, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

const SPHERE_COLOUR: [u8; 3] = [200, 200, 200];
const FLOOR_COLOUR: [u8; 3] = [225, 215, 200];

/// The colliders as meshes, for the picture and the glTF.
struct Scenery {
    sphere_x: Vec<Vec3A>,
    sphere_t: Vec<[u32; 3]>,
    floor_x: [Vec3A; 4],
    floor_t: [[u32; 3]; 2],
}

impl Scenery {
    fn new() -> Scenery {
        let (sphere_x, sphere_t) = render::sphere_mesh(Vec3A::ZERO, SPHERE_RADIUS, 24);
        let f = 0.3;
        Scenery {
            sphere_x,
            sphere_t,
            floor_x: [(-f, -f), (f, -f), (f, f), (-f, f)].map(|(x, y)| Vec3A::new(x, y, FLOOR)),
            floor_t: [[0, 1, 2], [0, 2, 3]],
        }
    }
}

/// The last frame of each drape: the localized fine mesh (coloured by material), the coarse
/// cloth it came from, and a zoom on the fine mesh.
fn picture(shots: &[Shot]) -> Image {
    const P: usize = 320;
    const GAP: usize = 12;
    const LABEL: usize = 24;
    let width = 2 * GAP + 3 * P + 2 * GAP;
    let height = GAP + shots.len() * (LABEL + P + GAP);
    let mut img = Image::new(width, height);
    // Low enough (15° above the floor) to see the sphere under the cloth's hem.
    let toward = Vec3A::new(0.55, -0.75, 0.25).normalize();
    let Scenery {
        sphere_x,
        sphere_t,
        floor_x,
        floor_t,
    } = Scenery::new();
    for (row, s) in shots.iter().enumerate() {
        let y = GAP + row * (LABEL + P + GAP) + LABEL;
        let panels = [0, 1, 2].map(|c| Panel {
            x: GAP + c * (P + GAP),
            y,
            w: P,
            h: P,
        });
        let cam = Camera::fit(
            toward,
            Vec3A::Z,
            &[&s.positions, &sphere_x],
            &panels[0],
            10.0,
        );
        // Zoom on the cloth where it lies on the sphere halfway between facing the camera and
        // facing up: 4 cm of cloth around it all face the camera, so they fill the panel.
        let aim = (toward + Vec3A::Z).normalize() * SPHERE_RADIUS;
        let focus = s
            .positions
            .iter()
            .copied()
            .min_by(|a, b| a.distance_squared(aim).total_cmp(&b.distance_squared(aim)))
            .unwrap_or(aim);
        let zoom = cam.zoomed(focus, P as f32 / 0.04);
        let labels = [
            format!("{}: {} fine tri.", s.name, s.triangles.len()),
            format!("coarse: {} tri.", s.coarse_triangles.len()),
            "zoom, fine mesh".to_string(),
        ];
        for (c, panel) in panels.iter().enumerate() {
            img.fill_rect(panel.x, panel.y, panel.w, panel.h, [246, 246, 246]);
            img.text(panel.x, panel.y - LABEL + 4, &labels[c], INK);
            let camera = if c == 2 { &zoom } else { &cam };
            let mut depth = Depth::new(*panel);
            render::draw_mesh_with(
                &mut img,
                &mut depth,
                camera,
                &floor_x,
                &floor_t,
                &|_| FLOOR_COLOUR,
                None,
            );
            render::draw_mesh_with(
                &mut img,
                &mut depth,
                camera,
                &sphere_x,
                &sphere_t,
                &|_| SPHERE_COLOUR,
                None,
            );
            if c == 1 {
                render::draw_mesh_with(
                    &mut img,
                    &mut depth,
                    camera,
                    &s.coarse,
                    &s.coarse_triangles,
                    &|_| [150, 170, 200],
                    Some([60, 60, 60]),
                );
            } else {
                render::draw_mesh(
                    &mut img,
                    &mut depth,
                    camera,
                    &s.positions,
                    &s.triangles,
                    &s.materials,
                    if c == 2 { Some([70, 70, 70]) } else { None },
                );
            }
        }
    }
    img
}
