//! Mesh and world init from decoded bytes, then edits (pins, colliders, positions, settings) and
//! steps. See `tests/fuzz_harness/mod.rs` for the encoding and the checked properties.
#![no_main]

#[path = "../../tests/fuzz_harness/mod.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = harness::world(data);
});
