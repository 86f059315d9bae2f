// ori.wgsl: draws the impostors of an Omni-directional Relief Impostor (ORI).
//
// One draw per selected impostor, closest direction first. The vertex stage draws the back
// faces of the impostor's occupied relief box (8 corners, 36 indices, front faces culled), so
// every pixel whose view ray meets the box runs the fragment stage exactly once, whatever the
// view's skew. The fragment stage follows the runtime rule of `crates/ori-eval/src/march.rs`
// step by step, with the same f32 operations in the same order:
//
//   1. ray: the pixel centre's ray in texture space, `(x, y) = o + z * dir`, `o` where it
//      crosses depth code 0 (x, y in texels, z in depth codes, 0 nearest the viewer);
//   2. extent: the part `[z_in, z_out]` of the ray inside the occupied relief volume,
//      narrowed to the columns of the map's column grid the ray crosses (`narrow`);
//   3. lookup: nearest texel, `textureLoad` of `floor(x, y)`, 255 (empty) outside the map;
//   4. linear search: `linear_steps` samples `z_in + ((z_out - z_in) / L) * k`, the first with
//      `z >= code` ends it;
//   5. binary search: `binary_steps` halvings of the bracket `(lo, hi)`;
//   6. vertical wall: discard when exactly one of `code(lo)`, `code(hi)` is empty, or they
//      differ by more than the threshold (in codes);
//   7. fragment: texel `hi` (normal, albedo), at relief depth `hi`.
//
// Priority between impostors, one of two rules per ORI (the pipeline's depth-stencil state
// and the record's `bias` choose):
//
// - option 3 (closest direction first) is "first writer wins" with the stencil buffer: every
//   impostor of one ORI draws with the ORI's stencil reference, passes only where the
//   stencil differs from it, and writes it whether the depth test passes or fails. The
//   fragment depth is the true depth of the hit, so impostors composite with ordinary
//   geometry through the depth buffer.
// - option 5 (biased depth, `bias.x > 0`): the least `depth - cos * bias.x` wins, `cos` the
//   stored normal's z in the impostor frame, `bias.x` a world length (the depth range / 32).
//   The fragment depth is the depth of the hit pushed away from the viewer by
//   `(1 - cos) * bias.x` (the same order, never nearer than the hit), no stencil, depth test
//   LESS, impostors in list order: the least biased depth wins, the earlier one on ties. The
//   depth buffer then holds the biased depth; the depth target keeps the true depth.
//
// Discarded fragments write nothing.

struct Globals {
    // World space to clip space (column-major).
    world_to_clip: mat4x4<f32>,
    // xyz: unit light direction (towards the light), fixed to the view.
    light: vec4<f32>,
    // Orthographic (w = 0): xyz is the view direction towards the viewer.
    // Perspective (w = 1): xyz is the eye.
    view: vec4<f32>,
    // How clip depth follows distance from the viewer (option 5's bias). Orthographic: x is
    // clip depth per world unit. Perspective: depth = y - z / distance.
    depth: vec4<f32>,
};

// One impostor as seen by this frame's camera (built on the CPU, `crates/ori-render/src/rays.rs`).
struct Impostor {
    // Texture space (x, y texels, z depth codes) to clip space.
    tex_to_clip: mat4x4<f32>,
    // The impostor frame (u, v, d) in world space: normals are stored in it.
    frame_u: vec4<f32>,
    frame_v: vec4<f32>,
    frame_d: vec4<f32>,
    // Orthographic rays: o(px, py) = o0 + px * ex + py * ey; dir constant.
    o0_ex: vec4<f32>,   // o0.x, o0.y, ex.x, ex.y
    ey_dir: vec4<f32>,  // ey.x, ey.y, dir.x, dir.y
    // Perspective rays: the eye in texture space, and the ray direction
    // r(px, py) = r0 + px * rx + py * ry (texture-space vector).
    eye: vec4<f32>,
    r0: vec4<f32>,
    rx: vec4<f32>,
    ry: vec4<f32>,
    // Occupied relief volume: x0, x1, y0, y1 (texels) ...
    bounds: vec4<f32>,
    // ... z0, z1 (codes); the map edge N in texels; the wall threshold in codes.
    depth_range: vec4<f32>,
    // x: option 5's bias per unit cos, a world length (depth range / 32); 0 under option 3.
    bias: vec4<f32>,
    // Texture array layer, projection (0 orthographic, 1 perspective), linear steps,
    // binary steps.
    info: vec4<u32>,
    // x: impostor index (written to the source target); y: cells per side of the map's
    // column grid (layer L's tops start at L * y * y in `column_tops`).
    ids: vec4<u32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;
@group(0) @binding(1) var<storage, read> impostors: array<Impostor>;

@group(1) @binding(0) var depth_maps: texture_2d_array<f32>;
@group(1) @binding(1) var normal_maps: texture_2d_array<f32>;
@group(1) @binding(2) var albedo_maps: texture_2d_array<f32>;
// Every map's column grid (`ori_eval::march::Columns`): per cell of COLUMN_CELL x COLUMN_CELL
// texels the least depth code of its non-empty texels, 255 when none; one u32 per cell.
@group(1) @binding(3) var<storage, read> column_tops: array<u32>;

const COLUMN_CELL: f32 = 8.0;
// 1 / COLUMN_CELL, exact.
const CELL_SCALE: f32 = 0.125;
// A depth no ray reaches (a stand-in for infinity).
const FAR: f32 = 3.0e38;

// The box's 12 triangles, wound counter-clockwise seen from outside; corner bits are x, y, z.
var<private> BOX: array<u32, 36> = array<u32, 36>(
    4u, 6u, 2u, 4u, 2u, 0u, 1u, 3u, 7u, 1u, 7u, 5u, 1u, 5u, 4u, 1u, 4u, 0u,
    2u, 6u, 7u, 2u, 7u, 3u, 2u, 3u, 1u, 2u, 1u, 0u, 4u, 5u, 7u, 4u, 7u, 6u
);

// Rasterised box grown by this much (texels and codes): the fragment stage clips exactly,
// the rasteriser only has to be conservative.
const GROW: f32 = 0.0625;

struct VsOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) slot: u32,
};

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) slot: u32) -> VsOut {
    let imp = impostors[slot];
    let corner = BOX[vertex];
    let b = imp.bounds;
    let z = imp.depth_range;
    let p = vec3<f32>(
        select(b.x - GROW, b.y + GROW, (corner & 1u) != 0u),
        select(b.z - GROW, b.w + GROW, (corner & 2u) != 0u),
        select(z.x - GROW, z.y + GROW, (corner & 4u) != 0u),
    );
    let clip = imp.tex_to_clip * vec4<f32>(p, 1.0);
    var out: VsOut;
    // The depth the rasteriser sees is irrelevant (the fragment writes its own); keeping it
    // mid-range leaves only the w > 0 clip (parts behind a perspective eye).
    out.position = vec4<f32>(clip.x, clip.y, 0.5 * clip.w, clip.w);
    out.slot = slot;
    return out;
}

// Rule 3: the depth code under (x, y); 255 (empty) outside the map.
fn code_at(layer: u32, n: f32, x: f32, y: f32) -> f32 {
    let inside = x >= 0.0 && y >= 0.0 && x < n && y < n;
    if !inside {
        return 255.0;
    }
    // Non-negative: truncation is floor.
    let texel = vec2<i32>(i32(x), i32(y));
    return round(textureLoad(depth_maps, texel, layer, 0).r * 255.0);
}

// Rule 2 on one axis: narrow `span` to the depths where o + z * d lies in [lo, hi].
fn clip_axis(o: f32, d: f32, lo: f32, hi: f32, span: ptr<function, vec2<f32>>) -> bool {
    if d == 0.0 {
        return o >= lo && o <= hi && (*span).x < (*span).y;
    }
    let a = (lo - o) / d;
    let b = (hi - o) / d;
    var near = b;
    var far = a;
    if a < b {
        near = a;
        far = b;
    }
    (*span).x = max((*span).x, near);
    (*span).y = min((*span).y, far);
    return (*span).x < (*span).y;
}

// Boundary crossings of one axis of the ray `o + z d` against the column grid
// (`Axis` in `crates/ori-eval/src/march.rs`): cell `i` spans boundaries `i` and `i + 1`, at
// `b * COLUMN_CELL` texels; the ray crosses boundary `b` at `(b * COLUMN_CELL - o) * inv`.
struct Axis {
    o: f32,
    inv: f32,
    step: i32,
    entry: i32,
    exit: i32,
};

fn axis(o: f32, d: f32) -> Axis {
    var a: Axis;
    a.o = o;
    a.inv = 0.0;
    a.step = 0;
    a.entry = 0;
    a.exit = 0;
    if d != 0.0 {
        a.inv = 1.0 / d;
    }
    if d > 0.0 {
        a.step = 1;
        a.exit = 1;
    } else if d < 0.0 {
        a.step = -1;
        a.entry = 1;
    }
    return a;
}

fn cell_entry(a: Axis, i: i32) -> f32 {
    if a.step == 0 {
        return -FAR;
    }
    return (f32(i + a.entry) * COLUMN_CELL - a.o) * a.inv;
}

fn cell_exit(a: Axis, i: i32) -> f32 {
    if a.step == 0 {
        return FAR;
    }
    return (f32(i + a.exit) * COLUMN_CELL - a.o) * a.inv;
}

fn cell_of(c: f32, k: i32) -> i32 {
    return clamp(i32(c * CELL_SCALE), 0, k - 1);
}

// Rule 2's narrowing to the columns the ray crosses (`Columns::narrow` in
// `crates/ori-eval/src/march.rs`, the same f32 operations): cells are walked from the front
// to the first column entry, and from the back to the last column exit; the segment runs from
// that entry, moved back by one texel of travel, to that exit. Empty: x >= y.
fn narrow(layer: u32, cells: u32, ox: f32, oy: f32, dx: f32, dy: f32, span: vec2<f32>) -> vec2<f32> {
    let za = span.x;
    let zb = span.y;
    let k = i32(cells);
    let base = layer * cells * cells;
    let ax = axis(ox, dx);
    let ay = axis(oy, dy);
    let nothing = vec2<f32>(0.0, 0.0);
    // From the front.
    var i = cell_of(ox + za * dx, k);
    var j = cell_of(oy + za * dy, k);
    var in_x = cell_entry(ax, i);
    var out_x = cell_exit(ax, i);
    var in_y = cell_entry(ay, j);
    var out_y = cell_exit(ay, j);
    var first = FAR;
    for (var n = 0; n < 2 * k + 2; n++) {
        let lo = max(max(za, in_x), in_y);
        let hi = min(min(zb, out_x), out_y);
        let top = f32(column_tops[base + u32(j * k + i)]);
        if top < 255.0 && max(lo, top - 1.0) < hi {
            first = max(lo, top - 1.0);
            break;
        }
        if hi >= zb {
            break;
        }
        if out_x <= out_y {
            i += ax.step;
            in_x = out_x;
            out_x = cell_exit(ax, i);
        } else {
            j += ay.step;
            in_y = out_y;
            out_y = cell_exit(ay, j);
        }
        if !(i >= 0 && j >= 0 && i < k && j < k) {
            break;
        }
    }
    if !(first < FAR) {
        return nothing;
    }
    // From the back.
    i = cell_of(ox + zb * dx, k);
    j = cell_of(oy + zb * dy, k);
    in_x = cell_entry(ax, i);
    out_x = cell_exit(ax, i);
    in_y = cell_entry(ay, j);
    out_y = cell_exit(ay, j);
    var last = -FAR;
    for (var n = 0; n < 2 * k + 2; n++) {
        let lo = max(max(za, in_x), in_y);
        let hi = min(min(zb, out_x), out_y);
        let top = f32(column_tops[base + u32(j * k + i)]);
        if top < 255.0 && max(lo, top - 1.0) < hi {
            last = hi;
            break;
        }
        if lo <= za {
            break;
        }
        if in_x >= in_y {
            i -= ax.step;
            out_x = in_x;
            in_x = cell_entry(ax, i);
        } else {
            j -= ay.step;
            out_y = in_y;
            in_y = cell_entry(ay, j);
        }
        if !(i >= 0 && j >= 0 && i < k && j < k) {
            break;
        }
    }
    if !(first < last) {
        return nothing;
    }
    let travel = max(abs(dx), abs(dy));
    var start = za;
    if travel > 0.0 {
        start = max(first - 1.0 / travel, za);
    }
    return vec2<f32>(start, last);
}

struct Hit {
    found: bool,
    texel: vec2<i32>,
    // Texture-space hit point (x, y, z).
    point: vec3<f32>,
};

// Rules 1 to 7 for the ray through pixel centre (px, py).
fn trace(imp: Impostor, px: f32, py: f32) -> Hit {
    var miss: Hit;
    miss.found = false;
    var ox: f32;
    var oy: f32;
    var dx: f32;
    var dy: f32;
    var span = imp.depth_range.xy;
    if imp.info.y == 0u {
        ox = imp.o0_ex.x + px * imp.o0_ex.z + py * imp.ey_dir.x;
        oy = imp.o0_ex.y + px * imp.o0_ex.w + py * imp.ey_dir.y;
        dx = imp.ey_dir.z;
        dy = imp.ey_dir.w;
    } else {
        let r = imp.r0.xyz + px * imp.rx.xyz + py * imp.ry.xyz;
        // The search assumes z grows along the ray.
        if !(r.z > 0.0) {
            return miss;
        }
        dx = r.x / r.z;
        dy = r.y / r.z;
        ox = imp.eye.x - imp.eye.z * dx;
        oy = imp.eye.y - imp.eye.z * dy;
        // Nothing behind the eye.
        span.x = max(span.x, imp.eye.z);
    }
    let b = imp.bounds;
    if !(clip_axis(ox, dx, b.x, b.y, &span) && clip_axis(oy, dy, b.z, b.w, &span)) {
        return miss;
    }
    let layer = imp.info.x;
    span = narrow(layer, imp.ids.y, ox, oy, dx, dy, span);
    if !(span.x < span.y) {
        return miss;
    }
    let n = imp.depth_range.z;
    let linear_steps = imp.info.z;
    let z_in = span.x;
    let z_out = span.y;
    let step = (z_out - z_in) / f32(linear_steps);
    var lo = z_in;
    var hi = z_in;
    var below = false;
    for (var k = 1u; k <= linear_steps; k++) {
        let z = z_in + step * f32(k);
        if z >= code_at(layer, n, ox + z * dx, oy + z * dy) {
            hi = z;
            below = true;
            break;
        }
        lo = z;
    }
    if !below {
        return miss;
    }
    for (var i = 0u; i < imp.info.w; i++) {
        let mid = 0.5 * (lo + hi);
        if mid >= code_at(layer, n, ox + mid * dx, oy + mid * dy) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let hx = ox + hi * dx;
    let hy = oy + hi * dy;
    // A sample below the surface is inside the map; kept as a guard.
    if !(hx >= 0.0 && hy >= 0.0 && hx < n && hy < n) {
        return miss;
    }
    let a = code_at(layer, n, ox + lo * dx, oy + lo * dy);
    let c = code_at(layer, n, hx, hy);
    if (a == 255.0) != (c == 255.0) || abs(a - c) > imp.depth_range.w {
        return miss;
    }
    var hit: Hit;
    hit.found = true;
    hit.texel = vec2<i32>(i32(hx), i32(hy));
    hit.point = vec3<f32>(hx, hy, hi);
    return hit;
}

struct FsOut {
    @location(0) color: vec4<f32>,
    @location(1) depth: f32,
    @location(2) source: u32,
    @builtin(frag_depth) frag_depth: f32,
};

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let imp = impostors[in.slot];
    let hit = trace(imp, in.position.x, in.position.y);
    let clip = imp.tex_to_clip * vec4<f32>(hit.point, 1.0);
    let depth = clip.z / clip.w;
    if !hit.found || !(clip.w > 0.0) || !(depth >= 0.0 && depth <= 1.0) {
        discard;
    }
    let layer = imp.info.x;
    // Normal x, y as stored (8-bit codes, as the evaluator decodes them), z rebuilt.
    let nxy = round(textureLoad(normal_maps, hit.texel, layer, 0).xy * 255.0) / 255.0 * 2.0 - 1.0;
    let nz = sqrt(max(0.0, 1.0 - nxy.x * nxy.x - nxy.y * nxy.y));
    let normal = imp.frame_u.xyz * nxy.x + imp.frame_v.xyz * nxy.y + imp.frame_d.xyz * nz;
    let albedo = textureLoad(albedo_maps, hit.texel, layer, 0).rgb;
    // The evaluator's comparison shading (ori_eval::Shading), in linear light; the target
    // encodes sRGB.
    let light = 0.3 + 0.7 * max(dot(normal, globals.light.xyz), 0.0);
    var out: FsOut;
    out.color = vec4<f32>(albedo * light, 1.0);
    out.depth = depth;
    out.source = imp.ids.x;
    out.frag_depth = depth;
    let shift = imp.bias.x;
    if shift > 0.0 {
        // Option 5: the hit pushed away from the viewer by (1 - cos) * shift, cos = nz.
        let away = shift * (1.0 - nz);
        var biased: f32;
        if globals.view.w == 0.0 {
            biased = depth + away * globals.depth.x;
        } else {
            biased = globals.depth.y - globals.depth.z / (clip.w + away);
        }
        out.frag_depth = min(biased, 1.0);
    }
    return out;
}
