//! Cameras: an orthographic one (the evaluator's, required for parity) and a perspective one.
//! All the geometry is `f64` on the CPU; the GPU gets `f32` matrices and ray records.

use ori_raster::{Frame, OrthoView};

/// How a camera projects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Parallel rays along `-frame.d`. The window is centred on `center` (`(u, v)`
    /// coordinates, as [`OrthoView::center`]) with half its height `half_size` (its width
    /// follows the image's aspect); depth 0 is the height `near` (`d . p`), depth 1 the height
    /// `far` (`near > far`).
    Orthographic {
        /// Window centre, `(u, v)` coordinates.
        center: [f64; 2],
        /// Half the window's height, world units.
        half_size: f64,
        /// Height `d . p` of depth 0.
        near: f64,
        /// Height `d . p` of depth 1.
        far: f64,
    },
    /// Rays from `eye` through the image; vertical field of view `fov_y` (radians, in
    /// `(0, pi)`), depth 0 at distance `near` along `-frame.d`, 1 at `far` (`0 < near <
    /// far`).
    Perspective {
        /// The eye, world space.
        eye: [f64; 3],
        /// Vertical field of view, radians.
        fov_y: f64,
        /// Distance of depth 0 along the view axis.
        near: f64,
        /// Distance of depth 1.
        far: f64,
    },
}

/// A camera: a right-handed frame (`u` right, `v` up, `d` from the scene towards the viewer)
/// and a projection. Pixel `(x, y)` of a `width x height` image has its centre at
/// `(x + 0.5, y + 0.5)`; row 0 is the top (largest `v`), as in `ori-raster`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// `u` right, `v` up, `d` towards the viewer (the camera looks along `-d`).
    pub frame: Frame,
    /// How it projects.
    pub projection: Projection,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    ori_raster::normalize(a)
}

impl Camera {
    /// The evaluator's camera for `view` (`ori_eval::Evaluator::view`): the same window,
    /// pixel for pixel at `view.size`, so a render matches the CPU evaluator's rays exactly.
    /// The depth range is the view's (the object's extent along the view direction) widened
    /// by that extent on each side, so geometry up to one object depth in front of or behind
    /// the object still draws and composites.
    pub fn from_view(view: &OrthoView) -> Camera {
        let range = view.near - view.far;
        Camera {
            frame: view.frame,
            projection: Projection::Orthographic {
                center: view.center,
                half_size: view.half_size,
                near: view.near + range,
                far: view.far - range,
            },
        }
    }

    /// An orthographic camera along `dir` (towards the viewer; `Frame::from_direction`'s
    /// frame) that frames the sphere `(center, radius)`: the square window is the sphere's
    /// bounding square, the depth range the sphere widened by its radius on each side.
    pub fn ortho_framing(center: [f64; 3], radius: f64, dir: [f64; 3]) -> Camera {
        let frame = Frame::from_direction(dir);
        let c = frame.to_local(center);
        Camera {
            frame,
            projection: Projection::Orthographic {
                center: [c[0], c[1]],
                half_size: radius,
                near: c[2] + 2.0 * radius,
                far: c[2] - 2.0 * radius,
            },
        }
    }

    /// A perspective camera at `eye` looking at `target` (`+Y` up, as
    /// `Frame::from_direction`), vertical field of view `fov_y` in radians, depth range
    /// `[near, far]` in distance along the view axis.
    pub fn perspective(eye: [f64; 3], target: [f64; 3], fov_y: f64, near: f64, far: f64) -> Camera {
        let back = std::array::from_fn(|k| eye[k] - target[k]);
        Camera {
            frame: Frame::from_direction(back),
            projection: Projection::Perspective {
                eye,
                fov_y,
                near,
                far,
            },
        }
    }

    /// A perspective camera looking at the sphere `(center, radius)` from direction `dir`
    /// (towards the viewer), at the distance where the sphere just fills the vertical field
    /// of view `fov_y` (radians).
    pub fn perspective_framing(center: [f64; 3], radius: f64, dir: [f64; 3], fov_y: f64) -> Camera {
        let dir = normalize(dir);
        let distance = radius / (0.5 * fov_y).sin();
        let eye = std::array::from_fn(|k| center[k] + dir[k] * distance);
        Camera::perspective(
            eye,
            center,
            fov_y,
            (distance - 1.5 * radius).max(1e-3 * distance),
            distance + 1.5 * radius,
        )
    }

    /// A perspective camera looking at the sphere `(center, radius)` from direction `dir`
    /// (towards the viewer), at the distance where the sphere's projection in an image
    /// `height` pixels high has edge `edge_px` ([`Camera::projected_sphere_edge`]); vertical
    /// field of view `fov_y` (radians).
    pub fn perspective_sized(
        center: [f64; 3],
        radius: f64,
        dir: [f64; 3],
        fov_y: f64,
        edge_px: f64,
        height: u32,
    ) -> Camera {
        let dir = normalize(dir);
        // The centred sphere's edge is 2 f r / sqrt(z^2 - r^2); solve for z.
        let t = edge_px / (f64::from(height) / (fov_y / 2.0).tan());
        let distance = radius * (1.0 + t * t).sqrt() / t;
        let eye = std::array::from_fn(|k| center[k] + dir[k] * distance);
        let near = (distance - radius).max(1e-3 * distance);
        Camera::perspective(eye, center, fov_y, near, distance + 2.0 * radius)
    }

    /// The direction from `target` (an object's centre) towards the viewer: what the
    /// selection table is looked up with. `frame.d` for an orthographic camera.
    pub fn view_direction(&self, target: [f64; 3]) -> [f64; 3] {
        match self.projection {
            Projection::Orthographic { .. } => self.frame.d,
            Projection::Perspective { eye, .. } => {
                let w = normalize(std::array::from_fn(|k| eye[k] - target[k]));
                if w.iter().all(|c| c.is_finite()) && dot(w, w) > 0.0 {
                    w
                } else {
                    self.frame.d
                }
            }
        }
    }

    /// The key light of the comparison shading (`ori_eval::Shading`): `normalize(0.3 u +
    /// 0.5 v + d)` of the camera frame.
    pub fn light(&self) -> [f64; 3] {
        let f = &self.frame;
        normalize(std::array::from_fn(|k| {
            0.3 * f.u[k] + 0.5 * f.v[k] + f.d[k]
        }))
    }

    /// Whether the camera can draw: finite, positive sizes and depth ranges.
    pub fn is_valid(&self) -> bool {
        let frame_ok = [self.frame.u, self.frame.v, self.frame.d]
            .iter()
            .flatten()
            .all(|c| c.is_finite());
        frame_ok
            && match self.projection {
                Projection::Orthographic {
                    center,
                    half_size,
                    near,
                    far,
                } => {
                    center.iter().all(|c| c.is_finite())
                        && half_size > 0.0
                        && half_size.is_finite()
                        && near.is_finite()
                        && far.is_finite()
                        && near > far
                }
                Projection::Perspective {
                    eye,
                    fov_y,
                    near,
                    far,
                } => {
                    eye.iter().all(|c| c.is_finite())
                        && fov_y > 0.0
                        && fov_y < std::f64::consts::PI
                        && near > 0.0
                        && far > near
                        && far.is_finite()
                }
            }
    }

    /// The edge in pixels of the square bounding the projection of the sphere `(center,
    /// radius)` in an image `height` pixels high: what a PLT is compared with
    /// (`ori_plt::ortho_sphere_edge`, `ori_plt::sphere_projected_edge`). `None` when the
    /// sphere reaches the eye's plane (unbounded).
    pub fn projected_sphere_edge(&self, center: [f64; 3], radius: f64, height: u32) -> Option<f64> {
        let h = f64::from(height);
        match self.projection {
            Projection::Orthographic { half_size, .. } => {
                Some(ori_plt::ortho_sphere_edge(radius, h / (2.0 * half_size)))
            }
            Projection::Perspective { eye, fov_y, .. } => {
                let rel: [f64; 3] = std::array::from_fn(|k| center[k] - eye[k]);
                let f = &self.frame;
                let local = [dot(rel, f.u), dot(rel, f.v), -dot(rel, f.d)];
                ori_plt::sphere_projected_edge(local, radius, h / 2.0 / (fov_y / 2.0).tan())
            }
        }
    }

    /// For an orthographic camera, the height `d . p` of a point at depth `depth` (what
    /// [`crate::Image::depth`] holds); `None` for a perspective camera.
    pub fn ortho_height(&self, depth: f64) -> Option<f64> {
        match self.projection {
            Projection::Orthographic { near, far, .. } => Some(near - depth * (near - far)),
            Projection::Perspective { .. } => None,
        }
    }

    /// The affine map from world space to clip space, as rows (`clip = M * (p, 1)`), for a
    /// `width x height` image. Clip depth is in `[0, 1]` (wgpu's convention).
    pub(crate) fn world_to_clip(&self, width: u32, height: u32) -> [[f64; 4]; 4] {
        let (u, v, d) = (self.frame.u, self.frame.v, self.frame.d);
        let aspect = f64::from(width) / f64::from(height);
        match self.projection {
            Projection::Orthographic {
                center,
                half_size,
                near,
                far,
            } => {
                let (hx, hy) = (half_size * aspect, half_size);
                let range = near - far;
                [
                    [u[0] / hx, u[1] / hx, u[2] / hx, -center[0] / hx],
                    [v[0] / hy, v[1] / hy, v[2] / hy, -center[1] / hy],
                    [-d[0] / range, -d[1] / range, -d[2] / range, near / range],
                    [0.0, 0.0, 0.0, 1.0],
                ]
            }
            Projection::Perspective {
                eye,
                fov_y,
                near,
                far,
            } => {
                let f = 1.0 / (0.5 * fov_y).tan();
                let fx = f / aspect;
                // Distance along the view axis: dist = -d . (p - eye).
                let a = far / (far - near);
                let b = far * near / (far - near);
                let (ue, ve, de) = (dot(u, eye), dot(v, eye), dot(d, eye));
                [
                    [u[0] * fx, u[1] * fx, u[2] * fx, -ue * fx],
                    [v[0] * f, v[1] * f, v[2] * f, -ve * f],
                    [-d[0] * a, -d[1] * a, -d[2] * a, de * a - b],
                    [-d[0], -d[1], -d[2], de],
                ]
            }
        }
    }
}

/// `a * b` for 4 x 4 matrices given as rows.
pub(crate) fn mul(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|k| a[i][k] * b[k][j]).sum()))
}

/// A row-major `f64` matrix as WGSL's column-major `mat4x4<f32>`.
pub(crate) fn to_gpu(m: &[[f64; 4]; 4]) -> [[f32; 4]; 4] {
    std::array::from_fn(|col| std::array::from_fn(|row| m[row][col] as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(m: &[[f64; 4]; 4], p: [f64; 3]) -> [f64; 4] {
        std::array::from_fn(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3])
    }

    #[test]
    fn orthographic_matches_the_view_projection() {
        let frame = Frame::from_direction([0.3, 0.4, 0.8]);
        let view = OrthoView {
            frame,
            center: [0.1, -0.2],
            half_size: 1.5,
            near: 2.0,
            far: -1.0,
            size: 64,
        };
        let cam = Camera::from_view(&view);
        let m = cam.world_to_clip(64, 64);
        let p = [0.2, 0.7, -0.3];
        let px = view.project(p);
        let clip = apply(&m, p);
        // NDC x, y -> pixels.
        let x = (clip[0] + 1.0) * 32.0;
        let y = (1.0 - clip[1]) * 32.0;
        assert!((x - px[0]).abs() < 1e-9 && (y - px[1]).abs() < 1e-9);
        let h = cam.ortho_height(clip[2]).unwrap();
        assert!((h - px[2]).abs() < 1e-9);
    }

    #[test]
    fn perspective_depth_spans_near_to_far() {
        let cam = Camera::perspective([0.0, 0.0, 5.0], [0.0; 3], 0.8, 1.0, 10.0);
        let m = cam.world_to_clip(32, 16);
        let near = apply(&m, [0.0, 0.0, 4.0]);
        let far = apply(&m, [0.0, 0.0, -5.0]);
        assert!((near[2] / near[3]).abs() < 1e-12);
        assert!((far[2] / far[3] - 1.0).abs() < 1e-12);
        // A point on the top edge of the field of view.
        let top = apply(&m, [0.0, (0.4f64).tan() * 5.0, 0.0]);
        assert!((top[1] / top[3] - 1.0).abs() < 1e-12);
        assert_eq!(cam.view_direction([0.0; 3]), [0.0, 0.0, 1.0]);
    }
}
