//! How long cloth takes to come to rest, by CG tolerance: the measurements behind the README's
//! "The default, re-examined" (the accuracy study's scenes are dynamic and do not measure rest).
//!
//! ```text
//! cargo run --release --example rest_sweep -- drape [N] [TOLERANCES] [ORIENTATIONS]
//! cargo run --release --example rest_sweep -- pile [TOLERANCES] [SEEDS]
//! ```
//!
//! * `drape`: the sheet of `tests/world.rs`'
//!   `a_drape_resting_on_a_sphere_is_not_redone_at_every_step` (`N × N` vertices, default 41),
//!   turned to `ORIENTATIONS` angles 0, 0.1, 0.2, … rad about the vertical (default 8), 1,500
//!   steps each: the step after which its fastest vertex stays below 1 mm/s, its fastest vertex
//!   at step 600 (the test's bound: 1 cm/s) and its CG iterations per step.
//! * `pile`: the drop of `a_cloth_fallen_into_a_pile_comes_to_rest` with jitter seeds 1..=`SEEDS`
//!   (default 40): whether it is at rest by the test's bounds over its last 90 of 600 steps
//!   (fastest vertex below 4e-5 m/s, fewer than 5 CG iterations a step), and its CG iterations
//!   per step over all 600.
//!
//! `TOLERANCES` is a comma-separated list (default `1e-3,2e-3,3e-3,5e-3,1e-2`); every other
//! setting is the default. Deterministic: the same build prints the same figures.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{anisotropic, drape_sheet, drape_sphere, drop_pile, memory, top_speed, world};
use weft::world::Settings;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: usize| args.get(k).map(String::as_str);
    let tolerances = |k: usize| -> Vec<f32> {
        arg(k)
            .unwrap_or("1e-3,2e-3,3e-3,5e-3,1e-2")
            .split(',')
            .map(|t| t.parse().expect("a tolerance"))
            .collect()
    };
    let count = |k: usize, default: u64| arg(k).map_or(default, |s| s.parse().expect("a count"));
    match arg(0) {
        Some("drape") => {
            let n = count(1, 41) as usize;
            let orientations = count(3, 8);
            println!(
                "tolerance | angle | at rest after (steps) | fastest at 600 (m/s) | CG it/step"
            );
            for tolerance in tolerances(2) {
                let mut rest = Vec::new();
                for k in 0..orientations {
                    let (steps, at600, per_step) = drape(n, tolerance, 0.1 * k as f32);
                    println!(
                        "{tolerance:e} | {:.1} | {steps} | {at600:.1e} | {per_step:.1}",
                        0.1 * k as f32
                    );
                    rest.push(steps);
                }
                rest.sort_unstable();
                println!(
                    "{tolerance:e}: median at rest after {} steps ({}–{})",
                    median(&rest),
                    rest.first().unwrap_or(&0),
                    rest.last().unwrap_or(&0)
                );
            }
        }
        Some("pile") => {
            let seeds = count(2, 40);
            for tolerance in tolerances(1) {
                let (mut rested, mut iterations) = (0, 0.0);
                for seed in 1..=seeds {
                    let (at_rest, per_step) = pile(tolerance, seed);
                    rested += u32::from(at_rest);
                    iterations += per_step;
                }
                println!(
                    "{tolerance:e}: {rested} of {seeds} piles at rest, {:.1} CG it/step",
                    iterations / seeds as f64
                );
            }
        }
        _ => eprintln!(
            "usage: rest_sweep drape [N] [TOLERANCES] [ORIENTATIONS] | pile [TOLERANCES] [SEEDS]"
        ),
    }
}

fn settings(tolerance: f32) -> Settings {
    Settings {
        tolerance,
        ..Settings::default()
    }
}

/// `(step after which the fastest vertex stays below 1 mm/s, fastest at step 600, CG it/step)`.
fn drape(n: usize, tolerance: f32, angle: f32) -> (u32, f32, f64) {
    let sheet = drape_sheet(n, angle);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, settings(tolerance));
    w.add_collider(drape_sphere()).unwrap();
    let (steps, mut moving, mut at600, mut iterations) = (1500u32, 0u32, 0.0f32, 0u64);
    for step in 1..=steps {
        iterations += u64::from(w.step().unwrap().iterations);
        let fastest = top_speed(&w);
        if fastest > 1e-3 {
            moving = step;
        }
        if step == 600 {
            at600 = fastest;
        }
    }
    (moving, at600, iterations as f64 / f64::from(steps))
}

/// `(at rest by the pile test's bounds, CG it/step over the whole drop)`.
fn pile(tolerance: f32, seed: u64) -> (bool, f64) {
    let run = drop_pile(seed, settings(tolerance));
    (run.at_rest(), run.per_step())
}

fn median(v: &[u32]) -> f64 {
    match v.len() {
        0 => 0.0,
        l if l % 2 == 1 => f64::from(v[l / 2]),
        l => 0.5 * f64::from(v[l / 2 - 1] + v[l / 2]),
    }
}
