//! `weft-study --tiny` end to end: the fine reference against coarse runs on a 2×2-cell sheet.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

const COLUMNS: [&str; 16] = [
    "scene",
    "cell",
    "material",
    "coarse_res",
    "strain",
    "cg_tol",
    "substeps",
    "warping",
    "localization",
    "ms_per_step",
    "localize_ms",
    "err_mean",
    "err_max",
    "steps_held",
    "steps_redone",
    "steps_limited",
];

#[test]
fn tiny_study_homogenized_beats_averaged_across_the_stripes() {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("study-tiny");
    let _ = std::fs::remove_dir_all(&out);
    let run = Command::new(env!("CARGO_BIN_EXE_weft-study"))
        .args(["--tiny", "--out", out.to_str().unwrap()])
        .output()
        .expect("run weft-study");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for f in ["study.csv", "study.md", "pareto.svg", "strain.svg"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }

    let csv = std::fs::read_to_string(out.join("study.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for c in COLUMNS {
        assert!(header.contains(&c), "column {c} missing from {header:?}");
    }
    let rows: Vec<HashMap<&str, &str>> = lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            assert_eq!(v.len(), header.len(), "ragged row {l}");
            header.iter().copied().zip(v).collect()
        })
        .collect();
    let num = |r: &HashMap<&str, &str>, c: &str| -> f64 {
        r[c].parse()
            .unwrap_or_else(|_| panic!("{c} = {} is not a number", r[c]))
    };
    // every run that completed counts the steps the energy balance redid, energy-limited and
    // held still (its last resort since it no longer refuses a step for its energy): counts,
    // "-" only for a run that did not complete
    for r in &rows {
        if r["status"] == "ok" {
            for c in ["steps_held", "steps_redone", "steps_limited"] {
                assert!(
                    r[c].parse::<usize>().is_ok(),
                    "{c} = {} is not a count in {r:?}",
                    r[c]
                );
            }
        }
    }

    // the fine reference: error 0 by definition, and it ran
    let fine: Vec<_> = rows.iter().filter(|r| r["material"] == "fine").collect();
    assert!(!fine.is_empty());
    for r in &fine {
        assert_eq!(r["status"], "ok");
        assert_eq!(num(r, "err_mean"), 0.0);
        assert!(num(r, "ms_per_step") > 0.0);
    }

    // the baseline coarse runs of the stripes pulled across the stripes (along v)
    let pick = |material: &str, localization: &str| {
        rows.iter()
            .find(|r| {
                r["scene"] == "stretch-v"
                    && r["cell"] == "stripes"
                    && r["material"] == material
                    && r["coarse_res"] == "1"
                    && r["cg_tol"] == "1e-3"
                    && r["substeps"] == "1"
                    && r["warping"] == "on"
                    && r["localization"] == localization
                    && r["normals"] == "blended"
            })
            .unwrap_or_else(|| panic!("no {material} row with localization {localization}"))
    };
    for loc in ["on", "off"] {
        let (h, a) = (pick("homogenized", loc), pick("averaged", loc));
        assert_eq!(h["status"], "ok");
        assert_eq!(a["status"], "ok");
        let (eh, ea) = (num(h, "err_mean"), num(a, "err_mean"));
        assert!(
            eh > 0.0 && eh < ea,
            "localization {loc}: homogenized error {eh} should be below averaged {ea}"
        );
        assert!(num(h, "err_max") >= eh);
        assert!(num(h, "localize_ms") >= 0.0);
    }
    // localization shapes the micro pattern: once the common offset is taken out, the
    // localized sheet is closer to the reference than the barycentric embedding
    let (on, off) = (pick("homogenized", "on"), pick("homogenized", "off"));
    assert!(num(on, "err_mean_aligned") < num(off, "err_mean_aligned"));
}
