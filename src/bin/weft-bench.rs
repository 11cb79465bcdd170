//! weft-bench: per-step cost of the runtime on N×N-vertex sheets.
//!
//! `cargo run --release --bin weft-bench -- --grid N [--steps S] [--effects LIST]
//! [--solver multigrid|lines|jacobi] [--tolerance T] [--json]`
//!
//! A 1 m × 1 m sheet of a bundled anisotropic cell (homogenized here, through the same blob the
//! engine would load), hanging with two adjacent corners pinned, dt = 1/60 s, a sphere in front
//! of it, all effects on unless `--effects` names fewer. Prints one JSON object with `--json`,
//! a readable table otherwise. `--effects-table` measures the cost of each effect by turning
//! it off alone. Speed is never quoted alone: every run also reports the steps the energy
//! balance redid, energy-limited or held still, the energy it removed, the energy drift (each
//! step's balance, end − start − input, summed: negative when the steps dissipate; and the
//! worst step's), and the worst edge strain.

use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;
use glam::Vec3A;
use weft::blob::Blob;
use weft::collide::{Collider, Shape};
use weft::world::{effects, Capacity, ClothDef, Materials, Settings, Solver, World};

#[derive(Parser)]
#[command(about = "Per-step cost of the weft runtime on an N×N-vertex sheet")]
struct Args {
    /// Vertices per side.
    #[arg(long, default_value_t = 21)]
    grid: u32,
    /// Timed steps (after 20 warm-up steps).
    #[arg(long, default_value_t = 300)]
    steps: u32,
    /// Comma-separated effects: gravity,bending,damping,pins,collision,wind,warping, or all/none.
    #[arg(long, default_value = "all")]
    effects: String,
    /// Cell description to homogenize for the sheet's material.
    #[arg(long, default_value = "cells/stripes.toml")]
    cell: PathBuf,
    /// PCG relative tolerance.
    #[arg(long, default_value_t = 1e-4)]
    tolerance: f32,
    #[arg(long, default_value_t = 1)]
    substeps: u32,
    /// Run exactly N CG iterations per solve (tolerance 0): equal solver work in every
    /// configuration, so an effects table shows each effect's own cost.
    #[arg(long)]
    iterations: Option<u32>,
    /// The CG preconditioner: `multigrid` (the default), `lines` (multigrid smoothed along lines
    /// of dominant couplings) or `jacobi` (block Jacobi).
    #[arg(long, default_value = "multigrid")]
    solver: String,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Measure every effect's cost (each turned off alone) and print a table.
    #[arg(long)]
    effects_table: bool,
    /// Run the scene this many times, the wind turned a little about the vertical in each
    /// after the first (0, +0.02, −0.02, +0.04, … rad), and report the spread over them: a
    /// change that moves where solves stop sends the swinging cloth on another trajectory,
    /// which alone moves a short run's CG count by ±5–10 % at 81 and 161 per side.
    #[arg(long, default_value_t = 1)]
    trajectories: u32,
}

const NAMES: [(&str, u32); 7] = [
    ("gravity", effects::GRAVITY),
    ("bending", effects::BENDING),
    ("damping", effects::DAMPING),
    ("pins", effects::PINS),
    ("collision", effects::COLLISION),
    ("wind", effects::WIND),
    ("warping", effects::WARPING),
];

fn parse_effects(list: &str) -> Result<u32, String> {
    match list {
        "all" => return Ok(NAMES.iter().fold(0, |m, (_, b)| m | b)),
        "none" | "" => return Ok(0),
        _ => {}
    }
    let mut mask = 0;
    for name in list.split(',') {
        let bit = NAMES
            .iter()
            .find(|(n, _)| *n == name.trim())
            .ok_or_else(|| format!("unknown effect '{name}'"))?
            .1;
        mask |= bit;
    }
    Ok(mask)
}

struct Run {
    us_median: f64,
    us_max: f64,
    cg_mean: f64,
    /// CG iterations per linear solve (a step solves once per substep, and again after
    /// contacts that pulled are let go or vertices the solve carried into a collider held).
    cg_per_solve: f64,
    /// CG iterations of a substep's first solve, and of each solve after contacts were let go
    /// or engaged.
    cg_first: f64,
    cg_per_resolve: f64,
    converged: f64,
    world_bytes: usize,
    /// Steps the energy balance redid, steps it energy-limited, steps it held still, energy
    /// it removed (J).
    redone: u32,
    limited: u32,
    stopped: u32,
    removed: f64,
    /// The energy drift: each step's balance (`StepStats::energy_gain`: end energy − start
    /// energy − work of the input, J) summed over the timed steps (negative: dissipated), and
    /// the largest single step's.
    drift: f64,
    worst_gain: f64,
    /// Largest |edge length / rest length − 1| over the timed steps, and in the last state
    /// (what a cloth that has come to rest keeps: peer engines' iterative solvers leave
    /// their hanging cloth stretched by a residual the maximum alone does not show).
    worst_strain: f64,
    final_strain: f64,
}

fn parse_solver(name: &str) -> Result<Solver, String> {
    match name {
        "multigrid" | "mg" => Ok(Solver::Multigrid),
        "jacobi" | "block-jacobi" => Ok(Solver::BlockJacobi),
        "lines" | "multigrid-lines" => Ok(Solver::MultigridLines),
        _ => Err(format!(
            "unknown solver '{name}' (multigrid, lines or jacobi)"
        )),
    }
}

/// Largest relative change of any triangle edge's length from its rest length.
fn worst_edge_strain(world: &World<'_>) -> f64 {
    let (x, rest) = (world.positions(), world.rest_positions());
    let mut worst = 0.0f64;
    for t in world.triangles() {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let (a, b) = (a as usize, b as usize);
            let l = f64::from((x[a] - x[b]).length());
            let l0 = f64::from((rest[a] - rest[b]).length());
            if l0 > 0.0 {
                worst = worst.max((l / l0 - 1.0).abs());
            }
        }
    }
    worst
}

/// The wind's turn about the vertical (rad) in trajectory `k` of `--trajectories`: none in the
/// first, then ±0.02 rad steps alternating in sign.
fn wind_turn(k: u32) -> f32 {
    let step = 0.02 * k.div_ceil(2) as f32;
    if k % 2 == 1 {
        step
    } else {
        -step
    }
}

fn run(blob: &Blob<'_>, args: &Args, mask: u32, turn: f32) -> Result<Run, String> {
    let (grid, steps, substeps) = (args.grid, args.steps, args.substeps);
    let (tolerance, max_iterations) = match args.iterations {
        Some(n) => (f32::MIN_POSITIVE, n.max(1)),
        None => (args.tolerance, Settings::default().max_iterations),
    };
    let n = grid as usize;
    let mut positions = vec![[0.0f32; 3]; n * n];
    let mut uvs = vec![[0.0f32; 2]; n * n];
    let mut triangles = vec![[0u32; 3]; 2 * (n - 1) * (n - 1)];
    weft::mesh::grid(n, n, 1.0, 1.0, &mut positions, &mut uvs, &mut triangles)
        .map_err(|e| format!("{e:?}"))?;
    // hang in the x–z plane
    for p in &mut positions {
        *p = [p[0], 0.0, p[1]];
    }
    let materials = vec![0u32; triangles.len()];
    let cap = Capacity::grid(grid);
    let bytes = cap.world_bytes();
    let mut mem = vec![0u8; bytes];
    let settings = Settings {
        effects: mask,
        time_step: 1.0 / 60.0,
        substeps,
        tolerance,
        max_iterations,
        // (0 + 0 keeps the unturned wind's x exactly +0)
        wind: [0.0 - 3.0 * turn.sin(), 3.0 * turn.cos(), 0.0],
        drag: 0.2,
        ..Settings::default()
    };
    let def = ClothDef {
        positions: &positions,
        uvs: &uvs,
        triangles: &triangles,
        materials: &materials,
    };
    let mut world = World::new(&mut mem, cap, &def, Materials::Blob(blob), settings)
        .map_err(|e| format!("init: {e:?}"))?;
    world.set_solver(parse_solver(&args.solver)?);
    let top = (n - 1) * n;
    for corner in [top, top + n - 1] {
        world
            .set_pin(corner as u32, positions[corner])
            .map_err(|e| format!("{e:?}"))?;
    }
    world
        .add_collider(Collider::new(
            Shape::Sphere {
                center: Vec3A::new(0.5, 0.35, 0.3),
                radius: 0.3,
            },
            0.3,
            0.005,
        ))
        .map_err(|e| format!("{e:?}"))?;
    for _ in 0..20 {
        world.step().map_err(|e| format!("{e:?}"))?;
    }
    let mut times = Vec::with_capacity(steps as usize);
    let (mut iterations, mut solves, mut first, mut substeps) = (0u64, 0u64, 0u64, 0u64);
    let mut converged = 0u32;
    let (mut redone, mut limited, mut stopped) = (0u32, 0u32, 0u32);
    let (mut removed, mut worst_strain) = (0.0f64, 0.0f64);
    let (mut drift, mut worst_gain) = (0.0f64, f64::NEG_INFINITY);
    let mut final_strain = worst_edge_strain(&world);
    for _ in 0..steps {
        let t0 = Instant::now();
        let r = world.step();
        times.push(t0.elapsed().as_secs_f64() * 1e6);
        match r {
            Ok(s) => {
                iterations += s.iterations as u64;
                solves += s.solves as u64;
                first += s.first_iterations as u64;
                substeps += s.substeps as u64;
                converged += s.converged as u32;
                redone += (s.redone > 0) as u32;
                limited += s.limited as u32;
                stopped += s.stopped as u32;
                removed += f64::from(s.energy_removed);
                drift += f64::from(s.energy_gain);
                worst_gain = worst_gain.max(f64::from(s.energy_gain));
            }
            Err(e) => return Err(format!("{e:?}")),
        }
        final_strain = worst_edge_strain(&world);
        worst_strain = worst_strain.max(final_strain);
    }
    times.sort_by(|a, b| a.total_cmp(b));
    Ok(Run {
        us_median: times[times.len() / 2],
        us_max: *times.last().unwrap_or(&0.0),
        cg_mean: iterations as f64 / steps.max(1) as f64,
        cg_per_solve: iterations as f64 / solves.max(1) as f64,
        cg_first: first as f64 / substeps.max(1) as f64,
        cg_per_resolve: (iterations - first) as f64 / (solves - substeps.min(solves)).max(1) as f64,
        converged: converged as f64 / steps.max(1) as f64,
        world_bytes: bytes,
        redone,
        limited,
        stopped,
        removed,
        drift,
        worst_gain,
        worst_strain,
        final_strain,
    })
}

fn main() {
    let args = Args::parse();
    if let Err(e) = real_main(&args) {
        eprintln!("weft-bench: {e}");
        std::process::exit(1);
    }
}

fn real_main(args: &Args) -> Result<(), String> {
    if args.grid < 2 {
        return Err("--grid must be at least 2".into());
    }
    let bytes = weft::homogenize::build_blob(std::slice::from_ref(&args.cell), 1, &mut |_, _| {})
        .map_err(|e| e.to_string())?;
    let aligned = weft::blob::AlignedBytes::copy_from(&bytes);
    let blob = Blob::parse(&aligned).map_err(|e| format!("blob: {e}"))?;
    let mask = parse_effects(&args.effects)?;
    if args.effects_table {
        let all = run(&blob, args, mask, 0.0)?;
        let none = run(&blob, args, 0, 0.0)?;
        println!(
            "grid {0}×{0}, {1} steps, median µs per step (ratios from the same run)",
            args.grid, args.steps
        );
        println!(
            "{:<22} {:>10} {:>10} {:>8}",
            "effects", "µs/step", "vs all", "CG it"
        );
        println!(
            "{:<22} {:>10.1} {:>10.3} {:>8.1}",
            "all", all.us_median, 1.0, all.cg_mean
        );
        for (name, bit) in NAMES {
            if mask & bit == 0 {
                continue;
            }
            let r = run(&blob, args, mask & !bit, 0.0)?;
            println!(
                "{:<22} {:>10.1} {:>10.3} {:>8.1}",
                format!("all but {name}"),
                r.us_median,
                r.us_median / all.us_median,
                r.cg_mean
            );
        }
        println!(
            "{:<22} {:>10.1} {:>10.3} {:>8.1}",
            "none",
            none.us_median,
            none.us_median / all.us_median,
            none.cg_mean
        );
        return Ok(());
    }
    let runs = (0..args.trajectories.max(1))
        .map(|k| run(&blob, args, mask, wind_turn(k)))
        .collect::<Result<Vec<_>, _>>()?;
    if runs.len() > 1 {
        return print_spread(args, &runs);
    }
    let r = &runs[0];
    if args.json {
        print_json(
            args,
            serde_json::json!({
                "us_per_step_median": r.us_median,
                "us_per_step_max": r.us_max,
                "cg_iterations_mean": r.cg_mean,
                "cg_iterations_per_solve": r.cg_per_solve,
                "cg_iterations_first_solve": r.cg_first,
                "cg_iterations_per_resolve": r.cg_per_resolve,
                "converged_fraction": r.converged,
                "world_bytes": r.world_bytes,
                "steps_redone": r.redone,
                "steps_limited": r.limited,
                "steps_stopped": r.stopped,
                "energy_removed_j": r.removed,
                "energy_drift_j": r.drift,
                "energy_gain_worst_step_j": r.worst_gain,
                "worst_edge_strain": r.worst_strain,
                "final_edge_strain": r.final_strain,
            }),
        );
    } else {
        println!("grid             {0}×{0} vertices", args.grid);
        println!("steps            {}", args.steps);
        println!("effects          {}", args.effects);
        println!("µs/step median   {:.1}", r.us_median);
        println!("µs/step max      {:.1}", r.us_max);
        println!(
            "CG iterations    {:.1} per step, {:.1} per solve (tolerance {})",
            r.cg_mean, r.cg_per_solve, args.tolerance
        );
        println!(
            "                 {:.1} in a substep's first solve, {:.1} per re-solve after a release or a catch",
            r.cg_first, r.cg_per_resolve
        );
        println!("converged        {:.0}% of steps", r.converged * 100.0);
        println!("solver           {}", args.solver);
        println!(
            "energy balance   {} steps redone, {} energy-limited, {} held still, {:.3e} J removed",
            r.redone, r.limited, r.stopped, r.removed
        );
        println!(
            "energy drift     {:+.3e} J over the steps (end − start − input; negative: \
             dissipated), worst step {:+.3e} J",
            r.drift, r.worst_gain
        );
        println!(
            "worst edge strain {:.4}% over the steps, {:.4}% at the end",
            r.worst_strain * 100.0,
            r.final_strain * 100.0
        );
        println!(
            "world memory     {} bytes ({:.2} MB)",
            r.world_bytes,
            r.world_bytes as f64 / 1e6
        );
    }
    Ok(())
}

/// `--trajectories`: each figure's median over the runs and its range.
fn print_spread(args: &Args, runs: &[Run]) -> Result<(), String> {
    let spread = |f: &dyn Fn(&Run) -> f64| {
        let mut v: Vec<f64> = runs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v[0], v[v.len() - 1])
    };
    let us = spread(&|r| r.us_median);
    let cg = spread(&|r| r.cg_mean);
    let first = spread(&|r| r.cg_first);
    let strain = spread(&|r| r.worst_strain);
    let redone: u32 = runs.iter().map(|r| r.redone).sum();
    let limited: u32 = runs.iter().map(|r| r.limited).sum();
    let stopped: u32 = runs.iter().map(|r| r.stopped).sum();
    let worst_gain = runs
        .iter()
        .map(|r| r.worst_gain)
        .fold(f64::NEG_INFINITY, f64::max);
    if args.json {
        print_json(
            args,
            serde_json::json!({
                "trajectories": runs.len(),
                "us_per_step_median": us.0,
                "us_per_step_median_range": [us.1, us.2],
                "cg_iterations_mean": cg.0,
                "cg_iterations_mean_range": [cg.1, cg.2],
                "cg_iterations_first_solve": first.0,
                "cg_iterations_first_solve_range": [first.1, first.2],
                "steps_redone": redone,
                "steps_limited": limited,
                "steps_stopped": stopped,
                "energy_gain_worst_step_j": worst_gain,
                "worst_edge_strain": strain.0,
                "worst_edge_strain_range": [strain.1, strain.2],
            }),
        );
    } else {
        println!(
            "grid             {0}×{0} vertices, {1} trajectories (medians over them, min–max)",
            args.grid,
            runs.len()
        );
        println!("steps            {}", args.steps);
        println!("µs/step median   {:.1} ({:.1}–{:.1})", us.0, us.1, us.2);
        println!(
            "CG iterations    {:.2} per step ({:.2}–{:.2}), {:.2} in a substep's first solve \
             ({:.2}–{:.2}) (tolerance {})",
            cg.0, cg.1, cg.2, first.0, first.1, first.2, args.tolerance
        );
        println!(
            "energy balance   {redone} steps redone, {limited} energy-limited, {stopped} held \
             still over all runs; \
             worst step {worst_gain:+.3e} J"
        );
        println!(
            "worst edge strain {:.4}% ({:.4}–{:.4}%)",
            strain.0 * 100.0,
            strain.1 * 100.0,
            strain.2 * 100.0
        );
    }
    Ok(())
}

/// Prints `figures` (a JSON object) with the scene's settings added: grid, steps, effects,
/// tolerance, substeps and solver.
fn print_json(args: &Args, mut figures: serde_json::Value) {
    if let Some(object) = figures.as_object_mut() {
        object.insert("grid".into(), args.grid.into());
        object.insert("steps".into(), args.steps.into());
        object.insert("effects".into(), args.effects.clone().into());
        object.insert("tolerance".into(), args.tolerance.into());
        object.insert("substeps".into(), args.substeps.into());
        object.insert("solver".into(), args.solver.clone().into());
    }
    println!("{figures}");
}
