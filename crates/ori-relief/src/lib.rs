//! The relief map: an object seen orthographically from one direction as depth, normal and
//! albedo texels (the guide's "Relief texel"), and the set of them an ORI is made of.
//!
//! Shared by the baker that writes maps and everything that reads them (placement,
//! selection, evaluation, compression, the report), so that none of those depends on the
//! baker for a type. This crate knows no mesh and no baking.

mod codec;

use ori_raster::OrthoView;

pub use ori_artifact::DecodeError;

/// The depth code of an empty texel.
pub const EMPTY_DEPTH: u8 = 255;
/// Depth codes 0..=MAX_DEPTH span the object's depth range.
pub const MAX_DEPTH: u8 = 254;

/// One relief map and the impostor quad it belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct ReliefMap {
    /// Where the map is seen from: its frame, quad window and depth range.
    pub view: OrthoView,
    /// `size^2` depth codes, row-major, row 0 at the top (+v).
    pub depth: Vec<u8>,
    /// `size^2` normal (x, y) in the impostor frame, each `round((c + 1) / 2 * 255)`.
    pub normal: Vec<[u8; 2]>,
    /// `size^2` sRGB albedo.
    pub albedo: Vec<[u8; 3]>,
}

impl ReliefMap {
    pub fn size(&self) -> u32 {
        self.view.size
    }

    /// Relief depth in [0, 1] of a depth code (None when empty).
    pub fn depth01(code: u8) -> Option<f64> {
        (code != EMPTY_DEPTH).then(|| f64::from(code) / f64::from(MAX_DEPTH))
    }

    /// Unit normal in the impostor frame rebuilt from the stored (x, y).
    #[inline]
    pub fn decode_normal(n: [u8; 2]) -> [f64; 3] {
        let x = f64::from(n[0]) / 255.0 * 2.0 - 1.0;
        let y = f64::from(n[1]) / 255.0 * 2.0 - 1.0;
        let z = (1.0 - x * x - y * y).max(0.0).sqrt();
        [x, y, z]
    }

    /// Number of non-empty texels.
    pub fn covered(&self) -> usize {
        self.depth.iter().filter(|&&d| d != EMPTY_DEPTH).count()
    }
}

/// The relief maps of one object, in the order of the planned directions.
#[derive(Clone, Debug, PartialEq)]
pub struct ReliefSet {
    pub maps: Vec<ReliefMap>,
}

impl ReliefSet {
    /// The canonical byte layout (the bake stage's artifact; see `codec.rs`).
    pub fn encode(&self) -> Vec<u8> {
        codec::encode(self)
    }

    pub fn decode(bytes: &[u8]) -> Result<ReliefSet, DecodeError> {
        codec::decode(bytes)
    }
}
