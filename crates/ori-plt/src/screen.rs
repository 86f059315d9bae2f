//! Projected size on screen: the bounding sphere as a conservative stand-in for the edge of
//! the square bounding box of the object's projection.

/// Edge, in pixels, of the square bounding box of the perspective projection of a sphere:
/// `center` in view space (camera at the origin looking along +z, x right, y up or down),
/// `radius` in the same units, `focal_px` the focal length in pixels
/// (`viewport_height / 2 / tan(fov_y / 2)`). Exact for the sphere, off-axis included (the
/// tangent planes through the camera bound its image), so never smaller than the box of
/// anything inside it. `None` when the sphere reaches the camera plane (`center.z <= radius`):
/// its projection is unbounded.
pub fn sphere_projected_edge(center: [f64; 3], radius: f64, focal_px: f64) -> Option<f64> {
    let [cx, cy, cz] = center;
    let r2 = radius * radius;
    let denom = cz * cz - r2;
    if !(cz > radius && denom > 0.0) {
        return None;
    }
    // The planes x = t z through the camera tangent to the sphere have
    // t = (cx cz +- r sqrt(cx^2 + cz^2 - r^2)) / (cz^2 - r^2); likewise for y.
    let extent = |c: f64| 2.0 * focal_px * radius * (c * c + cz * cz - r2).sqrt() / denom;
    Some(extent(cx).max(extent(cy)))
}

/// The same for an orthographic camera: the sphere's diameter times the pixels per unit.
pub fn ortho_sphere_edge(radius: f64, pixels_per_unit: f64) -> f64 {
    2.0 * radius * pixels_per_unit
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centred_sphere_matches_the_angular_size() {
        // r = 1 at distance 10: half-angle asin(0.1), image half-width f tan(asin 0.1).
        let f = 500.0;
        let e = sphere_projected_edge([0.0, 0.0, 10.0], 1.0, f).unwrap();
        let t = 0.1 / (1.0f64 - 0.01).sqrt();
        assert!((e - 2.0 * f * t).abs() < 1e-9);
        // Off axis the image is stretched, never shrunk.
        let off = sphere_projected_edge([6.0, 0.0, 10.0], 1.0, f).unwrap();
        assert!(off > e);
        assert_eq!(sphere_projected_edge([0.0, 0.0, 1.0], 1.0, f), None);
        assert_eq!(ortho_sphere_edge(2.0, 10.0), 40.0);
    }

    #[test]
    fn bounds_every_point_of_the_sphere() {
        let (c, r, f) = ([3.0, -2.0, 12.0], 2.5, 800.0);
        let edge = sphere_projected_edge(c, r, f).unwrap();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for i in 0..200 {
            for j in 0..100 {
                let (th, ph) = (
                    std::f64::consts::PI * f64::from(j) / 99.0,
                    2.0 * std::f64::consts::PI * f64::from(i) / 200.0,
                );
                let p = [
                    c[0] + r * th.sin() * ph.cos(),
                    c[1] + r * th.sin() * ph.sin(),
                    c[2] + r * th.cos(),
                ];
                for k in 0..2 {
                    let s = f * p[k] / p[2];
                    lo[k] = lo[k].min(s);
                    hi[k] = hi[k].max(s);
                }
            }
        }
        let sampled = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        assert!(sampled <= edge + 1e-9 && sampled > edge * 0.999);
    }
}
