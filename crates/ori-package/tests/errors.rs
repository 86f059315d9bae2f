//! Each kind of damage gives its specific, typed error, from `write` and from `read`.

mod common;

use common::{RES, assemble, manifest_json, rewrap, sample, textures};
use ori_package::{ALIGN, Manifest, PackageError, TextureFormat, read, write};

/// The message of a `Manifest` error, or a panic naming what came instead.
fn manifest_error<T: std::fmt::Debug>(result: Result<T, PackageError>) -> String {
    match result {
        Err(PackageError::Manifest(message)) => message,
        other => panic!("expected a manifest error, got {other:?}"),
    }
}

/// Changes the manifest of a valid file `bytes` in place, re-hashing it; the change must
/// keep the payload offset, so the textures stay where they are.
fn with_manifest(bytes: &[u8], change: impl FnOnce(&mut Manifest)) -> Vec<u8> {
    let mut m: Manifest = serde_json::from_slice(manifest_json(bytes)).unwrap();
    change(&mut m);
    let json = serde_json::to_vec(&m).unwrap();
    let payload = u64::from_le_bytes(bytes[56..64].try_into().unwrap());
    assert_eq!((64 + json.len() as u64).next_multiple_of(ALIGN), payload);
    let mut out = common::header(&json, payload);
    out.extend_from_slice(&json);
    out.resize(payload as usize, 0);
    out.extend_from_slice(&bytes[payload as usize..]);
    out
}

/// Checks that `change` makes `write` fail with a manifest error containing `needle`, and
/// that a file carrying the same manifest (written without validation) fails to read with
/// the same message.
fn both_reject(change: impl Fn(&mut Manifest), needle: &str) {
    let (mut m, t) = sample(2, TextureFormat::R8);
    change(&mut m);
    let written = manifest_error(write(&m, &t));
    assert!(
        written.contains(needle),
        "write: {written:?} lacks {needle:?}"
    );
    let read_back = manifest_error(read(&assemble(&m, &t)));
    assert_eq!(read_back, written);
}

/// Checks that `change` makes `write` fail with a manifest error containing `needle` (for
/// values JSON cannot carry, such as non-finite floats).
fn write_rejects(change: impl Fn(&mut Manifest), needle: &str) {
    let (mut m, t) = sample(2, TextureFormat::R8);
    change(&mut m);
    let written = manifest_error(write(&m, &t));
    assert!(
        written.contains(needle),
        "write: {written:?} lacks {needle:?}"
    );
}

#[test]
fn selection_index_out_of_range() {
    both_reject(
        |m| m.selection.entries[17].impostors = vec![0, 2],
        "entry 17 names impostor 2",
    );
}

#[test]
fn selection_with_319_entries() {
    both_reject(
        |m| drop(m.selection.entries.pop()),
        "319 entries, expected 320",
    );
}

#[test]
fn wrong_plt_gc() {
    // The PLT must follow from GC, and GC fit the image.
    both_reject(|m| m.plt.gc += 1, "plt.pixels");
    both_reject(|m| m.plt.gc = m.plt.s0 * m.plt.s0 + 1, "plt.gc");
}

#[test]
fn selection_entry_rules() {
    both_reject(
        |m| m.selection.entries[3].impostors = vec![1, 1],
        "names impostor 1 twice",
    );
    both_reject(
        |m| m.selection.entries[4].impostors.clear(),
        "entry 4 draws no impostor",
    );
    both_reject(
        |m| m.selection.directions = "icosahedron-80".into(),
        "icosahedron-320",
    );
    both_reject(
        |m| {
            m.selection.s0 = 16;
            m.plt.s0 = 16;
        },
        "more than s0 x s0 = 256",
    );
    both_reject(|m| m.selection.s0 = 0, "selection.s0 is 0");
}

#[test]
fn plt_rules() {
    both_reject(|m| m.plt.pixels = m.plt.pixels.next_up(), "plt.pixels");
    both_reject(|m| m.plt.at_least = true, "plt.at_least");
    both_reject(|m| m.plt.s0 = 512, "plt.s0");
    both_reject(|m| m.plt.recommended_resolution = 300, "power of two");
}

#[test]
fn impostor_geometry_rules() {
    write_rejects(|m| m.bounding_sphere.radius = f64::NAN, "must be finite");
    both_reject(|m| m.bounding_sphere.radius = 0.0, "radius");
    write_rejects(
        |m| m.impostors[1].half_size = f64::INFINITY,
        "impostors[1]: half_size is inf",
    );
    both_reject(|m| m.impostors[0].half_size = -1.0, "half_size is -1");
    both_reject(|m| m.impostors[0].near = m.impostors[0].far, "near");
    both_reject(|m| m.impostors[0].frame[0][0] += 1e-3, "frame u has length");
    both_reject(|m| m.impostors[0].frame.swap(0, 1), "left-handed");
    both_reject(
        |m| {
            let d = m.impostors[0].frame[2];
            m.impostors[0].direction = d.map(|x| -x);
        },
        "differs from direction",
    );
    both_reject(|m| m.impostors[0].occupied[1] = 17.0, "occupied texel box");
    both_reject(
        |m| m.impostors[0].occupied[5] = 255.0,
        "occupied depth codes",
    );
    write_rejects(|m| m.impostors[0].occupied[2] = f32::NAN, "occupied is NaN");
}

#[test]
fn top_level_rules() {
    both_reject(|m| m.format_version = 2, "format_version is 2");
    both_reject(|m| m.tool.clear(), "tool is empty");
    both_reject(|m| m.source.name = "/abs/model.glb".into(), "source.name");
    both_reject(
        |m| m.source.blake3 = m.source.blake3.to_uppercase(),
        "source.blake3",
    );
    both_reject(|m| m.resolution = 12, "resolution 12");
    both_reject(
        |m| m.params = serde_json::json!([1, 2]),
        "params must be a JSON object",
    );
    let (mut m, t) = sample(1, TextureFormat::R8);
    m.depth_format = TextureFormat::Bc5;
    assert!(manifest_error(write(&m, &t)).contains("depth_format"));
    let (mut m, _) = sample(1, TextureFormat::R8);
    m.impostors.clear();
    assert!(manifest_error(write(&m, &[])).contains("0 impostors"));
    let (m, t) = sample(2, TextureFormat::R8);
    assert!(manifest_error(write(&m, &t[..1])).contains("2 impostors but 1 texture sets"));
}

#[test]
fn unknown_fields_are_rejected() {
    let (m, t) = sample(1, TextureFormat::R8);
    let json = String::from_utf8(manifest_json(&write(&m, &t).unwrap()).to_vec()).unwrap();
    let top = json.replacen('{', r#"{"extra":1,"#, 1);
    assert!(manifest_error(read(&rewrap(top.as_bytes()))).contains("unknown field `extra`"));
    let nested = json.replacen(r#""half_size":"#, r#""colour":[1,2],"half_size":"#, 1);
    assert!(manifest_error(read(&rewrap(nested.as_bytes()))).contains("unknown field `colour`"));
}

#[test]
fn non_canonical_json_is_rejected() {
    let (m, t) = sample(1, TextureFormat::R8);
    let json = String::from_utf8(manifest_json(&write(&m, &t).unwrap()).to_vec()).unwrap();
    let spaced = json.replacen('{', "{ ", 1);
    let unsorted = json
        .replace(r#"{"alpha":0.5,"#, r#"{"#)
        .replace(r#""regular"}}}"#, r#""regular"},"alpha":0.5}}"#);
    let exponent = json.replace(r#""alpha":0.5"#, r#""alpha":5e-1"#);
    for text in [spaced, unsorted, exponent] {
        assert_ne!(text, json);
        let message = manifest_error(read(&rewrap(text.as_bytes())));
        assert!(message.contains("canonical"), "{message}");
    }
    let version = json.replacen(r#""format_version":1"#, r#""format_version":2"#, 1);
    assert!(manifest_error(read(&rewrap(version.as_bytes()))).contains("format_version is 2"));
    let garbage = rewrap(b"{\"format_version\":1,");
    assert!(manifest_error(read(&garbage)).contains("not valid manifest JSON"));
    let not_utf8 = rewrap(b"{\"tool\":\"\xff\"}");
    assert!(manifest_error(read(&not_utf8)).contains("not valid manifest JSON"));
}

#[test]
fn wrong_texture_size() {
    let (m, mut t) = sample(2, TextureFormat::R8);
    t[1].depth = textures(8, 0, TextureFormat::R8).depth;
    let expect = |result: Result<_, PackageError>| match result {
        Err(PackageError::Texture {
            impostor: 1,
            map: "depth",
            reason,
        }) => assert!(
            reason.contains("8 x 8 texels, expected 16 x 16"),
            "{reason}"
        ),
        other => panic!("{other:?}"),
    };
    expect(write(&m, &t).map(|_| ()));
    expect(read(&assemble(&m, &t)).map(|_| ()));
}

#[test]
fn wrong_texture_format() {
    let (m, mut t) = sample(2, TextureFormat::R8);
    t[0].normal = t[0].albedo.clone();
    match write(&m, &t) {
        Err(PackageError::Texture {
            impostor: 0,
            map: "normal",
            reason,
        }) => assert!(reason.contains("Bc1RgbSrgb, expected Bc5Unorm"), "{reason}"),
        other => panic!("{other:?}"),
    }
    // A reference declaring another format than the manifest's rules.
    let (mut m, t) = sample(2, TextureFormat::R8);
    m.impostors[1].albedo.format = TextureFormat::Bc5;
    match read(&assemble(&m, &t)) {
        Err(PackageError::Texture {
            impostor: 1,
            map: "albedo",
            reason,
        }) => assert!(reason.contains("declared as Bc5"), "{reason}"),
        other => panic!("{other:?}"),
    }
    // Not KTX2 at all.
    let (m, mut t) = sample(1, TextureFormat::R8);
    t[0].depth = vec![0; 100];
    let message = write(&m, &t).unwrap_err().to_string();
    assert!(
        message.starts_with("impostor 0 depth texture: invalid KTX2 file"),
        "{message}"
    );
}

#[test]
fn header_errors() {
    let (m, t) = sample(1, TextureFormat::R8);
    let bytes = write(&m, &t).unwrap();

    let mut text_mode = b"ORIPKG\n".to_vec();
    text_mode.extend_from_slice(&bytes[8..]);
    assert!(matches!(read(&text_mode), Err(PackageError::BadMagic)));
    assert!(matches!(read(b"PK\x03\x04"), Err(PackageError::BadMagic)));
    assert!(matches!(
        read(b""),
        Err(PackageError::Truncated {
            what: "header",
            need: 64,
            have: 0
        })
    ));

    // Version 2 is a hierarchy: `read` says so (and `read_hierarchy` then finds a version-1
    // manifest, which is no tree); an unknown version is named.
    let mut v2 = bytes.clone();
    v2[8] = 2;
    assert!(matches!(read(&v2), Err(PackageError::IsHierarchy)));
    assert!(ori_package::read_hierarchy(&v2).is_err());
    let mut v3 = bytes.clone();
    v3[8] = 3;
    let err = read(&v3).unwrap_err();
    assert!(matches!(err, PackageError::UnsupportedVersion(3)));
    assert!(err.to_string().contains("version 3"), "{err}");

    let mut flags = bytes.clone();
    flags[12] = 1;
    assert!(matches!(read(&flags), Err(PackageError::Header(m)) if m.contains("flags")));

    let mut payload = bytes.clone();
    payload[56] ^= 1;
    assert!(matches!(read(&payload), Err(PackageError::Header(m)) if m.contains("payload offset")));

    let mut json = bytes.clone();
    json[100] ^= 0x20;
    assert!(matches!(read(&json), Err(PackageError::ManifestHash)));
    let mut hash = bytes.clone();
    hash[30] ^= 1;
    assert!(matches!(read(&hash), Err(PackageError::ManifestHash)));
}

#[test]
fn texture_hash_mismatch() {
    let (m, t) = sample(2, TextureFormat::R8);
    let bytes = write(&m, &t).unwrap();
    let p = read(&bytes).unwrap();
    let mut copy = bytes.clone();
    copy[p.manifest.impostors[1].albedo.offset as usize + 90] ^= 4;
    let err = read(&copy).unwrap_err();
    assert!(
        matches!(
            err,
            PackageError::HashMismatch {
                impostor: 1,
                map: "albedo"
            }
        ),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        "impostor 1 albedo texture is corrupt: its blake3 does not match the manifest"
    );
    let bad_hex = with_manifest(&bytes, |m| {
        m.impostors[0].normal.blake3 = m.impostors[0].normal.blake3.to_uppercase();
    });
    assert!(manifest_error(read(&bad_hex)).contains("impostors[0].normal.blake3"));
}

#[test]
fn layout_errors() {
    let (m, t) = sample(2, TextureFormat::R8);
    let bytes = write(&m, &t).unwrap();
    let layout = |file: Vec<u8>| match read(&file) {
        Err(PackageError::Layout(message)) => message,
        other => panic!("expected a layout error, got {other:?}"),
    };

    let mut trailing = bytes.clone();
    trailing.push(0);
    assert!(layout(trailing).contains("1 trailing bytes"));
    let mut trailing = bytes.clone();
    trailing.resize(bytes.len() + 256, 0);
    assert!(layout(trailing).contains("256 trailing bytes"));

    let misaligned = with_manifest(&bytes, |m| m.impostors[0].normal.offset += 1);
    assert!(layout(misaligned).contains("not a multiple of 256"));
    let overlapping = with_manifest(&bytes, |m| {
        m.impostors[0].normal.offset = m.impostors[0].depth.offset;
    });
    assert!(layout(overlapping).contains("inside the previous part"));
    let gap = with_manifest(&bytes, |m| m.impostors[1].depth.offset += ALIGN);
    assert!(layout(gap).contains("expected"));
    let outside = with_manifest(&bytes, |m| m.impostors[1].albedo.length += 1000);
    assert!(matches!(
        read(&outside),
        Err(PackageError::Truncated {
            what: "texture data",
            ..
        })
    ));
}

#[test]
fn messages_say_what_is_wrong() {
    let err = PackageError::Truncated {
        what: "manifest",
        need: 900,
        have: 100,
    };
    assert_eq!(
        err.to_string(),
        "truncated file: the manifest needs 900 bytes, the file has 100"
    );
    let (m, mut t) = sample(1, TextureFormat::R8);
    t[0].albedo = textures(RES / 2, 0, TextureFormat::R8).albedo;
    assert_eq!(
        write(&m, &t).unwrap_err().to_string(),
        "impostor 0 albedo texture: 8 x 8 texels, expected 16 x 16 (the manifest's resolution)"
    );
}
