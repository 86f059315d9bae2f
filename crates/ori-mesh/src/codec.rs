//! The canonical byte layout of a [`Mesh`], used as the ingest stage's cached artifact.
//!
//! Little-endian throughout:
//! ```text
//! magic "ORIMESH\0", u32 layout version
//! u32 vertex count V, u32 triangle count T, u32 material count M, u32 texture count X
//! u8 flags (bit 0: uvs present, bit 1: colours present)
//! V x [f32; 3] positions, V x [f32; 3] normals, [V x [f32; 2] uvs], [V x [f32; 4] colours]
//! T x [u32; 3] triangles, T x u32 triangle materials
//! M x material: string name, [f32; 4] factor, i32 texture (-1: none), u8 alpha mode,
//!               f32 cutoff, u8 double-sided
//! X x texture: string name, u32 width, u32 height, u8 wrap s, u8 wrap t, u8 nearest,
//!              width*height*4 bytes RGBA8
//! string = u32 byte length + UTF-8 bytes
//! ```

use crate::{AlphaMode, Material, Mesh, Texture, Wrap};

const MAGIC: &[u8; 8] = b"ORIMESH\0";
const LAYOUT_VERSION: u32 = 1;

/// Bytes that are not a valid encoded mesh.
#[derive(Debug, thiserror::Error)]
#[error("invalid mesh artifact: {0}")]
pub struct DecodeError(String);

pub(crate) fn encode(mesh: &Mesh) -> Vec<u8> {
    let mut w = Writer(Vec::with_capacity(
        64 + mesh.positions.len() * 48 + mesh.triangles.len() * 16,
    ));
    w.0.extend_from_slice(MAGIC);
    w.u32(LAYOUT_VERSION);
    w.u32(mesh.positions.len() as u32);
    w.u32(mesh.triangles.len() as u32);
    w.u32(mesh.materials.len() as u32);
    w.u32(mesh.textures.len() as u32);
    w.0.push(u8::from(mesh.uvs.is_some()) | (u8::from(mesh.colors.is_some()) << 1));
    w.f32s(mesh.positions.iter().flatten());
    w.f32s(mesh.normals.iter().flatten());
    if let Some(uvs) = &mesh.uvs {
        w.f32s(uvs.iter().flatten());
    }
    if let Some(colors) = &mesh.colors {
        w.f32s(colors.iter().flatten());
    }
    for &i in mesh.triangles.iter().flatten() {
        w.u32(i);
    }
    for &m in &mesh.triangle_materials {
        w.u32(m);
    }
    for m in &mesh.materials {
        w.string(&m.name);
        w.f32s(m.base_color_factor.iter());
        w.0.extend_from_slice(&m.base_color_texture.map_or(-1, |t| t as i32).to_le_bytes());
        w.0.push(match m.alpha_mode {
            AlphaMode::Opaque => 0,
            AlphaMode::Mask => 1,
            AlphaMode::Blend => 2,
        });
        w.f32s([m.alpha_cutoff].iter());
        w.0.push(u8::from(m.double_sided));
    }
    for t in &mesh.textures {
        w.string(&t.name);
        w.u32(t.width);
        w.u32(t.height);
        w.0.push(wrap_code(t.wrap_s));
        w.0.push(wrap_code(t.wrap_t));
        w.0.push(u8::from(t.nearest));
        w.0.extend_from_slice(&t.rgba8);
    }
    w.0
}

pub(crate) fn decode(bytes: &[u8]) -> Result<Mesh, DecodeError> {
    let mut r = Reader { bytes, at: 0 };
    if r.take(8)? != MAGIC {
        return Err(DecodeError("bad magic".into()));
    }
    let version = r.u32()?;
    if version != LAYOUT_VERSION {
        return Err(DecodeError(format!(
            "layout version {version}, expected {LAYOUT_VERSION}"
        )));
    }
    let (nv, nt, nm, nx) = (r.len()?, r.len()?, r.len()?, r.len()?);
    let flags = r.u8()?;
    let positions = r.arrays::<3>(nv)?;
    let normals = r.arrays::<3>(nv)?;
    let uvs = if flags & 1 != 0 {
        Some(r.arrays::<2>(nv)?)
    } else {
        None
    };
    let colors = if flags & 2 != 0 {
        Some(r.arrays::<4>(nv)?)
    } else {
        None
    };
    let mut triangles = Vec::with_capacity(nt.min(bytes.len() / 12));
    for _ in 0..nt {
        let t = [r.u32()?, r.u32()?, r.u32()?];
        if t.iter().any(|&i| i as usize >= nv) {
            return Err(DecodeError(format!("triangle index out of range in {t:?}")));
        }
        triangles.push(t);
    }
    let mut triangle_materials = Vec::with_capacity(nt.min(bytes.len() / 4));
    for _ in 0..nt {
        let m = r.u32()?;
        if m as usize >= nm {
            return Err(DecodeError(format!("material index {m} out of range")));
        }
        triangle_materials.push(m);
    }
    let mut materials = Vec::new();
    for _ in 0..nm {
        let name = r.string()?;
        let f = r.arrays::<4>(1)?[0];
        let tex = i32::from_le_bytes(r.take(4)?.try_into().unwrap());
        let base_color_texture = match tex {
            -1 => None,
            t if t >= 0 && (t as usize) < nx => Some(t as u32),
            t => return Err(DecodeError(format!("texture index {t} out of range"))),
        };
        let alpha_mode = match r.u8()? {
            0 => AlphaMode::Opaque,
            1 => AlphaMode::Mask,
            2 => AlphaMode::Blend,
            a => return Err(DecodeError(format!("bad alpha mode {a}"))),
        };
        let alpha_cutoff = r.arrays::<1>(1)?[0][0];
        let double_sided = r.u8()? != 0;
        materials.push(Material {
            name,
            base_color_factor: f,
            base_color_texture,
            alpha_mode,
            alpha_cutoff,
            double_sided,
        });
    }
    let mut textures = Vec::new();
    for _ in 0..nx {
        let name = r.string()?;
        let (width, height) = (r.u32()?, r.u32()?);
        let wrap_s = wrap_from(r.u8()?)?;
        let wrap_t = wrap_from(r.u8()?)?;
        let nearest = r.u8()? != 0;
        let size = (width as usize)
            .checked_mul(height as usize)
            .and_then(|n| n.checked_mul(4))
            .ok_or_else(|| DecodeError("texture size overflows".into()))?;
        let rgba8 = r.take(size)?.to_vec();
        textures.push(Texture {
            name,
            width,
            height,
            rgba8,
            wrap_s,
            wrap_t,
            nearest,
        });
    }
    if r.at != bytes.len() {
        return Err(DecodeError(format!(
            "{} trailing bytes",
            bytes.len() - r.at
        )));
    }
    if triangles.is_empty() {
        return Err(DecodeError("no triangles".into()));
    }
    Ok(Mesh {
        positions,
        normals,
        uvs,
        colors,
        triangles,
        triangle_materials,
        materials,
        textures,
    })
}

fn wrap_code(w: Wrap) -> u8 {
    match w {
        Wrap::Repeat => 0,
        Wrap::MirroredRepeat => 1,
        Wrap::ClampToEdge => 2,
    }
}

fn wrap_from(c: u8) -> Result<Wrap, DecodeError> {
    match c {
        0 => Ok(Wrap::Repeat),
        1 => Ok(Wrap::MirroredRepeat),
        2 => Ok(Wrap::ClampToEdge),
        _ => Err(DecodeError(format!("bad wrap mode {c}"))),
    }
}

struct Writer(Vec<u8>);

impl Writer {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32s<'a>(&mut self, values: impl Iterator<Item = &'a f32>) {
        for v in values {
            self.0.extend_from_slice(&v.to_le_bytes());
        }
    }
    fn string(&mut self, s: &str) {
        self.u32(s.len() as u32);
        self.0.extend_from_slice(s.as_bytes());
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| DecodeError(format!("truncated at byte {}", self.at)))?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }
    fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    /// A count, which cannot exceed what the remaining bytes could hold.
    fn len(&mut self) -> Result<usize, DecodeError> {
        let n = self.u32()? as usize;
        if n > self.bytes.len() {
            return Err(DecodeError(format!("count {n} exceeds the artifact size")));
        }
        Ok(n)
    }
    fn arrays<const N: usize>(&mut self, count: usize) -> Result<Vec<[f32; N]>, DecodeError> {
        let raw = self.take(
            count
                .checked_mul(N * 4)
                .ok_or_else(|| DecodeError("overflow".into()))?,
        )?;
        Ok(raw
            .chunks_exact(N * 4)
            .map(|c| {
                std::array::from_fn(|k| f32::from_le_bytes(c[k * 4..k * 4 + 4].try_into().unwrap()))
            })
            .collect())
    }
    fn string(&mut self) -> Result<String, DecodeError> {
        let n = self.len()?;
        String::from_utf8(self.take(n)?.to_vec())
            .map_err(|_| DecodeError("string is not UTF-8".into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Material;

    fn sample() -> Mesh {
        Mesh {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            normals: vec![[0.0, 0.0, 1.0]; 3],
            uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
            colors: None,
            triangles: vec![[0, 1, 2]],
            triangle_materials: vec![0],
            materials: vec![Material {
                base_color_texture: Some(0),
                alpha_mode: AlphaMode::Mask,
                ..Material::default()
            }],
            textures: vec![Texture {
                name: "t.png".into(),
                width: 1,
                height: 2,
                rgba8: vec![1, 2, 3, 4, 5, 6, 7, 8],
                wrap_s: Wrap::Repeat,
                wrap_t: Wrap::ClampToEdge,
                nearest: true,
            }],
        }
    }

    #[test]
    fn round_trip() {
        let m = sample();
        assert_eq!(decode(&encode(&m)).unwrap(), m);
    }

    #[test]
    fn every_truncation_is_an_error() {
        let bytes = encode(&sample());
        for n in 0..bytes.len() {
            assert!(decode(&bytes[..n]).is_err(), "prefix of {n} bytes decoded");
        }
    }
}
