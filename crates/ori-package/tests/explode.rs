//! `explode`: every file written, the manifest parses back, previews decode.

mod common;

use common::{RES, sample};
use ori_package::{Manifest, PackageError, TextureFormat, explode, read, write};

#[test]
fn explode_writes_every_file() {
    for depth_format in [TextureFormat::R8, TextureFormat::Bc4] {
        let (m, t) = sample(2, depth_format);
        let package = read(&write(&m, &t).unwrap()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("nested").join("pkg");
        let written = explode(&package, &out).unwrap();
        assert_eq!(written.len(), 1 + 2 * 6);
        assert_eq!(written[0], out.join("manifest.json"));
        for path in &written {
            assert!(path.is_file(), "{} missing", path.display());
        }

        let text = std::fs::read_to_string(out.join("manifest.json")).unwrap();
        assert!(text.contains("\n  \"format_version\": 1,"));
        let back: Manifest = serde_json::from_str(&text).unwrap();
        assert_eq!(back, package.manifest);

        for (i, tex) in t.iter().enumerate() {
            for (map, bytes) in [
                ("depth", &tex.depth),
                ("normal", &tex.normal),
                ("albedo", &tex.albedo),
            ] {
                let ktx = std::fs::read(out.join(format!("impostor-{i:02}-{map}.ktx2"))).unwrap();
                assert_eq!(&ktx, bytes);
                let png = image::open(out.join(format!("impostor-{i:02}-{map}.png")))
                    .unwrap()
                    .to_rgb8();
                assert_eq!(png.dimensions(), (RES, RES));
                if map == "depth" {
                    // Corners are empty (black); the centre is relief (never black).
                    assert_eq!(png.get_pixel(0, 0).0, [0, 0, 0]);
                    assert_ne!(png.get_pixel(RES / 2, RES / 2).0, [0, 0, 0]);
                }
            }
        }
    }
}

#[test]
fn explode_errors_name_the_path() {
    let (m, t) = sample(1, TextureFormat::R8);
    let package = read(&write(&m, &t).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let err = explode(&package, &file.join("sub")).unwrap_err();
    assert!(matches!(err, PackageError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("a-file"), "{err}");
}
