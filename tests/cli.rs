//! `weft-cell inspect` and `weft-cell preview`, run as the binary on synthetic blobs; and
//! `weft-bench`'s report over several trajectories.

mod cells;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use cells::{laminate, material, small_cell, two_materials, Axis};
use weft::blob::{write, CellRecord};

fn tmp(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(name)
}

fn weft_cell(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_weft-cell"))
        .args(args)
        .output()
        .expect("run weft-cell")
}

fn two_cells() -> Vec<CellRecord> {
    vec![
        laminate(
            "stripes",
            Axis::U,
            &[0, 0, 1, 1, 0, 1],
            2,
            2,
            0.012,
            two_materials(),
        ),
        laminate("bands", Axis::V, &[1, 0, 0], 4, 3, 0.008, two_materials()),
    ]
}

fn save(cells: &[CellRecord], name: &str) -> PathBuf {
    let path = tmp(name);
    std::fs::write(&path, write(cells).unwrap()).unwrap();
    path
}

#[test]
fn inspect_json_reports_every_cell() {
    let cells = two_cells();
    let path = save(&cells, "cli_inspect.weft");
    let out = weft_cell(&["inspect", path.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("exactly one JSON value");
    assert_eq!(v["version"], 1);
    let listed = v["cells"].as_array().unwrap();
    assert_eq!(listed.len(), cells.len());
    let close = |j: &serde_json::Value, x: f64| (j.as_f64().unwrap() - x).abs() <= 1e-15 * x.abs();
    for (j, c) in listed.iter().zip(&cells) {
        assert_eq!(j["name"], c.name.as_str());
        assert!(close(&j["size"], c.size));
        assert_eq!(j["pixels"], serde_json::json!([c.cols, c.rows]));
        assert_eq!(j["refine"], c.refine);
        assert_eq!(j["nodes"], c.nodes.len());
        assert_eq!(j["triangles"], c.triangles.len());
        assert!(close(&j["density"], c.density));
        assert!(close(&j["bending"], c.bending));
        for (key, m) in [
            ("stiffness", &c.stiffness),
            ("voigt_bound", &c.voigt_bound),
            ("reuss_bound", &c.reuss_bound),
        ] {
            for (r, row) in m.iter().enumerate() {
                for (k, v) in row.iter().enumerate() {
                    assert!(close(&j[key][r][k], *v), "{key}[{r}][{k}]");
                }
            }
        }
        // What the table shows beyond the record: anisotropy, bounds, χ, materials.
        assert!(close(
            &j["anisotropy"],
            c.stiffness[0][0] / c.stiffness[1][1]
        ));
        assert_eq!(j["bounds"]["holds"], "yes");
        assert!(j["bounds"]["min_eig_ch_minus_reuss"].as_f64().unwrap() >= 0.0);
        assert!(j["bounds"]["min_eig_voigt_minus_ch"].as_f64().unwrap() >= 0.0);
        let max_chi = j["chi"]["max_norm"].as_array().unwrap();
        assert_eq!(max_chi.len(), 3);
        assert!(max_chi.iter().any(|v| v.as_f64().unwrap() > 0.0));
        assert!(j["chi"]["max_abs_mean"].as_f64().unwrap() < 1e-9);
        let mats = j["materials"].as_array().unwrap();
        assert_eq!(mats.len(), c.materials.len());
        let mut area = 0.0;
        for (jm, m) in mats.iter().zip(&c.materials) {
            assert!(close(&jm["density"], m.density));
            assert!(close(&jm["bending"], m.bending));
            assert!(close(&jm["c"][0][1], m.c[0][1]));
            area += jm["area_fraction"].as_f64().unwrap();
        }
        assert!((area - 1.0).abs() < 1e-12);
    }
}

/// `C^H` moved below the Reuss bound by a relative 1e-8 (solver precision) and by 1e-3: the
/// bounds check says neither "yes" beside a negative eigenvalue.
#[test]
fn bounds_check_never_says_yes_beside_a_negative_eigenvalue() {
    for (shrink, table_says, json_says) in [
        (0.0, "yes", "yes"),
        (1e-8, "within solver precision", "within solver precision"),
        (1e-3, "NO", "no"),
    ] {
        let mut cell = two_cells().remove(0);
        cell.stiffness = cell.reuss_bound.map(|r| r.map(|v| v * (1.0 - shrink)));
        let path = save(&[cell], "cli_bounds.weft");
        let text =
            String::from_utf8(weft_cell(&["inspect", path.to_str().unwrap()]).stdout).unwrap();
        let line = text
            .lines()
            .find(|l| l.contains("Reuss <= C^H <= Voigt"))
            .unwrap();
        assert!(line.contains(&format!("Voigt: {table_says} ")), "{line}");
        let out = weft_cell(&["inspect", path.to_str().unwrap(), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["cells"][0]["bounds"]["holds"], json_says, "{shrink}");
        let lower = v["cells"][0]["bounds"]["min_eig_ch_minus_reuss"]
            .as_f64()
            .unwrap();
        assert_eq!(lower < 0.0, shrink > 0.0, "{shrink}: {lower}");
    }
}

/// Writes `text` as a cell file in the test's temporary folder.
fn cell_file(name: &str, text: &str) -> PathBuf {
    let path = tmp(name);
    std::fs::write(&path, text).unwrap();
    path
}

const CELL: &str = r#"
size = 0.01
pattern = ["ab", "ba"]
[materials.a]
stiffness = 1000.0
poisson = 0.3
density = 0.2
[materials.b]
tensor = [[300.0, 40.0, 0.0], [40.0, 90.0, 0.0], [0.0, 0.0, 30.0]]
density = 0.1
"#;

/// In a pipeline (stderr not a terminal) `build` prints no progress lines, only what it wrote;
/// it warns about a material the pattern never uses; `preview` says where its picture went.
#[test]
fn build_and_preview_say_what_they_did_and_nothing_more() {
    let unused = cell_file(
        "cli_unused.toml",
        &format!("{CELL}[materials.c]\nstiffness = 5.0\npoisson = 0.0\ndensity = 0.1\n"),
    );
    let blob = tmp("cli_built.weft");
    let out = weft_cell(&[
        "build",
        unused.to_str().unwrap(),
        "-o",
        blob.to_str().unwrap(),
    ]);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.success(), "{err}");
    assert!(
        !err.contains("homogenizing") && !err.contains('\r'),
        "{err}"
    );
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(
        lines[0].contains("warning") && lines[0].contains("\"c\" is not used"),
        "{err}"
    );
    assert!(
        lines[1].starts_with(&format!("wrote {}", blob.display())),
        "{err}"
    );

    let clean = cell_file("cli_clean.toml", CELL);
    let out = weft_cell(&[
        "build",
        clean.to_str().unwrap(),
        "-o",
        blob.to_str().unwrap(),
    ]);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"));

    let png = tmp("cli_said.png");
    let out = weft_cell(&[
        "preview",
        blob.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8(out.stderr).unwrap().trim(),
        format!("wrote {}", png.display())
    );
    assert!(png.is_file());
}

/// Errors a technical artist meets: a misspelled key (with the key meant), a tensor that is
/// not symmetric and one that is not positive definite (told apart), a truncated blob (with
/// both sizes).
#[test]
fn errors_say_what_to_fix() {
    let build = |name: &str, text: &str| {
        let path = cell_file(name, text);
        let out = weft_cell(&[
            "build",
            path.to_str().unwrap(),
            "-o",
            tmp("cli_x.weft").to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        String::from_utf8(out.stderr).unwrap()
    };
    let err = build(
        "cli_typo.toml",
        &CELL.replace("density = 0.1", "densty = 0.1"),
    );
    assert!(
        err.contains("unknown key `densty`; did you mean `density`?"),
        "{err}"
    );
    let err = build("cli_asym.toml", &CELL.replace("[40.0, 90.0", "[41.0, 90.0"));
    assert!(err.contains("not symmetric") && err.contains("41"), "{err}");
    assert!(!err.contains("positive definite"), "{err}");
    let err = build(
        "cli_indef.toml",
        &CELL.replace("[0.0, 0.0, 30.0]", "[0.0, 0.0, -30.0]"),
    );
    assert!(err.contains("symmetric but not positive definite"), "{err}");

    let whole = save(&[small_cell()], "cli_whole.weft");
    let bytes = std::fs::read(&whole).unwrap();
    let cut = tmp("cli_cut.weft");
    std::fs::write(&cut, &bytes[..bytes.len() - 10]).unwrap();
    let out = weft_cell(&["inspect", cut.to_str().unwrap()]);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains(&format!(
            "{} bytes, expected at least {}",
            bytes.len() - 10,
            bytes.len()
        )),
        "{err}"
    );
}

#[test]
fn inspect_table_is_readable() {
    let cells = two_cells();
    let path = save(&cells, "cli_table.weft");
    let out = weft_cell(&["inspect", path.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("\"stripes\"") && text.contains("\"bands\""),
        "{text}"
    );
    assert!(text.contains("C11/C22"));
    // The laminates are exact, so their C^H lies within the bounds.
    assert_eq!(
        text.matches("Reuss <= C^H <= Voigt: yes").count(),
        2,
        "{text}"
    );
}

#[test]
fn errors_go_to_stderr_with_failure_status() {
    let path = save(&[small_cell()], "cli_corrupt.weft");
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    bytes[n - 20] ^= 0x40;
    std::fs::write(&path, &bytes).unwrap();
    for args in [
        vec!["inspect", path.to_str().unwrap()],
        vec!["inspect", "/nonexistent/x.weft", "--json"],
        vec![
            "preview",
            path.to_str().unwrap(),
            "-o",
            tmp("cli_never.png").to_str().unwrap(),
        ],
    ] {
        let out = weft_cell(&args);
        assert!(!out.status.success(), "{args:?}");
        assert!(out.stdout.is_empty());
        assert!(String::from_utf8_lossy(&out.stderr).starts_with("weft-cell: "));
    }
    assert!(!tmp("cli_never.png").exists());
}

/// Decodes an 8-bit RGB PNG into (width, height, pixels).
fn decode(path: &Path) -> (usize, usize, Vec<[u8; 3]>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    let px = buf[..info.buffer_size()]
        .chunks(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width as usize, info.height as usize, px)
}

// Layout of src/bin/weft-cell/preview.rs: 4 panels of 240 px with 16 px gaps and margins; each
// cell row is 24 (title) + 22 (labels) + 240 (panels) + 8 + 2·18 (legend) + 16 (gap) tall.
const WIDTH: usize = 2 * 16 + 4 * 240 + 3 * 16;
const ROW: usize = 24 + 22 + 240 + 8 + 2 * 18 + 16;
const PANEL_TOP: usize = 16 + 24 + 22;

#[test]
fn preview_draws_every_cell() {
    // Ten materials overflow the legend (eight slots): exercises its "+N more" entry.
    let many: Vec<_> = (0..10)
        .map(|m| material(500.0 + 300.0 * m as f64, 0.3, 0.2, 1e-5))
        .collect();
    let layers: Vec<u32> = (0..10).collect();
    let ten = laminate("ten", Axis::U, &layers, 3, 1, 0.02, many);
    for (cells, name) in [
        (vec![small_cell()], "preview_one"),
        (two_cells(), "preview_two"),
        (vec![ten], "preview_ten"),
    ] {
        let blob = save(&cells, &format!("{name}.weft"));
        let png_path = tmp(&format!("{name}.png"));
        let _ = std::fs::remove_file(&png_path);
        let out = weft_cell(&[
            "preview",
            blob.to_str().unwrap(),
            "-o",
            png_path.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let (w, h, px) = decode(&png_path);
        assert_eq!((w, h), (WIDTH, 2 * 16 + cells.len() * ROW));

        let white = [255u8; 3];
        let ink = px.iter().filter(|&&p| p != white).count();
        assert!(ink > w * h / 5, "mostly blank: {ink} of {}", w * h);
        let mut colours: Vec<[u8; 3]> = px.clone();
        colours.sort();
        colours.dedup();
        assert!(colours.len() >= 6, "{} colours", colours.len());

        // Every panel of every row is drawn, and the three deformed panels differ from each
        // other and from the pattern (the deformation is actually applied).
        for row in 0..cells.len() {
            let panel = |p: usize| -> Vec<[u8; 3]> {
                let (x0, y0) = (16 + p * 256, PANEL_TOP + row * ROW);
                (y0..y0 + 240)
                    .flat_map(|y| px[y * w + x0..y * w + x0 + 240].to_vec())
                    .collect()
            };
            let panels: Vec<_> = (0..4).map(panel).collect();
            for (p, pixels) in panels.iter().enumerate() {
                let background = [242u8; 3];
                let drawn = pixels
                    .iter()
                    .filter(|&&c| c != background && c != white)
                    .count();
                assert!(
                    drawn > 240 * 240 / 10,
                    "row {row} panel {p} nearly empty: {drawn}"
                );
            }
            for a in 0..4 {
                for b in a + 1..4 {
                    assert_ne!(
                        panels[a], panels[b],
                        "row {row}: panels {a} and {b} identical"
                    );
                }
            }
        }
    }
}

/// `weft-bench --trajectories K` runs its scene K times (the wind turned a little in each after
/// the first) and reports each figure's median and range over them; the runs differ (a turned
/// wind is another trajectory), and one trajectory prints what it always did (no spread keys).
#[test]
fn weft_bench_reports_the_spread_over_trajectories() {
    let bench = |extra: &[&str]| -> serde_json::Value {
        let out = Command::new(env!("CARGO_BIN_EXE_weft-bench"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args([
                "--grid",
                "9",
                "--steps",
                "20",
                "--tolerance",
                "1e-3",
                "--json",
            ])
            .args(extra)
            .output()
            .expect("run weft-bench");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).expect("JSON")
    };
    let one = bench(&[]);
    assert!(one.get("trajectories").is_none(), "{one}");
    let many = bench(&["--trajectories", "4"]);
    assert_eq!(many["trajectories"], 4);
    for key in [
        "cg_iterations_mean",
        "cg_iterations_first_solve",
        "worst_edge_strain",
    ] {
        let median = many[key].as_f64().expect(key);
        let range = &many[format!("{key}_range")];
        let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
        assert!(
            lo <= median && median <= hi,
            "{key}: {median} outside {lo}–{hi}"
        );
    }
    let strain = &many["worst_edge_strain_range"];
    assert!(
        strain[0].as_f64() < strain[1].as_f64(),
        "the turned winds gave the same cloth: {strain}"
    );
}
