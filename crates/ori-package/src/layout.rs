//! The byte layout (`docs/FORMAT.md`): the 64-byte header, the manifest, the packed
//! textures; [`write()`] and [`read`].

use crate::validate::{check_manifest, check_texture, hash_hex, is_hash_hex, manifest_bytes};
use crate::{
    ALIGN, FORMAT_VERSION, HIERARCHY_FORMAT_VERSION, ImpostorTextures, MAGIC, Manifest, Package,
    PackageError, TextureFormat, TextureRef,
};

/// Bytes of the fixed header; the manifest starts here.
const HEADER_LEN: u64 = 64;

/// The first multiple of [`ALIGN`] at or after `x`, `None` on overflow.
fn align_up(x: u64) -> Option<u64> {
    x.checked_next_multiple_of(ALIGN)
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"))
}

/// The texture references of impostor `i`, in file order, with their map names.
fn refs(m: &Manifest) -> impl Iterator<Item = (usize, &'static str, &TextureRef)> {
    m.impostors.iter().enumerate().flat_map(|(i, imp)| {
        [
            (i, "depth", &imp.depth),
            (i, "normal", &imp.normal),
            (i, "albedo", &imp.albedo),
        ]
    })
}

fn refs_mut(m: &mut Manifest) -> impl Iterator<Item = &mut TextureRef> {
    m.impostors
        .iter_mut()
        .flat_map(|imp| [&mut imp.depth, &mut imp.normal, &mut imp.albedo])
}

/// Builds the package file.
///
/// Every [`TextureRef`] is filled here from `textures` (format, offset, length, blake3);
/// what the caller put there is ignored. The manifest and the textures then go through the
/// checks [`read`] makes, so the result always reads back. Deterministic: the same inputs
/// give the same bytes.
///
/// `textures[i]` holds impostor `i`'s KTX2 files ([`ori_texture::Ktx2::to_bytes`]); there
/// must be one entry per impostor.
pub fn write(manifest: &Manifest, textures: &[ImpostorTextures]) -> Result<Vec<u8>, PackageError> {
    if textures.len() != manifest.impostors.len() {
        return Err(PackageError::Manifest(format!(
            "{} impostors but {} texture sets",
            manifest.impostors.len(),
            textures.len()
        )));
    }
    let mut m = manifest.clone();
    for (imp, tex) in m.impostors.iter_mut().zip(textures) {
        let formats = [m.depth_format, TextureFormat::Bc5, TextureFormat::Bc1Srgb];
        let refs = [&mut imp.depth, &mut imp.normal, &mut imp.albedo];
        for ((r, format), (_, bytes)) in refs.into_iter().zip(formats).zip(tex.maps()) {
            *r = TextureRef {
                format,
                offset: 0,
                length: bytes.len() as u64,
                blake3: hash_hex(bytes),
            };
        }
    }
    check_manifest(&m)?;
    for (i, tex) in textures.iter().enumerate() {
        let formats = [m.depth_format, TextureFormat::Bc5, TextureFormat::Bc1Srgb];
        for ((map, bytes), format) in tex.maps().into_iter().zip(formats) {
            check_texture(i, map, bytes, None, format, m.resolution)?;
        }
    }

    let lengths: Vec<u64> = refs(&m).map(|(_, _, r)| r.length).collect();
    let (json, offsets, end) = place(&lengths, |offsets| {
        for (r, &offset) in refs_mut(&mut m).zip(offsets) {
            r.offset = offset;
        }
        manifest_bytes(&m)
    })?;
    // The JSON must read back as the same manifest, or `read` would reject the file.
    match serde_json::from_slice::<Manifest>(&json) {
        Ok(back) if back == m => {}
        _ => {
            return Err(PackageError::Manifest(
                "the manifest does not read back equal from its JSON (a float that does not \
                 round-trip?)"
                    .into(),
            ));
        }
    }
    let data = textures.iter().flat_map(|t| t.maps().map(|(_, b)| b));
    assemble(
        FORMAT_VERSION,
        &json,
        offsets.iter().copied().zip(data),
        end,
    )
}

/// Lays out parts of `lengths` after a manifest whose bytes depend on the parts' offsets
/// (`json(offsets)`): each part at the first [`ALIGN`]ed offset after the previous one, the
/// first after the manifest. Returns the manifest bytes, the offsets and the file's end.
///
/// The manifest's length sets where the payload starts: iterate from the smallest payload
/// offset. Longer offsets only lengthen the manifest, so the payload offset only grows and
/// settles on the smallest consistent layout in a few steps.
pub(crate) fn place(
    lengths: &[u64],
    mut json: impl FnMut(&[u64]) -> Result<Vec<u8>, PackageError>,
) -> Result<(Vec<u8>, Vec<u64>, u64), PackageError> {
    let overflow = || PackageError::Layout("package larger than 2^64 bytes".into());
    let mut payload = align_up(HEADER_LEN).ok_or_else(overflow)?;
    loop {
        let mut pos = payload;
        let mut offsets = Vec::with_capacity(lengths.len());
        for &length in lengths {
            let offset = align_up(pos).ok_or_else(overflow)?;
            offsets.push(offset);
            pos = offset.checked_add(length).ok_or_else(overflow)?;
        }
        let bytes = json(&offsets)?;
        let needed = (bytes.len() as u64)
            .checked_add(HEADER_LEN)
            .and_then(align_up)
            .ok_or_else(overflow)?;
        if needed == payload {
            return Ok((bytes, offsets, pos));
        }
        payload = needed;
    }
}

/// The file: header (version `version`), manifest, then each `(offset, bytes)` part at its
/// offset with zero padding before it; `end` is the file's length.
pub(crate) fn assemble<'a>(
    version: u32,
    json: &[u8],
    parts: impl Iterator<Item = (u64, &'a [u8])>,
    end: u64,
) -> Result<Vec<u8>, PackageError> {
    let total = usize::try_from(end)
        .map_err(|_| PackageError::Layout("package larger than memory".into()))?;
    let payload = align_up(HEADER_LEN + json.len() as u64).unwrap_or(u64::MAX);
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // flags
    out.extend_from_slice(&(json.len() as u64).to_le_bytes());
    out.extend_from_slice(blake3::hash(json).as_bytes());
    out.extend_from_slice(&payload.to_le_bytes());
    out.extend_from_slice(json);
    for (offset, bytes) in parts {
        out.resize(offset as usize, 0);
        out.extend_from_slice(bytes);
    }
    debug_assert_eq!(out.len(), total);
    Ok(out)
}

/// Checks the header and the manifest's framing (magic, length, hash, payload offset, zero
/// padding) and returns the format version, the manifest bytes and the payload offset; the
/// caller checks the version.
pub(crate) fn frame(bytes: &[u8]) -> Result<(u32, &[u8], usize), PackageError> {
    let have = bytes.len() as u64;
    let n = bytes.len().min(MAGIC.len());
    if bytes[..n] != MAGIC[..n] {
        return Err(PackageError::BadMagic);
    }
    if have < HEADER_LEN {
        return Err(PackageError::Truncated {
            what: "header",
            need: HEADER_LEN,
            have,
        });
    }
    let version = u32_at(bytes, 8);
    if version != FORMAT_VERSION && version != HIERARCHY_FORMAT_VERSION {
        return Err(PackageError::UnsupportedVersion(version));
    }
    let flags = u32_at(bytes, 12);
    if flags != 0 {
        return Err(PackageError::Header(format!(
            "flags are {flags:#x}; no flags are defined, they must be 0"
        )));
    }
    let manifest_len = u64_at(bytes, 16);
    let manifest_end = HEADER_LEN.checked_add(manifest_len).ok_or_else(|| {
        PackageError::Header(format!(
            "manifest length {manifest_len} is impossibly large"
        ))
    })?;
    if manifest_end > have {
        return Err(PackageError::Truncated {
            what: "manifest",
            need: manifest_end,
            have,
        });
    }
    let payload = u64_at(bytes, 56);
    // manifest_end <= have, so this cannot overflow.
    let expected_payload = align_up(manifest_end).unwrap_or(u64::MAX);
    if payload != expected_payload {
        return Err(PackageError::Header(format!(
            "payload offset is {payload}, expected {expected_payload} (the first multiple of \
             {ALIGN} after the manifest)"
        )));
    }
    if payload > have {
        return Err(PackageError::Truncated {
            what: "padding after the manifest",
            need: payload,
            have,
        });
    }
    // Both are <= bytes.len() from here on.
    let (manifest_end, payload) = (manifest_end as usize, payload as usize);
    let json = &bytes[HEADER_LEN as usize..manifest_end];
    if blake3::hash(json).as_bytes()[..] != bytes[24..56] {
        return Err(PackageError::ManifestHash);
    }
    check_padding(bytes, manifest_end, payload, "after the manifest")?;
    Ok((version, json, payload))
}

/// Reads a package and checks everything: header, manifest hash, canonical JSON, the
/// manifest's rules, the layout (alignment, packing, zero padding, no trailing bytes), every
/// texture's blake3, and that every texture is a KTX2 file of the declared format and size.
///
/// Never panics, and never allocates more than a small multiple of `bytes.len()`, whatever
/// the input.
pub fn read(bytes: &[u8]) -> Result<Package, PackageError> {
    let (version, json, payload) = frame(bytes)?;
    match version {
        FORMAT_VERSION => {}
        HIERARCHY_FORMAT_VERSION => return Err(PackageError::IsHierarchy),
        v => return Err(PackageError::UnsupportedVersion(v)),
    }
    let manifest: Manifest = serde_json::from_slice(json)
        .map_err(|e| PackageError::Manifest(format!("not valid manifest JSON: {e}")))?;
    if manifest_bytes(&manifest)? != json {
        return Err(PackageError::Manifest(
            "not in canonical form (compact serde_json output, fields in schema order, params \
             keys sorted, numbers as serde_json prints them)"
                .into(),
        ));
    }
    check_manifest(&manifest)?;
    for (i, map, r) in refs(&manifest) {
        if !is_hash_hex(&r.blake3) {
            return Err(PackageError::Manifest(format!(
                "impostors[{i}].{map}.blake3 {:?} is not 64 lowercase hex digits",
                r.blake3
            )));
        }
    }

    check_packed(
        bytes,
        payload,
        refs(&manifest)
            .map(|(i, map, r)| (format!("impostor {i} {map} texture"), r.offset, r.length)),
    )?;

    let mut textures = Vec::with_capacity(manifest.impostors.len());
    for (i, imp) in manifest.impostors.iter().enumerate() {
        let copy = |map: &'static str, r: &TextureRef| -> Result<Vec<u8>, PackageError> {
            // Within the file: checked by the layout loop above.
            let data = &bytes[r.offset as usize..(r.offset + r.length) as usize];
            check_texture(i, map, data, Some(&r.blake3), r.format, manifest.resolution)?;
            Ok(data.to_vec())
        };
        textures.push(ImpostorTextures {
            depth: copy("depth", &imp.depth)?,
            normal: copy("normal", &imp.normal)?,
            albedo: copy("albedo", &imp.albedo)?,
        });
    }
    Ok(Package { manifest, textures })
}

/// Checks the layout of the parts after the manifest: each `(name, offset, length)` at the
/// first aligned offset after the previous part (the first after `payload`), within the file,
/// zero padding between, and nothing after the last.
pub(crate) fn check_packed(
    bytes: &[u8],
    payload: usize,
    parts: impl Iterator<Item = (String, u64, u64)>,
) -> Result<(), PackageError> {
    let have = bytes.len() as u64;
    let mut pos = payload as u64;
    for (place, offset, length) in parts {
        if offset % ALIGN != 0 {
            return Err(PackageError::Layout(format!(
                "{place} starts at {offset}, not a multiple of {ALIGN}"
            )));
        }
        if offset < pos {
            return Err(PackageError::Layout(format!(
                "{place} starts at {offset}, inside the previous part (which ends at {pos})"
            )));
        }
        let expected = align_up(pos).unwrap_or(u64::MAX);
        if offset != expected {
            return Err(PackageError::Layout(format!(
                "{place} starts at {offset}, expected {expected} (parts are packed at the next \
                 aligned offset)"
            )));
        }
        let end = offset.checked_add(length).ok_or_else(|| {
            PackageError::Layout(format!("{place} length {length} is impossibly large"))
        })?;
        if end > have {
            return Err(PackageError::Truncated {
                what: "texture data",
                need: end,
                have,
            });
        }
        check_padding(bytes, pos as usize, offset as usize, "before a part")?;
        pos = end;
    }
    if pos != have {
        return Err(PackageError::Layout(format!(
            "{} trailing bytes after the last part (which ends at {pos})",
            have - pos
        )));
    }
    Ok(())
}

/// Checks that `bytes[start..end]` (padding) is all zero.
fn check_padding(bytes: &[u8], start: usize, end: usize, what: &str) -> Result<(), PackageError> {
    match bytes[start..end].iter().position(|&b| b != 0) {
        Some(k) => Err(PackageError::Layout(format!(
            "nonzero byte {:#04x} at offset {} in the padding {what} (padding must be zero)",
            bytes[start + k],
            start + k
        ))),
        None => Ok(()),
    }
}
