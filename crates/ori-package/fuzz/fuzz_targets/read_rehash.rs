//! Like `read`, but first makes the header agree with the manifest the mutator left: the
//! manifest is taken to run from byte 64 to the first zero byte (JSON has none; padding is
//! zero), and its length, blake3 and the payload offset are written into the header. So
//! mutations of the JSON reach the parser and the manifest's rules instead of stopping at
//! the hash check.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut bytes = data.to_vec();
    if bytes.len() >= 64 {
        let end = bytes[64..]
            .iter()
            .position(|&b| b == 0)
            .map_or(bytes.len(), |k| 64 + k);
        let hash = blake3::hash(&bytes[64..end]);
        let payload = (end as u64).next_multiple_of(ori_package::ALIGN);
        bytes[16..24].copy_from_slice(&(end as u64 - 64).to_le_bytes());
        bytes[24..56].copy_from_slice(hash.as_bytes());
        bytes[56..64].copy_from_slice(&payload.to_le_bytes());
    }
    if let Ok(package) = ori_package::read(&bytes) {
        let written = ori_package::write(&package.manifest, &package.textures)
            .expect("a package that reads must write");
        assert!(written == bytes, "write(read(x)) differs from x");
        let again = ori_package::read(&written).expect("a written package must read");
        assert_eq!(again, package);
    }
});
