//! Angle-weighted vertex normals (Thürmer & Wüthrich): each face contributes its unit normal
//! times the angle of its corner at the vertex, which, unlike area weighting, does not depend
//! on how a surface happens to be triangulated.

/// Unit normals for every vertex. Sums run in triangle order in `f64` with portable angles, so
/// the result is bit-identical on every machine. A vertex no proper triangle touches gets +Z.
pub fn angle_weighted_normals(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut sums = vec![[0.0f64; 3]; positions.len()];
    let p = |i: u32| positions[i as usize].map(f64::from);
    for tri in triangles {
        let [a, b, c] = tri.map(p);
        let e0 = sub(b, a);
        let e1 = sub(c, b);
        let e2 = sub(a, c);
        let n = face_normal(positions, *tri);
        let len = dot(n, n).sqrt();
        if len == 0.0 || !len.is_finite() {
            continue; // degenerate: no direction to contribute
        }
        let n = n.map(|x| x / len);
        let corners = [
            (tri[0], ori_math::angle_between(e0, neg(e2))),
            (tri[1], ori_math::angle_between(e1, neg(e0))),
            (tri[2], ori_math::angle_between(e2, neg(e1))),
        ];
        for (v, angle) in corners {
            let s = &mut sums[v as usize];
            for k in 0..3 {
                s[k] += n[k] * angle;
            }
        }
    }
    sums.into_iter()
        .map(|s| {
            let len = dot(s, s).sqrt();
            if len > 0.0 {
                s.map(|x| (x / len) as f32)
            } else {
                [0.0, 0.0, 1.0]
            }
        })
        .collect()
}

/// The unnormalised normal of triangle `tri` by its winding (`(b - a) x (c - a)`, in `f64`):
/// its length is twice the triangle's area.
pub fn face_normal(positions: &[[f32; 3]], tri: [u32; 3]) -> [f64; 3] {
    let [a, b, c] = tri.map(|i| positions[i as usize].map(f64::from));
    cross(sub(b, a), sub(c, a))
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn neg(a: [f64; 3]) -> [f64; 3] {
    [-a[0], -a[1], -a[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_corner_normal_points_along_the_diagonal() {
        // Three faces of a unit cube meeting at the origin corner, each split in two triangles
        // differently: angle weighting makes the split irrelevant.
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 1.0],
            [1.0, 0.0, 1.0],
        ];
        // -Z face (0,2,4,1), -X face (0,3,5,2), -Y face (0,1,6,3)
        let triangles = vec![
            [0, 2, 4],
            [0, 4, 1],
            [0, 3, 5],
            [0, 5, 2],
            [0, 1, 6],
            [0, 6, 3],
        ];
        let n = angle_weighted_normals(&positions, &triangles)[0];
        let d = -1.0 / 3f32.sqrt();
        for k in 0..3 {
            assert!((n[k] - d).abs() < 1e-6, "{n:?}");
        }
    }

    #[test]
    fn isolated_and_degenerate_get_plus_z() {
        let positions = vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [5.0; 3]];
        let n = angle_weighted_normals(&positions, &[[0, 1, 2]]);
        assert_eq!(n[3], [0.0, 0.0, 1.0]);
        assert_eq!(n[0], [0.0, 0.0, 1.0]);
    }
}
