//! Clipping a mesh to an axis-aligned box: every triangle is clipped against the box's six
//! planes (Sutherland-Hodgman), new corners get interpolated attributes, and the clipped
//! polygons are fanned back into triangles. Used to cut a model into hierarchy nodes.

use crate::Mesh;

/// One corner of a polygon being clipped: an original vertex, or a point on an edge with
/// interpolated attributes.
#[derive(Clone, Copy)]
struct Corner {
    /// The original vertex index, while the corner is one.
    original: Option<u32>,
    position: [f64; 3],
    normal: [f64; 3],
    uv: [f64; 2],
    color: [f64; 4],
}

fn lerp<const N: usize>(a: [f64; N], b: [f64; N], t: f64) -> [f64; N] {
    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * t)
}

/// The point where the edge `a`-`b` crosses a plane, `da` and `db` their signed distances
/// (opposite signs). Computed from the endpoint that sorts first, so the edge two triangles
/// share gets the same point in both (no cracks between neighbours).
fn crossing(a: &Corner, da: f64, b: &Corner, db: f64) -> Corner {
    let (a, da, b, db) = if a.position < b.position {
        (a, da, b, db)
    } else {
        (b, db, a, da)
    };
    let t = da / (da - db);
    let n = lerp(a.normal, b.normal, t);
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    Corner {
        original: None,
        position: lerp(a.position, b.position, t),
        // Opposite normals can cancel at the crossing: keep the nearer endpoint's then.
        normal: if len > 1e-12 {
            n.map(|c| c / len)
        } else if t < 0.5 {
            a.normal
        } else {
            b.normal
        },
        uv: lerp(a.uv, b.uv, t),
        color: lerp(a.color, b.color, t),
    }
}

/// Clip `polygon` to the half-space where `distance >= 0`.
fn clip_polygon(polygon: &[Corner], distance: impl Fn(&Corner) -> f64) -> Vec<Corner> {
    let mut out = Vec::with_capacity(polygon.len() + 2);
    for (i, a) in polygon.iter().enumerate() {
        let b = &polygon[(i + 1) % polygon.len()];
        let (da, db) = (distance(a), distance(b));
        if da >= 0.0 {
            out.push(*a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(crossing(a, da, b, db));
        }
    }
    out
}

/// The part of `mesh` inside the box `min..max` (boundary included), or `None` when no
/// triangle of positive area is left.
///
/// Triangles entirely inside keep their vertices; triangles crossing the boundary are cut
/// against each of the six planes, the new corners interpolating position, normal
/// (renormalised), texture coordinates and colour along the cut edge; the resulting convex
/// polygons are fanned into triangles with the original's material. Materials and textures
/// are kept whole. Deterministic: vertices appear in the order triangles first use them.
pub fn clip_to_box(mesh: &Mesh, min: [f64; 3], max: [f64; 3]) -> Option<Mesh> {
    let corner = |v: u32| {
        let i = v as usize;
        Corner {
            original: Some(v),
            position: mesh.positions[i].map(f64::from),
            normal: mesh.normals[i].map(f64::from),
            uv: mesh.uvs.as_ref().map_or([0.0; 2], |u| u[i].map(f64::from)),
            color: mesh
                .colors
                .as_ref()
                .map_or([1.0; 4], |c| c[i].map(f64::from)),
        }
    };
    let inside = |p: [f64; 3]| (0..3).all(|k| p[k] >= min[k] && p[k] <= max[k]);

    let mut out = Mesh {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: mesh.uvs.as_ref().map(|_| Vec::new()),
        colors: mesh.colors.as_ref().map(|_| Vec::new()),
        triangles: Vec::new(),
        triangle_materials: Vec::new(),
        materials: mesh.materials.clone(),
        textures: mesh.textures.clone(),
    };
    // Original vertex -> output vertex.
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut emit = |out: &mut Mesh, c: &Corner| -> u32 {
        if let Some(v) = c.original
            && remap[v as usize] != u32::MAX
        {
            return remap[v as usize];
        }
        let index = out.positions.len() as u32;
        match c.original {
            Some(v) => {
                let i = v as usize;
                remap[i] = index;
                out.positions.push(mesh.positions[i]);
                out.normals.push(mesh.normals[i]);
                if let (Some(u), Some(src)) = (&mut out.uvs, &mesh.uvs) {
                    u.push(src[i]);
                }
                if let (Some(col), Some(src)) = (&mut out.colors, &mesh.colors) {
                    col.push(src[i]);
                }
            }
            None => {
                out.positions.push(c.position.map(|x| x as f32));
                out.normals.push(c.normal.map(|x| x as f32));
                if let Some(u) = &mut out.uvs {
                    u.push(c.uv.map(|x| x as f32));
                }
                if let Some(col) = &mut out.colors {
                    col.push(c.color.map(|x| x as f32));
                }
            }
        }
        index
    };

    for (t, tri) in mesh.triangles.iter().enumerate() {
        let material = mesh.triangle_materials[t];
        let corners = tri.map(corner);
        if corners.iter().all(|c| inside(c.position)) {
            let indices = corners.map(|c| emit(&mut out, &c));
            out.triangles.push(indices);
            out.triangle_materials.push(material);
            continue;
        }
        let mut polygon = corners.to_vec();
        for k in 0..3 {
            if polygon.len() < 3 {
                break;
            }
            polygon = clip_polygon(&polygon, |c| c.position[k] - min[k]);
            if polygon.len() < 3 {
                break;
            }
            polygon = clip_polygon(&polygon, |c| max[k] - c.position[k]);
        }
        if polygon.len() < 3 {
            continue;
        }
        let indices: Vec<u32> = polygon.iter().map(|c| emit(&mut out, c)).collect();
        for k in 1..indices.len() - 1 {
            let triangle = [indices[0], indices[k], indices[k + 1]];
            if area2(&out.positions, triangle) > 0.0 {
                out.triangles.push(triangle);
                out.triangle_materials.push(material);
            }
        }
    }
    (!out.triangles.is_empty()).then_some(out)
}

/// Four times the squared area of a triangle (the squared length of its face normal).
fn area2(positions: &[[f32; 3]], t: [u32; 3]) -> f64 {
    let n = crate::face_normal(positions, t);
    n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Material;

    /// A unit square in z = 0 split into two triangles, with UVs = (x, y) and colour (x, y, 0, 1).
    fn square() -> Mesh {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        Mesh {
            positions: p.to_vec(),
            normals: vec![[0.0, 0.0, 1.0]; 4],
            uvs: Some(p.iter().map(|q| [q[0], q[1]]).collect()),
            colors: Some(p.iter().map(|q| [q[0], q[1], 0.0, 1.0]).collect()),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            triangle_materials: vec![0, 0],
            materials: vec![Material::default()],
            textures: Vec::new(),
        }
    }

    fn area(m: &Mesh) -> f64 {
        m.triangles
            .iter()
            .map(|&t| area2(&m.positions, t).sqrt() / 2.0)
            .sum()
    }

    #[test]
    fn a_box_around_everything_keeps_the_mesh() {
        let m = square();
        assert_eq!(clip_to_box(&m, [-1.0; 3], [2.0; 3]), Some(m));
        assert_eq!(clip_to_box(&square(), [2.0; 3], [3.0; 3]), None);
    }

    #[test]
    fn quadrants_partition_the_area_and_interpolate_attributes() {
        let m = square();
        let mut total = 0.0;
        for (x0, y0) in [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5)] {
            let c = clip_to_box(&m, [x0, y0, -1.0], [x0 + 0.5, y0 + 0.5, 1.0]).unwrap();
            total += area(&c);
            assert!((area(&c) - 0.25).abs() < 1e-6, "{x0} {y0}: {}", area(&c));
            for (i, p) in c.positions.iter().enumerate() {
                assert!(p[0] >= x0 as f32 && p[0] <= (x0 + 0.5) as f32);
                // The attributes are linear in position, so interpolation reproduces them.
                assert_eq!(c.uvs.as_ref().unwrap()[i], [p[0], p[1]]);
                assert_eq!(c.colors.as_ref().unwrap()[i], [p[0], p[1], 0.0, 1.0]);
                assert_eq!(c.normals[i], [0.0, 0.0, 1.0]);
            }
        }
        assert!((total - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_shared_edge_is_cut_at_the_same_point_from_both_sides() {
        // Both triangles share the diagonal 0-2, walked in opposite directions.
        let c = clip_to_box(&square(), [-1.0, -1.0, -1.0], [0.3, 2.0, 1.0]).unwrap();
        let on_plane: Vec<[f32; 3]> = c
            .positions
            .iter()
            .copied()
            .filter(|p| p[0] == 0.3f64 as f32)
            .collect();
        // (0.3, 0), (0.3, 0.3) on the diagonal (once, shared bit for bit), (0.3, 1).
        let mut distinct = on_plane.clone();
        distinct.sort_by(|a, b| a.partial_cmp(b).unwrap());
        distinct.dedup();
        assert_eq!(distinct.len(), 3, "{on_plane:?}");
        assert!((area(&c) - 0.3).abs() < 1e-6);
    }
}
