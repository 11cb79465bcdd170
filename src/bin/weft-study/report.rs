//! The study's outputs: `study.csv`, `study.md`, the SVG plots and the PNG pictures.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3A;

use crate::plot::{style, Plot, Series, COLOURS};
use crate::preview::{Image, INK};
use crate::render::{self, Camera, Depth, Panel};
use crate::scenes::Kind;
use crate::upsample::Mode;
use crate::{median, BenchOut, Knobs, Picture, Row, CELLS, REFERENCE_MAX_ITER};

pub const CSV_COLUMNS: [&str; 28] = [
    "scene",
    "cell",
    "material",
    "coarse_res",
    "strain",
    "cg_tol",
    "cg_max_iter",
    "substeps",
    "warping",
    "solver",
    "localization",
    "normals",
    "ms_per_step",
    "localize_ms",
    "err_mean",
    "err_max",
    "err_mean_aligned",
    "err_normal_deg",
    "cg_iters",
    "fine_vertices",
    "fine_triangles",
    "coarse_vertices",
    "sheet_m",
    "max_speed",
    "steps_held",
    "steps_redone",
    "steps_limited",
    "status",
];

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map(|x| x.to_string()).unwrap_or_else(|| "-".into())
}

fn num(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else {
        format!("{v:.4e}")
    }
}

fn ms(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else {
        format!("{v:.4}")
    }
}

impl Row {
    fn localization(&self) -> &'static str {
        self.mode.map(Mode::localization).unwrap_or("-")
    }
    fn normals(&self) -> &'static str {
        self.mode.map(Mode::normals).unwrap_or("-")
    }
    fn csv(&self) -> String {
        [
            self.scene.clone(),
            self.cell.clone(),
            self.material.clone(),
            opt(self.coarse_res),
            opt(self.strain),
            format!("{:e}", self.cg_tol),
            self.cg_max_iter.to_string(),
            self.substeps.to_string(),
            if self.warping { "on" } else { "off" }.into(),
            self.solver.into(),
            self.localization().into(),
            self.normals().into(),
            ms(self.ms_per_step),
            self.localize_ms.map(ms).unwrap_or_else(|| "-".into()),
            num(self.err_mean),
            num(self.err_max),
            num(self.err_mean_aligned),
            if self.err_normal_deg.is_nan() {
                "-".into()
            } else {
                format!("{:.3}", self.err_normal_deg)
            },
            if self.cg_iters.is_nan() {
                "-".into()
            } else {
                format!("{:.1}", self.cg_iters)
            },
            self.fine_vertices.to_string(),
            self.fine_triangles.to_string(),
            opt(self.coarse_vertices),
            format!("{}", self.sheet_m),
            num(self.max_speed),
            opt(self.balance.map(|b| b.held)),
            opt(self.balance.map(|b| b.redone)),
            opt(self.balance.map(|b| b.limited)),
            self.status.replace(',', ";"),
        ]
        .join(",")
    }
    /// Time of one frame of the coarse method: step plus localization (or embedding).
    pub fn frame_ms(&self) -> f64 {
        self.ms_per_step + self.localize_ms.unwrap_or(0.0)
    }
    fn is(&self, material: &str, knobs: &Knobs) -> bool {
        self.material == material
            && self.coarse_res == Some(knobs.res)
            && self.cg_tol == knobs.tol
            && self.cg_max_iter == knobs.max_iter
            && self.substeps == knobs.substeps
            && self.warping == knobs.warping
            && self.solver == crate::solver_name(knobs.solver)
            && self.status == "ok"
    }
    fn knobs(&self) -> String {
        let mut parts = Vec::new();
        if let Some(r) = self.coarse_res {
            parts.push(format!("{r}x{r} cells/quad"));
        }
        parts.push(format!(
            "{} tol {:e}/{}",
            self.solver, self.cg_tol, self.cg_max_iter
        ));
        parts.push(format!("{} substep", self.substeps));
        if !self.warping {
            parts.push("no warping".into());
        }
        parts.join(", ")
    }
}

fn case_key(r: &Row) -> (String, String, String) {
    (
        r.scene.clone(),
        r.cell.clone(),
        r.strain.map(|s| format!("{s:.3}")).unwrap_or_default(),
    )
}

fn pct(s: Option<f64>) -> String {
    s.map(|s| format!("{:.0}%", s * 100.0)).unwrap_or_default()
}

const ON: Mode = Mode::On {
    recompute_normals: false,
};

pub fn write_all(
    out: &Path,
    preset: &str,
    rows: &[Row],
    pictures: &[Picture],
    bench: Option<&BenchOut>,
) -> Result<(), String> {
    let write = |name: &str, text: &str| {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))
    };
    let mut csv = CSV_COLUMNS.join(",");
    csv.push('\n');
    for r in rows {
        csv.push_str(&r.csv());
        csv.push('\n');
    }
    write("study.csv", &csv)?;
    write("study.md", &markdown(preset, rows, bench))?;
    write("strain.svg", &strain_plot(rows))?;
    let (combined, per_case) = pareto_plots(rows);
    write("pareto.svg", &combined)?;
    for (name, svg) in per_case {
        write(&name, &svg)?;
    }
    for p in pictures {
        let name = format!(
            "{}-{}{}.png",
            p.scene.name(),
            CELLS[p.cell],
            p.scene
                .strain()
                .map(|s| format!("-{:.0}", s * 100.0))
                .unwrap_or_default()
        );
        picture(p).save_png(&out.join(&name))?;
    }
    Ok(())
}

/// The fine reference row of a case.
fn reference_of<'a>(rows: &'a [Row], key: &(String, String, String)) -> Option<&'a Row> {
    rows.iter()
        .find(|r| case_key(r) == *key && r.material == "fine" && r.err_mean == 0.0)
}

fn coarse<'a>(
    rows: &'a [Row],
    key: &(String, String, String),
    material: &str,
    knobs: &Knobs,
    mode: Mode,
) -> Option<&'a Row> {
    rows.iter()
        .find(|r| case_key(r) == *key && r.is(material, knobs) && r.mode == Some(mode))
}

fn e(r: Option<&Row>) -> String {
    r.map(|r| format!("{:.2e}", r.err_mean))
        .unwrap_or_else(|| "-".into())
}

fn markdown(preset: &str, rows: &[Row], bench: Option<&BenchOut>) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# weft-study ({preset} preset)\n");
    let _ = writeln!(
        md,
        "Errors are the per-vertex distance to the fine reference averaged over all fine vertices \
         (`err_mean`, the paper's Fig. 7) or its maximum (`err_max`), divided by the sheet size. \
         The fine reference is the runtime `World` on the tiled micro meshes with each pixel's own \
         material and a tight CG (relative residual 1e-6, 1e-5 and 2 substeps for the dynamic \
         drape; at most {REFERENCE_MAX_ITER} iterations per solve). Coarse baseline: homogenized C^H, one cell per coarse quad, CG {:e} / {} \
         iterations, 1 substep, per-element warping. Times are medians over the steps of a run, one \
         core; `loc ms` is the median per-frame localization (or, off, barycentric embedding).\n",
        Knobs::BASE.tol,
        Knobs::BASE.max_iter
    );

    // --- error versus strain ---
    let mut keys: Vec<(String, String, String)> = Vec::new();
    for r in rows {
        let k = case_key(r);
        if !keys.contains(&k) && r.scene != "bench-drape" {
            keys.push(k);
        }
    }
    let avg = Knobs {
        averaged: true,
        ..Knobs::BASE
    };
    let header = "| scene | cell | strain | hom., loc. off | hom. + loc. | avg. + loc. | avg./hom. | aligned: hom., loc. off | hom. + loc. | avg. + loc. | avg./hom. | fine ms/step | coarse ms/step + loc. ms |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|";
    let _ = writeln!(md, "## Baseline: homogenized versus averaged material\n");
    let _ = writeln!(
        md,
        "Mean error / sheet size; *aligned*: the same once the mean offset (a uniform \
         translation of the whole sheet) is taken out.\n"
    );
    let _ = writeln!(md, "{header}");
    let ea = |r: Option<&Row>| {
        r.map(|r| format!("{:.2e}", r.err_mean_aligned))
            .unwrap_or_else(|| "-".into())
    };
    let ratio = |h: Option<&Row>, a: Option<&Row>, f: fn(&Row) -> f64| match (h, a) {
        (Some(h), Some(a)) => format!("{:.1}", f(a) / f(h)),
        _ => "-".into(),
    };
    for k in &keys {
        let r = |material: &str, knobs: &Knobs, mode: Mode| coarse(rows, k, material, knobs, mode);
        let ho = r("homogenized", &Knobs::BASE, Mode::Off);
        let hl = r("homogenized", &Knobs::BASE, ON);
        let al = r("averaged", &avg, ON);
        let fine = reference_of(rows, k)
            .map(|f| format!("{:.1}", f.ms_per_step))
            .unwrap_or_default();
        let cms = hl
            .or(ho)
            .map(|c| {
                format!(
                    "{:.3} + {:.3}",
                    c.ms_per_step,
                    c.localize_ms.unwrap_or(f64::NAN)
                )
            })
            .unwrap_or_default();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            k.0,
            k.1,
            pct(ho.or(hl).and_then(|r| r.strain)),
            e(ho),
            e(hl),
            e(al),
            ratio(hl, al, |r| r.err_mean),
            ea(ho),
            ea(hl),
            ea(al),
            ratio(hl, al, |r| r.err_mean_aligned),
            fine,
            cms
        );
    }

    // --- coarse resolution ---
    let _ = writeln!(
        md,
        "\n## Coarse resolution (cells per coarse quad side), localization on\n"
    );
    let _ = writeln!(
        md,
        "| scene | cell | strain | res | coarse vertices | hom. err | avg. err | hom. ms/step | loc. ms |\n|---|---|---|---|---|---|---|---|---|"
    );
    for k in &keys {
        for res in [1, 2, 4] {
            let h = coarse(rows, k, "homogenized", &Knobs { res, ..Knobs::BASE }, ON);
            let a = coarse(rows, k, "averaged", &Knobs { res, ..avg }, ON);
            if let Some(h) = h {
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {res} | {} | {:.2e} | {} | {:.3} | {:.3} |",
                    k.0,
                    k.1,
                    pct(h.strain),
                    opt(h.coarse_vertices),
                    h.err_mean,
                    e(a),
                    h.ms_per_step,
                    h.localize_ms.unwrap_or(f64::NAN)
                );
            }
        }
    }

    // --- knob sweeps ---
    let _ = writeln!(
        md,
        "\n## Knob sweeps (homogenized, one knob at a time from the baseline)\n"
    );
    let _ = writeln!(
        md,
        "| scene | cell | strain | configuration | ms/step | CG it./step | loc. off err | loc. on err | loc. on (Green) err | err max (on) | normals blended / recomputed (deg) | loc. ms blended / recomputed |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for k in &keys {
        let swept: Vec<&Row> = rows
            .iter()
            .filter(|r| {
                case_key(r) == *k
                    && r.material == "homogenized"
                    && r.coarse_res == Some(1)
                    && r.mode == Some(Mode::Off)
            })
            .collect();
        if swept.len() < 3 {
            continue;
        }
        for off in swept {
            let same = |mode: Mode| {
                rows.iter().find(|r| {
                    case_key(r) == *k
                        && r.material == off.material
                        && r.coarse_res == off.coarse_res
                        && r.cg_tol == off.cg_tol
                        && r.cg_max_iter == off.cg_max_iter
                        && r.substeps == off.substeps
                        && r.warping == off.warping
                        && r.mode == Some(mode)
                })
            };
            let on = same(ON);
            let rec = same(Mode::On {
                recompute_normals: true,
            });
            let green = same(Mode::Green);
            let f = |r: Option<&Row>, g: &dyn Fn(&Row) -> String| r.map(g).unwrap_or("-".into());
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {:.3} | {:.0} | {:.2e} | {} | {} | {} | {} / {} | {} / {} |",
                k.0,
                k.1,
                pct(off.strain),
                if off.status == "ok" {
                    off.knobs()
                } else {
                    format!("{} ({})", off.knobs(), off.status)
                },
                off.ms_per_step,
                off.cg_iters,
                off.err_mean,
                e(on),
                e(green),
                f(on, &|r| format!("{:.2e}", r.err_max)),
                f(on, &|r| format!("{:.2}", r.err_normal_deg)),
                f(rec, &|r| format!("{:.2}", r.err_normal_deg)),
                f(on, &|r| format!("{:.3}", r.localize_ms.unwrap_or(f64::NAN))),
                f(rec, &|r| format!(
                    "{:.3}",
                    r.localize_ms.unwrap_or(f64::NAN)
                )),
            );
        }
        if let Some(f) = rows
            .iter()
            .find(|r| case_key(r) == *k && r.material == "fine" && r.cg_tol == Knobs::BASE.tol)
        {
            let _ = writeln!(
                md,
                "| {} | {} | {} | **fine sheet** at the runtime's CG ({:e}/{}) | {:.3} | {:.0} | {:.2e} | | | {:.2e} | {:.2} | |",
                k.0,
                k.1,
                pct(f.strain),
                f.cg_tol,
                f.cg_max_iter,
                f.ms_per_step,
                f.cg_iters,
                f.err_mean,
                f.err_max,
                f.err_normal_deg
            );
        }
    }

    // --- speedup at each error level ---
    let _ = writeln!(
        md,
        "\n## Speedup of homogenized coarse + localization over the fine reference\n"
    );
    let _ = writeln!(
        md,
        "For each case and error level: the fastest homogenized coarse configuration with \
         localization on (any resolution / CG / substeps / warping) whose mean error is at most \
         the level; its time is the coarse step plus the localization. Speedup against the fine \
         reference (tight CG) and, in brackets, against the fine sheet stepped with the runtime's \
         own CG settings (when that run did not fail).\n"
    );
    let levels = [1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1];
    let _ = writeln!(
        md,
        "| scene | cell | strain | fine ms: reference (runtime CG) | {} |\n|---|---|---|---|{}",
        levels
            .iter()
            .map(|l| format!("err <= {l:.0e}"))
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(levels.len())
    );
    for k in &keys {
        let Some(fine_ref) = reference_of(rows, k) else {
            continue;
        };
        let Some(fine_rt) = rows
            .iter()
            .find(|r| case_key(r) == *k && r.material == "fine" && r.cg_tol == Knobs::BASE.tol)
        else {
            continue;
        };
        let rt_ok = fine_rt.status == "ok";
        let mut cells = Vec::new();
        for level in levels {
            let best = rows
                .iter()
                .filter(|r| {
                    case_key(r) == *k
                        && r.material == "homogenized"
                        && r.mode.is_some_and(Mode::is_on)
                        && r.status == "ok"
                        && r.err_mean <= level
                })
                .min_by(|a, b| a.frame_ms().total_cmp(&b.frame_ms()));
            cells.push(match best {
                Some(b) => format!(
                    "{:.0}x{} ({:.2} ms: {})",
                    fine_ref.ms_per_step / b.frame_ms(),
                    if rt_ok {
                        format!(" [{:.0}x]", fine_rt.ms_per_step / b.frame_ms())
                    } else {
                        String::new()
                    },
                    b.frame_ms(),
                    b.knobs()
                ),
                None => "-".into(),
            });
        }
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.1} ({}) | {} |",
            k.0,
            k.1,
            pct(fine_rt.strain),
            fine_ref.ms_per_step,
            if rt_ok {
                format!("{:.1}", fine_rt.ms_per_step)
            } else {
                fine_rt.status.clone()
            },
            cells.join(" | ")
        );
    }

    if let Some(b) = bench {
        let step = median(&b.coarse.ms);
        let loc = median(&b.localize_ms);
        let _ = writeln!(
            md,
            "\n## Speed on a {}-triangle fine sheet\n",
            b.fine_triangles
        );
        let _ = writeln!(
            md,
            "Drape scene (1/120 s steps). Medians over the timed steps; one core. A step the \
             energy balance redoes with more substeps, energy-limits or holds still (what it \
             does with a step that gains energy) is timed like the others and counted in the \
             status; so is a refused step (the balance refuses only when it is not a number, \
             `Unstable`).\n"
        );
        let _ = writeln!(
            md,
            "| | vertices | world bytes | CG tol / cap, substeps | steps timed | ms/step (median) | CG it./step | localization ms | speedup of coarse + loc. | status |\n|---|---|---|---|---|---|---|---|---|---|"
        );
        let coarse_loc = loc;
        let mut line = |label: &str,
                        verts: usize,
                        bytes: usize,
                        r: &crate::BenchRun,
                        loc: Option<f64>| {
            let ms = median(&r.ms);
            let _ = writeln!(
                md,
                "| {label} | {verts} | {bytes} | {:e} / {}, {} | {} | {:.3} | {:.0} | {} | {} | {} |",
                r.tol,
                r.max_iter,
                r.substeps,
                r.ms.len(),
                ms,
                r.iters,
                loc.map(|l| format!("{l:.3}")).unwrap_or_default(),
                if loc.is_none() {
                    format!("**{:.0}×**", ms / (step + coarse_loc))
                } else {
                    String::new()
                },
                r.status()
            );
        };
        line(
            "fine sheet, runtime CG",
            b.fine_vertices,
            b.world_bytes_fine,
            &b.fine,
            None,
        );
        if let Some(r) = &b.reference {
            line(
                "fine reference",
                b.fine_vertices,
                b.world_bytes_fine,
                r,
                None,
            );
        }
        line(
            "coarse + localization",
            b.coarse_vertices,
            b.world_bytes_coarse,
            &b.coarse,
            Some(loc),
        );
        let _ = writeln!(
            md,
            "\nSpeedup = fine ms/step ÷ (coarse ms/step {step:.3} + localization {loc:.3} ms)."
        );
    }

    let _ = writeln!(md, "\n## Every run\n");
    let _ = writeln!(md, "| {} |", CSV_COLUMNS.join(" | "));
    let _ = writeln!(md, "|{}", "---|".repeat(CSV_COLUMNS.len()));
    for r in rows {
        let _ = writeln!(md, "| {} |", r.csv().replace(',', " | "));
    }
    md
}

fn strain_plot(rows: &[Row]) -> String {
    let mut plots = Vec::new();
    type Metric = fn(&Row) -> f64;
    let metrics: [(&str, Metric); 2] =
        [("", |r| r.err_mean), (" (aligned)", |r| r.err_mean_aligned)];
    for (suffix, metric) in metrics {
        for cell in CELLS {
            let mut series = Vec::new();
            for (d, dir) in ["stretch-u", "stretch-v", "stretch-diag"]
                .iter()
                .enumerate()
            {
                for (material, knobs, marker) in [
                    ("homogenized", Knobs::BASE, 'o'),
                    (
                        "averaged",
                        Knobs {
                            averaged: true,
                            ..Knobs::BASE
                        },
                        's',
                    ),
                ] {
                    for (mode, dashed) in [(ON, false), (Mode::Off, true)] {
                        let mut pts: Vec<(f64, f64)> = rows
                            .iter()
                            .filter(|r| {
                                r.scene == *dir
                                    && r.cell == cell
                                    && r.is(material, &knobs)
                                    && r.mode == Some(mode)
                            })
                            .filter_map(|r| r.strain.map(|s| (s * 100.0, metric(r))))
                            .collect();
                        if pts.is_empty() {
                            continue;
                        }
                        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                        series.push(Series {
                            name: format!(
                                "{} {}{}",
                                &dir[8..],
                                &material[..3],
                                if dashed { ", loc. off" } else { " + loc." }
                            ),
                            colour: COLOURS[d * 2 + usize::from(material == "averaged")],
                            points: pts,
                            line: true,
                            dashed,
                            marker,
                        });
                    }
                }
            }
            if !series.is_empty() {
                plots.push(Plot {
                    title: format!("{cell}: error versus strain{suffix}"),
                    x_label: "macro strain (%)".into(),
                    y_label: format!("mean vertex error{suffix} / sheet size"),
                    x_log: true,
                    y_log: true,
                    series,
                });
            }
        }
    }
    combine(&plots, 2)
}

/// Plots in one SVG, `columns` per row.
fn combine(plots: &[Plot], columns: usize) -> String {
    let svgs: Vec<String> = plots.iter().map(Plot::svg).collect();
    let size = |s: &str, key: &str| -> f64 {
        s.split(&format!(" {key}=\""))
            .nth(1)
            .and_then(|t| t.split('"').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or(0.0)
    };
    let (mut w, mut h) = (0.0f64, 0.0f64);
    let (mut x, mut y, mut row_h) = (0.0f64, 0.0f64, 0.0f64);
    let mut body = String::new();
    for (k, s) in svgs.iter().enumerate() {
        if k > 0 && k % columns.max(1) == 0 {
            x = 0.0;
            y += row_h;
            row_h = 0.0;
        }
        let (sw, sh) = (size(s, "width"), size(s, "height"));
        let inner = s.replacen("<svg ", &format!("<svg x=\"{x}\" y=\"{y}\" "), 1);
        body.push_str(&inner);
        x += sw;
        w = w.max(x);
        row_h = row_h.max(sh);
        h = h.max(y + row_h);
    }
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">\n{body}</svg>\n"
    )
}

/// `pareto.svg` (every case with a sweep: its Pareto front, loc. on) and one plot per case
/// with every configuration.
fn pareto_plots(rows: &[Row]) -> (String, Vec<(String, String)>) {
    let mut keys: Vec<(String, String, String)> = Vec::new();
    for r in rows {
        let k = case_key(r);
        let swept = rows
            .iter()
            .any(|q| case_key(q) == k && q.material == "fine" && q.cg_tol == Knobs::BASE.tol);
        if swept && !keys.contains(&k) {
            keys.push(k);
        }
    }
    let mut fronts = Vec::new();
    let mut per_case = Vec::new();
    for k in &keys {
        let name = format!(
            "{} {}{}",
            k.0,
            k.1,
            if k.2.is_empty() {
                String::new()
            } else {
                format!(" {:.0}%", k.2.parse::<f64>().unwrap_or(0.0) * 100.0)
            }
        );
        let mut groups: BTreeMap<(usize, &str), Vec<(f64, f64)>> = BTreeMap::new();
        let mut front_pts = Vec::new();
        for r in rows
            .iter()
            .filter(|r| case_key(r) == *k && r.status == "ok")
        {
            let (g, label) = match (r.material.as_str(), r.mode) {
                ("fine", _) if r.err_mean == 0.0 => continue,
                ("fine", _) => (0, "fine sheet, runtime CG"),
                ("homogenized", Some(Mode::Off)) => (1, "homogenized, loc. off"),
                ("homogenized", Some(m)) if m.is_on() => (2, "homogenized + loc."),
                ("averaged", Some(Mode::Off)) => (3, "averaged, loc. off"),
                ("averaged", _) => (4, "averaged + loc."),
                _ => continue,
            };
            groups
                .entry((g, label))
                .or_default()
                .push((r.frame_ms(), r.err_mean));
            if r.mode.is_some_and(Mode::is_on) {
                front_pts.push((r.frame_ms(), r.err_mean));
            }
        }
        if groups.is_empty() {
            // A timing-only case (no error measured): nothing to plot.
            continue;
        }
        let reference_ms = reference_of(rows, k).map(|r| r.ms_per_step);
        let mut series: Vec<Series> = groups
            .into_iter()
            .map(|((g, label), points)| Series {
                name: label.into(),
                colour: COLOURS[g],
                points,
                line: false,
                dashed: false,
                marker: ['^', 'x', 'o', 'x', 's'][g],
            })
            .collect();
        let front = pareto_front(&front_pts);
        if let Some(ms) = reference_ms {
            let (lo, hi) = series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1))
                .filter(|v| *v > 0.0 && v.is_finite())
                .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
            if lo.is_finite() {
                series.push(Series {
                    name: "fine reference (err 0)".into(),
                    colour: COLOURS[6],
                    points: vec![(ms, lo), (ms, hi)],
                    line: true,
                    dashed: true,
                    marker: ' ',
                });
            }
        }
        series.push(Series {
            name: "Pareto front (loc. on)".into(),
            colour: COLOURS[9],
            points: front.clone(),
            line: true,
            dashed: false,
            marker: ' ',
        });
        let file = format!(
            "pareto-{}-{}{}.svg",
            k.0,
            k.1,
            if k.2.is_empty() {
                String::new()
            } else {
                format!("-{:.0}", k.2.parse::<f64>().unwrap_or(0.0) * 100.0)
            }
        );
        per_case.push((
            file,
            Plot {
                title: format!("{name}: error versus cost"),
                x_label: "ms per frame (coarse step + localization; fine: step)".into(),
                y_label: "mean vertex error / sheet size".into(),
                x_log: true,
                y_log: true,
                series,
            }
            .svg(),
        ));
        let (colour, marker) = style(fronts.len());
        fronts.push(Series {
            name,
            colour,
            points: front,
            line: true,
            dashed: false,
            marker,
        });
    }
    let combined = Plot {
        title: "Pareto fronts: coarse + localization".into(),
        x_label: "ms per frame (coarse step + localization)".into(),
        y_label: "mean vertex error / sheet size".into(),
        x_log: true,
        y_log: true,
        series: fronts,
    }
    .svg();
    (combined, per_case)
}

/// Points not dominated by a faster and more accurate one, by increasing time.
fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut out: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if out.last().is_none_or(|l| q.1 < l.1) {
            out.push(q);
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// pictures
// ---------------------------------------------------------------------------------------------

const PANEL: usize = 300;
const GAP: usize = 12;
const LABEL: usize = 40;
const MARGIN: usize = 12;

/// One picture per scene: the fine reference and the coarse runs side by side (top: whole
/// sheet; bottom: a zoom on two cells with the fine mesh drawn), the reference's outline
/// (black) drawn over every panel.
fn picture(p: &Picture) -> Image {
    let cols = 1 + p.panels.len();
    let title_h = 24;
    let width = 2 * MARGIN + cols * PANEL + (cols - 1) * GAP;
    let height = 2 * MARGIN + title_h + 3 * (LABEL + PANEL) + 2 * GAP;
    let mut img = Image::new(width, height);
    let title = format!(
        "{} {}{}: fine reference vs coarse (outline: reference)",
        p.scene.name(),
        CELLS[p.cell],
        p.scene
            .strain()
            .map(|s| format!(" {:.0}%", s * 100.0))
            .unwrap_or_default()
    );
    img.text(MARGIN, MARGIN, &title, INK);
    let mut all: Vec<(&str, &[Vec3A], f64)> = vec![("fine reference", &p.reference, 0.0)];
    for (l, x, e) in &p.panels {
        all.push((l, x, *e));
    }
    let (toward, up) = p.scene.view();
    let top = MARGIN + title_h;
    let panel_at = |c: usize, row: usize| Panel {
        x: MARGIN + c * (PANEL + GAP),
        y: top + row * (LABEL + PANEL + GAP) + LABEL,
        w: PANEL,
        h: PANEL,
    };
    let meshes: Vec<&[Vec3A]> = all.iter().map(|a| a.1).collect();
    let cam = Camera::fit(toward, up, &meshes, &panel_at(0, 0), 10.0);
    let outline = render::grid_boundary(&p.reference, p.fine.nx, p.fine.ny);
    let size = p.fine.width.max(p.fine.height);
    // zoom: two cells around a point where the scene does something
    let (fu, fv) = match p.scene.kind {
        Kind::Hang {
            along: crate::scenes::Dir::U,
            ..
        } => (0.88, 0.12),
        Kind::Hang { .. } => (0.12, 0.88),
        _ => (0.5, 0.5),
    };
    let (i, j) = (
        ((p.fine.nx - 1) as f64 * fu).round() as usize,
        ((p.fine.ny - 1) as f64 * fv).round() as usize,
    );
    let focus = p.reference[j * p.fine.nx + i];
    let cells_across = 2.2;
    let zoom_scale = PANEL as f32 / (p.cell_size as f32 * cells_across);
    let zoom = cam.zoomed(focus, zoom_scale.max(cam.scale()));
    // per-vertex distance to the reference, one colour scale for the whole picture
    let dist: Vec<Vec<f32>> = all
        .iter()
        .map(|a| {
            a.1.iter()
                .zip(&p.reference)
                .map(|(x, r)| (*x - *r).length())
                .collect()
        })
        .collect();
    let scale = dist
        .iter()
        .flatten()
        .copied()
        .fold(0.0f32, f32::max)
        .max(f32::MIN_POSITIVE);
    for (c, (label, x, err)) in all.iter().enumerate() {
        for (row, camera) in [(0, &cam), (1, &zoom), (2, &cam)] {
            let panel = panel_at(c, row);
            img.fill_rect(panel.x, panel.y, panel.w, panel.h, [246, 246, 246]);
            let mut depth = Depth::new(panel);
            if let Some((c, r)) = p.scene.sphere(p.fine.width as f32) {
                let (sx, st) = render::sphere_mesh(c, r, 24);
                render::draw_mesh_with(
                    &mut img,
                    &mut depth,
                    camera,
                    &sx,
                    &st,
                    &|_| [200, 200, 200],
                    None,
                );
            }
            if row == 2 {
                let d = &dist[c];
                render::draw_mesh_with(
                    &mut img,
                    &mut depth,
                    camera,
                    x,
                    &p.fine.triangles,
                    &|t| {
                        let [a, b, e] = p.fine.triangles[t].map(|i| d[i as usize]);
                        heat((a + b + e) / (3.0 * scale))
                    },
                    None,
                );
            } else {
                render::draw_mesh(
                    &mut img,
                    &mut depth,
                    camera,
                    x,
                    &p.fine.triangles,
                    &p.fine.materials,
                    if row == 1 { Some([60, 60, 60]) } else { None },
                );
            }
            render::draw_polyline(&mut img, camera, &panel, &outline, INK);
            if row == 2 {
                let text = if c == 0 {
                    format!("0 to {:.2}% of size", 100.0 * f64::from(scale) / size)
                } else {
                    "distance to reference".into()
                };
                img.text(panel.x, panel.y - LABEL + 20, &text, INK);
                if c == 0 {
                    // colour bar
                    for k in 0..panel.w - 20 {
                        let col = heat(k as f32 / (panel.w - 20) as f32);
                        img.fill_rect(panel.x + 10 + k, panel.y + panel.h - 18, 1, 10, col);
                    }
                }
            } else if row == 0 {
                img.text(panel.x, panel.y - LABEL + 2, label, INK);
                let sub = if c == 0 {
                    format!("{} triangles", p.fine.triangles.len())
                } else {
                    format!("err mean {:.2}% of size", err * 100.0)
                };
                img.text(panel.x, panel.y - LABEL + 20, &sub, INK);
            } else {
                img.text(panel.x, panel.y - LABEL + 20, "zoom, fine mesh", INK);
            }
        }
    }
    img
}

/// White (0) through yellow and orange to dark red (1).
fn heat(t: f32) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0);
    let stops: [(f32, [f32; 3]); 4] = [
        (0.0, [255.0, 255.0, 255.0]),
        (0.33, [255.0, 220.0, 60.0]),
        (0.66, [240.0, 100.0, 20.0]),
        (1.0, [140.0, 0.0, 20.0]),
    ];
    for w in stops.windows(2) {
        let ((a, ca), (b, cb)) = (w[0], w[1]);
        if t <= b {
            let f = (t - a) / (b - a);
            return [0, 1, 2].map(|k| (ca[k] + f * (cb[k] - ca[k])).round() as u8);
        }
    }
    [140, 0, 20]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, material: &str, mode: Option<Mode>, err: f64, status: &str) -> Row {
        Row {
            scene: scene.into(),
            cell: "three".into(),
            material: material.into(),
            coarse_res: (material != "fine").then_some(1),
            strain: None,
            cg_tol: Knobs::BASE.tol,
            cg_max_iter: 200,
            substeps: 1,
            warping: true,
            solver: "multigrid",
            mode,
            ms_per_step: 1.0 + err,
            localize_ms: mode.map(|_| 0.5),
            err_mean: err,
            err_max: err,
            err_mean_aligned: err,
            err_normal_deg: 0.0,
            cg_iters: 10.0,
            fine_vertices: 100,
            fine_triangles: 200,
            coarse_vertices: Some(9),
            sheet_m: 0.2,
            max_speed: 0.0,
            balance: Some(crate::Balance::default()),
            status: status.into(),
        }
    }

    /// Sixteen cases with errors and one timing-only case: the combined plot has a legend entry
    /// in its own colour and marker for each of the sixteen and none for the timing-only one,
    /// which also gets no SVG of its own.
    #[test]
    fn pareto_plots_skip_timing_only_cases_and_never_repeat_a_style() {
        let mut rows = Vec::new();
        for c in 0..16 {
            let scene = format!("case{c:02}");
            rows.push(row(&scene, "fine", None, 0.0, "ok"));
            rows.push(row(
                &scene,
                "homogenized",
                Some(ON),
                1e-3 * (c + 1) as f64,
                "ok",
            ));
            // slower and more accurate: a front of two points, drawn as a line
            let mut better = row(&scene, "homogenized", Some(ON), 1e-4, "ok");
            better.ms_per_step = 5.0;
            rows.push(better);
        }
        rows.push(row("bench", "fine", None, 0.0, "timing only"));
        rows.push(row(
            "bench",
            "homogenized",
            Some(ON),
            f64::NAN,
            "timing only",
        ));
        let (combined, per_case) = pareto_plots(&rows);
        assert_eq!(per_case.len(), 16);
        assert!(per_case.iter().all(|(name, _)| !name.contains("bench")));
        assert!(!combined.contains("bench"));
        let legend = combined.lines().filter(|l| l.contains(">case")).count();
        assert_eq!(legend, 16);
        let mut styles: Vec<String> = combined
            .lines()
            .filter(|l| l.starts_with("<polyline"))
            .map(|l| l.split("stroke=").nth(1).unwrap_or("").to_string())
            .collect();
        assert_eq!(styles.len(), 16);
        styles.sort();
        styles.dedup();
        assert_eq!(styles.len(), 16, "a colour is reused");
    }
}
