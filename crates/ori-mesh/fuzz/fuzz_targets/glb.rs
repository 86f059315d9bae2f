//! Arbitrary bytes as a `.glb` file (header, JSON chunk, binary chunk): never a panic;
//! whatever loads round-trips (see `common.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    common::check("m.glb", data, &[], &[]);
});
