//! Damaged and arbitrary input: always an error, never a panic, never a large allocation.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use common::{XorShift, sample};
use ori_package::{ALIGN, PackageError, TextureFormat, read, write};

/// Counts, per thread, the largest single allocation and the bytes allocated in all.
struct Counting;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
    static TOTAL: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|c| c.set(c.get().max(size)));
    let _ = TOTAL.try_with(|c| c.set(c.get().saturating_add(size)));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Reads `bytes`, returning the result and (largest allocation, total allocated).
fn measured_read(bytes: &[u8]) -> (Result<ori_package::Package, PackageError>, usize, usize) {
    LARGEST.with(|c| c.set(0));
    TOTAL.with(|c| c.set(0));
    let result = read(bytes);
    (result, LARGEST.with(Cell::get), TOTAL.with(Cell::get))
}

/// What read may allocate for an input of `len` bytes (all of it, summed).
fn budget(len: usize) -> usize {
    64 * len + (1 << 16)
}

fn valid() -> Vec<u8> {
    let (m, t) = sample(2, TextureFormat::R8);
    write(&m, &t).unwrap()
}

#[test]
fn every_truncation_is_an_error() {
    let bytes = valid();
    for len in 0..bytes.len() {
        match read(&bytes[..len]) {
            Ok(_) => panic!("a {len}-byte prefix of {} read as valid", bytes.len()),
            Err(PackageError::Truncated { need, have, .. }) => {
                assert_eq!(have, len as u64);
                assert!(need > have);
            }
            Err(e) => panic!("prefix {len}: {e}"),
        }
    }
    assert!(read(&bytes).is_ok());
}

#[test]
fn every_single_byte_change_is_an_error() {
    let bytes = valid();
    let mut copy = bytes.clone();
    for at in 0..bytes.len() {
        for mask in [0x01, 0x80, 0xff] {
            copy[at] ^= mask;
            let (result, largest, total) = measured_read(&copy);
            assert!(result.is_err(), "byte {at} ^ {mask:#x} went unnoticed");
            assert!(
                total <= budget(copy.len()),
                "byte {at}: {total} bytes allocated"
            );
            assert!(
                largest <= 2 * copy.len() + 4096,
                "byte {at}: allocation of {largest}"
            );
            copy[at] = bytes[at];
        }
    }
}

#[test]
fn nonzero_padding_is_rejected() {
    let bytes = valid();
    let p = read(&bytes).unwrap();
    let len = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    let first = &p.manifest.impostors[0];
    // The padding after the manifest, and between the first two textures.
    let gaps = [64 + len, (first.depth.offset + first.depth.length) as usize];
    for at in gaps {
        assert_eq!(bytes[at], 0);
        let mut copy = bytes.clone();
        copy[at] = 1;
        match read(&copy) {
            Err(PackageError::Layout(message)) => assert!(message.contains("padding"), "{message}"),
            other => panic!("padding byte {at}: {other:?}"),
        }
    }
}

#[test]
fn random_bytes_never_panic_or_over_allocate() {
    let base = valid();
    let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
    for case in 0..3000 {
        let input: Vec<u8> = match case % 3 {
            // Pure noise, often behind a valid magic so the header is parsed.
            0 => {
                let len = rng.below(512) as usize;
                let mut v: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
                if case % 2 == 0 && len >= 8 {
                    v[..8].copy_from_slice(b"ORIPKG\r\n");
                }
                v
            }
            // The valid file with a few random bytes changed.
            1 => {
                let mut v = base.clone();
                for _ in 0..1 + rng.below(8) {
                    let at = rng.below(v.len() as u64) as usize;
                    v[at] = rng.next() as u8;
                }
                v
            }
            // The valid header with random lengths and offsets.
            _ => {
                let mut v = base.clone();
                let field = [16usize, 56][rng.below(2) as usize];
                let value = match rng.below(3) {
                    0 => rng.next(),
                    1 => rng.below(base.len() as u64 * 2),
                    _ => u64::MAX - rng.below(1024),
                };
                v[field..field + 8].copy_from_slice(&value.to_le_bytes());
                v.truncate(rng.below(v.len() as u64 + 1) as usize);
                v
            }
        };
        let (result, largest, total) = measured_read(&input);
        if case % 3 != 1 {
            assert!(result.is_err(), "case {case} read as valid");
        }
        assert!(
            total <= budget(input.len()),
            "case {case}: {total} bytes allocated"
        );
        assert!(
            largest <= 2 * input.len() + 4096,
            "case {case}: allocation of {largest}"
        );
    }
}

#[test]
fn huge_manifest_length_is_an_error_without_allocation() {
    let bytes = valid();
    for claimed in [u64::MAX, u64::MAX - 63, 1 << 62, bytes.len() as u64] {
        let mut copy = bytes.clone();
        copy[16..24].copy_from_slice(&claimed.to_le_bytes());
        let (result, largest, _) = measured_read(&copy);
        match result {
            Err(PackageError::Truncated { what, .. }) => assert_eq!(what, "manifest"),
            Err(PackageError::Header(m)) => assert!(m.contains("manifest length"), "{m}"),
            other => panic!("length {claimed}: {other:?}"),
        }
        assert!(largest < 1024, "length {claimed}: allocation of {largest}");
    }
    // A huge payload offset and a huge texture length too.
    let mut copy = bytes.clone();
    copy[56..64].copy_from_slice(&(1u64 << 62).to_le_bytes());
    assert!(matches!(read(&copy), Err(PackageError::Header(_))));
    let mut copy = bytes[..64].to_vec();
    copy[16..24].copy_from_slice(&0u64.to_le_bytes());
    copy[56..64].copy_from_slice(&ALIGN.to_le_bytes());
    assert!(matches!(
        read(&copy),
        Err(PackageError::Truncated {
            what: "padding after the manifest",
            ..
        })
    ));
}

#[test]
fn the_recorded_march_is_read_within_its_ranges() {
    use ori_package::RecordedMarch;
    let of = |json: &str| RecordedMarch::of_params(&serde_json::from_str(json).unwrap());
    assert_eq!(
        of(r#"{"select": {"linear_steps": 16, "binary_steps": 7, "wall_threshold": 0.25}}"#),
        RecordedMarch {
            linear_steps: Some(16),
            binary_steps: Some(7),
            wall_threshold: Some(0.25)
        }
    );
    // Absent, of the wrong kind or out of range: not recorded (the reader's default).
    for json in [
        "{}",
        r#"{"select": 3}"#,
        r#"{"select": {"linear_steps": 0, "binary_steps": 33, "wall_threshold": -1}}"#,
        r#"{"select": {"linear_steps": 4294967312, "binary_steps": "7", "wall_threshold": null}}"#,
    ] {
        assert_eq!(of(json), RecordedMarch::default(), "{json}");
    }
}
