//! The checks shared by [`crate::read`] and [`crate::write`]: the manifest's canonical
//! bytes, its semantic rules, and each texture against its reference.

use ori_texture::Ktx2;
use serde_json::Value;

use crate::{FORMAT_VERSION, Manifest, PackageError, TextureFormat};

/// Number of selection directions (`"icosahedron-320"`).
pub(crate) const DIRECTIONS: usize = 320;
/// The only direction set of format version 1.
pub(crate) const DIRECTION_SET: &str = "icosahedron-320";
/// Most impostors in a package (indices fit in `u16` with room to spare).
pub(crate) const MAX_IMPOSTORS: usize = 256;
/// Tolerance on unit lengths, orthogonality and `d == direction`.
const TOLERANCE: f64 = 1e-6;
/// Greatest depth code of a surface (255 is "empty").
const MAX_DEPTH_CODE: f32 = 254.0;

/// The manifest's canonical bytes: serde_json's compact output (fields in declaration
/// order) with every object key in `params` sorted, whatever serde_json's map type.
pub(crate) fn manifest_bytes(manifest: &Manifest) -> Result<Vec<u8>, PackageError> {
    let mut canonical = manifest.clone();
    canonical.params = sorted(&manifest.params);
    serde_json::to_vec(&canonical)
        .map_err(|e| PackageError::Manifest(format!("cannot serialise: {e}")))
}

/// `value` with the keys of every object in sorted (byte-wise) order.
fn sorted(value: &Value) -> Value {
    match value {
        Value::Object(map) => {
            let mut entries: Vec<_> = map.iter().collect();
            entries.sort_by(|a, b| a.0.cmp(b.0));
            Value::Object(
                entries
                    .into_iter()
                    .map(|(k, v)| (k.clone(), sorted(v)))
                    .collect(),
            )
        }
        Value::Array(items) => Value::Array(items.iter().map(sorted).collect()),
        other => other.clone(),
    }
}

/// Whether `s` is 64 lowercase hex digits (a blake3 hash).
pub(crate) fn is_hash_hex(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// Lowercase hex of a blake3 hash.
pub(crate) fn hash_hex(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn finite(name: &str, values: &[f64]) -> Result<(), String> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(format!("{name} is {v} (floats must be finite)")),
        None => Ok(()),
    }
}

fn unit(name: &str, v: [f64; 3]) -> Result<(), String> {
    let len = dot(v, v).sqrt();
    if (len - 1.0).abs() > TOLERANCE {
        return Err(format!(
            "{name} has length {len}, expected 1 (within {TOLERANCE})"
        ));
    }
    Ok(())
}

/// Every rule of the manifest that does not need the texture bytes. Texture references are
/// checked for their declared format only (the layout code checks offsets and lengths).
pub(crate) fn check_manifest(m: &Manifest) -> Result<(), PackageError> {
    check_fields(m).map_err(PackageError::Manifest)?;
    for (i, imp) in m.impostors.iter().enumerate() {
        for (map, r, expected) in [
            ("depth", &imp.depth, m.depth_format),
            ("normal", &imp.normal, TextureFormat::Bc5),
            ("albedo", &imp.albedo, TextureFormat::Bc1Srgb),
        ] {
            if r.format != expected {
                return Err(PackageError::Texture {
                    impostor: i,
                    map,
                    reason: format!("declared as {:?}, expected {expected:?}", r.format),
                });
            }
        }
    }
    Ok(())
}

fn check_fields(m: &Manifest) -> Result<(), String> {
    if m.format_version != FORMAT_VERSION {
        return Err(format!(
            "format_version is {}, expected {FORMAT_VERSION} (the header's version)",
            m.format_version
        ));
    }
    if m.tool.is_empty() {
        return Err("tool is empty".into());
    }
    if m.source.name.is_empty() || m.source.name.starts_with('/') {
        return Err(format!(
            "source.name {:?} must be a non-empty path relative to the assets root",
            m.source.name
        ));
    }
    if !is_hash_hex(&m.source.blake3) {
        return Err(format!(
            "source.blake3 {:?} is not 64 lowercase hex digits",
            m.source.blake3
        ));
    }
    let sphere = &m.bounding_sphere;
    finite("bounding_sphere.center", &sphere.center)?;
    finite("bounding_sphere.radius", &[sphere.radius])?;
    if sphere.radius <= 0.0 {
        return Err(format!(
            "bounding_sphere.radius is {}, must be > 0",
            sphere.radius
        ));
    }
    if !m.resolution.is_power_of_two() || !(4..=8192).contains(&m.resolution) {
        return Err(format!(
            "resolution {} is not a power of two in 4..=8192",
            m.resolution
        ));
    }
    if !matches!(m.depth_format, TextureFormat::R8 | TextureFormat::Bc4) {
        return Err(format!(
            "depth_format {:?} is not r8 or bc4",
            m.depth_format
        ));
    }
    let n = m.impostors.len();
    if n == 0 || n > MAX_IMPOSTORS {
        return Err(format!("{n} impostors (1 to {MAX_IMPOSTORS} allowed)"));
    }
    for (i, imp) in m.impostors.iter().enumerate() {
        check_impostor(imp, m.resolution).map_err(|e| format!("impostors[{i}]: {e}"))?;
    }
    check_selection(m)?;
    check_plt(m)?;
    if !m.params.is_object() {
        return Err("params must be a JSON object".into());
    }
    Ok(())
}

fn check_impostor(imp: &crate::Impostor, resolution: u32) -> Result<(), String> {
    finite("direction", &imp.direction)?;
    for (k, axis) in imp.frame.iter().enumerate() {
        finite(&format!("frame[{k}]"), axis)?;
    }
    finite("center", &imp.center)?;
    finite("half_size", &[imp.half_size])?;
    finite("near", &[imp.near])?;
    finite("far", &[imp.far])?;
    let occupied = imp.occupied.map(f64::from);
    finite("occupied", &occupied)?;

    let [u, v, d] = imp.frame;
    unit("direction", imp.direction)?;
    for (name, axis) in [("frame u", u), ("frame v", v), ("frame d", d)] {
        unit(name, axis)?;
    }
    for (name, x) in [
        ("u . v", dot(u, v)),
        ("u . d", dot(u, d)),
        ("v . d", dot(v, d)),
    ] {
        if x.abs() > TOLERANCE {
            return Err(format!(
                "frame is not orthogonal: {name} = {x} (within {TOLERANCE})"
            ));
        }
    }
    if dot(cross(u, v), d) <= 0.0 {
        return Err("frame is left-handed (u x v must equal d)".into());
    }
    if (0..3).any(|k| (d[k] - imp.direction[k]).abs() > TOLERANCE) {
        return Err(format!(
            "frame d {d:?} differs from direction {:?} (within {TOLERANCE})",
            imp.direction
        ));
    }
    if imp.half_size <= 0.0 {
        return Err(format!("half_size is {}, must be > 0", imp.half_size));
    }
    if imp.near <= imp.far {
        return Err(format!(
            "near ({}) must be greater than far ({}): heights along the direction",
            imp.near, imp.far
        ));
    }
    let [x0, x1, y0, y1, z0, z1] = imp.occupied;
    let edge = resolution as f32;
    if !(0.0 <= x0 && x0 <= x1 && x1 <= edge && 0.0 <= y0 && y0 <= y1 && y1 <= edge) {
        return Err(format!(
            "occupied texel box {:?} is not 0 <= x0 <= x1 <= {resolution}, 0 <= y0 <= y1 <= \
             {resolution}",
            &imp.occupied[..4]
        ));
    }
    if !(0.0 <= z0 && z0 <= z1 && z1 <= MAX_DEPTH_CODE) {
        return Err(format!(
            "occupied depth codes [{z0}, {z1}] are not 0 <= z0 <= z1 <= 254"
        ));
    }
    Ok(())
}

fn check_selection(m: &Manifest) -> Result<(), String> {
    let sel = &m.selection;
    if sel.directions != DIRECTION_SET {
        return Err(format!(
            "selection.directions is {:?}, expected {DIRECTION_SET:?}",
            sel.directions
        ));
    }
    if sel.rule.is_empty() {
        return Err("selection.rule is empty".into());
    }
    finite("selection.goal_percent", &[sel.goal_percent])?;
    if !(0.0..=100.0).contains(&sel.goal_percent) {
        return Err(format!(
            "selection.goal_percent {} is not in [0, 100]",
            sel.goal_percent
        ));
    }
    if sel.s0 == 0 {
        return Err("selection.s0 is 0".into());
    }
    if sel.entries.len() != DIRECTIONS {
        return Err(format!(
            "selection has {} entries, expected {DIRECTIONS} (one per direction)",
            sel.entries.len()
        ));
    }
    let n = m.impostors.len();
    let pixels = u64::from(sel.s0) * u64::from(sel.s0);
    for (e, entry) in sel.entries.iter().enumerate() {
        if entry.impostors.is_empty() {
            return Err(format!("selection entry {e} draws no impostor"));
        }
        let mut seen = [false; MAX_IMPOSTORS];
        for &i in &entry.impostors {
            let i = usize::from(i);
            if i >= n {
                return Err(format!(
                    "selection entry {e} names impostor {i}, but there are only {n}"
                ));
            }
            if seen[i] {
                return Err(format!("selection entry {e} names impostor {i} twice"));
            }
            seen[i] = true;
        }
        if u64::from(entry.missed) > pixels {
            return Err(format!(
                "selection entry {e} misses {} pixels, more than s0 x s0 = {pixels}",
                entry.missed
            ));
        }
    }
    Ok(())
}

fn check_plt(m: &Manifest) -> Result<(), String> {
    let plt = &m.plt;
    if plt.s0 != m.selection.s0 {
        return Err(format!(
            "plt.s0 {} differs from selection.s0 {}",
            plt.s0, m.selection.s0
        ));
    }
    // GC(s0) is measured at the held-out directions, which the package does not carry: only
    // its range and the fields derived from it are checked.
    let gc = plt.gc;
    if u64::from(gc) > u64::from(plt.s0) * u64::from(plt.s0) {
        return Err(format!(
            "plt.gc is {gc}, more than the s0 x s0 = {} pixels of the image",
            u64::from(plt.s0) * u64::from(plt.s0)
        ));
    }
    let s2 = f64::from(plt.s0) * f64::from(plt.s0);
    let pixels = if gc == 0 { s2 } else { s2 / f64::from(gc) };
    if plt.pixels != pixels {
        return Err(format!(
            "plt.pixels is {}, expected s0 * s0 / gc = {pixels}",
            plt.pixels
        ));
    }
    if plt.at_least != (gc == 0) {
        return Err(format!(
            "plt.at_least is {}, must be {} (true exactly when gc is 0)",
            plt.at_least,
            gc == 0
        ));
    }
    if !plt.recommended_resolution.is_power_of_two() {
        return Err(format!(
            "plt.recommended_resolution {} is not a power of two",
            plt.recommended_resolution
        ));
    }
    Ok(())
}

/// Checks one texture's bytes: its blake3 (if `hash` is given), that it is a KTX2 file in
/// `format`, and that level 0 is `resolution` x `resolution`.
pub(crate) fn check_texture(
    impostor: usize,
    map: &'static str,
    bytes: &[u8],
    hash: Option<&str>,
    format: TextureFormat,
    resolution: u32,
) -> Result<(), PackageError> {
    if let Some(hash) = hash
        && hash_hex(bytes) != hash
    {
        return Err(PackageError::HashMismatch { impostor, map });
    }
    let bad = |reason: String| PackageError::Texture {
        impostor,
        map,
        reason,
    };
    let ktx = Ktx2::from_bytes(bytes).map_err(|e| bad(e.to_string()))?;
    if ktx.format() != format.vk_format() {
        return Err(bad(format!(
            "KTX2 format is {:?}, expected {:?}",
            ktx.format(),
            format.vk_format()
        )));
    }
    if ktx.width() != resolution || ktx.height() != resolution {
        return Err(bad(format!(
            "{} x {} texels, expected {resolution} x {resolution} (the manifest's resolution)",
            ktx.width(),
            ktx.height()
        )));
    }
    Ok(())
}
