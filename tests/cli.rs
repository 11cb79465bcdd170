//! `weft-cell inspect` and `weft-cell preview`, run as the binary on synthetic blobs.

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
            for r in 0..3 {
                for k in 0..3 {
                    assert!(close(&j[key][r][k], m[r][k]), "{key}[{r}][{k}]");
                }
            }
        }
    }
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
