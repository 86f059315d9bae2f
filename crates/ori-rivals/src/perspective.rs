//! Perspective billboard textures (seed 004): the object as a pinhole camera at a distance
//! sees it, projected onto the plane through the bounding sphere's centre.
//!
//! The baker is orthographic, so the mesh is warped instead: a perspective projection is a
//! projective map, which takes triangles to triangles, so baking the warped mesh
//! orthographically gives the perspective image (with attributes interpolated affinely across
//! each triangle, as they are across a screen-space triangle without perspective correction).
//! In the frame of the direction, about the centre, a point (x, y, z) with z towards the
//! camera at distance D becomes (x D/(D-z), y D/(D-z), z D/(D-z)): on the plane z = 0 nothing
//! moves, and the depth order along each camera ray is kept.

use std::sync::Arc;

use ori_bake::{BakeParams, Baker, Textures};
use ori_mesh::Mesh;
use ori_raster::Frame;
use ori_relief::ReliefMap;
use rayon::prelude::*;

use crate::{RivalError, Technique};

/// A camera whose view frustum fits the bounding sphere at `relative_distance` times the
/// distance where it fits exactly (seed 004's "base distance", radius / sin(fov / 2)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerspectiveCamera {
    pub fov_deg: f64,
    pub relative_distance: f64,
}

impl Default for PerspectiveCamera {
    /// Seed 004's middle field of view at its base distance.
    fn default() -> Self {
        PerspectiveCamera {
            fov_deg: 60.0,
            relative_distance: 1.0,
        }
    }
}

impl PerspectiveCamera {
    /// Distance from the centre of a sphere of radius `radius`.
    pub fn distance(&self, radius: f64) -> f64 {
        // ori_math: bit-identical on every machine.
        let (sin, _) = ori_math::sin_cos((self.fov_deg * 0.5).to_radians());
        self.relative_distance * radius / sin
    }

    pub fn describe(&self) -> String {
        format!(
            "perspective, {} degrees at {} x the base distance",
            self.fov_deg, self.relative_distance
        )
    }

    /// `mesh` warped to what this camera sees along `direction` (see the module).
    pub fn warp(&self, mesh: &Mesh, centre: [f64; 3], radius: f64, direction: [f64; 3]) -> Mesh {
        let frame = Frame::from_direction(direction);
        let distance = self.distance(radius);
        let positions = mesh
            .positions
            .iter()
            .map(|p| {
                let rel: [f64; 3] = std::array::from_fn(|k| f64::from(p[k]) - centre[k]);
                let l = frame.to_local(rel);
                // The camera lies outside the bounding sphere, so distance - z > 0.
                let s = distance / (distance - l[2]);
                let world = frame.to_world([l[0] * s, l[1] * s, l[2] * s]);
                std::array::from_fn(|k| (world[k] + centre[k]) as f32)
            })
            .collect();
        Mesh {
            positions,
            ..mesh.clone()
        }
    }

    /// One perspective texture per direction.
    pub fn bake(
        &self,
        mesh: &Mesh,
        centre: [f64; 3],
        radius: f64,
        directions: &[[f64; 3]],
        params: &BakeParams,
    ) -> Result<Vec<ReliefMap>, RivalError> {
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0 && self.relative_distance > 1.0 - 1e-9) {
            return Err(RivalError::Bake {
                technique: Technique::BillboardsPerspective.name(),
                reason: format!(
                    "a camera of {} degrees at {} x the base distance does not see the whole object",
                    self.fov_deg, self.relative_distance
                ),
            });
        }
        // Sorted and decoded once: each direction's warp keeps the triangles in order.
        let order = mesh.spatial_order();
        let ordered = mesh.reordered(&order);
        let textures = Arc::new(Textures::new(mesh));
        directions
            .par_iter()
            .map(|&d| {
                let warped = self.warp(&ordered, centre, radius, d);
                let mut set = Baker::in_order(warped, order.clone(), textures.clone())
                    .bake_any_resolution(&[d], params)
                    .map_err(|e| RivalError::Bake {
                        technique: Technique::BillboardsPerspective.name(),
                        reason: e.to_string(),
                    })?;
                Ok(set.maps.pop().expect("one direction, one map"))
            })
            .collect()
    }
}
