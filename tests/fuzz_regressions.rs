//! Replays the fuzz corpus in `cargo test`: the committed seeds (`fuzz/seeds/<target>/`) and every
//! input a fuzz run found crashing (`tests/fuzz-crashes/<target>/`, one file per crash, named
//! after what it found), through the very harness the fuzz targets run
//! (`tests/fuzz_harness/mod.rs`). The fuzzing itself is `scripts/fuzz.sh`, not part of CI.

mod fuzz_harness;

use std::path::{Path, PathBuf};

fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    v.sort();
    v
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn blob_seeds_are_valid_blobs() {
    let seeds = files(&root().join("fuzz/seeds/blob"));
    assert!(seeds.len() >= 4, "seed corpus missing: {seeds:?}");
    for path in seeds {
        let data = std::fs::read(&path).unwrap();
        // Valid as written, and still valid resealed (a no-op on a valid blob).
        assert_eq!(fuzz_harness::blob(&data), 2, "{}", path.display());
    }
}

#[test]
fn generated_blob_seeds_are_valid() {
    for (name, data) in fuzz_harness::blob_seeds(&root().join("cells")) {
        assert_eq!(fuzz_harness::blob(&data), 2, "{name}");
    }
}

#[test]
fn world_seeds_replay() {
    let seeds = files(&root().join("fuzz/seeds/world"));
    assert!(seeds.len() >= 4, "seed corpus missing: {seeds:?}");
    for path in seeds {
        let data = std::fs::read(&path).unwrap();
        // The seeds describe valid worlds: they must build (and then run their edits).
        let r = fuzz_harness::world(&data);
        assert!(r.is_ok(), "{}: {r:?}", path.display());
    }
    for (name, data) in fuzz_harness::world_seeds() {
        let r = fuzz_harness::world(&data);
        assert!(r.is_ok(), "{name}: {r:?}");
    }
}

#[test]
fn blob_crashes_stay_fixed() {
    for path in files(&root().join("tests/fuzz-crashes/blob")) {
        let data = std::fs::read(&path).unwrap();
        fuzz_harness::blob(&data);
    }
}

#[test]
fn world_crashes_stay_fixed() {
    for path in files(&root().join("tests/fuzz-crashes/world")) {
        let data = std::fs::read(&path).unwrap();
        let _ = fuzz_harness::world(&data);
    }
}
