//! The demo: `cargo run --release`.
//!
//! 1. homogenizes the bundled cells (`cells/*.toml`) into `out/cells.weft`, prints what the blob
//!    holds and renders `out/cells.png` (the same code as `weft-cell build/inspect/preview`);
//! 2. drops a 1 m × 1 m cloth of each cell onto a sphere and lets it drape, printing the
//!    per-step cost, and writes the last frame of each as `out/drape-<cell>.obj`.

#[path = "weft-cell/inspect.rs"]
mod inspect;
#[path = "weft-cell/preview.rs"]
mod preview;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3A;
use weft::blob::{load_aligned, Blob};
use weft::collide::{Collider, Shape};
use weft::world::{Capacity, ClothDef, Materials, Settings, World};

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
    let bytes =
        weft::homogenize::build_blob(&cells, 2, &mut |_, _| {}).map_err(|e| e.to_string())?;
    let blob_path = out.join("cells.weft");
    std::fs::write(&blob_path, &bytes).map_err(|e| format!("{}: {e}", blob_path.display()))?;
    println!(
        "homogenized {} cells (refine 2) in {:.1} ms → {}",
        cells.len(),
        t0.elapsed().as_secs_f64() * 1e3,
        blob_path.display()
    );
    inspect::run(&blob_path, false)?;
    let png = out.join("cells.png");
    preview::run(&blob_path, &png)?;
    println!("preview → {}\n", png.display());

    // 2. runtime
    let aligned = load_aligned(&blob_path).map_err(|e| format!("{}: {e}", blob_path.display()))?;
    let blob = Blob::parse(&aligned).map_err(|e| format!("blob: {e}"))?;
    for cell in 0..blob.cell_count() {
        drape(&blob, cell as u32, &out)?;
    }
    Ok(())
}

/// A 41×41-vertex sheet of cell `cell` dropped on a sphere; two seconds at 60 Hz.
fn drape(blob: &Blob<'_>, cell: u32, out: &Path) -> Result<(), String> {
    let n = 41usize;
    let mut positions = vec![[0.0f32; 3]; n * n];
    let mut uvs = vec![[0.0f32; 2]; n * n];
    let mut triangles = vec![[0u32; 3]; 2 * (n - 1) * (n - 1)];
    weft::mesh::grid(n, n, 1.0, 1.0, &mut positions, &mut uvs, &mut triangles)
        .map_err(|e| format!("{e:?}"))?;
    for p in &mut positions {
        *p = [p[0] - 0.5, p[1] - 0.5, 0.5];
    }
    let materials = vec![cell; triangles.len()];
    let cap = Capacity::grid(n as u32);
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
    let mut world = World::new(&mut memory, cap, &def, Materials::Blob(blob), settings)
        .map_err(|e| format!("{e:?}"))?;
    world
        .add_collider(Collider::new(
            Shape::Sphere {
                center: Vec3A::ZERO,
                radius: 0.25,
            },
            0.4,
            0.005,
        ))
        .map_err(|e| format!("{e:?}"))?;
    world
        .add_collider(Collider::new(
            Shape::Plane {
                normal: Vec3A::Z,
                offset: -0.3,
            },
            0.6,
            0.005,
        ))
        .map_err(|e| format!("{e:?}"))?;
    let mut times = Vec::new();
    let mut iterations = 0u64;
    for _ in 0..120 {
        let t = Instant::now();
        let s = world.step().map_err(|e| format!("{e:?}"))?;
        times.push(t.elapsed().as_secs_f64() * 1e6);
        iterations += s.iterations as u64;
    }
    times.sort_by(f64::total_cmp);
    let name = blob.cell(cell as usize).map(|c| c.name).unwrap_or("cell");
    println!(
        "drape '{name}': {n}×{n} vertices, 120 steps of 1/60 s (2 substeps): median {:.0} µs/step, {:.1} CG iterations/step",
        times[times.len() / 2],
        iterations as f64 / 120.0
    );
    let obj = out.join(format!("drape-{name}.obj"));
    let mut text = String::new();
    for p in world.positions() {
        let _ = writeln!(text, "v {} {} {}", p.x, p.y, p.z);
    }
    for t in world.triangles() {
        let _ = writeln!(text, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(&obj, text).map_err(|e| format!("{}: {e}", obj.display()))?;
    println!("  last frame → {}", obj.display());
    Ok(())
}
