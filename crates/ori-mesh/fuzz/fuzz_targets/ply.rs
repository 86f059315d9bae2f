//! Arbitrary bytes as a PLY model: never a panic, never an allocation from an unchecked
//! header count; whatever loads round-trips (see `common.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    common::check("m.ply", data, &[], &[]);
});
