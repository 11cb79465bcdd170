//! `include/weft.h` is generated from the `src/ffi/` folder by cbindgen (the exact version is
//! pinned in Cargo.toml; it runs here through its library API, never in build.rs) and
//! committed. These tests regenerate it and fail when the committed one is stale
//! (`WEFT_BLESS=1 cargo test --test header` rewrites it), check that every declaration in it is
//! documented, and that its literal constants agree with the kernel.

use std::path::{Path, PathBuf};

use weft::ffi::*;
use weft::world::{effects, Capacity};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn header_path() -> PathBuf {
    root().join("include").join("weft.h")
}

fn generate() -> String {
    let config = cbindgen::Config::from_file(root().join("cbindgen.toml"))
        .expect("cbindgen.toml is a valid cbindgen configuration");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(root().join("src").join("ffi").join("mod.rs"))
        .generate()
        .expect("cbindgen generates the header from src/ffi/");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("the header is UTF-8")
}

#[test]
fn header_is_current() {
    let fresh = generate();
    let path = header_path();
    if std::env::var_os("WEFT_BLESS").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &fresh).unwrap();
        eprintln!("blessed {}", path.display());
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != fresh {
        let line = committed
            .lines()
            .zip(fresh.lines())
            .position(|(a, b)| a != b)
            .map_or_else(
                || committed.lines().count().min(fresh.lines().count()) + 1,
                |i| i + 1,
            );
        panic!(
            "{} is stale (first difference at line {line}): src/ffi/ or cbindgen.toml changed. \
             Regenerate it with `WEFT_BLESS=1 cargo test --test header` and commit it.",
            path.display()
        );
    }
}

/// Every function, constant, type, field and enum value carries a comment right above it.
#[test]
fn every_declaration_is_documented() {
    let text = generate();
    let lines: Vec<&str> = text.lines().collect();
    let mut undocumented = Vec::new();
    let mut in_body = false; // inside a struct or enum body
    let mut checked = 0;
    for (i, raw) in lines.iter().enumerate() {
        let line = raw.trim();
        let previous = lines[..i]
            .iter()
            .rev()
            .map(|l| l.trim())
            .find(|l| !l.is_empty())
            .unwrap_or("");
        let documented = previous.ends_with("*/");
        let is_decl = if line.starts_with("#define WEFT_") {
            !line.starts_with("#define WEFT_H")
        } else if line.starts_with("typedef struct") || line.starts_with("enum ") {
            in_body = line.ends_with('{');
            true
        } else if line == "{" {
            in_body = true; // an enum's body opens after its `#if ... : uint32_t` lines
            false
        } else if line.starts_with('}') {
            in_body = false;
            false
        } else if in_body {
            !line.is_empty()
                && !line.starts_with("/*")
                && !line.starts_with('*')
                && !line.starts_with('#')
        } else {
            line.contains("weft_") && line.contains('(') && !line.starts_with('*')
        };
        checked += is_decl as usize;
        if is_decl && !documented {
            undocumented.push(format!("{}: {line}", i + 1));
        }
    }
    assert!(checked > 100, "the checker saw only {checked} declarations");
    assert!(
        undocumented.is_empty(),
        "undocumented declarations in the header:\n{}",
        undocumented.join("\n")
    );
}

#[test]
fn default_capacity_matches_the_kernel() {
    let d = Capacity::DEFAULT;
    assert_eq!(WEFT_DEFAULT_MAX_VERTICES, d.vertices);
    assert_eq!(WEFT_DEFAULT_MAX_TRIANGLES, d.triangles);
    assert_eq!(WEFT_DEFAULT_MAX_EDGES, d.edges);
    assert_eq!(WEFT_DEFAULT_MAX_COLLIDERS, d.colliders);
    assert_eq!(WEFT_DEFAULT_MAX_PINS, d.pins);
}

/// The literal in the header is what `weft_world_memory_size` says for the default capacity:
/// the reserved header and `Capacity::DEFAULT.world_bytes()`, rounded up to the block
/// alignment (nothing else: the kernel reads the caller's strided input in place). When the
/// kernel's arrays change, update the literal and bless the header.
#[test]
fn default_world_memory_size_matches_the_kernel() {
    let cap = weft_default_capacity();
    let mut size = 0usize;
    let r = unsafe { weft_world_memory_size(&cap, &mut size, std::ptr::null_mut()) };
    assert_eq!(r, WeftResult::Ok);
    let d = Capacity::DEFAULT;
    let expected = (WEFT_WORLD_HEADER_SIZE + d.world_bytes() + 15) & !15;
    assert_eq!(size, expected);
    if cfg!(target_pointer_width = "64") {
        assert_eq!(
            WEFT_DEFAULT_WORLD_MEMORY_SIZE,
            expected,
            "update WEFT_DEFAULT_WORLD_MEMORY_SIZE in src/ffi/mod.rs to {expected} \
             (Capacity::DEFAULT.world_bytes() = {}) and bless the header",
            d.world_bytes()
        );
    }
    assert_eq!(WEFT_DEFAULT_WORLD_MEMORY_SIZE % WEFT_WORLD_MEMORY_ALIGN, 0);
}

#[test]
fn effect_bits_match_the_kernel() {
    let pairs = [
        (WEFT_EFFECT_GRAVITY, effects::GRAVITY),
        (WEFT_EFFECT_BENDING, effects::BENDING),
        (WEFT_EFFECT_DAMPING, effects::DAMPING),
        (WEFT_EFFECT_PINS, effects::PINS),
        (WEFT_EFFECT_COLLISION, effects::COLLISION),
        (WEFT_EFFECT_WIND, effects::WIND),
        (WEFT_EFFECT_WARPING, effects::WARPING),
        (WEFT_EFFECT_SLEEP, effects::SLEEP),
        (WEFT_EFFECT_ALL, effects::ALL),
    ];
    for (c, k) in pairs {
        assert_eq!(c, k);
    }
}

#[test]
fn versions_match_the_crate_and_the_blob_reader() {
    let v = |s: &str| s.parse::<u32>().unwrap();
    assert_eq!(WEFT_VERSION_MAJOR, v(env!("CARGO_PKG_VERSION_MAJOR")));
    assert_eq!(WEFT_VERSION_MINOR, v(env!("CARGO_PKG_VERSION_MINOR")));
    assert_eq!(WEFT_VERSION_PATCH, v(env!("CARGO_PKG_VERSION_PATCH")));
    assert_eq!(weft_version(), WEFT_VERSION);
    assert_eq!(WEFT_BLOB_VERSION, weft::blob::VERSION);
    assert_eq!(WEFT_BLOB_ALIGN, weft::blob::BASE_ALIGN);
}
