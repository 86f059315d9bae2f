// The ORI runtime in WebGL2, written from docs/RUNTIME.md: the per-impostor set-up of
// section 9.1 in f64 (JavaScript numbers) rounded once to f32, the per-pixel rule of section
// 9.9 in GLSL ES 3.0 (binary32), the entry of section 10.1 and option 3's priority (first
// writer wins, with the stencil buffer), the hierarchy traversal of docs/FORMAT.md.
"use strict";

// Linear light to the sRGB bytes the canvas shows (the wgpu target encodes the same way).
const SRGB_ENCODE = `vec3 srgbEncode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}`;

const ORI_VERTEX = `#version 300 es
precision highp float;
precision highp int;
uniform mat4 texToClip;
uniform vec4 bounds;      // x0, x1, y0, y1 (texels)
uniform vec4 depthRange;  // z0, z1 (codes), N, wall threshold (codes)
// The box's 12 triangles, counter-clockwise seen from outside; corner bits are x, y, z.
const int BOX[36] = int[36](4, 6, 2, 4, 2, 0, 1, 3, 7, 1, 7, 5, 1, 5, 4, 1, 4, 0,
                            2, 6, 7, 2, 7, 3, 2, 3, 1, 2, 1, 0, 4, 5, 7, 4, 7, 6);
// The rasterised box is grown a little: the fragment stage clips exactly.
const float GROW = 0.0625;
void main() {
  int corner = BOX[gl_VertexID];
  vec3 p = vec3((corner & 1) != 0 ? bounds.y + GROW : bounds.x - GROW,
                (corner & 2) != 0 ? bounds.w + GROW : bounds.z - GROW,
                (corner & 4) != 0 ? depthRange.y + GROW : depthRange.x - GROW);
  vec4 clip = texToClip * vec4(p, 1.0);
  // The fragment writes its own depth; keep the rasterised one mid-range.
  gl_Position = vec4(clip.x, clip.y, 0.0, clip.w);
}`;

const ORI_FRAGMENT = `#version 300 es
precision highp float;
precision highp int;
precision highp usampler2D;
uniform mat4 texToClip;
uniform vec4 o0ex;        // o0.x, o0.y, ex.x, ex.y (orthographic rays)
uniform vec4 eyDir;       // ey.x, ey.y, dir.x, dir.y
uniform vec4 eye;         // perspective rays: the eye in texture space ...
uniform vec4 r0;          // ... and r(px, py) = r0 + px rx + py ry
uniform vec4 rx;
uniform vec4 ry;
uniform vec4 bounds;
uniform vec4 depthRange;
uniform ivec4 info;       // projection (0 orthographic), linear steps, binary steps, cells per side
uniform vec3 frameU;
uniform vec3 frameV;
uniform vec3 frameD;
uniform vec3 light;
uniform vec4 tint;        // rgb multiplier, a: 1 to tint
uniform float height;     // framebuffer height: rows count from the top
uniform float bias;       // option 5: the bias per unit cos, a world length; 0 under option 3
uniform vec4 depthModel;  // clip depth from distance: x per world unit (orthographic); y - z / distance
uniform sampler2D depthMap;
uniform sampler2D normalMap;
uniform sampler2D albedoMap;
uniform usampler2D tops;
out vec4 color;

const float COLUMN_CELL = 8.0;
const float CELL_SCALE = 0.125;
const float FAR = 3.0e38;

// 9.2: the code under (x, y); 255 (empty) outside the map.
float codeAt(float n, float x, float y) {
  if (!(x >= 0.0 && y >= 0.0 && x < n && y < n)) return 255.0;
  return floor(texelFetch(depthMap, ivec2(int(x), int(y)), 0).r * 255.0 + 0.5);
}

// 9.3 on one axis.
bool clipAxis(float o, float d, float lo, float hi, inout vec2 span) {
  if (d == 0.0) return o >= lo && o <= hi && span.x < span.y;
  float a = (lo - o) / d;
  float b = (hi - o) / d;
  float near = a < b ? a : b;
  float far = a < b ? b : a;
  span.x = max(span.x, near);
  span.y = min(span.y, far);
  return span.x < span.y;
}

struct Axis { float o; float inv; int step; int entry; int exit; };

Axis axisOf(float o, float d) {
  Axis a = Axis(o, 0.0, 0, 0, 0);
  if (d != 0.0) a.inv = 1.0 / d;
  if (d > 0.0) { a.step = 1; a.exit = 1; }
  else if (d < 0.0) { a.step = -1; a.entry = 1; }
  return a;
}

float cellEntry(Axis a, int i) {
  if (a.step == 0) return -FAR;
  return (float(i + a.entry) * COLUMN_CELL - a.o) * a.inv;
}

float cellExit(Axis a, int i) {
  if (a.step == 0) return FAR;
  return (float(i + a.exit) * COLUMN_CELL - a.o) * a.inv;
}

int cellOf(float c, int k) { return clamp(int(c * CELL_SCALE), 0, k - 1); }

float topAt(int i, int j) { return float(texelFetch(tops, ivec2(i, j), 0).r); }

// 9.4: the span narrowed to the columns the ray crosses; empty when x >= y.
vec2 narrow(int k, float ox, float oy, float dx, float dy, vec2 span) {
  float za = span.x;
  float zb = span.y;
  Axis ax = axisOf(ox, dx);
  Axis ay = axisOf(oy, dy);
  int i = cellOf(ox + za * dx, k);
  int j = cellOf(oy + za * dy, k);
  float inX = cellEntry(ax, i);
  float outX = cellExit(ax, i);
  float inY = cellEntry(ay, j);
  float outY = cellExit(ay, j);
  float first = FAR;
  for (int n = 0; n < 2 * k + 2; n++) {
    float lo = max(max(za, inX), inY);
    float hi = min(min(zb, outX), outY);
    float top = topAt(i, j);
    if (top < 255.0 && max(lo, top - 1.0) < hi) { first = max(lo, top - 1.0); break; }
    if (hi >= zb) break;
    if (outX <= outY) { i += ax.step; inX = outX; outX = cellExit(ax, i); }
    else { j += ay.step; inY = outY; outY = cellExit(ay, j); }
    if (!(i >= 0 && j >= 0 && i < k && j < k)) break;
  }
  if (!(first < FAR)) return vec2(0.0);
  i = cellOf(ox + zb * dx, k);
  j = cellOf(oy + zb * dy, k);
  inX = cellEntry(ax, i);
  outX = cellExit(ax, i);
  inY = cellEntry(ay, j);
  outY = cellExit(ay, j);
  float last = -FAR;
  for (int n = 0; n < 2 * k + 2; n++) {
    float lo = max(max(za, inX), inY);
    float hi = min(min(zb, outX), outY);
    float top = topAt(i, j);
    if (top < 255.0 && max(lo, top - 1.0) < hi) { last = hi; break; }
    if (lo <= za) break;
    if (inX >= inY) { i -= ax.step; outX = inX; inX = cellEntry(ax, i); }
    else { j -= ay.step; outY = inY; inY = cellEntry(ay, j); }
    if (!(i >= 0 && j >= 0 && i < k && j < k)) break;
  }
  if (!(first < last)) return vec2(0.0);
  float travel = max(abs(dx), abs(dy));
  float start = za;
  if (travel > 0.0) start = max(first - 1.0 / travel, za);
  return vec2(start, last);
}

${SRGB_ENCODE}

void main() {
  float px = gl_FragCoord.x;
  float py = height - gl_FragCoord.y;
  float ox; float oy; float dx; float dy;
  vec2 span = depthRange.xy;
  if (info.x == 0) {
    ox = o0ex.x + px * o0ex.z + py * eyDir.x;
    oy = o0ex.y + px * o0ex.w + py * eyDir.y;
    dx = eyDir.z;
    dy = eyDir.w;
  } else {
    vec3 r = r0.xyz + px * rx.xyz + py * ry.xyz;
    if (!(r.z > 0.0)) discard;
    dx = r.x / r.z;
    dy = r.y / r.z;
    ox = eye.x - eye.z * dx;
    oy = eye.y - eye.z * dy;
    span.x = max(span.x, eye.z);
  }
  if (!(clipAxis(ox, dx, bounds.x, bounds.y, span) && clipAxis(oy, dy, bounds.z, bounds.w, span))) discard;
  span = narrow(info.w, ox, oy, dx, dy, span);
  if (!(span.x < span.y)) discard;
  float n = depthRange.z;
  float zIn = span.x;
  float stepZ = (span.y - zIn) / float(info.y);
  float lo = zIn;
  float hi = zIn;
  bool below = false;
  for (int k = 1; k <= info.y; k++) {
    float z = zIn + stepZ * float(k);
    if (z >= codeAt(n, ox + z * dx, oy + z * dy)) { hi = z; below = true; break; }
    lo = z;
  }
  if (!below) discard;
  for (int i = 0; i < info.z; i++) {
    float mid = 0.5 * (lo + hi);
    if (mid >= codeAt(n, ox + mid * dx, oy + mid * dy)) hi = mid; else lo = mid;
  }
  float hx = ox + hi * dx;
  float hy = oy + hi * dy;
  if (!(hx >= 0.0 && hy >= 0.0 && hx < n && hy < n)) discard;
  float a = codeAt(n, ox + lo * dx, oy + lo * dy);
  float c = codeAt(n, hx, hy);
  // 9.7: the vertical wall.
  if ((a == 255.0) != (c == 255.0) || abs(a - c) > depthRange.w) discard;
  vec4 clip = texToClip * vec4(hx, hy, hi, 1.0);
  float depth = clip.z / clip.w;
  if (!(clip.w > 0.0) || !(depth >= 0.0 && depth <= 1.0)) discard;
  ivec2 texel = ivec2(int(hx), int(hy));
  vec2 nxy = floor(texelFetch(normalMap, texel, 0).xy * 255.0 + 0.5) / 255.0 * 2.0 - 1.0;
  float nz = sqrt(max(0.0, 1.0 - nxy.x * nxy.x - nxy.y * nxy.y));
  vec3 normal = frameU * nxy.x + frameV * nxy.y + frameD * nz;
  vec3 albedo = texelFetch(albedoMap, texel, 0).rgb;
  float shade = 0.3 + 0.7 * max(dot(normal, light), 0.0);
  vec3 linear = albedo * shade;
  if (tint.a > 0.0) linear *= tint.rgb;
  color = vec4(srgbEncode(linear), 1.0);
  gl_FragDepth = depth;
  if (bias > 0.0) {
    // Option 5: the hit pushed away from the viewer by (1 - cos) * bias, cos = nz.
    float away = bias * (1.0 - nz);
    float biased = info.x == 0 ? depth + away * depthModel.x : depthModel.y - depthModel.z / (clip.w + away);
    gl_FragDepth = min(biased, 1.0);
  }
}`;

const MESH_VERTEX = `#version 300 es
precision highp float;
uniform mat4 worldToClip;
uniform vec3 lo;
uniform vec3 scale;
in vec3 quantised;
in vec4 albedo;
in vec3 normalIn;
out vec3 world;
out vec3 colour;
out vec3 normal;
void main() {
  world = lo + quantised * scale;
  normal = normalIn;
  // sRGB bytes to linear light.
  vec3 c = albedo.rgb;
  colour = mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
  vec4 clip = worldToClip * vec4(world, 1.0);
  gl_Position = vec4(clip.xy, 2.0 * clip.z - clip.w, clip.w);
}`;

const MESH_FRAGMENT = `#version 300 es
precision highp float;
uniform vec3 light;
uniform vec3 cellLo;
uniform vec3 cellHi;
uniform vec4 tint;
in vec3 world;
in vec3 colour;
in vec3 normal;
out vec4 color;
${SRGB_ENCODE}
void main() {
  // A hierarchy leaf draws the model inside its cell only.
  if (any(lessThan(world, cellLo)) || any(greaterThan(world, cellHi))) discard;
  // The face normal turned towards the viewer (window rows grow upwards here), and the
  // vertex normal turned to agree with it; the face's where the mesh has none.
  vec3 face = normalize(cross(dFdx(world), dFdy(world)));
  vec3 n = dot(normal, normal) > 0.0 ? normalize(normal) : face;
  if (dot(n, face) < 0.0) n = -n;
  float shade = 0.3 + 0.7 * max(dot(n, light), 0.0);
  vec3 linear = colour * shade;
  if (tint.a > 0.0) linear *= tint.rgb;
  color = vec4(srgbEncode(linear), 1.0);
}`;

const LINE_VERTEX = `#version 300 es
precision highp float;
uniform mat4 worldToClip;
in vec3 position;
void main() {
  vec4 clip = worldToClip * vec4(position, 1.0);
  gl_Position = vec4(clip.xy, -clip.w, clip.w);
}`;

const LINE_FRAGMENT = `#version 300 es
precision highp float;
uniform vec4 tint;
out vec4 color;
void main() { color = tint; }`;

const COMPOSE_VERTEX = `#version 300 es
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID & 2) * 2 - 1));
  gl_Position = vec4(p, 0.0, 1.0);
}`;

// The difference of two renders, as `ori preview` draws it: red where only the mesh covers,
// blue where only the ORI does, and the colour difference x 4 where both do.
const COMPOSE_FRAGMENT = `#version 300 es
precision highp float;
uniform sampler2D meshImage;
uniform sampler2D oriImage;
out vec4 color;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 m = texelFetch(meshImage, p, 0);
  vec4 o = texelFetch(oriImage, p, 0);
  if (m.a > 0.0 && o.a == 0.0) color = vec4(1.0, 0.0, 0.0, 1.0);
  else if (m.a == 0.0 && o.a > 0.0) color = vec4(0.0, 0.0, 1.0, 1.0);
  else if (m.a == 0.0) color = vec4(0.0);
  else color = vec4(1.0 - min(abs(m.rgb - o.rgb) * 4.0, 1.0), 1.0);
}`;

// ---- f64 geometry (RUNTIME.md sections 1 and 4) -------------------------------------------

// `Frame::from_direction`: u horizontal, v up, d towards the viewer.
function frameFromDirection(w) {
  const d = normalize0(w);
  const up = Math.abs(d[1]) < 0.99 ? [0.0, 1.0, 0.0] : [0.0, 0.0, -1.0];
  const u = normalize0(cross3(up, d));
  const v = cross3(d, u);
  return { u, v, d };
}

// An orthographic camera framing the sphere (center, radius) from `dir`, as
// `Camera::ortho_framing`; or a perspective one at the distance where the sphere's edge is
// `edgePx` pixels in an image `height` high, as `Camera::perspective_sized`.
// The camera of an evaluation view (RUNTIME.md section 5, `Camera::from_view`): its window, with
// the depth range widened by the view's range on each side.
function evaluationCamera(view) {
  const [u, v, d] = view.frame;
  const range = view.near - view.far;
  return { frame: { u, v, d }, ortho: true, center: view.center, halfSize: view.half_size, near: view.near + range, far: view.far - range };
}

function orthoCamera(center, radius, dir) {
  const frame = frameFromDirection(dir);
  const c = [dot3(frame.u, center), dot3(frame.v, center), dot3(frame.d, center)];
  return { frame, ortho: true, center: [c[0], c[1]], halfSize: radius, near: c[2] + 2.0 * radius, far: c[2] - 2.0 * radius };
}

function perspectiveCamera(center, radius, dir, fovY, edgePx, height) {
  const d = normalize0(dir);
  const t = edgePx / (height / Math.tan(fovY / 2.0));
  const distance = (radius * Math.sqrt(1.0 + t * t)) / t;
  const eye = [0, 1, 2].map((k) => center[k] + d[k] * distance);
  const frame = frameFromDirection([0, 1, 2].map((k) => eye[k] - center[k]));
  const near = Math.max(distance - radius, 1e-3 * distance);
  return { frame, ortho: false, eye, fovY, near, far: distance + 2.0 * radius };
}

// The direction the selection table is looked up with (RUNTIME.md section 10.1).
function viewDirection(camera, target) {
  if (camera.ortho) return camera.frame.d;
  const w = normalize0([0, 1, 2].map((k) => camera.eye[k] - target[k]));
  return w.every(Number.isFinite) && dot3(w, w) > 0 ? w : camera.frame.d;
}

// The key light: normalize(0.3 u + 0.5 v + d) of the camera frame.
function cameraLight(camera) {
  const f = camera.frame;
  return normalize0([0, 1, 2].map((k) => 0.3 * f.u[k] + 0.5 * f.v[k] + f.d[k]));
}

// How clip depth follows distance from the viewer, for option 5's bias.
function depthModel(camera) {
  if (camera.ortho) return [1.0 / (camera.near - camera.far), 0, 0, 0];
  const range = camera.far - camera.near;
  return [0, camera.far / range, (camera.far * camera.near) / range, 0];
}

// World to clip, as rows; clip depth in [0, 1].
function worldToClipRows(camera, width, height) {
  const { u, v, d } = camera.frame;
  const aspect = width / height;
  if (camera.ortho) {
    const hx = camera.halfSize * aspect;
    const hy = camera.halfSize;
    const range = camera.near - camera.far;
    return [
      [u[0] / hx, u[1] / hx, u[2] / hx, -camera.center[0] / hx],
      [v[0] / hy, v[1] / hy, v[2] / hy, -camera.center[1] / hy],
      [-d[0] / range, -d[1] / range, -d[2] / range, camera.near / range],
      [0.0, 0.0, 0.0, 1.0],
    ];
  }
  const f = 1.0 / Math.tan(0.5 * camera.fovY);
  const fx = f / aspect;
  const a = camera.far / (camera.far - camera.near);
  const b = (camera.far * camera.near) / (camera.far - camera.near);
  const e = camera.eye;
  return [
    [u[0] * fx, u[1] * fx, u[2] * fx, -dot3(u, e) * fx],
    [v[0] * f, v[1] * f, v[2] * f, -dot3(v, e) * f],
    [-d[0] * a, -d[1] * a, -d[2] * a, dot3(d, e) * a - b],
    [-d[0], -d[1], -d[2], dot3(d, e)],
  ];
}

function mulRows(a, b) {
  return a.map((row) => [0, 1, 2, 3].map((j) => row[0] * b[0][j] + row[1] * b[1][j] + row[2] * b[2][j] + row[3] * b[3][j]));
}

// Rows to a column-major Float32Array, as uniformMatrix4fv wants.
function columnMajor(rows) {
  const out = new Float32Array(16);
  for (let r = 0; r < 4; r++) for (let c = 0; c < 4; c++) out[c * 4 + r] = rows[r][c];
  return out;
}

// The edge in pixels of the square bounding a sphere's projection (`ori_plt`), or null when
// the sphere reaches the eye's plane.
function projectedSphereEdge(camera, center, radius, height) {
  if (camera.ortho) return 2.0 * radius * (height / (2.0 * camera.halfSize));
  const rel = [0, 1, 2].map((k) => center[k] - camera.eye[k]);
  const f = camera.frame;
  const [cx, cy, cz] = [dot3(rel, f.u), dot3(rel, f.v), -dot3(rel, f.d)];
  const focal = height / 2.0 / Math.tan(camera.fovY / 2.0);
  const r2 = radius * radius;
  const denom = cz * cz - r2;
  if (!(cz > radius && denom > 0.0)) return null;
  const extent = (c) => (2.0 * focal * radius * Math.sqrt(c * c + cz * cz - r2)) / denom;
  return Math.max(extent(cx), extent(cy));
}

// Section 9.1 for impostor `imp` (maps N texels square) and `camera` drawing width x height:
// the uniforms of its draw, or null when it cannot draw (seen from behind, degenerate, empty).
function impostorRecord(imp, n, camera, width, height) {
  const [u, v, d] = imp.frame;
  const occ = imp.occupied;
  if (!(occ[0] < occ[1] && occ[2] < occ[3])) return null;
  const k = n / (2.0 * imp.half_size);
  const depthScale = 254.0 / (imp.near - imp.far);
  if (!(Number.isFinite(k) && Number.isFinite(depthScale) && depthScale > 0.0)) return null;
  const point = (q) => [(dot3(u, q) - imp.center[0] + imp.half_size) * k, (imp.center[1] + imp.half_size - dot3(v, q)) * k, (imp.near - dot3(d, q)) * depthScale];
  const vector = (g) => [dot3(u, g) * k, -dot3(v, g) * k, -dot3(d, g) * depthScale];
  const f = Math.fround;
  const rec = { o0ex: [0, 0, 0, 0], eyDir: [0, 0, 0, 0], eye: [0, 0, 0, 0], r0: [0, 0, 0, 0], rx: [0, 0, 0, 0], ry: [0, 0, 0, 0], projection: 0 };
  const { u: ue, v: ve, d: w } = camera.frame;
  if (camera.ortho) {
    const facing = dot3(d, w);
    const zr = facing * depthScale;
    if (!(facing > 0.0 && zr > 0.0 && Number.isFinite(zr))) return null;
    const dir = [(-dot3(u, w) * k) / zr, (dot3(v, w) * k) / zr];
    const pixel = (2.0 * camera.halfSize) / height;
    const halfW = camera.halfSize * (width / height);
    const left = camera.center[0] - halfW;
    const top = camera.center[1] + camera.halfSize;
    const q00 = [0, 1, 2].map((i) => ue[i] * left + ve[i] * top);
    const gx = ue.map((c) => c * pixel);
    const gy = ve.map((c) => -c * pixel);
    const crossing = (t) => [t[0] - t[2] * dir[0], t[1] - t[2] * dir[1]];
    const o0 = crossing(point(q00));
    const ex = crossing(vector(gx));
    const ey = crossing(vector(gy));
    rec.o0ex = [o0[0], o0[1], ex[0], ex[1]].map(f);
    rec.eyDir = [ey[0], ey[1], dir[0], dir[1]].map(f);
  } else {
    const t = Math.tan(0.5 * camera.fovY);
    const aspect = width / height;
    const sx = (2.0 * t * aspect) / width;
    const sy = (2.0 * t) / height;
    const r0 = [0, 1, 2].map((i) => -w[i] - ue[i] * t * aspect + ve[i] * t);
    rec.eye = [...point(camera.eye), 0].map(f);
    rec.r0 = [...vector(r0), 0].map(f);
    rec.rx = [...vector(ue.map((c) => c * sx)), 0].map(f);
    rec.ry = [...vector(ve.map((c) => -c * sy)), 0].map(f);
    rec.projection = 1;
  }
  const p0 = [0, 1, 2].map((i) => u[i] * (imp.center[0] - imp.half_size) + v[i] * (imp.center[1] + imp.half_size) + d[i] * imp.near);
  const texToWorld = [
    [u[0] / k, -v[0] / k, -d[0] / depthScale, p0[0]],
    [u[1] / k, -v[1] / k, -d[1] / depthScale, p0[1]],
    [u[2] / k, -v[2] / k, -d[2] / depthScale, p0[2]],
    [0.0, 0.0, 0.0, 1.0],
  ];
  rec.texToClip = columnMajor(mulRows(worldToClipRows(camera, width, height), texToWorld));
  const all = [...rec.o0ex, ...rec.eyDir, ...rec.eye, ...rec.r0, ...rec.rx, ...rec.ry, ...rec.texToClip];
  return all.every(Number.isFinite) ? rec : null;
}

// ---- WebGL --------------------------------------------------------------------------------

function compile(gl, vertex, fragment) {
  const program = gl.createProgram();
  for (const [type, source] of [[gl.VERTEX_SHADER, vertex], [gl.FRAGMENT_SHADER, fragment]]) {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, source);
    gl.compileShader(shader);
    if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(shader)}`);
    gl.attachShader(program, shader);
  }
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`program: ${gl.getProgramInfoLog(program)}`);
  const uniforms = {};
  const count = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
  for (let i = 0; i < count; i++) {
    const name = gl.getActiveUniform(program, i).name;
    uniforms[name] = gl.getUniformLocation(program, name);
  }
  return { program, uniforms };
}

class OriRenderer {
  // `decodeOnCpu`: upload every map decoded, as for a browser without BC texture support.
  constructor(canvas, decodeOnCpu) {
    const gl = canvas.getContext("webgl2", { stencil: true, depth: true, antialias: false, preserveDrawingBuffer: true, premultipliedAlpha: false });
    if (!gl) throw new Error("this browser has no WebGL2");
    this.gl = gl;
    this.canvas = canvas;
    const rgtc = gl.getExtension("EXT_texture_compression_rgtc");
    const s3tc = gl.getExtension("WEBGL_compressed_texture_s3tc");
    const srgb = gl.getExtension("WEBGL_compressed_texture_s3tc_srgb");
    this.compressed = decodeOnCpu ? { rgtc: null, bc1: null } : { rgtc, bc1: s3tc && srgb ? srgb : null };
    this.ori = compile(gl, ORI_VERTEX, ORI_FRAGMENT);
    this.mesh = compile(gl, MESH_VERTEX, MESH_FRAGMENT);
    this.line = compile(gl, LINE_VERTEX, LINE_FRAGMENT);
    this.compose = compile(gl, COMPOSE_VERTEX, COMPOSE_FRAGMENT);
    this.lineBuffer = gl.createBuffer();
    this.targets = null;
    // Textures and buffers of the loaded asset, deleted when another is loaded.
    this.owned = [];
  }

  // Free everything `loadPackage` and `loadMesh` made.
  unload() {
    const gl = this.gl;
    for (const o of this.owned) {
      if (o instanceof WebGLTexture) gl.deleteTexture(o);
      else if (o instanceof WebGLBuffer) gl.deleteBuffer(o);
      else if (o instanceof WebGLRenderbuffer) gl.deleteRenderbuffer(o);
      else if (o instanceof WebGLFramebuffer) gl.deleteFramebuffer(o);
      else if (o instanceof WebGLVertexArrayObject) gl.deleteVertexArray(o);
    }
    this.owned = [];
    this.targets = null;
  }

  // Which textures stay compressed on the GPU.
  summary() {
    const c = this.compressed;
    return `BC4/BC5 ${c.rgtc ? "compressed" : "decoded"}, BC1 ${c.bc1 ? "compressed" : "decoded"}`;
  }

  texture(setup) {
    const gl = this.gl;
    const t = gl.createTexture();
    this.owned.push(t);
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    setup(gl);
    for (const [p, v] of [[gl.TEXTURE_MIN_FILTER, gl.NEAREST], [gl.TEXTURE_MAG_FILTER, gl.NEAREST], [gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE], [gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE], [gl.TEXTURE_MAX_LEVEL, 0]]) {
      gl.texParameteri(gl.TEXTURE_2D, p, v);
    }
    return t;
  }

  // One version-1 package on the GPU: per impostor its three maps and its column grid.
  loadPackage(pkg) {
    const gl = this.gl;
    const n = pkg.manifest.resolution;
    const { rgtc, bc1 } = this.compressed;
    const maps = pkg.maps.map((m) => ({
      depth: this.texture(() => {
        if (pkg.manifest.depth_format === "bc4" && rgtc) gl.compressedTexImage2D(gl.TEXTURE_2D, 0, rgtc.COMPRESSED_RED_RGTC1_EXT, n, n, 0, m.depth);
        else gl.texImage2D(gl.TEXTURE_2D, 0, gl.R8, n, n, 0, gl.RED, gl.UNSIGNED_BYTE, m.codes);
      }),
      normal: this.texture(() => {
        if (rgtc) gl.compressedTexImage2D(gl.TEXTURE_2D, 0, rgtc.COMPRESSED_RED_GREEN_RGTC2_EXT, n, n, 0, m.normal);
        else gl.texImage2D(gl.TEXTURE_2D, 0, gl.RG8, n, n, 0, gl.RG, gl.UNSIGNED_BYTE, decodeBc5(m.normal, n));
      }),
      albedo: this.texture(() => {
        if (bc1) gl.compressedTexImage2D(gl.TEXTURE_2D, 0, bc1.COMPRESSED_SRGB_S3TC_DXT1_EXT, n, n, 0, m.albedo);
        else gl.texImage2D(gl.TEXTURE_2D, 0, gl.SRGB8_ALPHA8, n, n, 0, gl.RGBA, gl.UNSIGNED_BYTE, decodeBc1(m.albedo, n));
      }),
      tops: this.texture(() => gl.texImage2D(gl.TEXTURE_2D, 0, gl.R8UI, m.columns.k, m.columns.k, 0, gl.RED_INTEGER, gl.UNSIGNED_BYTE, m.columns.tops)),
      cells: m.columns.k,
    }));
    return { pkg, maps, directions: TABLE_DIRECTIONS };
  }

  // A viewer mesh (`mesh.bin`) on the GPU.
  loadMesh(mesh) {
    const gl = this.gl;
    const vao = gl.createVertexArray();
    this.owned.push(vao);
    gl.bindVertexArray(vao);
    const attribute = (name, data, size, type) => {
      const b = gl.createBuffer();
      this.owned.push(b);
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
      const at = gl.getAttribLocation(this.mesh.program, name);
      gl.enableVertexAttribArray(at);
      gl.vertexAttribPointer(at, size, type, true, 0, 0);
    };
    attribute("quantised", mesh.positions, 3, gl.UNSIGNED_SHORT);
    attribute("albedo", mesh.colours, 4, gl.UNSIGNED_BYTE);
    attribute("normalIn", mesh.normals, 4, gl.BYTE);
    const indices = gl.createBuffer();
    this.owned.push(indices);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, indices);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, mesh.indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return { vao, count: mesh.indices.length, lo: mesh.lo, scale: mesh.scale };
  }

  // The selection entry a camera draws for a loaded package.
  entryFor(gpu, camera) {
    // Already unit: the camera frame's d, or the normalised direction to the eye.
    return nearestEntry(gpu.directions, viewDirection(camera, gpu.pkg.manifest.bounding_sphere.center));
  }

  // Draw one ORI: its entry's impostors in list order. Returns the entry and the impostors
  // that could draw.
  drawOri(gpu, camera, width, height, priority) {
    const entry = this.entryFor(gpu, camera);
    const list = gpu.pkg.manifest.selection.entries[entry].impostors;
    return { entry, drawn: this.drawImpostors(gpu, list, camera, width, height, priority) };
  }

  // Draw the impostors `list` of a loaded package in list order, under option 3 (`priority`
  // `{stencil: ref}`: the first writer wins) or option 5 (`{biased: true}`: the least biased
  // depth wins, the bias unit the bounding sphere's diameter, as the runtime's hierarchy
  // draws its nodes); `priority.tint` colours them. Returns the impostors that could draw
  // (facing the camera, not empty).
  drawImpostors(gpu, list, camera, width, height, priority) {
    const gl = this.gl;
    const { program, uniforms: u } = this.ori;
    gl.useProgram(program);
    const march = gpu.pkg.march;
    const light = cameraLight(camera);
    if (priority.biased) {
      gl.disable(gl.STENCIL_TEST);
    } else {
      gl.enable(gl.STENCIL_TEST);
      gl.stencilFunc(gl.NOTEQUAL, priority.stencil, 0xff);
      gl.stencilOp(gl.KEEP, gl.REPLACE, gl.REPLACE);
    }
    const sphere = gpu.pkg.manifest.bounding_sphere;
    gl.uniform1f(u.bias, priority.biased ? Math.fround((2.0 * sphere.radius) / 32.0) : 0.0);
    gl.uniform4fv(u.depthModel, depthModel(camera));
    gl.enable(gl.CULL_FACE);
    gl.cullFace(gl.FRONT);
    gl.frontFace(gl.CCW);
    gl.uniform3fv(u.light, light);
    gl.uniform1f(u.height, height);
    gl.uniform4fv(u.tint, priority.tint || [1, 1, 1, 0]);
    gl.uniform1i(u.depthMap, 0);
    gl.uniform1i(u.normalMap, 1);
    gl.uniform1i(u.albedoMap, 2);
    gl.uniform1i(u.tops, 3);
    const drawn = [];
    for (const i of list) {
      const imp = gpu.pkg.manifest.impostors[i];
      const rec = impostorRecord(imp, gpu.pkg.manifest.resolution, camera, width, height);
      if (!rec) continue;
      const maps = gpu.maps[i];
      gl.uniformMatrix4fv(u.texToClip, false, rec.texToClip);
      gl.uniform4fv(u.o0ex, rec.o0ex);
      gl.uniform4fv(u.eyDir, rec.eyDir);
      gl.uniform4fv(u.eye, rec.eye);
      gl.uniform4fv(u.r0, rec.r0);
      gl.uniform4fv(u.rx, rec.rx);
      gl.uniform4fv(u.ry, rec.ry);
      const occ = imp.occupied;
      gl.uniform4fv(u.bounds, [occ[0], occ[1], occ[2], occ[3]]);
      gl.uniform4fv(u.depthRange, [occ[4], occ[5], gpu.pkg.manifest.resolution, Math.fround(march.wallThreshold * 254.0)]);
      gl.uniform4iv(u.info, [rec.projection, march.linearSteps, march.binarySteps, maps.cells]);
      gl.uniform3fv(u.frameU, imp.frame[0]);
      gl.uniform3fv(u.frameV, imp.frame[1]);
      gl.uniform3fv(u.frameD, imp.frame[2]);
      [maps.depth, maps.normal, maps.albedo, maps.tops].forEach((t, unit) => {
        gl.activeTexture(gl.TEXTURE0 + unit);
        gl.bindTexture(gl.TEXTURE_2D, t);
      });
      gl.drawArrays(gl.TRIANGLES, 0, 36);
      drawn.push(i);
    }
    gl.disable(gl.STENCIL_TEST);
    gl.disable(gl.CULL_FACE);
    return drawn;
  }

  drawMesh(mesh, camera, width, height, cell, tint) {
    const gl = this.gl;
    const { program, uniforms: u } = this.mesh;
    gl.useProgram(program);
    gl.uniformMatrix4fv(u.worldToClip, false, columnMajor(worldToClipRows(camera, width, height)));
    gl.uniform3fv(u.lo, mesh.lo);
    gl.uniform3fv(u.scale, mesh.scale);
    gl.uniform3fv(u.light, cameraLight(camera));
    gl.uniform3fv(u.cellLo, cell ? cell[0] : [-1e30, -1e30, -1e30]);
    gl.uniform3fv(u.cellHi, cell ? cell[1] : [1e30, 1e30, 1e30]);
    gl.uniform4fv(u.tint, tint || [1, 1, 1, 0]);
    gl.bindVertexArray(mesh.vao);
    gl.drawElements(gl.TRIANGLES, mesh.count, gl.UNSIGNED_INT, 0);
    gl.bindVertexArray(null);
  }

  // The outline of each drawn impostor's occupied box (its near face), in world space.
  drawOutlines(gpu, impostors, camera, width, height, colours) {
    const gl = this.gl;
    const { program, uniforms: u } = this.line;
    gl.useProgram(program);
    gl.uniformMatrix4fv(u.worldToClip, false, columnMajor(worldToClipRows(camera, width, height)));
    gl.bindBuffer(gl.ARRAY_BUFFER, this.lineBuffer);
    const at = gl.getAttribLocation(program, "position");
    const labels = [];
    impostors.forEach((i, rank) => {
      const corners = impostorCorners(gpu.pkg.manifest, i);
      gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(corners.flat()), gl.STREAM_DRAW);
      gl.enableVertexAttribArray(at);
      gl.vertexAttribPointer(at, 3, gl.FLOAT, false, 0, 0);
      gl.uniform4fv(u.tint, colours[rank % colours.length]);
      gl.drawArrays(gl.LINE_LOOP, 0, 4);
      labels.push({ impostor: i, rank, at: projectToPixels(camera, width, height, corners[0]) });
    });
    gl.disableVertexAttribArray(at);
    return labels;
  }

  // Off-screen colour targets for the difference view.
  offscreen(width, height) {
    const gl = this.gl;
    if (this.targets && this.targets.width === width && this.targets.height === height) return this.targets;
    const make = () => {
      const texture = this.texture(() => gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, width, height, 0, gl.RGBA, gl.UNSIGNED_BYTE, null));
      const depth = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH24_STENCIL8, width, height);
      const fb = gl.createFramebuffer();
      this.owned.push(depth, fb);
      gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, texture, 0);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_STENCIL_ATTACHMENT, gl.RENDERBUFFER, depth);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      return { fb, texture };
    };
    this.targets = { width, height, mesh: make(), ori: make() };
    return this.targets;
  }

  clear(fb, width, height) {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.viewport(0, 0, width, height);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    gl.depthMask(true);
    gl.clearColor(0, 0, 0, 0);
    gl.clearDepth(1);
    gl.clearStencil(0);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT | gl.STENCIL_BUFFER_BIT);
  }

  composeDifference(width, height) {
    const gl = this.gl;
    const t = this.offscreen(width, height);
    this.clear(null, width, height);
    gl.disable(gl.DEPTH_TEST);
    gl.useProgram(this.compose.program);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, t.mesh.texture);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D, t.ori.texture);
    gl.uniform1i(this.compose.uniforms.meshImage, 0);
    gl.uniform1i(this.compose.uniforms.oriImage, 1);
    gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
  }

  // The canvas as RGBA rows from the top.
  readPixels() {
    const gl = this.gl;
    const { width, height } = this.canvas;
    const raw = new Uint8Array(width * height * 4);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, raw);
    const out = new Uint8Array(raw.length);
    const row = width * 4;
    for (let y = 0; y < height; y++) out.set(raw.subarray((height - 1 - y) * row, (height - y) * row), y * row);
    return out;
  }
}

// The corners of impostor i's occupied texel box on its near plane (code z0), world space.
function impostorCorners(m, i) {
  const imp = m.impostors[i];
  const [u, v, d] = imp.frame;
  const k = m.resolution / (2.0 * imp.half_size);
  const scale = (imp.near - imp.far) / 254.0;
  const [x0, x1, y0, y1, z0] = imp.occupied;
  const world = (x, y) => {
    const a = imp.center[0] - imp.half_size + x / k;
    const b = imp.center[1] + imp.half_size - y / k;
    const h = imp.near - z0 * scale;
    return [0, 1, 2].map((c) => u[c] * a + v[c] * b + d[c] * h);
  };
  return [world(x0, y0), world(x1, y0), world(x1, y1), world(x0, y1)];
}

function projectToPixels(camera, width, height, p) {
  const rows = worldToClipRows(camera, width, height);
  const c = rows.map((r) => r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + r[3]);
  return [((c[0] / c[3] + 1) * width) / 2, ((1 - c[1] / c[3]) * height) / 2];
}

// `mesh.bin` as the report writes it: magic `ORIMESH1`, u32 vertex and triangle counts,
// f32 x 3 lowest corner and f32 x 3 extent, then u16 x 3 positions (fractions of the
// extent, padded to 4 bytes), sRGB RGBA8 albedo and i8 x 4 normal per vertex, u32 x 3
// triangles.
function readMesh(bytes) {
  const fail = (m) => {
    throw new Error(`mesh file: ${m}`);
  };
  const magic = "ORIMESH1";
  if (bytes.length < 40 || ![...magic].every((c, i) => bytes[i] === c.charCodeAt(0))) fail("not a viewer mesh");
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const vertices = view.getUint32(8, true);
  const triangles = view.getUint32(12, true);
  const lo = [0, 1, 2].map((k) => view.getFloat32(16 + 4 * k, true));
  const scale = [0, 1, 2].map((k) => view.getFloat32(28 + 4 * k, true));
  const positionsAt = 40;
  const coloursAt = positionsAt + Math.ceil((vertices * 6) / 4) * 4;
  const normalsAt = coloursAt + vertices * 4;
  const indicesAt = normalsAt + vertices * 4;
  if (bytes.length !== indicesAt + triangles * 12) fail("its size does not match its counts");
  const indices = new Uint32Array(bytes.slice(indicesAt).buffer);
  if (indices.some((i) => i >= vertices)) fail("a triangle names a missing vertex");
  return {
    lo,
    scale,
    positions: new Uint16Array(bytes.slice(positionsAt, positionsAt + vertices * 6).buffer),
    colours: bytes.slice(coloursAt, coloursAt + vertices * 4),
    normals: new Int8Array(bytes.slice(normalsAt, normalsAt + vertices * 4).buffer),
    indices,
  };
}
