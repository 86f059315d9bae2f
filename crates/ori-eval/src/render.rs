//! Renders of the ORI: per-impostor layers (every pixel's trace, computed once per view) and
//! their composition under the fragment-priority rule.

use ori_raster::OrthoView;
use ori_relief::{ReliefMap, ReliefSet};

use crate::march::{ImpostorRays, Trace};
use crate::reference::world_normal;
use crate::{Mask, Priority};

/// Marks a pixel no impostor drew (or a pixel of the mesh render) in [`Render::source`].
pub const NO_SOURCE: u16 = u16::MAX;

/// An image of the mesh or of an ORI from an evaluation view.
#[derive(Clone, Debug, PartialEq)]
pub struct Render {
    /// Edge in pixels.
    pub size: u32,
    /// Pixels drawn.
    pub coverage: Mask,
    /// Depth in the evaluation view (0 at its near plane, 1 at the object's far side); NaN
    /// where nothing is drawn.
    pub depth: Vec<f32>,
    /// sRGB albedo.
    pub albedo: Vec<[u8; 3]>,
    /// Unit world-space normal.
    pub normal: Vec<[f32; 3]>,
    /// Index of the impostor that drew each pixel; [`NO_SOURCE`] elsewhere and in mesh renders.
    pub source: Vec<u16>,
}

impl Render {
    /// Pixel `i` as where nothing is drawn (its coverage bit aside).
    pub(crate) fn clear(&mut self, i: usize) {
        self.depth[i] = f32::NAN;
        self.albedo[i] = [0; 3];
        self.normal[i] = [0.0; 3];
        self.source[i] = NO_SOURCE;
    }

    /// A `size` x `size` render with nothing drawn.
    pub fn empty(size: u32) -> Render {
        let n = size as usize * size as usize;
        Render {
            size,
            coverage: Mask::new(size),
            depth: vec![f32::NAN; n],
            albedo: vec![[0; 3]; n],
            normal: vec![[0.0; 3]; n],
            source: vec![NO_SOURCE; n],
        }
    }
}

/// Marks a pixel without fragment in a [`Layer`].
const NO_TEXEL: u32 = u32::MAX;

/// Everything one impostor draws from one evaluation view: each pixel's fragment (texel and
/// relief depth) or none. Layers are traced once per view and composed in any order.
#[derive(Clone, Debug)]
pub struct Layer {
    pub(crate) impostor: usize,
    pub(crate) rays: Option<ImpostorRays>,
    pub(crate) mask: Mask,
    /// Fragment texel per pixel, [`NO_TEXEL`] where none.
    pub(crate) texel: Vec<u32>,
    /// Relief depth (codes) of the fragment per pixel.
    pub(crate) z: Vec<f32>,
    pub(crate) walls: u32,
}

impl Layer {
    /// The impostor's index in the relief set.
    pub fn impostor(&self) -> usize {
        self.impostor
    }

    /// Pixels where the impostor produces a fragment.
    pub fn mask(&self) -> &Mask {
        &self.mask
    }

    /// Rays that ended on a vertical wall (discarded fragments).
    pub fn walls(&self) -> u32 {
        self.walls
    }

    pub(crate) fn trace(
        view: &OrthoView,
        map: &ReliefMap,
        impostor: usize,
        rays: Option<ImpostorRays>,
        within: Option<&Mask>,
    ) -> Layer {
        let s = view.size;
        let n = s as usize * s as usize;
        let mut layer = Layer {
            impostor,
            rays: None,
            mask: Mask::new(s),
            texel: vec![NO_TEXEL; n],
            z: vec![0.0; n],
            walls: 0,
        };
        let Some(rays) = rays else {
            return layer;
        };
        let pixels = pixels_to_trace(&rays, s, within);
        rays.trace_many(&map.depth, &pixels, |i, trace| match trace {
            Trace::Hit { z, texel } => {
                layer.mask.set(i);
                layer.texel[i] = texel;
                layer.z[i] = z;
            }
            Trace::Wall => layer.walls += 1,
            Trace::Miss => {}
        });
        layer.rays = Some(rays);
        layer
    }
}

/// The pixels `(index, x, y)` of `within` (all pixels when `None`) inside the footprint of
/// `rays`, row by row, so that the lockstep search's lanes hold neighbouring rays (similar
/// steps, nearby texels).
pub(crate) fn pixels_to_trace(
    rays: &ImpostorRays,
    size: u32,
    within: Option<&Mask>,
) -> Vec<(usize, u32, u32)> {
    let [x0, x1, y0, y1] = rays.footprint(size);
    let s = size as usize;
    let mut pixels = Vec::new();
    for y in y0..y1 {
        let row = y as usize * s;
        match within {
            Some(mask) => pixels.extend(
                mask.ones_in(row + x0 as usize, row + x1 as usize)
                    .map(|i| (i, (i - row) as u32, y)),
            ),
            None => pixels.extend((x0..x1).map(|x| (row + x as usize, x, y))),
        }
    }
    pixels
}

/// Bias of the paper's option 5, in units of the view's depth range.
const OPTION5_BIAS: f64 = 1.0 / 32.0;

/// Compose `layers` (in priority order, closest direction first) into one image.
pub(crate) fn compose(set: &ReliefSet, size: u32, layers: &[&Layer], priority: Priority) -> Render {
    let mut out = Render::empty(size);
    let s = size as usize;
    for i in 0..s * s {
        let (x, y) = ((i % s) as u32, (i / s) as u32);
        // (layer, texel, view depth, priority key); the first layer wins ties.
        let mut best: Option<(&Layer, u32, f64, f64)> = None;
        for &layer in layers {
            let texel = layer.texel[i];
            if texel == NO_TEXEL {
                continue;
            }
            let rays = layer
                .rays
                .as_ref()
                .expect("a layer with fragments has rays");
            let depth = rays.eval_depth(x, y, layer.z[i]);
            let key = match priority {
                Priority::ClosestDirection => 0.0,
                Priority::BiasedDepth => {
                    let map = &set.maps[layer.impostor];
                    let cos = ReliefMap::decode_normal(map.normal[texel as usize])[2];
                    depth - OPTION5_BIAS * cos
                }
            };
            if best.is_none_or(|b| key < b.3) {
                best = Some((layer, texel, depth, key));
            }
            if priority == Priority::ClosestDirection {
                break;
            }
        }
        if let Some((layer, texel, depth, _)) = best {
            let map = &set.maps[layer.impostor];
            out.coverage.set(i);
            out.depth[i] = depth as f32;
            out.albedo[i] = map.albedo[texel as usize];
            out.normal[i] = world_normal(map, texel as usize);
            out.source[i] = layer.impostor as u16;
        }
    }
    out
}
