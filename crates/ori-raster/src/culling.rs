//! Back-face culling, and the test that lets most back faces be skipped before their corners
//! are read.
//!
//! A culled triangle is skipped where its screen area, computed from its projected corners,
//! has the sign of a back face ([`crate::faces_away`]). On a closed mesh about half the
//! triangles face away from any view, and reading their corners costs as much as drawing
//! the rest. [`InView::surely_away`] decides from the view direction and one small record
//! per triangle, read in order, that the computed area is positive whatever the rounding;
//! where it cannot tell (a triangle seen almost edge-on, a sliver, a degenerate one), the
//! area decides as before. So it changes no pixel.
//!
//! # The bound
//! The exact area of the projected triangle is `-scale^2 (g . d)`, `g = (b - a) x (c - a)`.
//! A projection computing `(u . p - cx + half) * scale` (or `(cy - v . p) * scale`) moves each
//! coordinate by at most `delta = 8 eps scale (R + C)` (R: the mesh's radius, C: the sum of
//! the window's offsets, eps = `f64::EPSILON`), so the computed area is within
//! `16 delta (L + delta) + 16 eps L^2` of the exact one (L: the longest edge on screen), and a
//! computed `g` within `10 eps e^2` of the exact one (e: the longest edge in the world). The
//! area is therefore positive when `-(g . d) > eps (128 (R + C) e + 26 e^2)` and `e` exceeds
//! `8 eps (R + C)`. [`Facing::margin`] is eight times the first over `|g|` with C = 0, plus
//! what the `f32` cosine can be off by; each view scales it by `(R + C) / R`. A triangle that
//! passes has `e > 1024 eps (R + C)`, so the second condition holds too.

use crate::{OrthoView, cross, dot};

/// Which triangles are culled from behind, with each triangle's [`Facing`].
#[derive(Clone, Debug)]
pub struct Culling {
    single_sided: Vec<bool>,
    facing: Vec<Facing>,
    /// The largest distance of a vertex from the origin.
    radius: f64,
}

/// A triangle's unit normal and the margin by which its cosine with a view direction must
/// be negative for it to surely face away: `f32`, so that the array read once per triangle
/// and view stays small.
#[derive(Clone, Copy, Debug)]
struct Facing {
    normal: [f32; 3],
    margin: f32,
}

impl Culling {
    /// `single_sided[t]`: whether triangle `t` is culled from behind (missing ones are not).
    pub fn new(positions: &[[f32; 3]], triangles: &[[u32; 3]], single_sided: Vec<bool>) -> Self {
        let radius = positions
            .iter()
            .map(|p| p.map(f64::from))
            .map(|p| dot(p, p).sqrt())
            .fold(0.0, f64::max);
        let facing = triangles
            .iter()
            .map(|t| {
                let corners = t.map(|i| positions.get(i as usize).copied());
                match corners {
                    [Some(a), Some(b), Some(c)] => Facing::of([a, b, c], radius),
                    _ => Facing::UNKNOWN,
                }
            })
            .collect();
        Culling {
            single_sided,
            facing,
            radius,
        }
    }

    /// Whether triangle `t` is culled from behind.
    #[inline]
    pub fn single_sided(&self, t: usize) -> bool {
        self.single_sided.get(t).copied().unwrap_or(false)
    }

    /// The test of one view.
    pub fn in_view(&self, view: &OrthoView) -> InView<'_> {
        let offsets = view.center[0].abs() + view.center[1].abs() + 2.0 * view.half_size;
        let scale = ((self.radius + offsets) / self.radius * (1.0 + 1e-6)) as f32;
        InView {
            culling: self,
            d: view.frame.d.map(|x| x as f32),
            // A NaN (a mesh of no extent, or not finite) proves nothing.
            scale: if scale >= 1.0 { scale } else { f32::INFINITY },
        }
    }
}

impl Facing {
    /// Never surely away.
    const UNKNOWN: Facing = Facing {
        normal: [0.0; 3],
        margin: f32::INFINITY,
    };

    fn of(corners: [[f32; 3]; 3], radius: f64) -> Facing {
        let [a, b, c] = corners.map(|p| p.map(f64::from));
        let sub = |p: [f64; 3], q: [f64; 3]| [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
        let (ab, ac, bc) = (sub(a, b), sub(a, c), sub(b, c));
        let g = cross(ab, ac);
        let edge = [ab, ac, bc]
            .map(|v| dot(v, v).sqrt())
            .into_iter()
            .fold(0.0, f64::max);
        let length = dot(g, g).sqrt();
        let bound = f64::EPSILON * (1024.0 * radius * edge + 256.0 * edge * edge) / length;
        // The f32 cosine (normal, direction and products rounded) is within 4e-7 of the
        // exact one.
        let margin = (bound * (1.0 + 1e-6) + 1e-6) as f32;
        if length > 0.0 && margin.is_finite() {
            Facing {
                normal: g.map(|x| (x / length) as f32),
                margin,
            }
        } else {
            Facing::UNKNOWN
        }
    }
}

/// [`Culling`] in one view.
pub struct InView<'a> {
    culling: &'a Culling,
    d: [f32; 3],
    scale: f32,
}

impl InView<'_> {
    /// Whether triangle `t` is culled and surely faces away: the area of its projected
    /// corners is positive, whatever the rounding.
    #[inline]
    pub fn surely_away(&self, t: usize) -> bool {
        let Some(f) = self.culling.facing.get(t) else {
            return false;
        };
        let n = f.normal;
        let cos = n[0] * self.d[0] + n[1] * self.d[1] + n[2] * self.d[2];
        -cos > f.margin * self.scale && self.culling.single_sided(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Frame, edge, faces_away};

    /// A seeded generator of `f64` in [0, 1).
    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn a_triangle_surely_away_has_a_positive_screen_area_however_it_is_projected() {
        let mut next = uniform(0x5851_f42d_4c95_7f2d);
        let unit = |next: &mut dyn FnMut() -> f64| {
            let v = [0; 3].map(|_| next() * 2.0 - 1.0);
            crate::normalize(v)
        };
        let directions: Vec<[f64; 3]> = (0..24).map(|_| unit(&mut next)).collect();
        for offset in [0.0f32, 3.0, 1e4] {
            let (mut p, mut t) = (Vec::new(), Vec::new());
            let mut push = |corners: [[f64; 3]; 3]| {
                let base = p.len() as u32;
                p.extend(corners.map(|c| c.map(|x| x as f32 + offset)));
                t.push([base, base + 1, base + 2]);
            };
            for k in 0..6000 {
                let centre = [0; 3].map(|_| next() * 2.0 - 1.0);
                let size = 10f64.powf(-1.0 - 3.0 * next());
                let (e1, e2) = (unit(&mut next), unit(&mut next));
                let corner = |a: f64, b: f64| {
                    std::array::from_fn(|i| centre[i] + size * (a * e1[i] + b * e2[i]))
                };
                match k % 3 {
                    // Any small triangle.
                    0 => push([corner(0.0, 0.0), corner(1.0, 0.0), corner(0.0, 1.0)]),
                    // Seen almost edge-on from one of the directions: its plane holds the
                    // direction, tilted by 1e-3 to 1e-15.
                    1 => {
                        let d = directions[k % directions.len()];
                        let side = crate::normalize(cross(d, e1));
                        let tilt = 10f64.powf(-3.0 - 12.0 * next());
                        let along: [f64; 3] = std::array::from_fn(|i| d[i] + tilt * side[i]);
                        let q = |a: f64, b: f64| -> [f64; 3] {
                            std::array::from_fn(|i| centre[i] + size * (a * e1[i] + b * along[i]))
                        };
                        let sign = if next() < 0.5 { 1.0 } else { -1.0 };
                        push([q(0.0, 0.0), q(1.0, 0.0), q(0.0, sign)]);
                    }
                    // A sliver: the third corner 1e-4 to 1e-12 off the line of the others.
                    _ => {
                        let off = 10f64.powf(-4.0 - 8.0 * next());
                        push([corner(0.0, 0.0), corner(1.0, 0.0), corner(0.5, off)]);
                    }
                }
            }
            let culling = Culling::new(&p, &t, vec![true; t.len()]);
            let mut skipped = 0;
            for &d in &directions {
                let view = OrthoView::fit(Frame::from_direction(d), &p, 512, 0).unwrap();
                let away = culling.in_view(&view);
                // The rasterizer's projection, and the coverage test's (other operations in
                // another order).
                let screen = |q: [f32; 3]| {
                    let q = q.map(f64::from);
                    let raster = view.project(q);
                    let scale = f64::from(view.size) / (2.0 * view.half_size);
                    let x = (dot(view.frame.u, q) - view.center[0] + view.half_size) * scale;
                    let y = (view.center[1] + view.half_size - dot(view.frame.v, q)) * scale;
                    [raster, [x, y, 0.0]]
                };
                for (k, tri) in t.iter().enumerate() {
                    if !away.surely_away(k) {
                        continue;
                    }
                    skipped += 1;
                    let [a, b, c] = tri.map(|i| screen(p[i as usize]));
                    for form in 0..2 {
                        let area = edge(a[form], b[form], c[form]);
                        assert!(
                            area.is_finite() && faces_away(area),
                            "triangle {k} from {d:?}, offset {offset}: area {area}"
                        );
                    }
                }
            }
            // Half of the triangles of each kind face away from each direction; most of those
            // seen almost edge-on, and the thinnest slivers, cannot be told.
            let tests = t.len() * directions.len();
            assert!(skipped * 4 > tests, "{skipped} of {tests} skipped");
        }
    }

    #[test]
    fn degenerate_and_unknown_triangles_are_never_surely_away() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let t = [[0, 1, 2], [0, 1, 3], [0, 1, 9]];
        let culling = Culling::new(&p, &t, vec![true, false, true]);
        let view = OrthoView::fit(Frame::from_direction([0.0, 0.0, -1.0]), &p, 8, 0).unwrap();
        let away = culling.in_view(&view);
        // Collinear; faces away but double-sided; a corner out of range; no such triangle.
        assert!((0..4).all(|k| !away.surely_away(k)));
        // Single-sided, the same triangle faces away from -Z.
        let culling = Culling::new(&p, &t, vec![true, true, true]);
        assert!(culling.in_view(&view).surely_away(1));
    }
}
