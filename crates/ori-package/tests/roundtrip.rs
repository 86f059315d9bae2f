//! Writing and reading back: equality, determinism, the layout of docs/FORMAT.md.

mod common;

use common::{RES, assemble, sample};
use ori_package::{ALIGN, FORMAT_VERSION, MAGIC, TextureFormat, read, write};
use ori_texture::VkFormat;

#[test]
fn round_trip_gives_back_manifest_and_textures() {
    for depth_format in [TextureFormat::R8, TextureFormat::Bc4] {
        let (m, t) = sample(3, depth_format);
        let bytes = write(&m, &t).unwrap();
        let p = read(&bytes).unwrap();
        assert_eq!(p.textures, t);
        // Equal but for the texture references, which write fills.
        let mut expected = m.clone();
        for (e, got) in expected.impostors.iter_mut().zip(&p.manifest.impostors) {
            e.depth = got.depth.clone();
            e.normal = got.normal.clone();
            e.albedo = got.albedo.clone();
        }
        assert_eq!(p.manifest, expected);
        for (i, imp) in p.manifest.impostors.iter().enumerate() {
            for (r, data) in [
                (&imp.depth, &t[i].depth),
                (&imp.normal, &t[i].normal),
                (&imp.albedo, &t[i].albedo),
            ] {
                assert_eq!(r.offset % ALIGN, 0);
                assert_eq!(r.length, data.len() as u64);
                assert_eq!(r.blake3, blake3::hash(data).to_hex().to_string());
                let start = r.offset as usize;
                assert_eq!(&bytes[start..start + data.len()], &data[..]);
            }
            assert_eq!(imp.depth.format, depth_format);
            let depth = p.depth(i);
            assert_eq!(depth.format(), depth_format.vk_format());
            assert_eq!((depth.width(), depth.height()), (RES, RES));
            assert_eq!(p.normal(i).format(), VkFormat::Bc5Unorm);
            assert_eq!(p.albedo(i).format(), VkFormat::Bc1RgbSrgb);
        }
        let total: usize = t
            .iter()
            .map(|x| x.depth.len() + x.normal.len() + x.albedo.len())
            .sum();
        assert_eq!(p.texture_bytes(), total as u64);
        // Writing what was read gives the same file.
        assert_eq!(write(&p.manifest, &p.textures).unwrap(), bytes);
    }
}

#[test]
fn write_is_deterministic_and_ignores_callers_references() {
    let (m, t) = sample(2, TextureFormat::R8);
    let a = write(&m, &t).unwrap();
    let b = write(&m.clone(), &t.clone()).unwrap();
    assert_eq!(a, b);
    let mut junk = m.clone();
    for imp in &mut junk.impostors {
        imp.depth.offset = 12345;
        imp.depth.length = 7;
        imp.normal.format = TextureFormat::R8;
        imp.albedo.blake3 = "not a hash".into();
    }
    assert_eq!(write(&junk, &t).unwrap(), a);
}

#[test]
fn layout_follows_format_md() {
    let (m, t) = sample(2, TextureFormat::R8);
    let bytes = write(&m, &t).unwrap();
    // An independent writer following docs/FORMAT.md gives the very same bytes.
    assert_eq!(assemble(&m, &t), bytes);

    assert_eq!(bytes[..8], MAGIC);
    assert_eq!(&MAGIC, b"ORIPKG\r\n");
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()),
        FORMAT_VERSION
    );
    assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().unwrap()), 0);
    let len = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    let json = &bytes[64..64 + len as usize];
    assert_eq!(&bytes[24..56], blake3::hash(json).as_bytes());
    let payload = u64::from_le_bytes(bytes[56..64].try_into().unwrap());
    assert_eq!(payload, (64 + len).next_multiple_of(ALIGN));
    assert!(
        bytes[64 + len as usize..payload as usize]
            .iter()
            .all(|&b| b == 0)
    );
    // Canonical JSON: compact, schema order, params keys sorted.
    let text = std::str::from_utf8(json).unwrap();
    assert!(text.starts_with(r#"{"format_version":1,"tool":"#));
    assert!(text.contains(r#""params":{"alpha":0.5,"bake":{"margin_texels":1,"resolution":16},"views":{"count":20,"strategy":"regular"}}}"#));
    assert!(!text.contains('\n') && !text.contains(": "));

    let p = read(&bytes).unwrap();
    let first = &p.manifest.impostors[0].depth;
    assert_eq!(first.offset, payload);
    let last = &p.manifest.impostors[1].albedo;
    assert_eq!(last.offset + last.length, bytes.len() as u64);
}

#[test]
fn params_are_sorted_whatever_the_insertion_order() {
    let (mut m, t) = sample(1, TextureFormat::R8);
    let mut map = serde_json::Map::new();
    map.insert("zeta".into(), 1.into());
    map.insert(
        "alpha".into(),
        serde_json::json!({"y": 2, "b": [3, {"k": 1, "c": 0}]}),
    );
    m.params = serde_json::Value::Object(map);
    let bytes = write(&m, &t).unwrap();
    let text = String::from_utf8_lossy(common::manifest_json(&bytes)).into_owned();
    assert!(text.ends_with(r#""params":{"alpha":{"b":[3,{"c":0,"k":1}],"y":2},"zeta":1}}"#));
    assert_eq!(read(&bytes).unwrap().manifest.params, m.params);
}

#[test]
fn floats_round_trip_exactly() {
    let (mut m, t) = sample(1, TextureFormat::R8);
    m.bounding_sphere.center = [0.1 + 0.2, 1e-300, -123456.789e10];
    m.bounding_sphere.radius = std::f64::consts::PI;
    m.impostors[0].center = [f64::MIN_POSITIVE, -0.0];
    m.impostors[0].half_size = 1.0 / 3.0;
    m.impostors[0].occupied = [0.1, 0.7, 1.0 / 3.0, 15.999999, 0.5, 253.99998];
    m.selection.goal_percent = 0.2000000000000001;
    let p = read(&write(&m, &t).unwrap()).unwrap();
    assert_eq!(p.manifest.bounding_sphere, m.bounding_sphere);
    assert_eq!(p.manifest.impostors[0].center, m.impostors[0].center);
    assert_eq!(p.manifest.impostors[0].half_size, 1.0 / 3.0);
    assert_eq!(p.manifest.impostors[0].occupied, m.impostors[0].occupied);
    assert_eq!(p.manifest.selection.goal_percent, 0.2000000000000001);
}

#[test]
fn gc_zero_means_at_least() {
    let (mut m, t) = sample(1, TextureFormat::R8);
    for e in &mut m.selection.entries {
        e.missed = 0;
    }
    m.plt.gc = 0;
    m.plt.pixels = 65536.0;
    m.plt.at_least = true;
    let p = read(&write(&m, &t).unwrap()).unwrap();
    assert!(p.manifest.plt.at_least);
}

#[test]
fn mip_levels_are_allowed() {
    let (m, mut t) = sample(1, TextureFormat::R8);
    let levels = (0..5)
        .map(|l| vec![7u8; ((RES >> l) * (RES >> l)) as usize])
        .collect();
    t[0].depth = ori_texture::Ktx2::new(VkFormat::R8Unorm, RES, RES, levels)
        .unwrap()
        .to_bytes();
    let p = read(&write(&m, &t).unwrap()).unwrap();
    assert_eq!(p.depth(0).levels().len(), 5);
}
