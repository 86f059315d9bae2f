//! Byte layout of a [`ReliefSet`] (the bake stage's artifact), little-endian:
//! ```text
//! "ORIRELF\0", u32 layout version, u32 map count
//! per map: f64 x 9 frame (u, v, d), f64 x 2 window centre, f64 half size, f64 near, f64 far,
//!          u32 size, size^2 depth bytes, size^2 x 2 normal bytes, size^2 x 3 albedo bytes
//! ```

use ori_raster::{Frame, OrthoView};

use crate::{ReliefMap, ReliefSet};

const MAGIC: &[u8; 8] = b"ORIRELF\0";
const LAYOUT_VERSION: u32 = 1;

/// Bytes that are not a valid relief set.
#[derive(Debug, thiserror::Error)]
#[error("invalid relief-map artifact: {0}")]
pub struct DecodeError(String);

pub(crate) fn encode(set: &ReliefSet) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&LAYOUT_VERSION.to_le_bytes());
    out.extend_from_slice(&(set.maps.len() as u32).to_le_bytes());
    for m in &set.maps {
        let v = &m.view;
        let f = &v.frame;
        for x in f.u.iter().chain(&f.v).chain(&f.d).chain(&v.center) {
            out.extend_from_slice(&x.to_le_bytes());
        }
        for x in [v.half_size, v.near, v.far] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out.extend_from_slice(&v.size.to_le_bytes());
        out.extend_from_slice(&m.depth);
        out.extend(m.normal.iter().flatten());
        out.extend(m.albedo.iter().flatten());
    }
    out
}

pub(crate) fn decode(bytes: &[u8]) -> Result<ReliefSet, DecodeError> {
    let mut at = 0usize;
    let mut take = |n: usize| -> Result<&[u8], DecodeError> {
        let end = at.checked_add(n).filter(|&e| e <= bytes.len());
        let end = end.ok_or_else(|| DecodeError(format!("truncated at byte {at}")))?;
        let s = &bytes[at..end];
        at = end;
        Ok(s)
    };
    if take(8)? != MAGIC {
        return Err(DecodeError("bad magic".into()));
    }
    let u32_at = |b: &[u8]| u32::from_le_bytes(b.try_into().expect("4 bytes"));
    let version = u32_at(take(4)?);
    if version != LAYOUT_VERSION {
        return Err(DecodeError(format!(
            "layout version {version}, expected {LAYOUT_VERSION}"
        )));
    }
    let count = u32_at(take(4)?) as usize;
    let mut maps = Vec::new();
    for _ in 0..count {
        let mut f = [0.0f64; 14];
        for x in &mut f {
            *x = f64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
        }
        let size = u32_at(take(4)?);
        let texels = (size as usize)
            .checked_mul(size as usize)
            .ok_or_else(|| DecodeError("size overflows".into()))?;
        let depth = take(texels)?.to_vec();
        let normal = take(texels.saturating_mul(2))?
            .chunks_exact(2)
            .map(|c| [c[0], c[1]])
            .collect();
        let albedo = take(texels.saturating_mul(3))?
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let view = OrthoView {
            frame: Frame {
                u: [f[0], f[1], f[2]],
                v: [f[3], f[4], f[5]],
                d: [f[6], f[7], f[8]],
            },
            center: [f[9], f[10]],
            half_size: f[11],
            near: f[12],
            far: f[13],
            size,
        };
        maps.push(ReliefMap {
            view,
            depth,
            normal,
            albedo,
        });
    }
    if at != bytes.len() {
        return Err(DecodeError(format!("{} trailing bytes", bytes.len() - at)));
    }
    Ok(ReliefSet { maps })
}
