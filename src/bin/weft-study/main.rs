//! `weft-study`: accuracy and speed of coarse homogenized cloth + localization against the fine
//! heterogeneous reference (the paper's Fig. 4, 5, 7, 8).
//!
//! ```sh
//! cargo run --release --bin weft-study -- [--quick] --out DIR
//! ```
//!
//! Every scene runs twice on the same sheet, with the same time step, pins and colliders: once
//! as the fine reference (the cells' micro meshes tiled over the sheet, each triangle with its
//! own material, see `reference.rs`) and once per coarse configuration (homogenized `C^H` or the
//! naive area average of `C`, coarse resolution, CG tolerance, substeps, warping). The coarse
//! result is compared with the reference at every fine vertex, with localization on (the
//! localized positions) or off (the barycentric embedding). Outputs in DIR: `study.csv`,
//! `study.md`, `pareto.svg`, `strain.svg` and one PNG per pictured scene.

#[allow(dead_code)]
#[path = "../weft-cell/preview.rs"]
mod preview;

mod plot;
mod reference;
mod render;
mod report;
mod scenes;
mod upsample;

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Parser;
use glam::Vec3A;
use weft::blob::{AlignedBytes, Blob};
use weft::cell::CellDesc;
use weft::world::{Material, Materials, Settings, Solver, World};

use reference::Sheet;
use scenes::{Dir, Scene};
use upsample::{Mode, Upsampler};

#[derive(Parser)]
#[command(
    about = "Coarse homogenized cloth + localization against the fine heterogeneous reference"
)]
struct Args {
    /// A subset that finishes in a few minutes (every scene, both materials).
    #[arg(long)]
    quick: bool,
    /// A seconds-long smoke configuration (the test suite's): stripes, 2×2 cells.
    #[arg(long, conflicts_with = "quick")]
    tiny: bool,
    /// Skip the 288k-triangle speed measurement.
    #[arg(long)]
    no_bench: bool,
    /// Run only the cases whose `scene cell` contains this text (e.g. `drape`, `hang-v three`).
    #[arg(long)]
    only: Option<String>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

fn main() {
    let args = Args::parse();
    if let Err(e) = run(&args) {
        eprintln!("weft-study: {e}");
        std::process::exit(1);
    }
}

/// The cells of the study, by index in the blob.
pub const CELLS: [&str; 2] = ["stripes", "three"];
const STRIPES: usize = 0;
const THREE: usize = 1;

/// What a preset runs.
struct Preset {
    name: &'static str,
    /// Pixel refinement of the fine sheets and of the homogenization.
    refine: usize,
    stretch_tiles: usize,
    stretch_cells: Vec<usize>,
    dirs: Vec<Dir>,
    strains: Vec<f64>,
    /// The strain at which the stretches get the whole knob sweep.
    sweep_strain: f64,
    hang_tiles: usize,
    hangs: Vec<(usize, Dir)>,
    hang_gravity: f32,
    drape_tiles: usize,
    drape_cells: Vec<usize>,
    /// Coarse resolutions (cells per coarse quad side).
    resolutions: Vec<usize>,
    /// Whole knob sweep (CG, substeps, warping) besides material × resolution.
    knob_sweep: bool,
    bench: Option<Bench>,
    pictures: bool,
}

/// The speed measurement on a big fine sheet.
#[derive(Clone, Copy)]
struct Bench {
    cell: usize,
    refine: usize,
    tiles: usize,
    /// Coarse vertices per side.
    coarse_n: usize,
    /// Steps of the fine sheet at the runtime's CG settings and at the reference's.
    fine_steps: usize,
    reference_steps: usize,
    coarse_steps: usize,
}

impl Preset {
    fn full() -> Preset {
        Preset {
            name: "full",
            refine: 1,
            stretch_tiles: 8,
            stretch_cells: vec![STRIPES, THREE],
            dirs: vec![Dir::U, Dir::V, Dir::Diag],
            strains: vec![0.01, 0.02, 0.05, 0.10, 0.20],
            sweep_strain: 0.10,
            hang_tiles: 8,
            hangs: vec![
                (STRIPES, Dir::V),
                (STRIPES, Dir::U),
                (THREE, Dir::V),
                (THREE, Dir::U),
            ],
            hang_gravity: 1000.0,
            drape_tiles: 16,
            drape_cells: vec![STRIPES, THREE],
            resolutions: vec![1, 2, 4],
            knob_sweep: true,
            bench: Some(Bench {
                cell: THREE,
                refine: 2,
                tiles: 19,
                coarse_n: 21,
                fine_steps: 5,
                reference_steps: 2,
                coarse_steps: 100,
            }),
            pictures: true,
        }
    }

    fn quick() -> Preset {
        Preset {
            name: "quick",
            strains: vec![0.02, 0.10],
            hangs: vec![(STRIPES, Dir::V), (THREE, Dir::V)],
            drape_tiles: 8,
            resolutions: vec![1, 2],
            bench: Some(Bench {
                cell: THREE,
                refine: 2,
                tiles: 19,
                coarse_n: 21,
                fine_steps: 3,
                reference_steps: 0,
                coarse_steps: 60,
            }),
            ..Preset::full()
        }
    }

    fn tiny() -> Preset {
        Preset {
            name: "tiny",
            refine: 1,
            stretch_tiles: 2,
            stretch_cells: vec![STRIPES],
            dirs: vec![Dir::V, Dir::U],
            strains: vec![0.10],
            sweep_strain: 0.10,
            hang_tiles: 2,
            hangs: vec![],
            hang_gravity: 1000.0,
            drape_tiles: 2,
            drape_cells: vec![],
            resolutions: vec![1],
            knob_sweep: false,
            bench: None,
            pictures: true,
        }
    }
}

/// One coarse configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Knobs {
    pub averaged: bool,
    pub res: usize,
    pub tol: f32,
    pub max_iter: u32,
    pub substeps: u32,
    pub warping: bool,
    /// The CG preconditioner.
    pub solver: Solver,
}

impl Knobs {
    /// The runtime's defaults.
    pub const BASE: Knobs = Knobs {
        averaged: false,
        res: 1,
        tol: 1e-3,
        max_iter: 200,
        substeps: 1,
        warping: true,
        solver: Solver::Multigrid,
    };
    fn settings(&self, scene: &Scene) -> Settings {
        let base = Settings {
            tolerance: self.tol,
            max_iterations: self.max_iter,
            substeps: self.substeps,
            ..Settings::default()
        };
        scene.settings(base, self.warping)
    }
}

/// The CSV name of a solver.
pub fn solver_name(solver: Solver) -> &'static str {
    match solver {
        Solver::Multigrid => "multigrid",
        Solver::BlockJacobi => "block-jacobi",
        Solver::MultigridLines => "multigrid-lines",
    }
}

/// The fine reference's solver settings: the runtime's step with a tight CG (tolerance and
/// substeps per scene: `Scene::reference_tolerance`, `Scene::reference_substeps`).
pub const REFERENCE_MAX_ITER: u32 = 4000;

/// Everything the study needs about the cells.
struct Cells {
    descs: Vec<CellDesc>,
    blob: AlignedBytes,
    /// Per cell: the naive area average of `C` (the Voigt bound), same density and bending.
    averaged: Vec<Material>,
}

impl Cells {
    fn build(refine: usize) -> Result<Cells, String> {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("cells");
        let paths: Vec<PathBuf> = CELLS
            .iter()
            .map(|n| root.join(format!("{n}.toml")))
            .collect();
        let descs = paths
            .iter()
            .map(|p| weft::cell::load(p).map_err(|e| e.to_string()))
            .collect::<Result<Vec<_>, _>>()?;
        let bytes = weft::homogenize::build_blob(&paths, refine, &mut |_, _| {})
            .map_err(|e| e.to_string())?;
        let blob = AlignedBytes::copy_from(&bytes);
        let parsed = Blob::parse(&blob).map_err(|e| e.to_string())?;
        let averaged = parsed
            .cells()
            .map(|c| Material {
                stiffness: c.voigt_bound,
                density: c.density,
                bending: c.bending,
            })
            .collect();
        Ok(Cells {
            descs,
            blob,
            averaged,
        })
    }
    fn blob(&self) -> Result<Blob<'_>, String> {
        Blob::parse(&self.blob).map_err(|e| e.to_string())
    }
}

/// One row of `study.csv`.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub cell: String,
    /// `homogenized`, `averaged` or `fine`.
    pub material: String,
    /// Cells per coarse quad side; `None` for the fine sheet.
    pub coarse_res: Option<usize>,
    pub strain: Option<f64>,
    pub cg_tol: f32,
    pub cg_max_iter: u32,
    pub substeps: u32,
    pub warping: bool,
    /// `multigrid` or `block-jacobi`.
    pub solver: &'static str,
    /// `Some(mode)` for coarse rows.
    pub mode: Option<Mode>,
    pub ms_per_step: f64,
    pub localize_ms: Option<f64>,
    pub err_mean: f64,
    pub err_max: f64,
    /// `err_mean` once the mean offset (a uniform translation) is taken out.
    pub err_mean_aligned: f64,
    pub err_normal_deg: f64,
    pub cg_iters: f64,
    pub fine_vertices: usize,
    pub fine_triangles: usize,
    pub coarse_vertices: Option<usize>,
    pub sheet_m: f64,
    /// Largest vertex speed at the end (m/s): how close to rest a static scene got.
    pub max_speed: f64,
    /// What the energy balance did in the run's steps (`None` when the run did not
    /// complete): its cost is in `ms_per_step`.
    pub balance: Option<Balance>,
    pub status: String,
}

/// How many of a run's steps the energy balance redid, energy-limited or held still.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Balance {
    /// Steps redone with more substeps at least once (`StepStats::redone`), because an
    /// attempt gained energy that nothing supplied: each costs its attempts.
    pub redone: usize,
    /// Steps done once more with each substep energy-limited (`StepStats::limited`).
    pub limited: usize,
    /// Steps the balance held the cloth still, its last resort (`StepStats::stopped`: the
    /// positions of the start, pins on their targets, velocities zero).
    pub held: usize,
}

impl Balance {
    fn count(&mut self, stats: &weft::world::StepStats) {
        self.redone += usize::from(stats.redone > 0);
        self.limited += usize::from(stats.limited);
        self.held += usize::from(stats.stopped);
    }
}

impl std::ops::Add for Balance {
    type Output = Balance;
    fn add(self, o: Balance) -> Balance {
        Balance {
            redone: self.redone + o.redone,
            limited: self.limited + o.limited,
            held: self.held + o.held,
        }
    }
}

/// The result of stepping one world through a scene.
struct SimOut {
    positions: Vec<Vec3A>,
    step_ms: Vec<f64>,
    /// CG iterations summed over the accepted steps.
    iterations: u64,
    max_speed: f64,
    /// What the energy balance did in the accepted steps.
    balance: Balance,
    /// Steps the world refused (lenient runs only) and the first refusal. The energy balance
    /// refuses a step only when it is not a number (`StepError::Unstable`); a step that gains
    /// energy is redone, energy-limited or held still instead (`balance`). The other refusals
    /// are the step's other errors (non-finite state, solver breakdown).
    refused: usize,
    first_refusal: Option<String>,
}

/// Steps `sheet` through `scene` with `materials` and `settings`; `hook` runs after every step.
fn simulate(
    sheet: &Sheet,
    materials: Materials<'_>,
    scene: &Scene,
    settings: Settings,
    solver: Solver,
    steps: usize,
    hook: &mut dyn FnMut(&World<'_>, usize) -> Result<(), String>,
) -> Result<SimOut, String> {
    simulate_with(
        sheet, materials, scene, settings, solver, steps, false, hook,
    )
}

/// [`simulate`]; `lenient`: a step the world refuses (it keeps its state) is counted in
/// `SimOut::refused` and timed like the others instead of ending the run (for timing only).
/// What the energy balance did is counted in `SimOut::balance` in every run.
#[allow(clippy::too_many_arguments)]
fn simulate_with(
    sheet: &Sheet,
    materials: Materials<'_>,
    scene: &Scene,
    settings: Settings,
    solver: Solver,
    steps: usize,
    lenient: bool,
    hook: &mut dyn FnMut(&World<'_>, usize) -> Result<(), String>,
) -> Result<SimOut, String> {
    let pinned = scene.pinned(sheet);
    let cap = sheet.capacity(pinned.len());
    let mut memory = vec![0u8; cap.world_bytes()];
    let mut world = World::new(&mut memory, cap, &sheet.def(), materials, settings)
        .map_err(|e| format!("init: {e:?}"))?;
    world.set_solver(solver);
    let (w, h) = (sheet.width as f32, sheet.height as f32);
    for c in scene.colliders(w) {
        world
            .add_collider(c)
            .map_err(|e| format!("collider: {e:?}"))?;
    }
    let mut step_ms = Vec::with_capacity(steps);
    let mut iterations = 0u64;
    let (mut balance, mut refused, mut first_refusal) = (Balance::default(), 0usize, None);
    for step in 0..steps {
        if step == 0 || scene.pins_move(step) {
            for &p in &pinned {
                let target = scene.pin_target(sheet.uvs[p as usize], w, h, step);
                world
                    .set_pin(p, target)
                    .map_err(|e| format!("pin: {e:?}"))?;
            }
        }
        let t = Instant::now();
        let result = world.step();
        step_ms.push(t.elapsed().as_secs_f64() * 1e3);
        match result {
            Ok(stats) => {
                iterations += u64::from(stats.iterations);
                balance.count(&stats);
            }
            Err(e) if lenient => {
                refused += 1;
                if first_refusal.is_none() {
                    first_refusal = Some(format!("step {step}: {e:?}"));
                }
            }
            Err(e) => return Err(format!("step {step}: {e:?}")),
        }
        hook(&world, step)?;
    }
    let max_speed = world
        .velocities()
        .iter()
        .map(|v| f64::from(v.length()))
        .fold(0.0, f64::max);
    Ok(SimOut {
        positions: world.positions().to_vec(),
        step_ms,
        iterations,
        max_speed,
        balance,
        refused,
        first_refusal,
    })
}

pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Mean of `|a_i - b_i - t|` over the vertices, divided by `size`, where `t` is the mean of
/// `a_i - b_i`: the error once a uniform translation is taken out.
fn aligned_error(a: &[Vec3A], b: &[Vec3A], size: f64) -> f64 {
    let n = a.len().max(1) as f64;
    let mut t = [0.0f64; 3];
    for (p, q) in a.iter().zip(b) {
        let d = *p - *q;
        t[0] += f64::from(d.x) / n;
        t[1] += f64::from(d.y) / n;
        t[2] += f64::from(d.z) / n;
    }
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            let d = *p - *q;
            let e = [
                f64::from(d.x) - t[0],
                f64::from(d.y) - t[1],
                f64::from(d.z) - t[2],
            ];
            (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
        })
        .sum();
    sum / n / size
}

/// Mean and max of `|a_i - b_i|` over the vertices, divided by `size`.
fn position_error(a: &[Vec3A], b: &[Vec3A], size: f64) -> (f64, f64) {
    let mut sum = 0.0;
    let mut max = 0.0f64;
    for (p, q) in a.iter().zip(b) {
        let d = f64::from((*p - *q).length());
        sum += d;
        max = max.max(d);
    }
    (sum / a.len().max(1) as f64 / size, max / size)
}

/// Mean angle (degrees) between the unit normals `a_i` and `b_i` (orientation ignored).
fn normal_error(a: &[Vec3A], b: &[Vec3A]) -> f64 {
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| f64::from(p.dot(*q).abs().min(1.0)).acos().to_degrees())
        .sum();
    sum / a.len().max(1) as f64
}

/// Pictures of one scene: fine-mesh positions of the reference and of some coarse runs.
pub struct Picture {
    pub scene: Scene,
    pub cell: usize,
    pub fine: Sheet,
    /// Width of one cell, metres.
    pub cell_size: f64,
    pub reference: Vec<Vec3A>,
    /// (label, positions, mean error)
    pub panels: Vec<(String, Vec<Vec3A>, f64)>,
}

/// What one up-sampling mode produced over a coarse run.
struct ModeOutput {
    /// Fine positions and normals after the last step.
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    /// Per-step time of the up-sampling, ms.
    ms: Vec<f64>,
    failed: Option<String>,
}

/// One scene on one cell: the fine reference and the coarse configurations.
struct Case {
    scene: Scene,
    cell: usize,
    tiles: usize,
    /// Run the CG / substeps / warping sweep (and the fine sheet at the runtime's CG).
    sweep: bool,
    picture: bool,
}

fn run(args: &Args) -> Result<(), String> {
    let preset = if args.tiny {
        Preset::tiny()
    } else if args.quick {
        Preset::quick()
    } else {
        Preset::full()
    };
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let started = Instant::now();
    println!(
        "weft-study ({} preset) → {}",
        preset.name,
        args.out.display()
    );
    let cells = Cells::build(preset.refine)?;

    let mut cases = Vec::new();
    for &cell in &preset.stretch_cells {
        for &dir in &preset.dirs {
            for &strain in &preset.strains {
                let at_sweep = (strain - preset.sweep_strain).abs() < 1e-12;
                cases.push(Case {
                    scene: Scene::stretch(dir, strain),
                    cell,
                    tiles: preset.stretch_tiles,
                    sweep: at_sweep && preset.knob_sweep,
                    picture: at_sweep && preset.pictures && dir != Dir::U,
                });
            }
        }
    }
    for &(cell, along) in &preset.hangs {
        cases.push(Case {
            scene: Scene::hang(along, preset.hang_gravity),
            cell,
            tiles: preset.hang_tiles,
            sweep: preset.knob_sweep,
            picture: preset.pictures,
        });
    }
    for &cell in &preset.drape_cells {
        cases.push(Case {
            scene: Scene::drape(),
            cell,
            tiles: preset.drape_tiles,
            sweep: preset.knob_sweep,
            picture: preset.pictures,
        });
    }

    if let Some(only) = &args.only {
        cases.retain(|c| format!("{} {}", c.scene.name(), CELLS[c.cell]).contains(only.as_str()));
    }
    let mut rows = Vec::new();
    let mut pictures = Vec::new();
    for (k, case) in cases.iter().enumerate() {
        let t = Instant::now();
        let (case_rows, picture) = run_case(&preset, &cells, case)?;
        let base = case_rows
            .iter()
            .find(|r| {
                r.material == "homogenized"
                    && r.coarse_res == Some(1)
                    && r.cg_tol == Knobs::BASE.tol
                    && r.substeps == 1
                    && r.warping
            })
            .map(|r| r.err_mean)
            .unwrap_or(f64::NAN);
        println!(
            "[{}/{}] {} {} {}: {} rows, homogenized err {:.2e}, fine {:.1} ms/step ({:.1} s)",
            k + 1,
            cases.len(),
            case.scene.name(),
            CELLS[case.cell],
            case.scene
                .strain()
                .map(|s| format!("{:.0}%", s * 100.0))
                .unwrap_or_default(),
            case_rows.len(),
            base,
            case_rows
                .iter()
                .find(|r| r.material == "fine")
                .map(|r| r.ms_per_step)
                .unwrap_or(f64::NAN),
            t.elapsed().as_secs_f64()
        );
        rows.extend(case_rows);
        pictures.extend(picture);
    }

    let bench = match (preset.bench, args.no_bench) {
        (Some(b), false) => Some(run_bench(&b)?),
        _ => None,
    };
    if let Some(b) = &bench {
        rows.extend(b.rows.iter().cloned());
    }

    report::write_all(&args.out, preset.name, &rows, &pictures, bench.as_ref())?;
    println!(
        "done in {:.1} s: {} rows → {}",
        started.elapsed().as_secs_f64(),
        rows.len(),
        args.out.join("study.csv").display()
    );
    Ok(())
}

/// The coarse configurations of a case.
fn knob_list(preset: &Preset, case: &Case) -> Vec<Knobs> {
    let mut out = Vec::new();
    for &res in &preset.resolutions {
        if !case.tiles.is_multiple_of(res) || case.tiles / res < 1 {
            continue;
        }
        for averaged in [false, true] {
            out.push(Knobs {
                averaged,
                res,
                ..Knobs::BASE
            });
        }
    }
    if case.sweep {
        for solver in [
            Solver::Multigrid,
            Solver::BlockJacobi,
            Solver::MultigridLines,
        ] {
            for (tol, max_iter) in [
                (1e-2, 200),
                (1e-3, 200),
                (1e-4, 200),
                (1e-5, 1000),
                (1e-3, 10),
                (1e-3, 40),
            ] {
                let knobs = Knobs {
                    tol,
                    max_iter,
                    solver,
                    ..Knobs::BASE
                };
                if knobs != Knobs::BASE {
                    out.push(knobs);
                }
            }
        }
        for substeps in [2, 4] {
            out.push(Knobs {
                substeps,
                ..Knobs::BASE
            });
        }
        out.push(Knobs {
            warping: false,
            ..Knobs::BASE
        });
    }
    out
}

fn run_case(
    preset: &Preset,
    cells: &Cells,
    case: &Case,
) -> Result<(Vec<Row>, Option<Picture>), String> {
    let scene = &case.scene;
    let desc = &cells.descs[case.cell];
    let blob = cells.blob()?;
    let (mut fine, table) = reference::fine_sheet(desc, preset.refine, case.tiles);
    let (w, h) = (fine.width as f32, fine.height as f32);
    fine.place(|uv| scene.place(uv, w, h));
    let size = fine.width.max(fine.height);
    let steps = scene.steps;
    let row = |material: &str, knobs: &Knobs| Row {
        scene: scene.name(),
        cell: CELLS[case.cell].to_string(),
        material: material.to_string(),
        coarse_res: None,
        strain: scene.strain(),
        cg_tol: knobs.tol,
        cg_max_iter: knobs.max_iter,
        substeps: knobs.substeps,
        warping: knobs.warping,
        solver: solver_name(knobs.solver),
        mode: None,
        ms_per_step: f64::NAN,
        localize_ms: None,
        err_mean: f64::NAN,
        err_max: f64::NAN,
        err_mean_aligned: f64::NAN,
        err_normal_deg: f64::NAN,
        cg_iters: f64::NAN,
        fine_vertices: fine.uvs.len(),
        fine_triangles: fine.triangles.len(),
        coarse_vertices: None,
        sheet_m: size,
        max_speed: f64::NAN,
        balance: None,
        status: "ok".into(),
    };
    let mut rows = Vec::new();

    // --- the fine reference ---
    let reference_knobs = Knobs {
        tol: scene.reference_tolerance(),
        max_iter: REFERENCE_MAX_ITER,
        substeps: scene.reference_substeps(),
        ..Knobs::BASE
    };
    let out = match simulate(
        &fine,
        Materials::Table(&table),
        scene,
        reference_knobs.settings(scene),
        reference_knobs.solver,
        steps,
        &mut |_, _| Ok(()),
    ) {
        Ok(o) => o,
        Err(e) => {
            // no reference, nothing to compare with
            eprintln!(
                "fine reference of {} {} failed: {e}",
                scene.name(),
                CELLS[case.cell]
            );
            let failed = Row {
                status: format!("failed: {e}"),
                ..row("fine", &reference_knobs)
            };
            return Ok((vec![failed], None));
        }
    };
    let reference = out.positions;
    let mut reference_normals = vec![Vec3A::Z; reference.len()];
    upsample::area_normals(&fine.triangles, &reference, &mut reference_normals);
    rows.push(Row {
        ms_per_step: median(&out.step_ms),
        err_mean: 0.0,
        err_max: 0.0,
        err_mean_aligned: 0.0,
        err_normal_deg: 0.0,
        cg_iters: out.iterations as f64 / steps as f64,
        max_speed: out.max_speed,
        balance: Some(out.balance),
        ..row("fine", &reference_knobs)
    });
    // The fine sheet with the runtime's own CG settings: what the fine simulation would cost
    // (and how far it is from converged) at the coarse baseline's solver settings.
    if case.sweep {
        let r = simulate(
            &fine,
            Materials::Table(&table),
            scene,
            Knobs::BASE.settings(scene),
            Knobs::BASE.solver,
            steps,
            &mut |_, _| Ok(()),
        );
        let mut fine_row = row("fine", &Knobs::BASE);
        match r {
            Ok(o) => {
                let (m, x) = position_error(&o.positions, &reference, size);
                let mut nrm = vec![Vec3A::Z; o.positions.len()];
                upsample::area_normals(&fine.triangles, &o.positions, &mut nrm);
                fine_row.ms_per_step = median(&o.step_ms);
                fine_row.err_mean = m;
                fine_row.err_max = x;
                fine_row.err_mean_aligned = aligned_error(&o.positions, &reference, size);
                fine_row.err_normal_deg = normal_error(&nrm, &reference_normals);
                fine_row.cg_iters = o.iterations as f64 / steps as f64;
                fine_row.max_speed = o.max_speed;
                fine_row.balance = Some(o.balance);
            }
            Err(e) => fine_row.status = format!("failed: {e}"),
        }
        rows.push(fine_row);
    }

    // --- the coarse configurations ---
    let modes = [
        Mode::Off,
        Mode::On {
            recompute_normals: false,
        },
        Mode::On {
            recompute_normals: true,
        },
        Mode::Green,
    ];
    let mut picture_panels: Vec<(String, Vec<Vec3A>, f64)> = Vec::new();
    for knobs in knob_list(preset, case) {
        let quads = case.tiles / knobs.res;
        let mut coarse = reference::coarse_sheet(fine.width, fine.height, quads, case.cell as u32);
        coarse.place(|uv| scene.place(uv, w, h));
        let materials = if knobs.averaged {
            Materials::Table(&cells.averaged)
        } else {
            Materials::Blob(&blob)
        };
        let n_fine = fine.uvs.len();
        let mut upsampler: Option<Upsampler> = None;
        let mut outputs: Vec<ModeOutput> = modes
            .iter()
            .map(|_| ModeOutput {
                positions: vec![[0.0; 3]; n_fine],
                normals: vec![[0.0, 0.0, 1.0]; n_fine],
                ms: Vec::new(),
                failed: None,
            })
            .collect();
        let result = simulate(
            &coarse,
            materials,
            scene,
            knobs.settings(scene),
            knobs.solver,
            steps,
            &mut |world, _| {
                if upsampler.is_none() {
                    upsampler = Some(Upsampler::new(world, &blob, &fine.uvs, &fine.triangles)?);
                }
                let Some(up) = upsampler.as_mut() else {
                    return Ok(());
                };
                for (mode, o) in modes.iter().zip(outputs.iter_mut()) {
                    if o.failed.is_some() {
                        continue;
                    }
                    let t = Instant::now();
                    match up.run(world, *mode, &mut o.positions, &mut o.normals) {
                        Ok(()) => o.ms.push(t.elapsed().as_secs_f64() * 1e3),
                        Err(e) => o.failed = Some(e),
                    }
                }
                Ok(())
            },
        );
        let material = if knobs.averaged {
            "averaged"
        } else {
            "homogenized"
        };
        let base = Row {
            coarse_res: Some(knobs.res),
            coarse_vertices: Some(coarse.uvs.len()),
            ..row(material, &knobs)
        };
        match result {
            Err(e) => {
                for mode in modes {
                    rows.push(Row {
                        mode: Some(mode),
                        status: format!("failed: {e}"),
                        ..base.clone()
                    });
                }
            }
            Ok(o) => {
                for (mode, mo) in modes.iter().zip(&outputs) {
                    let (pos, nrm, times, failed) =
                        (&mo.positions, &mo.normals, &mo.ms, &mo.failed);
                    let mut r = Row {
                        mode: Some(*mode),
                        ms_per_step: median(&o.step_ms),
                        cg_iters: o.iterations as f64 / steps as f64,
                        max_speed: o.max_speed,
                        balance: Some(o.balance),
                        ..base.clone()
                    };
                    if let Some(e) = failed {
                        r.status = format!("skipped: {e}");
                        rows.push(r);
                        continue;
                    }
                    let pos = upsample::to_vec3a(pos);
                    let (m, x) = position_error(&pos, &reference, size);
                    r.localize_ms = Some(median(times));
                    r.err_mean = m;
                    r.err_max = x;
                    r.err_mean_aligned = aligned_error(&pos, &reference, size);
                    r.err_normal_deg = normal_error(&upsample::to_vec3a(nrm), &reference_normals);
                    // pictures: the baseline's localized and embedded, the averaged localized
                    let is_base = Knobs {
                        averaged: false,
                        ..knobs
                    } == Knobs::BASE;
                    if case.picture
                        && is_base
                        && matches!(
                            mode,
                            Mode::Off
                                | Mode::On {
                                    recompute_normals: false
                                }
                        )
                    {
                        let label = match (knobs.averaged, mode) {
                            (false, Mode::Off) => "homogenized, no loc.",
                            (false, _) => "homogenized + loc.",
                            (true, Mode::Off) => "averaged, no loc.",
                            (true, _) => "averaged + loc.",
                        };
                        picture_panels.push((label.to_string(), pos, m));
                    }
                    rows.push(r);
                }
            }
        }
    }
    let picture = if case.picture {
        // order: homogenized + loc, averaged + loc, homogenized without (the reference first)
        let order = [
            "homogenized + loc.",
            "averaged + loc.",
            "homogenized, no loc.",
            "averaged, no loc.",
        ];
        picture_panels.sort_by_key(|(l, _, _)| order.iter().position(|o| o == l));
        picture_panels.truncate(3);
        Some(Picture {
            scene: *scene,
            cell: case.cell,
            cell_size: desc.width(),
            fine,
            reference,
            panels: picture_panels,
        })
    } else {
        None
    };
    Ok((rows, picture))
}

/// The speed measurement: a big fine sheet for a few steps against the coarse cloth +
/// localization of the same sheet.
pub struct BenchOut {
    pub fine_triangles: usize,
    pub fine_vertices: usize,
    pub coarse_vertices: usize,
    /// The fine sheet at the runtime's CG settings.
    pub fine: BenchRun,
    /// The fine sheet at the reference's CG settings (none in the quick preset).
    pub reference: Option<BenchRun>,
    pub coarse: BenchRun,
    pub localize_ms: Vec<f64>,
    pub world_bytes_fine: usize,
    pub world_bytes_coarse: usize,
    pub rows: Vec<Row>,
}

/// Timings of one world in the bench.
pub struct BenchRun {
    pub ms: Vec<f64>,
    pub tol: f32,
    pub max_iter: u32,
    pub substeps: u32,
    pub solver: Solver,
    /// CG iterations per accepted step.
    pub iters: f64,
    /// What the energy balance did (steps redone, limited, held still); timed like the others.
    pub balance: Balance,
    /// Steps refused (only for an energy balance that is not a number, `StepError::Unstable`,
    /// or another step error); timed like the others.
    pub refused: usize,
    pub first_refusal: Option<String>,
}

impl BenchRun {
    fn new(o: &SimOut, knobs: &Knobs) -> BenchRun {
        let accepted = (o.step_ms.len() - o.refused).max(1);
        BenchRun {
            ms: o.step_ms.clone(),
            tol: knobs.tol,
            max_iter: knobs.max_iter,
            substeps: knobs.substeps,
            solver: knobs.solver,
            iters: o.iterations as f64 / accepted as f64,
            balance: o.balance,
            refused: o.refused,
            first_refusal: o.first_refusal.clone(),
        }
    }
    /// `timing only; of M steps R redone, L energy-limited, H held still` (always: counts of 0
    /// say the run was checked), then the refusals if any.
    pub fn status(&self) -> String {
        let Balance {
            redone,
            limited,
            held,
        } = self.balance;
        let mut s = format!(
            "timing only; of {} steps {redone} redone, {limited} energy-limited, {held} held still",
            self.ms.len()
        );
        if let Some(e) = &self.first_refusal {
            s += &format!("; {} refused (first: {e})", self.refused);
        }
        s
    }
}

fn run_bench(b: &Bench) -> Result<BenchOut, String> {
    println!(
        "bench: fine {0}×{0} tiles of '{1}' at refine {2} vs {3}×{3} coarse vertices + localization",
        b.tiles, CELLS[b.cell], b.refine, b.coarse_n
    );
    let cells = Cells::build(b.refine)?;
    let blob = cells.blob()?;
    let scene = Scene::drape();
    let (mut fine, table) = reference::fine_sheet(&cells.descs[b.cell], b.refine, b.tiles);
    let (w, h) = (fine.width as f32, fine.height as f32);
    fine.place(|uv| scene.place(uv, w, h));
    let mut coarse =
        reference::coarse_sheet(fine.width, fine.height, b.coarse_n - 1, b.cell as u32);
    coarse.place(|uv| scene.place(uv, w, h));
    let world_bytes_fine = fine.capacity(0).world_bytes();
    let world_bytes_coarse = coarse.capacity(0).world_bytes();
    let n_fine = fine.uvs.len();
    let mode = Mode::On {
        recompute_normals: false,
    };

    // Interleaved: coarse, fine, coarse (, reference), so a swing of the machine shows.
    let mut localize_ms = Vec::new();
    let mut coarse_runs = Vec::new();
    let coarse_run = |localize_ms: &mut Vec<f64>| -> Result<SimOut, String> {
        let mut up: Option<Upsampler> = None;
        let (mut pos, mut nrm) = (vec![[0.0f32; 3]; n_fine], vec![[0.0f32; 3]; n_fine]);
        simulate(
            &coarse,
            Materials::Blob(&blob),
            &scene,
            Knobs::BASE.settings(&scene),
            Knobs::BASE.solver,
            b.coarse_steps,
            &mut |world, _| {
                if up.is_none() {
                    up = Some(Upsampler::new(world, &blob, &fine.uvs, &fine.triangles)?);
                }
                if let Some(u) = up.as_mut() {
                    let t = Instant::now();
                    u.run(world, mode, &mut pos, &mut nrm)?;
                    localize_ms.push(t.elapsed().as_secs_f64() * 1e3);
                }
                Ok(())
            },
        )
    };
    coarse_runs.push(coarse_run(&mut localize_ms)?);
    let fine_time = |knobs: &Knobs, steps: usize| -> Result<BenchRun, String> {
        let t = Instant::now();
        let o = simulate_with(
            &fine,
            Materials::Table(&table),
            &scene,
            knobs.settings(&scene),
            knobs.solver,
            steps,
            true,
            &mut |_, _| Ok(()),
        )?;
        println!(
            "  fine sheet, CG {:e}/{}, {} substep(s): {} steps in {:.1} s",
            knobs.tol,
            knobs.max_iter,
            knobs.substeps,
            steps,
            t.elapsed().as_secs_f64()
        );
        Ok(BenchRun::new(&o, knobs))
    };
    let fine_run = fine_time(&Knobs::BASE, b.fine_steps)?;
    coarse_runs.push(coarse_run(&mut localize_ms)?);
    let reference_knobs = Knobs {
        tol: scene.reference_tolerance(),
        max_iter: REFERENCE_MAX_ITER,
        substeps: scene.reference_substeps(),
        ..Knobs::BASE
    };
    let reference_run = if b.reference_steps > 0 {
        Some(fine_time(&reference_knobs, b.reference_steps)?)
    } else {
        None
    };
    let coarse_o = SimOut {
        positions: Vec::new(),
        step_ms: coarse_runs.iter().flat_map(|o| o.step_ms.clone()).collect(),
        iterations: coarse_runs.iter().map(|o| o.iterations).sum(),
        max_speed: 0.0,
        balance: coarse_runs
            .iter()
            .fold(Balance::default(), |b, o| b + o.balance),
        refused: 0,
        first_refusal: None,
    };
    let coarse_bench = BenchRun::new(&coarse_o, &Knobs::BASE);
    let row = |material: &str, run: &BenchRun| Row {
        scene: "bench-drape".into(),
        cell: CELLS[b.cell].into(),
        material: material.into(),
        coarse_res: None,
        strain: None,
        cg_tol: run.tol,
        cg_max_iter: run.max_iter,
        substeps: run.substeps,
        warping: true,
        solver: solver_name(run.solver),
        mode: None,
        ms_per_step: median(&run.ms),
        localize_ms: None,
        err_mean: f64::NAN,
        err_max: f64::NAN,
        err_mean_aligned: f64::NAN,
        err_normal_deg: f64::NAN,
        cg_iters: run.iters,
        fine_vertices: fine.uvs.len(),
        fine_triangles: fine.triangles.len(),
        coarse_vertices: None,
        sheet_m: fine.width,
        max_speed: f64::NAN,
        balance: Some(run.balance),
        status: run.status(),
    };
    let mut rows = vec![row("fine", &fine_run)];
    if let Some(r) = &reference_run {
        rows.push(row("fine", r));
    }
    rows.push(Row {
        coarse_vertices: Some(coarse.uvs.len()),
        coarse_res: Some(1),
        mode: Some(mode),
        localize_ms: Some(median(&localize_ms)),
        ..row("homogenized", &coarse_bench)
    });
    Ok(BenchOut {
        fine_triangles: fine.triangles.len(),
        fine_vertices: fine.uvs.len(),
        coarse_vertices: coarse.uvs.len(),
        fine: fine_run,
        reference: reference_run,
        coarse: coarse_bench,
        localize_ms,
        world_bytes_fine,
        world_bytes_coarse,
        rows,
    })
}
