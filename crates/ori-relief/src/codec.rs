//! Byte layout of a [`ReliefSet`] (the bake stage's artifact), little-endian:
//! ```text
//! "ORIRELF\0", u32 layout version, u32 map count
//! per map: f64 x 9 frame (u, v, d), f64 x 2 window centre, f64 half size, f64 near, f64 far,
//!          u32 size, size^2 depth bytes, size^2 x 2 normal bytes, size^2 x 3 albedo bytes
//! ```

use ori_artifact::{DecodeError, Layout};
use ori_raster::{Frame, OrthoView};

use crate::{ReliefMap, ReliefSet};

const LAYOUT: Layout = Layout {
    kind: "relief-map",
    magic: *b"ORIRELF\0",
    version: 1,
};

pub(crate) fn encode(set: &ReliefSet) -> Vec<u8> {
    let mut w = LAYOUT.writer();
    w.count(set.maps.len());
    for m in &set.maps {
        let v = &m.view;
        let f = &v.frame;
        for &x in f.u.iter().chain(&f.v).chain(&f.d).chain(&v.center) {
            w.f64(x);
        }
        for x in [v.half_size, v.near, v.far] {
            w.f64(x);
        }
        w.u32(v.size);
        w.bytes(&m.depth);
        w.bytes(m.normal.as_flattened());
        w.bytes(m.albedo.as_flattened());
    }
    w.finish()
}

pub(crate) fn decode(bytes: &[u8]) -> Result<ReliefSet, DecodeError> {
    let mut r = LAYOUT.reader(bytes)?;
    // A map's view takes 116 bytes before its texels.
    let count = r.count(116)?;
    let mut maps = Vec::with_capacity(count);
    for _ in 0..count {
        let mut f = [0.0f64; 14];
        for x in &mut f {
            *x = r.f64()?;
        }
        let size = r.u32()?;
        let texels = (size as usize)
            .checked_mul(size as usize)
            .ok_or_else(|| r.error("size overflows"))?;
        let depth = r.take(texels)?.to_vec();
        let normal = r.byte_arrays::<2>(texels)?;
        let albedo = r.byte_arrays::<3>(texels)?;
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
    r.finish()?;
    Ok(ReliefSet { maps })
}
