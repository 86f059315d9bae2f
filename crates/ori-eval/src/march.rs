//! The runtime rendering rule for one impostor seen from one evaluation view: the view ray of
//! a pixel, carried into the impostor's texture space, searched against the heightfield.
//! The runtime shader implements the same steps; they are written so that it can.
//!
//! Texture space (all of it `f32`, as in a shader): `x` and `y` in texels (the map's pixel
//! coordinates: texel `(i, j)` spans `[i, i + 1) x [j, j + 1)`, row 0 at the top), `z` in
//! depth codes (0 at the near plane, 254 at the far side of the object). For an evaluation
//! view with direction `w` (towards the viewer) and an impostor with frame `(u, v, d)`, a
//! square window of `N` texels and depth range `[far, near]`:
//!
//! 1. **Ray.** Pixel centre `(x + 0.5, y + 0.5)`, seen along `-w`, is the line
//!    `(x, y) = o + z * dir`, `o` where it crosses the near plane and
//!    `dir = (-(u . w), v . w) * texels_per_unit / ((d . w) * codes_per_unit)` the texel
//!    displacement per depth code. Only impostors facing the viewer (`d . w > 0`) are drawn,
//!    so `z` grows along the ray.
//! 2. **Extent.** The searched segment `[z_in, z_out]` is the part of the ray inside the
//!    occupied relief volume: depth codes `[z0, z1]` (the least and greatest stored code,
//!    widened by one code each way within `[0, 254]`) and the texel box of the non-empty
//!    texels grown by one texel on each side (so a ray entering from a side starts over an
//!    empty texel), within the window `0 <= x, y <= N`; the quad is extended for skewed
//!    views (every pixel whose ray meets the volume gets a fragment shader run). That part
//!    is then narrowed to the *columns* the ray crosses ([`Columns::narrow`]): the map is cut
//!    into cells of 8 x 8 texels, and under a heightfield everything below a cell's least
//!    code (its top) is solid, so outside the columns the ray cannot be below the surface.
//!    The segment runs from the first column entry, moved back by one texel of travel, to
//!    the last column exit. No such part: no fragment. The 16 steps are thus spent where the
//!    surface can be: at a grazing angle a step spans a few texels instead of a tenth of the
//!    map, so thin parts (fingers, ears, claws) are no longer stepped over. On the armadillo
//!    (best:6, wall threshold 0.125) the occupied volume took the average coverage error from
//!    0.271 % to 0.246 % and the columns to 0.150 % (impostors per view 5.24 -> 3.21). The
//!    volume's box is per map ([`occupied_volume`]) and carried by the package; the column
//!    grid a runtime computes from the depth map when it loads it.
//! 3. **Lookup.** Nearest texel: the sample at `(x, y)` reads the depth code of texel
//!    `(floor x, floor y)`, 255 (empty) outside `[0, N)`. Empty is deeper than any ray depth,
//!    so a ray always passes over an empty texel.
//! 4. **Linear search.** `L` samples (`L = 16`) at `z_k = z_in + ((z_out - z_in) / L) * k`
//!    (in that order, in `f32`), `k = 1..=L`; the first with `z_k >= code(z_k)` is below the
//!    surface. None: no fragment. The bracket is `(lo, hi) = (z_{k-1}, z_k)`, with `z_0 = z_in`.
//! 5. **Binary search.** `B` times (`B = 7`): `mid = (lo + hi) / 2`; `hi = mid` if
//!    `mid >= code(mid)`, else `lo = mid`.
//! 6. **Vertical wall.** `a = code(lo)` and `b = code(hi)` are the stored depths of the two
//!    samples that bracket the hit. If `|a - b| > threshold * 254`, or exactly one of them is
//!    empty (an empty texel has no depth: the step to it is the projection's silhouette, of
//!    unbounded height), the ray ran into a vertical wall made by the projection and the
//!    fragment is discarded.
//! 7. **Fragment.** Otherwise the fragment is texel `hi` (its normal and albedo), at relief
//!    depth `hi`.
//!
//! Changing any step of this rule changes measured results and pictures: bump the select
//! stage's version (`ori-pipeline`'s `SelectStage`) so cached selections are redone, and
//! `ori_report::PICTURES_VERSION` so report pictures are redrawn; keep `shaders/ori.wgsl` in
//! step (the parity test in `ori-render` holds them together).
//!
//! Why empty counts as unbounded rather than as code 255 (just past the far plane): with 255,
//! silhouette texels in the deepest `threshold` of the range keep their extruded "shadow
//! volume", which on the Stanford scans more than doubles the pixels the ORI adds outside the
//! mesh for a few percent fewer missed pixels (see the crate documentation).

use ori_raster::OrthoView;
use ori_relief::{EMPTY_DEPTH, MAX_DEPTH, ReliefMap};

use crate::lanes::{LaneMask, Lanes};

/// What the ray through one pixel found in one impostor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trace {
    /// The ray never went below the surface inside the relief volume.
    Miss,
    /// The search ended on a vertical wall made by the projection; the fragment is discarded.
    Wall,
    /// A fragment at relief depth `z` (depth codes) from texel `texel` (row-major index).
    Hit { z: f32, texel: u32 },
}

/// Search parameters of the runtime rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchParams {
    /// Linear-search steps `L` (>= 1).
    pub linear_steps: u32,
    /// Binary-search steps `B` (<= 32).
    pub binary_steps: u32,
    /// Largest depth step between the two bracketing samples that is still a surface, as a
    /// fraction of the impostor's depth range.
    pub wall_threshold: f32,
}

impl MarchParams {
    /// The wall threshold in depth codes.
    pub fn threshold_codes(&self) -> f32 {
        self.wall_threshold * f32::from(MAX_DEPTH)
    }
}

/// One impostor seen from one evaluation view: the affine map from evaluation pixels to rays
/// in the impostor's texture space. Built by [`ImpostorRays::new`], it traces any pixel.
#[derive(Clone, Debug)]
pub struct ImpostorRays {
    /// Texture-space point where the ray of pixel (0, 0) (its corner, not its centre) crosses
    /// depth code 0, and its change per pixel along x and y.
    o0: [f32; 2],
    ex: [f32; 2],
    ey: [f32; 2],
    /// Texel displacement per depth code along the ray.
    dir: [f32; 2],
    n: usize,
    n_f: f32,
    /// `N - 1`: the largest texel coordinate.
    last: f32,
    params: MarchParams,
    /// The relief volume actually occupied: texel-space box `[x0, x1] x [y0, y1]` and depth
    /// codes `[z0, z1]` of the non-empty texels.
    bounds: [f32; 6],
    /// The map's column grid (rule 2's per-ray narrowing) and the rays' direction for it.
    columns: Columns,
    column_dir: ColumnDir,
    threshold_codes: f32,
    /// Whether the binary search always ends on a bracket shorter than a texel, so that its
    /// two samples are the same or neighbouring texels (used by [`ImpostorRays::covers`]).
    adjacent_end: bool,
    /// Evaluation-view depth (fraction of the view's depth range) of the ray at code 0, per
    /// pixel (affine: `e00 + px * epx + py * epy`), and its change per code.
    e00: f64,
    epx: f64,
    epy: f64,
    de: f64,
    /// The SIMD code [`ImpostorRays::covers_many`] and [`ImpostorRays::trace_many`] run.
    simd: Simd,
}

/// Which SIMD code [`ImpostorRays::covers_many`] and [`ImpostorRays::trace_many`] run. Every
/// choice gives the same answer (each lane does the scalar rule's IEEE operations); they differ
/// only in speed. A choice the processor lacks runs as [`Simd::Four`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Simd {
    /// The widest the processor has (the default).
    #[default]
    Widest,
    /// Eight lanes compiled for AVX-512 (AVX operations, twice the registers).
    Avx512,
    /// Eight lanes in AVX2 registers.
    Avx2,
    /// Four lanes: SSE registers on x86-64, plain arrays elsewhere.
    Four,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl ImpostorRays {
    /// The rays of `eval`'s pixels in `map`'s texture space; `None` when the impostor does not
    /// face the viewer (`d . w <= 0`) or the geometry is degenerate.
    pub fn new(
        eval: &OrthoView,
        map: &ReliefMap,
        occupancy: &Occupancy,
        params: MarchParams,
    ) -> Option<ImpostorRays> {
        let (ue, ve, w) = (eval.frame.u, eval.frame.v, eval.frame.d);
        let m = &map.view;
        let (u, v, d) = (m.frame.u, m.frame.v, m.frame.d);
        let facing = dot(d, w);
        let k = f64::from(m.size) / (2.0 * m.half_size); // texels per world unit
        let depth_scale = f64::from(MAX_DEPTH) / (m.near - m.far); // codes per world unit
        let zr = facing * depth_scale; // codes per world unit along the ray
        if !(facing > 0.0 && zr > 0.0 && zr.is_finite() && k.is_finite() && m.size > 0) {
            return None;
        }
        let dir = [-dot(u, w) * k / zr, dot(v, w) * k / zr];
        // Pixel coordinates (px, py) -> point Q on the evaluation plane through the origin
        // (w . Q = 0): Q = q00 + px * gx + py * gy.
        let pixel = 2.0 * eval.half_size / f64::from(eval.size);
        let q00: [f64; 3] = std::array::from_fn(|i| {
            ue[i] * (eval.center[0] - eval.half_size) + ve[i] * (eval.center[1] + eval.half_size)
        });
        let gx = ue.map(|c| c * pixel);
        let gy = ve.map(|c| -c * pixel);
        // Texture coordinates and depth code of a point, and of a vector (the linear part).
        let point = |q: [f64; 3]| {
            [
                (dot(u, q) - m.center[0] + m.half_size) * k,
                (m.center[1] + m.half_size - dot(v, q)) * k,
                (m.near - dot(d, q)) * depth_scale,
            ]
        };
        let vector = |g: [f64; 3]| [dot(u, g) * k, -dot(v, g) * k, -dot(d, g) * depth_scale];
        // Slide along the ray to depth code 0.
        let crossing = |t: [f64; 3]| [t[0] - t[2] * dir[0], t[1] - t[2] * dir[1]];
        let (t00, tx, ty) = (point(q00), vector(gx), vector(gy));
        let eval_range = eval.near - eval.far;
        // The final bracket spans at most N / (L 2^B) texels per axis; below 3/4 its two
        // samples are the same or neighbouring texels whatever the rounding.
        let final_bracket = f64::from(m.size)
            / (f64::from(params.linear_steps) * (1u64 << params.binary_steps.min(32)) as f64);
        let out = ImpostorRays {
            o0: crossing(t00).map(|c| c as f32),
            ex: crossing(tx).map(|c| c as f32),
            ey: crossing(ty).map(|c| c as f32),
            dir: dir.map(|c| c as f32),
            n: m.size as usize,
            n_f: m.size as f32,
            last: (m.size - 1) as f32,
            params,
            bounds: occupancy.volume,
            columns: occupancy.columns.clone(),
            column_dir: ColumnDir::new(dir[0] as f32, dir[1] as f32),
            threshold_codes: params.threshold_codes(),
            adjacent_end: final_bracket < 0.75,
            e00: (eval.near - t00[2] / zr) / eval_range,
            epx: -tx[2] / zr / eval_range,
            epy: -ty[2] / zr / eval_range,
            de: 1.0 / (zr * eval_range),
            simd: Simd::Widest,
        };
        let finite = out.o0.iter().chain(&out.ex).chain(&out.ey).chain(&out.dir);
        finite.into_iter().all(|c| c.is_finite()).then_some(out)
    }

    /// Row-major index of the texel under texture-space point `(x, y)`, if inside the map.
    #[inline]
    fn texel(&self, x: f32, y: f32) -> Option<usize> {
        // In range, truncation is floor; `as i32` is the cheapest conversion and the map edge
        // (at most 8192) keeps the index far from overflow.
        (x >= 0.0 && y >= 0.0 && x < self.n_f && y < self.n_f).then(|| {
            (y as i32 as usize)
                .wrapping_mul(self.n)
                .wrapping_add(x as i32 as usize)
        })
    }

    /// Column and row of the texel under `(x, y)`, if inside the map.
    #[inline]
    fn texel_xy(&self, x: f32, y: f32) -> Option<(usize, usize)> {
        (x >= 0.0 && y >= 0.0 && x < self.n_f && y < self.n_f)
            .then_some((x as i32 as usize, y as i32 as usize))
    }

    /// Rule 3: the depth code under `(x, y)`, 255 outside the map. Branch-free: the hot
    /// loops call this for every sample, and which side of the window a sample falls on is
    /// not predictable.
    #[inline]
    fn code(&self, depth: &[u8], x: f32, y: f32) -> u8 {
        let inside = (x >= 0.0) & (y >= 0.0) & (x < self.n_f) & (y < self.n_f);
        // Clamped into the map (NaN clamps to 0), so the truncations below are in range;
        // inside the map they are the floor.
        let (xc, yc) = (x.max(0.0).min(self.last), y.max(0.0).min(self.last));
        // SAFETY: `xc` and `yc` are finite and in `[0, N - 1]`, which fits `u32`.
        let (xi, yi) = unsafe { (xc.to_int_unchecked::<u32>(), yc.to_int_unchecked::<u32>()) };
        let code = depth[(yi * self.n as u32 + xi) as usize];
        if inside { code } else { EMPTY_DEPTH }
    }

    /// Rules 1, 2 and 4: the ray's near-plane crossing `(ox, oy)` and the linear search's
    /// bracket `(lo, hi)`, or `None` when the ray never goes below the surface.
    #[inline]
    fn linear(&self, depth: &[u8], x: u32, y: u32) -> Option<Bracket> {
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        let ox = self.o0[0] + px * self.ex[0] + py * self.ey[0];
        let oy = self.o0[1] + px * self.ex[1] + py * self.ey[1];
        let [dx, dy] = self.dir;
        let b = self.bounds;
        let mut span = (b[4], b[5]);
        if !(clip(ox, dx, b[0], b[1], &mut span) && clip(oy, dy, b[2], b[3], &mut span)) {
            return None;
        }
        let (z_in, z_out) = self.columns.narrow(ox, oy, &self.column_dir, span)?;
        let step = (z_out - z_in) / self.params.linear_steps as f32;
        let mut lo = z_in;
        for k in 1..=self.params.linear_steps {
            let z = z_in + step * k as f32;
            if z >= f32::from(self.code(depth, ox + z * dx, oy + z * dy)) {
                return Some(Bracket { ox, oy, lo, hi: z });
            }
            lo = z;
        }
        None
    }

    /// Rules 5 to 7 on a linear bracket.
    #[inline]
    fn refine(&self, depth: &[u8], bracket: Bracket) -> Trace {
        let Bracket {
            ox,
            oy,
            mut lo,
            mut hi,
        } = bracket;
        let [dx, dy] = self.dir;
        let at = |z: f32| self.code(depth, ox + z * dx, oy + z * dy);
        for _ in 0..self.params.binary_steps {
            let mid = 0.5 * (lo + hi);
            let below = mid >= f32::from(at(mid));
            (lo, hi) = (select(below, lo, mid), select(below, mid, hi));
        }
        let texel = self
            .texel(ox + hi * dx, oy + hi * dy)
            .expect("a sample below the surface is inside the map");
        if is_wall(at(lo), depth[texel], self.threshold_codes) {
            Trace::Wall
        } else {
            Trace::Hit {
                z: hi,
                texel: texel as u32,
            }
        }
    }

    /// Trace the ray of pixel `(x, y)` through `depth` (the depth codes of the map given to
    /// [`ImpostorRays::new`]).
    #[inline]
    pub fn trace(&self, depth: &[u8], x: u32, y: u32) -> Trace {
        match self.linear(depth, x, y) {
            Some(bracket) => self.refine(depth, bracket),
            None => Trace::Miss,
        }
    }

    /// Whether [`ImpostorRays::trace`] gives a [`Trace::Hit`] at pixel `(x, y)`, usually
    /// without the binary search: the final samples lie between the linear bracket's ends
    /// (positions are monotonic along the ray), so when those ends are in one texel, or in a
    /// block of texels free of walls (`walls`, built for this map and threshold) while the
    /// final bracket is shorter than a texel, the search can only end on a hit.
    #[inline]
    pub fn covers(&self, depth: &[u8], walls: &WallMap, x: u32, y: u32) -> bool {
        match self.linear(depth, x, y).map(|b| self.quick(walls, b)) {
            None => false,
            Some(Ok(covered)) => covered,
            Some(Err(bracket)) => matches!(self.refine(depth, bracket), Trace::Hit { .. }),
        }
    }

    /// These rays with [`ImpostorRays::covers_many`] and [`ImpostorRays::trace_many`] running
    /// `simd` (the tests hold every choice to the scalar rule).
    pub fn with_simd(mut self, simd: Simd) -> ImpostorRays {
        self.simd = simd;
        self
    }

    /// [`ImpostorRays::covers`] for many pixels at once: `f(i, covered)` once for each
    /// `(i, x, y)` of `pixels`, not in order (rays the binary search decides are reported a
    /// few pixels late). Rays are searched several at a time in SIMD lanes
    /// (eight in AVX registers where the processor has AVX2, else four in SSE registers), and
    /// the binary searches left to do as well, so that their dependent lookups overlap. Each
    /// lane performs exactly the operations of the scalar rule, so the answer does not depend
    /// on the processor. The lane code is generic and `#[inline(always)]` down to the lane
    /// operations, so that each width is compiled whole inside its `target_feature` function.
    pub fn covers_many(
        &self,
        depth: &[u8],
        walls: &WallMap,
        pixels: &[(usize, u32, u32)],
        mut f: impl FnMut(usize, bool),
    ) {
        self.search_many(depth, Some(walls), pixels, |i, found| {
            f(
                i,
                matches!(found, Found::Covered | Found::Traced(Trace::Hit { .. })),
            );
        });
    }

    /// [`ImpostorRays::trace`] for many pixels at once: `f(i, trace)` once for each
    /// `(i, x, y)` of `pixels`, not in order, searched in SIMD lanes as
    /// [`ImpostorRays::covers_many`] does (with no shortcut: every hit's fragment is located),
    /// with the same answer as the scalar rule.
    pub fn trace_many(
        &self,
        depth: &[u8],
        pixels: &[(usize, u32, u32)],
        mut f: impl FnMut(usize, Trace),
    ) {
        self.search_many(depth, None, pixels, |i, found| match found {
            Found::Traced(trace) => f(i, trace),
            Found::Covered => unreachable!("the shortcuts need a wall map"),
        });
    }

    /// The lockstep search behind [`ImpostorRays::covers_many`] (with `walls`: its shortcuts)
    /// and [`ImpostorRays::trace_many`] (without), on the widest lanes `self.simd` allows.
    fn search_many(
        &self,
        depth: &[u8],
        walls: Option<&WallMap>,
        pixels: &[(usize, u32, u32)],
        f: impl FnMut(usize, Found),
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let widest = self.simd == Simd::Widest;
            if (widest || self.simd == Simd::Avx512) && has!("avx512f") && has!("avx512vl") {
                // SAFETY: the features were detected just above.
                unsafe { self.search_many_avx512(depth, walls, pixels, f) };
                return;
            }
            if (widest || self.simd == Simd::Avx2) && has!("avx2") {
                // SAFETY: AVX2 was detected just above.
                unsafe { self.search_many_avx2(depth, walls, pixels, f) };
                return;
            }
        }
        self.search_many_lanes::<crate::lanes::F4, 4>(depth, walls, pixels, f)
    }

    /// [`ImpostorRays::search_many`] on eight lanes, compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn search_many_avx2(
        &self,
        depth: &[u8],
        walls: Option<&WallMap>,
        pixels: &[(usize, u32, u32)],
        f: impl FnMut(usize, Found),
    ) {
        self.search_many_lanes::<crate::lanes::F8, 8>(depth, walls, pixels, f)
    }

    /// [`ImpostorRays::search_many`] on eight lanes, compiled for AVX-512 (the same AVX
    /// operations, with twice the registers, so fewer values go through the stack).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn search_many_avx512(
        &self,
        depth: &[u8],
        walls: Option<&WallMap>,
        pixels: &[(usize, u32, u32)],
        f: impl FnMut(usize, Found),
    ) {
        self.search_many_lanes::<crate::lanes::F8, 8>(depth, walls, pixels, f)
    }

    /// [`ImpostorRays::search_many`] on `W` lanes of `V`.
    #[inline(always)]
    fn search_many_lanes<V: Lanes<W>, const W: usize>(
        &self,
        depth: &[u8],
        walls: Option<&WallMap>,
        pixels: &[(usize, u32, u32)],
        mut f: impl FnMut(usize, Found),
    ) {
        // Brackets the binary search must decide, refined `W` at a time (at most `2 W - 1`
        // wait).
        let mut pending = [(0usize, Bracket::default()); 16];
        let mut count = 0;
        for chunk in pixels.chunks(W) {
            let lanes = self.linear_lanes::<V, W>(depth, walls, chunk);
            for (&(i, _, _), lane) in chunk.iter().zip(lanes) {
                match lane {
                    Lane::Miss => f(i, Found::Traced(Trace::Miss)),
                    Lane::Covered => f(i, Found::Covered),
                    Lane::Refine(b) => {
                        pending[count] = (i, b);
                        count += 1;
                    }
                }
            }
            if count >= W {
                self.refine_lanes::<V, W>(depth, &pending[..W], &mut f);
                pending.copy_within(W..count, 0);
                count -= W;
            }
        }
        if count > 0 {
            self.refine_lanes::<V, W>(depth, &pending[..count], &mut f);
        }
    }

    /// Rule 3 on `W` lanes.
    #[inline(always)]
    fn codes_lanes<V: Lanes<W>, const W: usize>(&self, depth: &[u8], x: V, y: V) -> V {
        let (inside, xi, yi) = self.texels_lanes::<V, W>(x, y);
        let stride = self.n as u32;
        let mut codes = [EMPTY; W];
        for (l, code) in codes.iter_mut().enumerate() {
            let texel = f32::from(depth[(yi[l] as u32 * stride + xi[l] as u32) as usize]);
            *code = if inside[l] { texel } else { EMPTY };
        }
        V::from_array(codes)
    }

    /// [`ImpostorRays::linear`] for up to `W` pixels in lockstep (rules 1 to 4) and, given
    /// `walls`, the shortcuts of [`ImpostorRays::quick`]; the same operations lane by lane.
    #[inline(always)]
    fn linear_lanes<V: Lanes<W>, const W: usize>(
        &self,
        depth: &[u8],
        walls: Option<&WallMap>,
        pixels: &[(usize, u32, u32)],
    ) -> [Lane; W] {
        let centre = |l: usize, c: fn(&(usize, u32, u32)) -> u32| {
            pixels.get(l).map_or(0.5, |p| c(p) as f32 + 0.5)
        };
        let px = V::from_array(std::array::from_fn(|l| centre(l, |p| p.1)));
        let py = V::from_array(std::array::from_fn(|l| centre(l, |p| p.2)));
        // (Lane operations stay out of closures: a closure is not compiled with the
        // features of the function it is inlined into, which would leave AVX calls in it.)
        let [o0x, o0y] = self.o0.map(V::splat);
        let [exx, exy] = self.ex.map(V::splat);
        let [eyx, eyy] = self.ey.map(V::splat);
        let ox = o0x.add(px.mul(exx)).add(py.mul(eyx));
        let oy = o0y.add(px.mul(exy)).add(py.mul(eyy));
        // Rule 2, as `clip` does it: the direction is the same for every lane.
        let bd = self.bounds;
        let mut z_in = V::splat(bd[4]);
        let mut z_out = V::splat(bd[5]);
        let mut open = V::Mask::from_array(std::array::from_fn(|l| l < pixels.len()));
        for (o, d, lo, hi) in [
            (ox, self.dir[0], bd[0], bd[1]),
            (oy, self.dir[1], bd[2], bd[3]),
        ] {
            let (lo, hi) = (V::splat(lo), V::splat(hi));
            if d == 0.0 {
                open = open.and(o.ge(lo)).and(o.le(hi));
            } else {
                let d = V::splat(d);
                let (a, b) = (lo.sub(o).div(d), hi.sub(o).div(d));
                z_in = z_in.max(a.min(b));
                z_out = z_out.min(a.max(b));
            }
        }
        // Rule 2's narrowing to the columns.
        let spans = self.columns.narrow_lanes::<V, W>(
            (ox, oy),
            &self.column_dir,
            (z_in, z_out),
            open.and(z_in.lt(z_out)).to_array(),
        );
        let open = V::Mask::from_array(spans.map(|s| s.is_some()));
        let z_in = V::from_array(spans.map(|s| s.map_or(0.0, |s| s.0)));
        let z_out = V::from_array(spans.map(|s| s.map_or(0.0, |s| s.1)));
        let mut searching = open.and(z_in.lt(z_out));
        let step = z_out
            .sub(z_in)
            .div(V::splat(self.params.linear_steps as f32));
        let [dx, dy] = self.dir.map(V::splat);
        let mut lo = z_in;
        let mut hi = V::splat(f32::NAN);
        for k in 1..=self.params.linear_steps {
            if !searching.any() {
                break;
            }
            let z = z_in.add(step.mul(V::splat(k as f32)));
            let codes = self.codes_lanes::<V, W>(depth, ox.add(z.mul(dx)), oy.add(z.mul(dy)));
            let below = searching.and(z.ge(codes));
            hi = V::select(below, z, hi);
            searching = searching.and_not(below);
            lo = V::select(searching, z, lo);
        }
        let (oxs, oys, los, his) = (ox.to_array(), oy.to_array(), lo.to_array(), hi.to_array());
        let mut lanes: [Lane; W] = std::array::from_fn(|l| {
            if his[l].is_nan() {
                Lane::Miss
            } else {
                Lane::Refine(Bracket {
                    ox: oxs[l],
                    oy: oys[l],
                    lo: los[l],
                    hi: his[l],
                })
            }
        });
        // The shortcuts, which need the texels of both ends of the bracket.
        if let Some(walls) = walls {
            let (in_lo, xl, yl) = self.texels_lanes::<V, W>(ox.add(lo.mul(dx)), oy.add(lo.mul(dy)));
            let (in_hi, xh, yh) = self.texels_lanes::<V, W>(ox.add(hi.mul(dx)), oy.add(hi.mul(dy)));
            for (l, lane) in lanes.iter_mut().enumerate() {
                if !(matches!(lane, Lane::Refine(_)) && in_lo[l] && in_hi[l]) {
                    continue;
                }
                let (tl, th) = (
                    (xl[l] as usize, yl[l] as usize),
                    (xh[l] as usize, yh[l] as usize),
                );
                let ((x0, x1), (y0, y1)) = (minmax(tl.0, th.0), minmax(tl.1, th.1));
                if tl == th || (self.adjacent_end && !walls.any(x0, y0, x1, y1)) {
                    *lane = Lane::Covered;
                }
            }
        }
        lanes
    }

    /// Per lane: whether texture-space point `(x, y)` lies in the map, and its texel
    /// (clamped into the map).
    #[inline(always)]
    fn texels_lanes<V: Lanes<W>, const W: usize>(
        &self,
        x: V,
        y: V,
    ) -> ([bool; W], [i32; W], [i32; W]) {
        let (zero, n, last) = (V::splat(0.0), V::splat(self.n_f), V::splat(self.last));
        let inside = x.ge(zero).and(y.ge(zero)).and(x.lt(n)).and(y.lt(n));
        (
            inside.to_array(),
            x.max(zero).min(last).trunc(),
            y.max(zero).min(last).trunc(),
        )
    }

    /// [`ImpostorRays::refine`] on up to `W` brackets in lockstep.
    #[inline(always)]
    fn refine_lanes<V: Lanes<W>, const W: usize>(
        &self,
        depth: &[u8],
        batch: &[(usize, Bracket)],
        f: &mut impl FnMut(usize, Found),
    ) {
        let lane = |l: usize| batch[l.min(batch.len() - 1)].1;
        let ox = V::from_array(std::array::from_fn(|l| lane(l).ox));
        let oy = V::from_array(std::array::from_fn(|l| lane(l).oy));
        let mut lo = V::from_array(std::array::from_fn(|l| lane(l).lo));
        let mut hi = V::from_array(std::array::from_fn(|l| lane(l).hi));
        let (dx, dy) = (V::splat(self.dir[0]), V::splat(self.dir[1]));
        let half = V::splat(0.5);
        for _ in 0..self.params.binary_steps {
            let mid = half.mul(lo.add(hi));
            let below =
                mid.ge(self.codes_lanes::<V, W>(depth, ox.add(mid.mul(dx)), oy.add(mid.mul(dy))));
            hi = V::select(below, mid, hi);
            lo = V::select(below, lo, mid);
        }
        let (lo, hi) = (lo.to_array(), hi.to_array());
        let [dx, dy] = self.dir;
        for (l, &(i, b)) in batch.iter().enumerate() {
            let texel = self
                .texel(b.ox + hi[l] * dx, b.oy + hi[l] * dy)
                .expect("a sample below the surface is inside the map");
            let a = self.code(depth, b.ox + lo[l] * dx, b.oy + lo[l] * dy);
            let trace = if is_wall(a, depth[texel], self.threshold_codes) {
                Trace::Wall
            } else {
                Trace::Hit {
                    z: hi[l],
                    texel: texel as u32,
                }
            };
            f(i, Found::Traced(trace));
        }
    }

    /// The shortcuts of [`ImpostorRays::covers`] on a linear bracket: the answer, or the
    /// bracket when the binary search must decide.
    #[inline]
    fn quick(&self, walls: &WallMap, bracket: Bracket) -> Result<bool, Bracket> {
        let Bracket { ox, oy, lo, hi } = bracket;
        let [dx, dy] = self.dir;
        let ends = (
            self.texel_xy(ox + lo * dx, oy + lo * dy),
            self.texel_xy(ox + hi * dx, oy + hi * dy),
        );
        if let (Some(tl), Some(th)) = ends {
            if tl == th {
                return Ok(true);
            }
            if self.adjacent_end {
                let (x0, x1) = minmax(tl.0, th.0);
                let (y0, y1) = minmax(tl.1, th.1);
                if !walls.any(x0, y0, x1, y1) {
                    return Ok(true);
                }
            }
        }
        Err(bracket)
    }

    /// Evaluation-view depth (0 at the view's near plane, 1 at the object's far side) of the
    /// point at relief depth `z` on the ray of pixel `(x, y)`.
    pub fn eval_depth(&self, x: u32, y: u32, z: f32) -> f64 {
        let (px, py) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
        self.e00 + px * self.epx + py * self.epy + f64::from(z) * self.de
    }

    /// Pixel bounds `[x0, x1, y0, y1]` (half-open) outside which no ray meets the relief
    /// volume, on an evaluation image of edge `size`: for skipping work, conservative.
    pub fn footprint(&self, size: u32) -> [u32; 4] {
        // Pixel positions are affine in texture space, so the pixels whose segment meets the
        // window lie in the box of the window's corners mapped back at z = 0 and z = 254.
        let [ex0, ex1] = self.ex.map(f64::from);
        let [ey0, ey1] = self.ey.map(f64::from);
        let det = ex0 * ey1 - ex1 * ey0;
        if det.is_nan() || det.abs() <= 1e-12 {
            return [0, size, 0, size];
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let n = f64::from(self.n_f);
        for z in [0.0, f64::from(MAX_DEPTH)] {
            for (cx, cy) in [(0.0, 0.0), (n, 0.0), (0.0, n), (n, n)] {
                let rx = cx - f64::from(self.o0[0]) - z * f64::from(self.dir[0]);
                let ry = cy - f64::from(self.o0[1]) - z * f64::from(self.dir[1]);
                let px = (rx * ey1 - ry * ey0) / det;
                let py = (ex0 * ry - ex1 * rx) / det;
                lo = [lo[0].min(px), lo[1].min(py)];
                hi = [hi[0].max(px), hi[1].max(py)];
            }
        }
        // Pixel x's centre is at x + 0.5; two pixels of slack cover f32 rounding.
        let clamp = |v: f64| v.clamp(0.0, f64::from(size)) as u32;
        [
            clamp(lo[0] - 2.0),
            clamp(hi[0] + 2.0),
            clamp(lo[1] - 2.0),
            clamp(hi[1] + 2.0),
        ]
    }
}

/// What the lockstep search reports for one pixel.
enum Found {
    /// A fragment, not located: one of the shortcuts of [`ImpostorRays::covers`], taken only
    /// given a wall map.
    Covered,
    /// What [`ImpostorRays::trace`] gives.
    Traced(Trace),
}

/// What the lockstep search decided for one lane.
#[derive(Clone, Copy)]
enum Lane {
    Miss,
    /// A shortcut decided it is a hit (only given a wall map).
    Covered,
    /// The binary search and the wall test decide.
    Refine(Bracket),
}

/// A linear-search bracket on the ray that crosses the near plane at `(ox, oy)`.
#[derive(Clone, Copy, Default)]
struct Bracket {
    ox: f32,
    oy: f32,
    lo: f32,
    hi: f32,
}

/// `if c { a } else { b }` without a branch: the binary search's outcome is a coin toss for
/// the branch predictor, and a mispredicted branch costs more than the whole step.
#[inline]
fn select(c: bool, a: f32, b: f32) -> f32 {
    let m = 0u32.wrapping_sub(u32::from(c));
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// Rule 6: whether samples with depth codes `a` and `b` bracket a vertical wall.
#[inline]
fn is_wall(a: u8, b: u8, threshold_codes: f32) -> bool {
    (a == EMPTY_DEPTH) != (b == EMPTY_DEPTH)
        || (f32::from(a) - f32::from(b)).abs() > threshold_codes
}

fn minmax(a: usize, b: usize) -> (usize, usize) {
    if a < b { (a, b) } else { (b, a) }
}

/// Where a map has walls, for [`ImpostorRays::covers`]: one bit per texel `t`, set when a
/// pair (`t`, `t + e`), `e` in {(1, 0), (0, 1), (1, 1), (-1, 1)} (every pair of 8-neighbours
/// once), is a wall by rule 6. Rows of 64-bit words: 8 KiB for a 256 x 256 map, so queries
/// stay in the first-level cache.
#[derive(Clone, Debug)]
pub struct WallMap {
    words_per_row: usize,
    bits: Vec<u64>,
}

impl WallMap {
    /// The walls of a `size` x `size` depth map for a threshold in depth codes.
    pub fn new(depth: &[u8], size: u32, threshold_codes: f32) -> WallMap {
        let n = size as usize;
        let words_per_row = n.div_ceil(64);
        let wall = |x: usize, y: usize, x2: usize, y2: usize| {
            is_wall(depth[y * n + x], depth[y2 * n + x2], threshold_codes)
        };
        let mut bits = vec![0u64; words_per_row * n];
        for y in 0..n {
            for x in 0..n {
                let flagged = (x + 1 < n && wall(x, y, x + 1, y))
                    || (y + 1 < n && wall(x, y, x, y + 1))
                    || (x + 1 < n && y + 1 < n && wall(x, y, x + 1, y + 1))
                    || (x > 0 && y + 1 < n && wall(x, y, x - 1, y + 1));
                if flagged {
                    bits[y * words_per_row + x / 64] |= 1 << (x % 64);
                }
            }
        }
        WallMap {
            words_per_row,
            bits,
        }
    }

    /// Whether a flagged texel lies in `[x0, x1] x [y0, y1]` (inclusive).
    #[inline(always)]
    pub fn any(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> bool {
        let (w0, w1) = (x0 / 64, x1 / 64);
        // Bits x0 % 64 and up of the first word, up to x1 % 64 of the last.
        let first = u64::MAX << (x0 % 64);
        let last = u64::MAX >> (63 - x1 % 64);
        for y in y0..=y1 {
            let row = &self.bits[y * self.words_per_row..(y + 1) * self.words_per_row];
            let hit = if w0 == w1 {
                row[w0] & first & last != 0
            } else {
                let mut any = row[w0] & first != 0 || row[w1] & last != 0;
                for &w in &row[w0 + 1..w1] {
                    any |= w != 0;
                }
                any
            };
            if hit {
                return true;
            }
        }
        false
    }
}

/// Narrow `span` to the depths where `o + z * d` lies in `[0, n]`; false when nothing is left.
#[inline]
fn clip(o: f32, d: f32, lo: f32, hi: f32, span: &mut (f32, f32)) -> bool {
    if d == 0.0 {
        return o >= lo && o <= hi && span.0 < span.1;
    }
    let (a, b) = ((lo - o) / d, (hi - o) / d);
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    span.0 = span.0.max(lo);
    span.1 = span.1.min(hi);
    span.0 < span.1
}

/// The occupied relief volume of a map: `[x0, x1, y0, y1, z0, z1]` (texel edges and depth
/// codes) around its non-empty texels; an empty box for an empty map.
pub fn occupied_volume(depth: &[u8], n: usize) -> [f32; 6] {
    let (mut x0, mut x1, mut y0, mut y1) = (n, 0, n, 0);
    let (mut z0, mut z1) = (MAX_DEPTH, 0u8);
    for (y, row) in depth.chunks_exact(n).enumerate() {
        for (x, &c) in row.iter().enumerate() {
            if c != EMPTY_DEPTH {
                (x0, x1, y0, y1) = (x0.min(x), x1.max(x + 1), y0.min(y), y1.max(y + 1));
                (z0, z1) = (z0.min(c), z1.max(c));
            }
        }
    }
    if x0 >= x1 {
        return [0.0; 6];
    }
    // One empty texel around the box, so a ray entering from a side starts over empty and its
    // step onto the relief is seen as the wall it is.
    let (x0, y0) = (x0.saturating_sub(1), y0.saturating_sub(1));
    let (x1, y1) = ((x1 + 1).min(n), (y1 + 1).min(n));
    // And one code above and below, so that a flat relief (z0 == z1) has a segment to search.
    let (z0, z1) = (z0.saturating_sub(1), z1.saturating_add(1).min(MAX_DEPTH));
    [
        x0 as f32,
        x1 as f32,
        y0 as f32,
        y1 as f32,
        f32::from(z0),
        f32::from(z1),
    ]
}

/// What rule 2 needs of a map, computed once per map: its occupied volume
/// ([`occupied_volume`]) and its column grid.
#[derive(Clone, Debug)]
pub struct Occupancy {
    pub volume: [f32; 6],
    pub columns: Columns,
}

impl Occupancy {
    pub fn new(map: &ReliefMap) -> Occupancy {
        let n = map.size() as usize;
        Occupancy {
            volume: occupied_volume(&map.depth, n),
            columns: Columns::new(&map.depth, n),
        }
    }
}

/// Edge in texels of the cells of a map's column grid ([`Columns`]).
pub const COLUMN_CELL: u32 = 8;
const CELL: f32 = COLUMN_CELL as f32;
/// `1 / CELL`, exact (a power of two): texel coordinate to cell index by a multiplication.
const CELL_SCALE: f32 = 1.0 / CELL;
/// A depth no ray reaches (the shader's stand-in for infinity).
const FAR: f32 = 3.0e38;
/// [`EMPTY_DEPTH`] as a top.
const EMPTY: f32 = EMPTY_DEPTH as f32;

/// A map's column grid: the map cut into cells of [`COLUMN_CELL`] x [`COLUMN_CELL`] texels,
/// each with the least depth code of its non-empty texels (its *top*; [`EMPTY_DEPTH`] when it
/// has none). Under a heightfield every texel is solid from its depth down, so a cell's
/// column, from its top down, holds every point of the cell that lies below the surface:
/// outside the columns a ray is above the surface or over empty texels, and the linear
/// search spends its steps on the part of the ray that crosses them ([`Columns::narrow`]).
/// A runtime computes the grid from the depth map when it loads it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Columns {
    /// Cells per side: `ceil(N / COLUMN_CELL)`.
    cells: u32,
    /// Row-major tops.
    tops: Vec<u8>,
}

impl Columns {
    /// The column grid of an `n` x `n` depth map.
    pub fn new(depth: &[u8], n: usize) -> Columns {
        let t = COLUMN_CELL as usize;
        let cells = n.div_ceil(t);
        let mut tops = vec![EMPTY_DEPTH; cells * cells];
        for (y, row) in depth.chunks_exact(n).enumerate() {
            let line = &mut tops[(y / t) * cells..(y / t + 1) * cells];
            for (x, &c) in row.iter().enumerate() {
                let top = &mut line[x / t];
                *top = (*top).min(c);
            }
        }
        Columns {
            cells: cells as u32,
            tops,
        }
    }

    /// Cells per side.
    pub fn cells(&self) -> u32 {
        self.cells
    }

    /// Row-major top codes, [`EMPTY_DEPTH`] for a cell without surface.
    pub fn tops(&self) -> &[u8] {
        &self.tops
    }

    /// Rule 2's narrowing: the part of the ray `(x, y) = (ox, oy) + z (dx, dy)` (`dir`), `z`
    /// in `span` (whose start lies in the map), that can go below the surface, or `None`. In
    /// grid cell `(i, j)` the ray runs over `[lo, hi]`, the depths where it crosses the cell's
    /// entry and exit boundaries (each computed from the boundary itself, so neighbouring
    /// cells share the value), and is in the column from `top - 1` down. The result runs
    /// from the first column entry, moved back by one texel of travel (so that a ray entering
    /// a column through its side starts over the neighbouring texel, which it is above, and
    /// the step onto the relief is seen as the wall it is), to the last column exit. The
    /// cells are walked from the front until the first entry and from the back until the last
    /// exit: most rays meet a column within a few cells each way. The shader does the same
    /// operations in `f32`.
    #[inline]
    pub fn narrow(
        &self,
        ox: f32,
        oy: f32,
        dir: &ColumnDir,
        span: (f32, f32),
    ) -> Option<(f32, f32)> {
        let (za, zb) = span;
        let k = self.cells as i32;
        let (ax, ay) = (&dir.x, &dir.y);
        let [dx, dy] = dir.d;
        // From the front: the first piece whose column the ray enters.
        let (mut i, mut j) = (self.cell(ox + za * dx), self.cell(oy + za * dy));
        let (mut in_x, mut out_x) = ax.crossings(ox, i);
        let (mut in_y, mut out_y) = ay.crossings(oy, j);
        let mut first = FAR;
        for _ in 0..2 * k + 2 {
            let (lo, hi) = (za.max(in_x).max(in_y), zb.min(out_x).min(out_y));
            let top = f32::from(self.tops[(j * k + i) as usize]);
            if top < EMPTY && lo.max(top - 1.0) < hi {
                first = lo.max(top - 1.0);
                break;
            }
            if hi >= zb {
                break;
            }
            // The next cell's entry is this one's exit: the same boundary, the same value.
            if out_x <= out_y {
                i += ax.step;
                (in_x, out_x) = (out_x, ax.exit(ox, i));
            } else {
                j += ay.step;
                (in_y, out_y) = (out_y, ay.exit(oy, j));
            }
            if !(i >= 0 && j >= 0 && i < k && j < k) {
                break;
            }
        }
        (first < FAR)
            .then(|| self.back(ox, oy, dir, span, first))
            .flatten()
    }

    /// [`Columns::narrow`] for `W` rays with the same direction, both walks in lockstep (the
    /// same operations lane by lane); `None` for the lanes not `open`.
    #[inline(always)]
    fn narrow_lanes<V: Lanes<W>, const W: usize>(
        &self,
        (ox, oy): (V, V),
        dir: &ColumnDir,
        (za, zb): (V, V),
        open: [bool; W],
    ) -> [Option<(f32, f32)>; W] {
        let k = self.cells as i32;
        let (ax, ay) = (&dir.x, &dir.y);
        let [dx, dy] = dir.d;
        let (mut i, mut j) = (
            self.cells_lanes::<V, W>(ox.add(za.mul(V::splat(dx)))),
            self.cells_lanes::<V, W>(oy.add(za.mul(V::splat(dy)))),
        );
        let (mut in_x, mut out_x) = (ax.entry_lanes::<V, W>(ox, i), ax.exit_lanes::<V, W>(ox, i));
        let (mut in_y, mut out_y) = (ay.entry_lanes::<V, W>(oy, j), ay.exit_lanes::<V, W>(oy, j));
        let (sx, sy) = (V::splat(ax.step as f32), V::splat(ay.step as f32));
        let (zero, kf) = (V::splat(0.0), V::splat(k as f32));
        let (one, empty) = (V::splat(1.0), V::splat(EMPTY));
        // From the front: the first cell whose column the ray enters.
        let mut first = V::splat(FAR);
        let mut active = V::Mask::from_array(open);
        for _ in 0..2 * k + 2 {
            if !active.any() {
                break;
            }
            let (lo, hi) = (za.max(in_x).max(in_y), zb.min(out_x).min(out_y));
            let tops = self.tops_lanes::<V, W>(i, j);
            let entered = lo.max(tops.sub(one));
            let found = active.and(tops.lt(empty)).and(entered.lt(hi));
            first = V::select(found, entered, first);
            active = active.and_not(found).and_not(hi.ge(zb));
            let step_x = out_x.le(out_y);
            let (next_i, next_j) = (i.add(sx), j.add(sy));
            i = V::select(step_x, next_i, i);
            j = V::select(step_x, j, next_j);
            (in_x, out_x) = (
                V::select(step_x, out_x, in_x),
                V::select(step_x, ax.exit_lanes::<V, W>(ox, next_i), out_x),
            );
            (in_y, out_y) = (
                V::select(step_x, in_y, out_y),
                V::select(step_x, out_y, ay.exit_lanes::<V, W>(oy, next_j)),
            );
            let inside = i.ge(zero).and(j.ge(zero)).and(i.lt(kf)).and(j.lt(kf));
            active = active.and(inside);
        }
        // From the back, for the lanes that found a first entry.
        let (mut i, mut j) = (
            self.cells_lanes::<V, W>(ox.add(zb.mul(V::splat(dx)))),
            self.cells_lanes::<V, W>(oy.add(zb.mul(V::splat(dy)))),
        );
        let (mut in_x, mut out_x) = (ax.entry_lanes::<V, W>(ox, i), ax.exit_lanes::<V, W>(ox, i));
        let (mut in_y, mut out_y) = (ay.entry_lanes::<V, W>(oy, j), ay.exit_lanes::<V, W>(oy, j));
        let mut last = V::splat(-FAR);
        let mut active = V::Mask::from_array(open).and(first.lt(V::splat(FAR)));
        for _ in 0..2 * k + 2 {
            if !active.any() {
                break;
            }
            let (lo, hi) = (za.max(in_x).max(in_y), zb.min(out_x).min(out_y));
            let tops = self.tops_lanes::<V, W>(i, j);
            let found = active.and(tops.lt(empty)).and(lo.max(tops.sub(one)).lt(hi));
            last = V::select(found, hi, last);
            active = active.and_not(found).and_not(lo.le(za));
            let step_x = in_x.ge(in_y);
            let (next_i, next_j) = (i.sub(sx), j.sub(sy));
            i = V::select(step_x, next_i, i);
            j = V::select(step_x, j, next_j);
            (in_x, out_x) = (
                V::select(step_x, ax.entry_lanes::<V, W>(ox, next_i), in_x),
                V::select(step_x, in_x, out_x),
            );
            (in_y, out_y) = (
                V::select(step_x, in_y, ay.entry_lanes::<V, W>(oy, next_j)),
                V::select(step_x, out_y, in_y),
            );
            let inside = i.ge(zero).and(j.ge(zero)).and(i.lt(kf)).and(j.lt(kf));
            active = active.and(inside);
        }
        let start = match dir.back_off {
            Some(b) => first.sub(V::splat(b)).max(za),
            None => za,
        };
        let (first, last, start) = (first.to_array(), last.to_array(), start.to_array());
        std::array::from_fn(|l| (open[l] && first[l] < last[l]).then_some((start[l], last[l])))
    }

    /// The tops of cells `(i, j)` (lanes of exact integers), clamped into the grid.
    #[inline(always)]
    fn tops_lanes<V: Lanes<W>, const W: usize>(&self, i: V, j: V) -> V {
        let (zero, last) = (V::splat(0.0), V::splat(self.cells as f32 - 1.0));
        let index = j
            .max(zero)
            .min(last)
            .mul(V::splat(self.cells as f32))
            .add(i.max(zero).min(last))
            .trunc();
        let mut tops = [EMPTY; W];
        for (top, t) in tops.iter_mut().zip(index) {
            *top = f32::from(self.tops[t as usize]);
        }
        V::from_array(tops)
    }

    /// [`Columns::cell`] on `W` lanes, as lanes of exact integers.
    #[inline(always)]
    fn cells_lanes<V: Lanes<W>, const W: usize>(&self, c: V) -> V {
        let last = self.cells as i32 - 1;
        let mut cells = [0.0; W];
        for (cell, t) in cells.iter_mut().zip(c.mul(V::splat(CELL_SCALE)).trunc()) {
            *cell = t.clamp(0, last) as f32;
        }
        V::from_array(cells)
    }

    /// The cell index of texel coordinate `c`, clamped into the grid.
    #[inline]
    fn cell(&self, c: f32) -> i32 {
        ((c * CELL_SCALE) as i32).clamp(0, self.cells as i32 - 1)
    }

    /// [`Columns::narrow`] after the front walk found the first column entry `first`: the
    /// walk from the back to the last column exit, and the segment.
    #[inline]
    fn back(
        &self,
        ox: f32,
        oy: f32,
        dir: &ColumnDir,
        span: (f32, f32),
        first: f32,
    ) -> Option<(f32, f32)> {
        let (za, zb) = span;
        let k = self.cells as i32;
        let (ax, ay) = (&dir.x, &dir.y);
        let [dx, dy] = dir.d;
        let (mut i, mut j) = (self.cell(ox + zb * dx), self.cell(oy + zb * dy));
        let (mut in_x, mut out_x) = ax.crossings(ox, i);
        let (mut in_y, mut out_y) = ay.crossings(oy, j);
        let mut last = -FAR;
        for _ in 0..2 * k + 2 {
            let (lo, hi) = (za.max(in_x).max(in_y), zb.min(out_x).min(out_y));
            let top = f32::from(self.tops[(j * k + i) as usize]);
            if top < EMPTY && lo.max(top - 1.0) < hi {
                last = hi;
                break;
            }
            if lo <= za {
                break;
            }
            if in_x >= in_y {
                i -= ax.step;
                (in_x, out_x) = (ax.entry(ox, i), in_x);
            } else {
                j -= ay.step;
                (in_y, out_y) = (ay.entry(oy, j), in_y);
            }
            if !(i >= 0 && j >= 0 && i < k && j < k) {
                break;
            }
        }
        if first >= last {
            return None;
        }
        let start = dir.back_off.map_or(za, |b| (first - b).max(za));
        Some((start, last))
    }
}

/// One axis of a ray direction against the cell grid: the depths at which a ray crosses the
/// boundaries of cell column (or row) `i`, each computed from the boundary itself (never
/// accumulated), so that walking from the front and from the back agree and neighbouring
/// cells share the value of their common boundary.
#[derive(Clone, Copy, Debug)]
struct Axis {
    /// `1 / d` (0 where `d` is 0).
    inv: f32,
    /// Cell step along the ray: 1, -1, or 0 where the ray does not move on this axis.
    step: i32,
    /// Boundary offsets of a cell's entry and exit: cell `i` spans boundaries `i` and `i + 1`.
    entry: i32,
    exit: i32,
}

impl Axis {
    fn new(d: f32) -> Axis {
        let (step, entry, exit) = if d > 0.0 {
            (1, 0, 1)
        } else if d < 0.0 {
            (-1, 1, 0)
        } else {
            (0, 0, 0)
        };
        let inv = if d != 0.0 { 1.0 / d } else { 0.0 };
        Axis {
            inv,
            step,
            entry,
            exit,
        }
    }

    /// Depth at which the ray through `o` crosses boundary `b` (at `b * CELL` texels).
    #[inline]
    fn at(&self, o: f32, b: i32) -> f32 {
        (b as f32 * CELL - o) * self.inv
    }

    /// Entry crossing of cell `i` (`-FAR` on an axis the ray does not move on).
    #[inline]
    fn entry(&self, o: f32, i: i32) -> f32 {
        if self.step == 0 {
            -FAR
        } else {
            self.at(o, i + self.entry)
        }
    }

    /// Exit crossing of cell `i` (`FAR` on an axis the ray does not move on).
    #[inline]
    fn exit(&self, o: f32, i: i32) -> f32 {
        if self.step == 0 {
            FAR
        } else {
            self.at(o, i + self.exit)
        }
    }

    #[inline]
    fn crossings(&self, o: f32, i: i32) -> (f32, f32) {
        (self.entry(o, i), self.exit(o, i))
    }

    /// [`Axis::entry`] and [`Axis::exit`] on `W` lanes, the same operations lane by lane.
    #[inline(always)]
    fn entry_lanes<V: Lanes<W>, const W: usize>(&self, o: V, i: V) -> V {
        self.at_lanes::<V, W>(o, i.add(V::splat(self.entry as f32)), -FAR)
    }

    #[inline(always)]
    fn exit_lanes<V: Lanes<W>, const W: usize>(&self, o: V, i: V) -> V {
        self.at_lanes::<V, W>(o, i.add(V::splat(self.exit as f32)), FAR)
    }

    /// [`Axis::at`] on `W` lanes; `off` on an axis the ray does not move on.
    #[inline(always)]
    fn at_lanes<V: Lanes<W>, const W: usize>(&self, o: V, b: V, off: f32) -> V {
        if self.step == 0 {
            V::splat(off)
        } else {
            b.mul(V::splat(CELL)).sub(o).mul(V::splat(self.inv))
        }
    }
}

/// A ray direction `(dx, dy)` (texels per depth code) as [`Columns::narrow`] uses it: made
/// once per impostor and view, shared by all its rays.
#[derive(Clone, Copy, Debug)]
pub struct ColumnDir {
    d: [f32; 2],
    x: Axis,
    y: Axis,
    /// Depth codes per texel of travel along the faster axis (`None` for a ray that does not
    /// move across the map).
    back_off: Option<f32>,
}

impl ColumnDir {
    pub fn new(dx: f32, dy: f32) -> ColumnDir {
        let travel = dx.abs().max(dy.abs());
        ColumnDir {
            d: [dx, dy],
            x: Axis::new(dx),
            y: Axis::new(dy),
            back_off: (travel > 0.0).then(|| 1.0 / travel),
        }
    }
}
