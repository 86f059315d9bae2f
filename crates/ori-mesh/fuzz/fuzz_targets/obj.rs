//! Arbitrary bytes as an OBJ model (`mtllib m.mtl` finds a real library): never a panic,
//! never a large allocation; whatever loads round-trips (see `common.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

const MTL: &[u8] = b"newmtl m\nKd 0.8 0.4 0.2\nd 0.5\nmap_Kd t.png\nnewmtl n\nKd 0.1 0.9 0.1\n";

fuzz_target!(|data: &[u8]| {
    common::check("m.obj", data, &[("m.mtl", MTL)], &[]);
});
