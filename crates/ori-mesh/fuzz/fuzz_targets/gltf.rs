//! Arbitrary bytes as a `.gltf` document. Buffer URIs read the Avocado sample's real binary
//! buffer (23,580 bytes) and image URIs a small PNG, so mutations of a real document reach
//! accessors, materials and textures: never a panic; whatever loads round-trips.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

const BIN: &[u8] = include_bytes!("../../../../samples/avocado/Avocado.bin");

fuzz_target!(|data: &[u8]| {
    common::check("m.gltf", data, &[], BIN);
});
