//! Arbitrary bytes as the MTL library of a fixed, textured OBJ that uses materials `a` and
//! `b`: never a panic; whatever loads round-trips (see `common.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

const OBJ: &[u8] = b"mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n\
usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 2/2 4/1 3/3\nusemtl a\nf 3/3 4/1 2/2\n";

fuzz_target!(|data: &[u8]| {
    common::check("m.obj", OBJ, &[("m.mtl", data)], &[]);
});
