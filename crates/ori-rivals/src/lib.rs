//! Rival impostor techniques, each baked from the mesh at a byte budget and drawn by the CPU
//! evaluator's conventions (the same evaluation views, reference and error measures as the
//! ORI), so that "which looks closest to the mesh for the same memory?" has a measured answer.
//!
//! | [`Technique`]             | drawn per view                                             |
//! |---------------------------|------------------------------------------------------------|
//! | `octahedral`              | a camera-facing quad blending the 3 nearest frames of an N x N octahedral atlas over the sphere, each frame's lookup offset once by its depth (parallax) |
//! | `hemi-octahedral`         | the same over the upper hemisphere; views from below use the nearest edge frames |
//! | `billboards-orthographic` | the quad of the nearest of a set of directions (icosahedron face centres), perpendicular to it through the bounding sphere's centre, with an orthographic texture |
//! | `billboards-perspective`  | the same with textures seen by a perspective camera ([`perspective`]) |
//! | `relief-box`              | six axis-aligned relief maps drawn with the ORI's relief rule (the 3 facing ones) |
//! | `billboard-cloud`         | textured planes found by hierarchical face clustering with seed 001's merge cost ([`BillboardCloud`]), the facing ones drawn with a depth test |
//! | `simplified-mesh`         | the mesh simplified by meshoptimizer until its vertex and index bytes fit the budget |
//! | `ori`                     | the ORI: its selection table's subset at every direction |
//!
//! Bytes are counted as a package stores them: relief texels 2.5 bytes (depth R8, normal BC5,
//! albedo BC1), billboard texels 1.5 (normal BC5, albedo BC1 with its 1-bit alpha), a billboard
//! cloud's cards 92 bytes each besides (four corners, six indices), mesh
//! vertices 24 bytes (position and normal as f32) plus 8 for UVs and 4 for colours where the
//! mesh has them, indices 2 bytes below 65,536 vertices and 4 above. Textures are drawn as
//! baked (not block-compressed), as the ORI's quality figures are.
//!
//! Every technique picks its layout (resolution, frame or billboard count, camera distance)
//! for the budget from a short list, keeping the one with the least silhouette error (pixels
//! missed plus pixels added) at *tuning* directions ([`tuning_directions`]), which are none
//! of the held-out ones the comparison reports.

mod billboard;
mod cloud;
mod measure;
mod octahedral;
pub mod perspective;
mod relief_box;
mod simplified;

use ori_eval::Render;
use ori_mesh::Mesh;
use ori_raster::OrthoView;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use billboard::{Billboards, Projection};
pub use cloud::BillboardCloud;
pub use measure::{Comparison, Measured, References, Row, compare, measure, picture, summarize};
pub use octahedral::{Octahedral, Sphere};
pub use relief_box::{Relief, Subsets};
pub use simplified::SimplifiedMesh;

/// The techniques compared, by the names `cargo xtask compare` prints and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Technique {
    Octahedral,
    HemiOctahedral,
    BillboardsOrthographic,
    BillboardsPerspective,
    ReliefBox,
    BillboardCloud,
    SimplifiedMesh,
    Ori,
}

impl Technique {
    /// Every technique, in the order of the comparison's rows.
    pub const ALL: [Technique; 8] = [
        Technique::Octahedral,
        Technique::HemiOctahedral,
        Technique::BillboardsOrthographic,
        Technique::BillboardsPerspective,
        Technique::ReliefBox,
        Technique::BillboardCloud,
        Technique::SimplifiedMesh,
        Technique::Ori,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Technique::Octahedral => "octahedral",
            Technique::HemiOctahedral => "hemi-octahedral",
            Technique::BillboardsOrthographic => "billboards-orthographic",
            Technique::BillboardsPerspective => "billboards-perspective",
            Technique::ReliefBox => "relief-box",
            Technique::BillboardCloud => "billboard-cloud",
            Technique::SimplifiedMesh => "simplified-mesh",
            Technique::Ori => "ori",
        }
    }

    pub fn from_name(name: &str) -> Option<Technique> {
        Technique::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether it is drawn from textures (the comparison's goal ranks these).
    pub fn is_texture(self) -> bool {
        self != Technique::SimplifiedMesh
    }
}

/// What one view draws: quads (impostors, billboards) or the mesh's triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Primitive {
    Quads,
    Triangles,
}

impl Primitive {
    /// As the JSON and the tables write it.
    pub fn name(self) -> &'static str {
        match self {
            Primitive::Quads => "quads",
            Primitive::Triangles => "triangles",
        }
    }
}

/// One view of a technique.
pub struct Drawn {
    pub render: Render,
    /// Quads or triangles drawn.
    pub count: u32,
}

/// A baked technique, ready to draw any view.
pub trait Rival: Send + Sync {
    fn technique(&self) -> Technique;
    /// Bytes as a package would store them (see the crate documentation).
    fn bytes(&self) -> u64;
    /// Its layout in words, e.g. "9 x 9 frames of 128 x 128".
    fn layout(&self) -> String;
    fn primitive(&self) -> Primitive;
    /// The view `view` (an evaluation view of the mesh: `ori_eval::eval_view`).
    fn draw(&self, view: &OrthoView) -> Result<Drawn, RivalError>;
    /// The triangles drawn when it draws the mesh itself (so that the reference render of a
    /// view is its drawing).
    fn draws_the_mesh(&self) -> Option<u32> {
        None
    }
}

/// Why a technique could not be baked or drawn.
#[derive(Debug, thiserror::Error)]
pub enum RivalError {
    #[error("{technique}: {reason}")]
    Bake {
        technique: &'static str,
        reason: String,
    },
    #[error("{0}")]
    Eval(#[from] ori_eval::EvalError),
    #[error(
        "{technique}: no layout fits {budget} bytes within 5 % (the closest is {closest} bytes)"
    )]
    Budget {
        technique: &'static str,
        budget: u64,
        closest: u64,
    },
}

/// Bytes per relief texel: depth R8 (1), normal BC5 (1), albedo BC1 (0.5), as a package.
pub fn relief_bytes(texels: u64) -> u64 {
    texels * 5 / 2
}

/// Bytes per billboard texel: normal BC5 (1), albedo BC1 with 1-bit alpha (0.5).
pub fn billboard_bytes(texels: u64) -> u64 {
    texels * 3 / 2
}

/// Whether `bytes` is within 5 % of `budget`.
pub fn within_budget(bytes: u64, budget: u64) -> bool {
    bytes.abs_diff(budget) * 20 <= budget
}

/// The largest edge `r` (a multiple of `step`, at least `step`) with `count` maps of `r` x `r`
/// texels within `budget`, by `bytes_of(texels)`; `None` when even `step` is too large.
fn edge_for(budget: u64, count: u64, step: u32, bytes_of: fn(u64) -> u64) -> Option<u32> {
    let mut r = step;
    if bytes_of(count * u64::from(r) * u64::from(r)) > budget {
        return None;
    }
    while bytes_of(count * u64::from(r + step) * u64::from(r + step)) <= budget {
        r += step;
    }
    Some(r)
}

/// The centre and radius of the sphere the techniques centre their quads on
/// ([`ori_views::BoundingSphere`]).
pub(crate) fn bounding_sphere(
    mesh: &Mesh,
    technique: Technique,
) -> Result<([f64; 3], f64), RivalError> {
    let sphere = ori_views::BoundingSphere::of(mesh).map_err(|e| RivalError::Bake {
        technique: technique.name(),
        reason: e.to_string(),
    })?;
    Ok((sphere.center, sphere.radius))
}

/// `count` of the held-out directions of `seed`, evenly spread through the list (every one
/// when `count` is 3,280 or more), so that a sample keeps both the regular and the random
/// ones over the whole sphere.
pub fn held_out_sample(seed: u64, count: usize) -> Vec<[f64; 3]> {
    let all = ori_views::held_out_directions(seed);
    let count = count.clamp(1, all.len());
    (0..count).map(|i| all[i * all.len() / count]).collect()
}

/// The seed of the tuning directions: the held-out seed's, changed so that the two sets
/// share no direction.
const TUNING_SALT: u64 = 0x7475_6e69_6e67;

/// How many directions a technique's layouts are chosen by.
pub const TUNING_COUNT: usize = 128;

/// The directions a technique's layout is chosen by: `TUNING_COUNT` seeded uniform
/// directions, from a seed no held-out set uses.
pub fn tuning_directions(held_out_seed: u64) -> Vec<[f64; 3]> {
    let all = ori_views::held_out_directions(held_out_seed ^ TUNING_SALT);
    all[ori_views::HELD_OUT_REGULAR..][..TUNING_COUNT].to_vec()
}

/// Choose, among `layouts` (each baked by `bake`), the one with the least silhouette error
/// summed over the tuning views `references` (ties: the earlier).
pub fn choose<L: Copy, R: Rival>(
    technique: Technique,
    layouts: &[L],
    bake: impl Fn(L) -> Result<R, RivalError>,
    references: &References,
) -> Result<R, RivalError> {
    best_of(
        technique,
        layouts.iter().map(|&layout| bake(layout)),
        references,
    )
}

/// The candidate with the least silhouette error summed over `references` (ties: the
/// earlier).
pub fn best_of<R: Rival>(
    technique: Technique,
    candidates: impl IntoIterator<Item = Result<R, RivalError>>,
    references: &References,
) -> Result<R, RivalError> {
    let mut best: Option<(u64, R)> = None;
    for rival in candidates {
        let rival = rival?;
        let error = references.silhouette_error(&rival)?;
        if best.as_ref().is_none_or(|(b, _)| error < *b) {
            best = Some((error, rival));
        }
    }
    best.map(|(_, r)| r).ok_or_else(|| RivalError::Bake {
        technique: technique.name(),
        reason: "no layout fits the budget within 5 %".into(),
    })
}

/// One baked rival (what the [`Rival`]s of [`Rivals::all`] borrow).
pub enum Baked {
    Octahedral(Octahedral),
    Billboards(Billboards),
    ReliefBox(ori_relief::ReliefSet),
    BillboardCloud(BillboardCloud),
    SimplifiedMesh(SimplifiedMesh),
}

/// The rivals of the ORI baked at one budget, in the order of [`Technique::ALL`].
pub struct Rivals {
    pub baked: Vec<Baked>,
}

impl Rivals {
    /// Bake the techniques of `wanted` (the ORI aside) within `budget` bytes, each in the
    /// layout that `tuning` measures best, several at once; `progress` hears each technique's
    /// name once it is baked.
    pub fn bake(
        mesh: &Mesh,
        budget: u64,
        wanted: &[Technique],
        tuning: &References,
        progress: &(dyn Fn(Technique) + Sync),
    ) -> Result<Rivals, RivalError> {
        let techniques: Vec<Technique> = Technique::ALL
            .into_iter()
            .filter(|t| wanted.contains(t) && *t != Technique::Ori)
            .collect();
        // At once: a technique's search for its layout does not keep both cores busy (the
        // cloud's clustering is sequential), and each bake depends on nothing but the mesh.
        let bake_one = |technique: Technique| -> Result<Baked, RivalError> {
            let octahedral = |sphere| {
                // Each layout is measured with the frames the tuning views blend; only the
                // one chosen is baked whole.
                let seen = tuning.directions();
                choose(
                    technique,
                    &Octahedral::layouts(budget),
                    |(n, r)| Octahedral::bake_for(mesh, sphere, n, r, &seen),
                    tuning,
                )
                .and_then(|chosen| chosen.complete(mesh))
                .map(Baked::Octahedral)
            };
            let billboards = |projection| {
                choose(
                    technique,
                    &Billboards::layouts(budget),
                    |(count, r)| Billboards::bake(mesh, projection, count, r),
                    tuning,
                )
                .map(Baked::Billboards)
            };
            let baked = match technique {
                Technique::Octahedral => octahedral(Sphere::Full)?,
                Technique::HemiOctahedral => octahedral(Sphere::Upper)?,
                Technique::BillboardsOrthographic => billboards(Projection::Orthographic)?,
                Technique::BillboardsPerspective => {
                    // Seed 004's relative distances 1, 2 and 4 (its least average error).
                    let layouts: Vec<(usize, u32, f64)> = Billboards::layouts(budget)
                        .into_iter()
                        .flat_map(|(count, r)| [1.0, 2.0, 4.0].map(|d| (count, r, d)))
                        .collect();
                    let bake = |(count, r, relative_distance)| {
                        let camera = perspective::PerspectiveCamera {
                            relative_distance,
                            ..Default::default()
                        };
                        Billboards::bake(mesh, Projection::Perspective(camera), count, r)
                    };
                    Baked::Billboards(choose(technique, &layouts, bake, tuning)?)
                }
                Technique::ReliefBox => Baked::ReliefBox(Relief::bake_box(mesh, budget)?),
                Technique::BillboardCloud => Baked::BillboardCloud(best_of(
                    technique,
                    BillboardCloud::bake_all(mesh, &BillboardCloud::COUNTS, budget)?
                        .into_iter()
                        .map(Ok),
                    tuning,
                )?),
                Technique::SimplifiedMesh => {
                    Baked::SimplifiedMesh(SimplifiedMesh::new(mesh, budget)?)
                }
                Technique::Ori => unreachable!("skipped above"),
            };
            progress(technique);
            Ok(baked)
        };
        // Every bake runs to its end, so that the error reported is the first in order, the
        // same on every run.
        let baked = techniques
            .into_par_iter()
            .map(bake_one)
            .collect::<Vec<_>>()
            .into_iter()
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Rivals { baked })
    }

    /// Each rival, drawable.
    pub fn all<'a>(&'a self, mesh: &'a Mesh) -> Result<Vec<Box<dyn Rival + 'a>>, RivalError> {
        self.baked
            .iter()
            .map(|b| -> Result<Box<dyn Rival + 'a>, RivalError> {
                Ok(match b {
                    Baked::Octahedral(o) => Box::new(o),
                    Baked::Billboards(b) => Box::new(b),
                    Baked::ReliefBox(maps) => Box::new(Relief::relief_box(mesh, maps)?),
                    Baked::BillboardCloud(c) => Box::new(c),
                    Baked::SimplifiedMesh(m) => Box::new(m),
                })
            })
            .collect()
    }
}

impl<R: Rival + ?Sized> Rival for &R {
    fn technique(&self) -> Technique {
        (**self).technique()
    }
    fn bytes(&self) -> u64 {
        (**self).bytes()
    }
    fn layout(&self) -> String {
        (**self).layout()
    }
    fn primitive(&self) -> Primitive {
        (**self).primitive()
    }
    fn draw(&self, view: &OrthoView) -> Result<Drawn, RivalError> {
        (**self).draw(view)
    }
    fn draws_the_mesh(&self) -> Option<u32> {
        (**self).draws_the_mesh()
    }
}
