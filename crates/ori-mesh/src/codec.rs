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

use ori_artifact::{DecodeError, Layout};

use crate::{AlphaMode, Material, Mesh, Texture, Wrap};

const LAYOUT: Layout = Layout {
    kind: "mesh",
    magic: *b"ORIMESH\0",
    version: 1,
};

pub(crate) fn encode(mesh: &Mesh) -> Vec<u8> {
    let mut w = LAYOUT.writer();
    w.reserve(64 + mesh.positions.len() * 48 + mesh.triangles.len() * 16);
    w.count(mesh.positions.len());
    w.count(mesh.triangles.len());
    w.count(mesh.materials.len());
    w.count(mesh.textures.len());
    w.u8(u8::from(mesh.uvs.is_some()) | (u8::from(mesh.colors.is_some()) << 1));
    let uvs = mesh.uvs.iter().flatten().flatten();
    let colors = mesh.colors.iter().flatten().flatten();
    for &v in (mesh.positions.iter().flatten())
        .chain(mesh.normals.iter().flatten())
        .chain(uvs)
        .chain(colors)
    {
        w.f32(v);
    }
    for &i in mesh.triangles.iter().flatten() {
        w.u32(i);
    }
    for &m in &mesh.triangle_materials {
        w.u32(m);
    }
    for m in &mesh.materials {
        w.string(&m.name);
        for &f in &m.base_color_factor {
            w.f32(f);
        }
        w.i32(m.base_color_texture.map_or(-1, |t| t as i32));
        w.u8(match m.alpha_mode {
            AlphaMode::Opaque => 0,
            AlphaMode::Mask => 1,
            AlphaMode::Blend => 2,
        });
        w.f32(m.alpha_cutoff);
        w.u8(u8::from(m.double_sided));
    }
    for t in &mesh.textures {
        w.string(&t.name);
        w.u32(t.width);
        w.u32(t.height);
        w.u8(wrap_code(t.wrap_s));
        w.u8(wrap_code(t.wrap_t));
        w.u8(u8::from(t.nearest));
        w.bytes(&t.rgba8);
    }
    w.finish()
}

pub(crate) fn decode(bytes: &[u8]) -> Result<Mesh, DecodeError> {
    let mut r = LAYOUT.reader(bytes)?;
    // The least bytes one vertex, triangle, material and texture take.
    let (nv, nt, nm, nx) = (r.count(24)?, r.count(16)?, r.count(30)?, r.count(15)?);
    let flags = r.u8()?;
    let positions = r.f32_arrays::<3>(nv)?;
    let normals = r.f32_arrays::<3>(nv)?;
    let uvs = if flags & 1 != 0 {
        Some(r.f32_arrays::<2>(nv)?)
    } else {
        None
    };
    let colors = if flags & 2 != 0 {
        Some(r.f32_arrays::<4>(nv)?)
    } else {
        None
    };
    let mut triangles = Vec::with_capacity(nt);
    for _ in 0..nt {
        let t = [r.u32()?, r.u32()?, r.u32()?];
        if t.iter().any(|&i| i as usize >= nv) {
            return Err(r.error(format!("triangle index out of range in {t:?}")));
        }
        triangles.push(t);
    }
    let mut triangle_materials = Vec::with_capacity(nt);
    for _ in 0..nt {
        let m = r.u32()?;
        if m as usize >= nm {
            return Err(r.error(format!("material index {m} out of range")));
        }
        triangle_materials.push(m);
    }
    let mut materials = Vec::with_capacity(nm);
    for _ in 0..nm {
        let name = r.string()?;
        let base_color_factor = r.f32_arrays::<4>(1)?[0];
        let base_color_texture = match r.i32()? {
            -1 => None,
            t if t >= 0 && (t as usize) < nx => Some(t as u32),
            t => return Err(r.error(format!("texture index {t} out of range"))),
        };
        let alpha_mode = match r.u8()? {
            0 => AlphaMode::Opaque,
            1 => AlphaMode::Mask,
            2 => AlphaMode::Blend,
            a => return Err(r.error(format!("bad alpha mode {a}"))),
        };
        let alpha_cutoff = r.f32()?;
        let double_sided = r.u8()? != 0;
        materials.push(Material {
            name,
            base_color_factor,
            base_color_texture,
            alpha_mode,
            alpha_cutoff,
            double_sided,
        });
    }
    let mut textures = Vec::with_capacity(nx);
    for _ in 0..nx {
        let name = r.string()?;
        let (width, height) = (r.u32()?, r.u32()?);
        let mut wrap = || {
            r.u8().and_then(|c| match c {
                0 => Ok(Wrap::Repeat),
                1 => Ok(Wrap::MirroredRepeat),
                2 => Ok(Wrap::ClampToEdge),
                _ => Err(r.error(format!("bad wrap mode {c}"))),
            })
        };
        let (wrap_s, wrap_t) = (wrap()?, wrap()?);
        let nearest = r.u8()? != 0;
        let size = (width as usize)
            .checked_mul(height as usize)
            .and_then(|n| n.checked_mul(4))
            .ok_or_else(|| r.error("texture size overflows"))?;
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
    if triangles.is_empty() {
        return Err(r.error("no triangles"));
    }
    r.finish()?;
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
