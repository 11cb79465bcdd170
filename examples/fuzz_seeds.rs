//! Writes the seed corpus of the fuzz targets (`fuzz/`): small valid blobs built by the library
//! (`homogenize::build_blob` on the bundled cells at refine 1, and `blob::write` on tiny cells)
//! and a few world inputs in the harness encoding (`tests/fuzz_harness/mod.rs`).
//!
//! Run from the repository root: `cargo run --example fuzz_seeds [-- OUT_DIR]` (default
//! `fuzz/seeds`). The seeds are committed; rerun only when the harness encoding changes.

#[cfg(feature = "std")]
#[path = "../tests/fuzz_harness/mod.rs"]
mod harness;

#[cfg(feature = "std")]
fn main() -> std::io::Result<()> {
    use std::path::PathBuf;
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "fuzz/seeds".into()),
    );
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    for (target, seeds) in [
        ("blob", harness::blob_seeds(&root.join("cells"))),
        ("world", harness::world_seeds()),
    ] {
        let dir = out.join(target);
        std::fs::create_dir_all(&dir)?;
        for (name, bytes) in seeds {
            let path = dir.join(&name);
            std::fs::write(&path, &bytes)?;
            println!("{} ({} bytes)", path.display(), bytes.len());
        }
    }
    Ok(())
}

#[cfg(not(feature = "std"))]
fn main() {}
