//! `Blob::parse` on arbitrary bytes: as they are, misaligned, and resealed (size and CRC fixed so
//! mutations reach the checks behind the checksum). See `tests/fuzz_harness/mod.rs`.
#![no_main]

#[path = "../../tests/fuzz_harness/mod.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    harness::blob(data);
});
