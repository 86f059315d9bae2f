// The `.ori` package reader, written from docs/FORMAT.md alone: every check of "Validation,
// in the order `read` applies it", for version 1 (one ORI) and version 2 (a hierarchy).
// Errors carry the kind the Rust reader names (`BadMagic`, `Truncated`, `UnsupportedVersion`,
// `IsHierarchy`, `Header`, `ManifestHash`, `Layout`, `Manifest`, `Texture`, `HashMismatch`).
// Depth codes follow docs/RUNTIME.md section 8; the column grid section 7.
"use strict";

class OriError extends Error {
  constructor(kind, message) {
    super(`${message} (${kind})`);
    this.kind = kind;
  }
}

const MAGIC = [0x4f, 0x52, 0x49, 0x50, 0x4b, 0x47, 0x0d, 0x0a];
const TWO32 = 0x100000000;

function u32At(bytes, at) {
  return (bytes[at] | (bytes[at + 1] << 8) | (bytes[at + 2] << 16)) + bytes[at + 3] * 0x1000000;
}

// A u64 as a number; values above 2^53 are not exact, but every such value is larger than
// any file, which is all the checks below need.
function u64At(bytes, at) {
  return u32At(bytes, at) + u32At(bytes, at + 4) * TWO32;
}

function hex(bytes) {
  return Array.from(bytes, (b) => b.toString(16).padStart(2, "0")).join("");
}

// ---- Canonical JSON (docs/FORMAT.md "Manifest") ------------------------------------------

// serde_json's float printing: the shortest digits that read back (to the f64, or with
// `bits32` to the f32), laid out as serde_json does: plain decimals for 10^-5 (f32: 10^-6) up
// to 10^16 (f32: 10^13), else scientific with `e-` or `e+` (`1e-7`, `1.5e+300`).
function ryuFormat(x, bits32) {
  if (x === 0) return Object.is(x, -0) ? "-0.0" : "0.0";
  const sign = x < 0 ? "-" : "";
  const a = Math.abs(x);
  const [digits, kk] = bits32 ? shortestF32(a) : shortestF64(a);
  const len = digits.length;
  const k = kk - len; // a = digits x 10^k, 10^(kk-1) <= a < 10^kk
  const max = bits32 ? 13 : 16;
  const min = bits32 ? -6 : -5;
  let out;
  if (k >= 0 && kk <= max) out = digits + "0".repeat(k) + ".0";
  else if (kk > 0 && kk <= max) out = digits.slice(0, kk) + "." + digits.slice(kk);
  else if (kk > min && kk <= 0) out = "0." + "0".repeat(-kk) + digits;
  else {
    const e = kk - 1;
    const exp = e < 0 ? `e${e}` : `e+${e}`;
    out = (len === 1 ? digits : digits[0] + "." + digits.slice(1)) + exp;
  }
  return sign + out;
}

// Digits (no trailing zeros) and decimal exponent `kk` of a scientific form `d.ddd e(kk-1)`.
function splitScientific(text) {
  const [mant, expText] = text.split("e");
  return [mant.replace(".", "").replace(/0+$/, "") || "0", Number(expText) + 1];
}

function shortestF64(a) {
  return splitScientific(a.toExponential());
}

// The shortest digits that read back to the f32 `a`, the closest to it among those.
function shortestF32(a) {
  for (let p = 1; p <= 9; p++) {
    const [digits, kk] = splitScientific(a.toExponential(p - 1));
    const m = BigInt(digits.padEnd(p, "0"));
    let best = null;
    // The correctly rounded p digits, and their neighbours (at a power of two the interval
    // that reads back is lopsided).
    for (const c of [m - 1n, m, m + 1n]) {
      if (c <= 0n) continue;
      const text = `${c}e${kk - p}`;
      const value = Number(text);
      if (Math.fround(value) !== a) continue;
      if (best === null || Math.abs(value - a) < Math.abs(best.value - a)) best = { text, value };
    }
    if (best !== null) return splitScientific(best.value.toExponential(p - 1));
  }
  return splitScientific(a.toExponential(8));
}

// A JSON object as read: its [key, value] pairs in file order.
class JsonObject {
  constructor(pairs) {
    this.pairs = pairs;
  }
}

// A JSON number as read: its value, the text it was written as, and whether it is a float.
class JsonNumber {
  constructor(text) {
    this.text = text;
    this.value = Number(text);
    this.isFloat = /[.eE]/.test(text);
  }
}

// Parses `bytes` as compact serde_json output and rejects anything serde_json would not
// write: whitespace, escapes other than serde_json's, non-canonical numbers. Objects become
// `JsonObject`s (order kept), numbers `JsonNumber`s.
function parseCanonicalJson(bytes) {
  let text;
  try {
    text = new TextDecoder("utf-8", { fatal: true, ignoreBOM: true }).decode(bytes);
  } catch (e) {
    throw new OriError("Manifest", "the manifest is not UTF-8");
  }
  let at = 0;
  const fail = (what) => {
    throw new OriError("Manifest", `not canonical JSON at byte ${at}: ${what}`);
  };
  const SHORT = { '"': '"', "\\": "\\", b: "\b", t: "\t", n: "\n", f: "\f", r: "\r" };
  const string = () => {
    at++; // the opening quote
    let out = "";
    for (;;) {
      if (at >= text.length) fail("unterminated string");
      const c = text[at];
      const code = text.charCodeAt(at);
      if (c === '"') {
        at++;
        return out;
      }
      if (code < 0x20) fail("a raw control character in a string");
      if (c !== "\\") {
        out += c;
        at++;
        continue;
      }
      const e = text[at + 1];
      if (e in SHORT) {
        out += SHORT[e];
        at += 2;
        continue;
      }
      const m = /^u00([0-1][0-9a-f])/.exec(text.slice(at + 1, at + 6));
      const value = m ? parseInt(m[1], 16) : -1;
      if (value < 0 || "\b\t\n\f\r".includes(String.fromCharCode(value))) {
        fail("an escape serde_json does not write");
      }
      out += String.fromCharCode(value);
      at += 6;
    }
  };
  const number = () => {
    const m = /^-?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][-+]?[0-9]+)?/.exec(text.slice(at, at + 400));
    if (!m) fail("a bad number");
    at += m[0].length;
    const n = new JsonNumber(m[0]);
    if (!Number.isFinite(n.value)) fail("a number out of range");
    // Every float as serde_json prints an f64; f32 fields are held to their own form later.
    // Integers beyond u64 and i64 read as floats and print in float form.
    if (n.isFloat) {
      if (ryuFormat(n.value, false) !== n.text && ryuFormat(Math.fround(n.value), true) !== n.text) {
        fail(`the float ${n.text} is not in its shortest form`);
      }
    } else {
      const big = BigInt(n.text);
      if (n.text === "-0" || big > 18446744073709551615n || big < -9223372036854775808n) fail(`the integer ${n.text}`);
    }
    return n;
  };
  const value = (depth) => {
    if (depth > 127) fail("nested too deeply");
    const c = text[at];
    if (c === "{") {
      at++;
      const pairs = [];
      if (text[at] === "}") {
        at++;
        return new JsonObject(pairs);
      }
      for (;;) {
        if (text[at] !== '"') fail("expected a key");
        const key = string();
        if (text[at] !== ":") fail("expected ':'");
        at++;
        pairs.push([key, value(depth + 1)]);
        if (text[at] === ",") {
          at++;
          continue;
        }
        if (text[at] === "}") {
          at++;
          return new JsonObject(pairs);
        }
        fail("expected ',' or '}'");
      }
    }
    if (c === "[") {
      at++;
      const items = [];
      if (text[at] === "]") {
        at++;
        return items;
      }
      for (;;) {
        items.push(value(depth + 1));
        if (text[at] === ",") {
          at++;
          continue;
        }
        if (text[at] === "]") {
          at++;
          return items;
        }
        fail("expected ',' or ']'");
      }
    }
    if (c === '"') return string();
    for (const [word, v] of [["true", true], ["false", false], ["null", null]]) {
      if (text.startsWith(word, at)) {
        at += word.length;
        return v;
      }
    }
    return number();
  };
  const root = value(0);
  if (at !== text.length) fail("bytes after the JSON value");
  return root;
}

// Schema reading: each helper checks one JSON type and names the field on failure.
const bad = (message) => {
  throw new OriError("Manifest", message);
};

function fields(object, names, where) {
  if (!(object instanceof JsonObject)) bad(`${where} must be an object`);
  const pairs = object.pairs;
  const keys = pairs.map((p) => p[0]);
  if (keys.join("\n") !== names.join("\n")) {
    bad(`${where} has fields [${keys.join(", ")}], expected exactly [${names.join(", ")}] in that order`);
  }
  return Object.fromEntries(pairs);
}

function integer(v, where, max = 0xffffffff) {
  if (!(v instanceof JsonNumber) || v.isFloat || v.value < 0 || v.value > max) {
    bad(`${where} must be an integer in 0..=${max}`);
  }
  return v.value;
}

// A u64 field, exactly (a BigInt): offsets and lengths are checked against the file with
// u64 arithmetic.
function u64(v, where) {
  if (!(v instanceof JsonNumber) || v.isFloat || v.text.startsWith("-")) bad(`${where} must be an integer in 0..=2^64-1`);
  return BigInt(v.text);
}

function float(v, where, bits32) {
  const value = v instanceof JsonNumber ? (bits32 ? Math.fround(v.value) : v.value) : NaN;
  if (!(v instanceof JsonNumber) || !v.isFloat || ryuFormat(value, bits32) !== v.text) {
    bad(`${where} must be a float in its shortest ${bits32 ? "f32" : "f64"} form`);
  }
  return value;
}

function floats(v, n, where, bits32) {
  if (!Array.isArray(v) || v.length !== n) bad(`${where} must be ${n} floats`);
  return v.map((x, i) => float(x, `${where}[${i}]`, bits32));
}

function str(v, where) {
  if (typeof v !== "string") bad(`${where} must be a string`);
  return v;
}

function bool(v, where) {
  if (typeof v !== "boolean") bad(`${where} must be true or false`);
  return v;
}

function isHashHex(s) {
  return typeof s === "string" && /^[0-9a-f]{64}$/.test(s);
}

function isPowerOfTwo(n) {
  return n > 0 && (n & (n - 1)) === 0;
}

// `params`: any JSON object with its keys sorted byte-wise at every depth, kept as plain
// JavaScript objects and arrays with `JsonNumber`s.
function plain(v, where) {
  if (v instanceof JsonNumber) {
    if (v.isFloat && ryuFormat(v.value, false) !== v.text) bad(`${where}: the float ${v.text} is not in its shortest form`);
    return v;
  }
  if (Array.isArray(v)) return v.map((x, i) => plain(x, `${where}[${i}]`));
  if (!(v instanceof JsonObject)) return v;
  const out = Object.create(null);
  v.pairs.forEach(([key, value], i) => {
    if (i > 0 && !utf8Less(v.pairs[i - 1][0], key)) bad(`${where}: keys not in sorted order at ${key}`);
    out[key] = plain(value, `${where}.${key}`);
  });
  return out;
}

function utf8Less(a, b) {
  const x = new TextEncoder().encode(a);
  const y = new TextEncoder().encode(b);
  for (let i = 0; i < Math.min(x.length, y.length); i++) {
    if (x[i] !== y[i]) return x[i] < y[i];
  }
  return x.length < y.length;
}

const dot3 = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross3 = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const TOLERANCE = 1e-6;

function unit(v, where) {
  const len = Math.sqrt(dot3(v, v));
  if (Math.abs(len - 1) > TOLERANCE) bad(`${where} has length ${len}, expected 1`);
}

const TEXTURE_FORMATS = ["r8", "bc4", "bc5", "bc1_srgb"];

function textureRef(v, where) {
  const f = fields(v, ["format", "offset", "length", "blake3"], where);
  const format = str(f.format, `${where}.format`);
  if (!TEXTURE_FORMATS.includes(format)) bad(`${where}.format ${format} is not a texture format`);
  return {
    format,
    offset: u64(f.offset, `${where}.offset`),
    length: u64(f.length, `${where}.length`),
    blake3: str(f.blake3, `${where}.blake3`),
  };
}

function impostor(v, resolution, where) {
  const f = fields(v, ["direction", "frame", "center", "half_size", "near", "far", "occupied", "depth", "normal", "albedo"], where);
  if (!Array.isArray(f.frame) || f.frame.length !== 3) bad(`${where}.frame must be 3 vectors`);
  const imp = {
    direction: floats(f.direction, 3, `${where}.direction`, false),
    frame: f.frame.map((a, k) => floats(a, 3, `${where}.frame[${k}]`, false)),
    center: floats(f.center, 2, `${where}.center`, false),
    half_size: float(f.half_size, `${where}.half_size`, false),
    near: float(f.near, `${where}.near`, false),
    far: float(f.far, `${where}.far`, false),
    occupied: floats(f.occupied, 6, `${where}.occupied`, true),
    depth: textureRef(f.depth, `${where}.depth`),
    normal: textureRef(f.normal, `${where}.normal`),
    albedo: textureRef(f.albedo, `${where}.albedo`),
  };
  const [u, vv, d] = imp.frame;
  unit(imp.direction, `${where}.direction`);
  unit(u, `${where}: frame u`);
  unit(vv, `${where}: frame v`);
  unit(d, `${where}: frame d`);
  for (const [name, x] of [["u . v", dot3(u, vv)], ["u . d", dot3(u, d)], ["v . d", dot3(vv, d)]]) {
    if (Math.abs(x) > TOLERANCE) bad(`${where}: frame is not orthogonal: ${name} = ${x}`);
  }
  if (dot3(cross3(u, vv), d) <= 0) bad(`${where}: frame is left-handed`);
  if ([0, 1, 2].some((k) => Math.abs(d[k] - imp.direction[k]) > TOLERANCE)) bad(`${where}: frame d differs from direction`);
  if (imp.half_size <= 0) bad(`${where}.half_size must be > 0`);
  if (imp.near <= imp.far) bad(`${where}: near must be greater than far`);
  const [x0, x1, y0, y1, z0, z1] = imp.occupied;
  if (!(0 <= x0 && x0 <= x1 && x1 <= resolution && 0 <= y0 && y0 <= y1 && y1 <= resolution)) {
    bad(`${where}.occupied texel box is not inside the map`);
  }
  if (!(0 <= z0 && z0 <= z1 && z1 <= 254)) bad(`${where}.occupied depth codes are not 0 <= z0 <= z1 <= 254`);
  return imp;
}

// The manifest of a version-1 package, checked field by field (docs/FORMAT.md "Fields").
function manifestOf(root) {
  const f = fields(root, ["format_version", "tool", "source", "bounding_sphere", "resolution", "depth_format", "impostors", "selection", "plt", "params"], "manifest");
  const m = {};
  m.format_version = integer(f.format_version, "format_version", 0xffffffff);
  if (m.format_version !== 1) bad(`format_version is ${m.format_version}, expected 1 (the header's version)`);
  m.tool = str(f.tool, "tool");
  if (m.tool === "") bad("tool is empty");
  const source = fields(f.source, ["name", "blake3"], "source");
  m.source = { name: str(source.name, "source.name"), blake3: str(source.blake3, "source.blake3") };
  if (m.source.name === "" || m.source.name.startsWith("/")) bad("source.name must be a relative path");
  if (!isHashHex(m.source.blake3)) bad("source.blake3 is not 64 lowercase hex digits");
  const sphere = fields(f.bounding_sphere, ["center", "radius"], "bounding_sphere");
  m.bounding_sphere = {
    center: floats(sphere.center, 3, "bounding_sphere.center", false),
    radius: float(sphere.radius, "bounding_sphere.radius", false),
  };
  if (!(m.bounding_sphere.radius > 0)) bad("bounding_sphere.radius must be > 0");
  m.resolution = integer(f.resolution, "resolution", 0xffffffff);
  if (!isPowerOfTwo(m.resolution) || m.resolution < 4 || m.resolution > 8192) bad(`resolution ${m.resolution} is not a power of two in 4..=8192`);
  m.depth_format = str(f.depth_format, "depth_format");
  if (!TEXTURE_FORMATS.includes(m.depth_format)) bad(`depth_format ${m.depth_format} is not a texture format`);
  if (m.depth_format !== "r8" && m.depth_format !== "bc4") bad(`depth_format ${m.depth_format} is not r8 or bc4`);
  if (!Array.isArray(f.impostors) || f.impostors.length < 1 || f.impostors.length > 256) bad("1 to 256 impostors allowed");
  m.impostors = f.impostors.map((v, i) => impostor(v, m.resolution, `impostors[${i}]`));
  const sel = fields(f.selection, ["directions", "rule", "goal_percent", "s0", "entries"], "selection");
  m.selection = {
    directions: str(sel.directions, "selection.directions"),
    rule: str(sel.rule, "selection.rule"),
    goal_percent: float(sel.goal_percent, "selection.goal_percent", false),
    s0: integer(sel.s0, "selection.s0", 0xffffffff),
  };
  if (m.selection.directions !== "icosahedron-320") bad("selection.directions must be icosahedron-320");
  if (m.selection.rule === "") bad("selection.rule is empty");
  if (!(m.selection.goal_percent >= 0 && m.selection.goal_percent <= 100)) bad("selection.goal_percent is not in [0, 100]");
  if (m.selection.s0 === 0) bad("selection.s0 is 0");
  if (!Array.isArray(sel.entries) || sel.entries.length !== 320) bad("selection must have 320 entries");
  const pixels = m.selection.s0 * m.selection.s0;
  m.selection.entries = sel.entries.map((v, e) => {
    const entry = fields(v, ["impostors", "missed"], `selection entry ${e}`);
    if (!Array.isArray(entry.impostors) || entry.impostors.length === 0) bad(`selection entry ${e} draws no impostor`);
    const list = entry.impostors.map((x) => integer(x, `selection entry ${e}`, 0xffff));
    if (list.some((i) => i >= m.impostors.length)) bad(`selection entry ${e} names a missing impostor`);
    if (new Set(list).size !== list.length) bad(`selection entry ${e} names an impostor twice`);
    const missed = integer(entry.missed, `selection entry ${e}.missed`, 0xffffffff);
    if (missed > pixels) bad(`selection entry ${e} misses more than s0 x s0 pixels`);
    return { impostors: list, missed };
  });
  const plt = fields(f.plt, ["s0", "gc", "pixels", "at_least", "recommended_resolution", "measured_by"], "plt");
  m.plt = {
    s0: integer(plt.s0, "plt.s0", 0xffffffff),
    gc: integer(plt.gc, "plt.gc", 0xffffffff),
    pixels: float(plt.pixels, "plt.pixels", false),
    at_least: bool(plt.at_least, "plt.at_least"),
    recommended_resolution: integer(plt.recommended_resolution, "plt.recommended_resolution", 0xffffffff),
    measured_by: str(plt.measured_by, "plt.measured_by"),
  };
  if (m.plt.s0 !== m.selection.s0) bad("plt.s0 differs from selection.s0");
  if (m.plt.gc > m.plt.s0 * m.plt.s0) bad("plt.gc is more than s0 x s0");
  const s2 = m.plt.s0 * m.plt.s0;
  if (m.plt.pixels !== (m.plt.gc === 0 ? s2 : s2 / m.plt.gc)) bad("plt.pixels is not s0 * s0 / gc");
  if (m.plt.at_least !== (m.plt.gc === 0)) bad("plt.at_least must be true exactly when gc is 0");
  if (!isPowerOfTwo(m.plt.recommended_resolution)) bad("plt.recommended_resolution is not a power of two");
  if (!(f.params instanceof JsonObject)) bad("params must be a JSON object");
  m.params = plain(f.params, "params");
  for (const [i, imp] of m.impostors.entries()) {
    for (const [map, expected] of [["depth", m.depth_format], ["normal", "bc5"], ["albedo", "bc1_srgb"]]) {
      if (imp[map].format !== expected) {
        throw new OriError("Texture", `impostor ${i} ${map}: declared as ${imp[map].format}, expected ${expected}`);
      }
    }
  }
  for (const [i, imp] of m.impostors.entries()) {
    for (const map of ["depth", "normal", "albedo"]) {
      if (!isHashHex(imp[map].blake3)) bad(`impostor ${i} ${map}: blake3 is not 64 lowercase hex digits`);
    }
  }
  return m;
}

// ---- Header and layout ---------------------------------------------------------------------

// Header checks shared by both versions: the manifest bytes and where the payload starts.
function headerVersion(bytes) {
  for (let i = 0; i < Math.min(bytes.length, 8); i++) {
    if (bytes[i] !== MAGIC[i]) throw new OriError("BadMagic", "not an .ori package (bad magic)");
  }
  if (bytes.length < 64) throw new OriError("Truncated", "the file ends inside the header");
  return u32At(bytes, 8);
}

function frame(bytes, versions) {
  const version = headerVersion(bytes);
  if (!versions.includes(version)) {
    if (version === 2) throw new OriError("IsHierarchy", "a hierarchy package (version 2)");
    throw new OriError("UnsupportedVersion", `format version ${version} is not supported`);
  }
  if (u32At(bytes, 12) !== 0) throw new OriError("Header", "nonzero flags");
  const high = u32At(bytes, 20);
  const length = u64At(bytes, 16);
  if (high === 0xffffffff && u32At(bytes, 16) > 0xffffffff - 64) throw new OriError("Header", "manifest length overflows");
  const end = 64 + length;
  if (end > bytes.length) throw new OriError("Truncated", "the file ends inside the manifest");
  const payload = u64At(bytes, 56);
  if (payload !== Math.ceil(end / 256) * 256) throw new OriError("Header", `payload offset ${payload} is not the first multiple of 256 after the manifest`);
  if (payload > bytes.length) throw new OriError("Truncated", "the file ends inside the padding after the manifest");
  const json = bytes.subarray(64, end);
  if (hex(blake3(json)) !== hex(bytes.subarray(24, 56))) throw new OriError("ManifestHash", "the manifest's blake3 does not match the header");
  for (let i = end; i < payload; i++) {
    if (bytes[i] !== 0) throw new OriError("Layout", "nonzero padding after the manifest");
  }
  return { version, json, payload };
}

// The packing rule of docs/FORMAT.md "Textures" for parts `[{what, offset, length}]`
// (offsets and lengths as BigInt: the checks are u64 arithmetic, as the format's).
function checkPacked(bytes, payload, parts) {
  const have = BigInt(bytes.length);
  const U64_MAX = 18446744073709551615n;
  const alignUp = (x) => {
    const up = ((x + 255n) / 256n) * 256n;
    return up > U64_MAX ? U64_MAX : up;
  };
  let pos = BigInt(payload);
  for (const p of parts) {
    if (p.offset % 256n !== 0n) throw new OriError("Layout", `${p.what} is misaligned`);
    if (p.offset < pos) throw new OriError("Layout", `${p.what} overlaps the part before it`);
    if (p.offset !== alignUp(pos)) throw new OriError("Layout", `${p.what}: a gap before it`);
    const end = p.offset + p.length;
    if (end > U64_MAX) throw new OriError("Layout", `${p.what}: its length is impossibly large`);
    if (end > have) throw new OriError("Truncated", `${p.what}: the file ends inside the texture data`);
    for (let i = Number(pos); i < Number(p.offset); i++) {
      if (bytes[i] !== 0) throw new OriError("Layout", `nonzero padding before ${p.what}`);
    }
    pos = end;
  }
  if (pos !== have) throw new OriError("Layout", "trailing bytes after the last part");
}

// The bytes of a part `checkPacked` accepted.
function partOf(bytes, ref) {
  return bytes.subarray(Number(ref.offset), Number(ref.offset + ref.length));
}

const VK_FORMATS = { r8: 9, bc4: 139, bc5: 141, bc1_srgb: 132 };
const COLOR_MODELS = { 9: 1, 131: 128, 132: 128, 139: 131, 141: 132 };
const KTX2_IDENTIFIER = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x32, 0x30, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];

function levelSize(vk, w, h) {
  if (vk === 9) return w * h;
  const blocks = Math.ceil(w / 4) * Math.ceil(h / 4);
  return blocks * (vk === 141 ? 16 : 8);
}

// Level 0 of a KTX2 file, checked as `ori_texture::Ktx2::from_bytes` does.
function ktx2Level0(file, format, resolution, what) {
  const fail = (m) => {
    throw new OriError("Texture", `${what}: ${m}`);
  };
  if (file.length < 80) fail("shorter than the KTX2 header");
  if (!KTX2_IDENTIFIER.every((b, i) => file[i] === b)) fail("not a KTX2 file (bad identifier)");
  const vk = u32At(file, 12);
  if (!(vk in COLOR_MODELS)) fail(`unsupported vkFormat ${vk}`);
  const width = u32At(file, 20);
  const height = u32At(file, 24);
  if (u32At(file, 16) !== 1) fail("typeSize is not 1");
  if (width === 0 || height === 0 || u32At(file, 28) !== 0) fail("only 2D textures are supported");
  if (u32At(file, 32) > 1 || u32At(file, 36) !== 1) fail("array and cube-map textures are not supported");
  if (u32At(file, 44) !== 0) fail("supercompression is not supported");
  const levels = Math.max(1, u32At(file, 40));
  const chain = Math.floor(Math.log2(Math.max(width, height))) + 1;
  if (levels > chain) fail(`${levels} levels for ${width} x ${height}`);
  if (file.length < 80 + 24 * levels) fail("truncated level index");
  const dfdOffset = u32At(file, 48);
  const dfdLength = u32At(file, 52);
  if (dfdOffset + dfdLength > file.length) fail("data format descriptor lies outside the file");
  const dfd = file.subarray(dfdOffset, dfdOffset + dfdLength);
  if (dfd.length < 28 || u32At(dfd, 0) !== dfd.length) fail("data format descriptor: wrong size");
  if (u32At(dfd, 4) !== 0) fail("data format descriptor: not a Khronos basic block");
  if (dfd[12] !== COLOR_MODELS[vk]) fail("data format descriptor: colour model does not match");
  if (dfd[14] !== (vk === 132 ? 2 : 1)) fail("data format descriptor: transfer function does not match");
  let level0 = null;
  for (let l = 0; l < levels; l++) {
    const entry = 80 + 24 * l;
    const offset = u64At(file, entry);
    const length = u64At(file, entry + 8);
    const w = Math.max(1, width >> l);
    const h = Math.max(1, height >> l);
    const expected = levelSize(vk, w, h);
    if (length !== expected || u64At(file, entry + 16) !== length) fail(`level ${l} has ${length} bytes, expected ${expected}`);
    if (offset + expected > file.length) fail(`level ${l} lies outside the file (truncated?)`);
    if (l === 0) level0 = file.subarray(offset, offset + expected);
  }
  if (vk !== VK_FORMATS[format]) fail(`KTX2 format is ${vk}, expected ${VK_FORMATS[format]}`);
  if (width !== resolution || height !== resolution) fail(`${width} x ${height} texels, expected ${resolution} x ${resolution}`);
  return level0;
}

// ---- Block decoding (docs/RUNTIME.md section 8; BC1 and BC5 for browsers without BC) -----

// BC4 block values as 8-bit codes, in the integer form of section 8 (equal to its f32 form).
function bc4Palette(r0, r1) {
  const p = [r0, r1];
  if (r0 > r1) {
    for (let i = 1; i <= 6; i++) p.push(Math.floor(((7 - i) * r0 + i * r1 + 3) / 7));
  } else {
    for (let i = 1; i <= 4; i++) p.push(Math.floor(((5 - i) * r0 + i * r1 + 2) / 5));
    p.push(0, 255);
  }
  return p;
}

// A BC4 (or one half of a BC5) level into one byte per texel at `stride` bytes apart.
function decodeBc4Into(data, blockBytes, blockOffset, n, out, stride, channel) {
  const blocks = Math.ceil(n / 4);
  for (let by = 0; by < blocks; by++) {
    for (let bx = 0; bx < blocks; bx++) {
      const b = (by * blocks + bx) * blockBytes + blockOffset;
      const palette = bc4Palette(data[b], data[b + 1]);
      let bits = 0;
      for (let t = 0; t < 16; t++) {
        const bit = 3 * t;
        const byte = b + 2 + (bit >> 3);
        const shift = bit & 7;
        const word = data[byte] | (byte + 1 < b + 8 ? data[byte + 1] << 8 : 0);
        bits = (word >> shift) & 7;
        const x = bx * 4 + (t & 3);
        const y = by * 4 + (t >> 2);
        if (x < n && y < n) out[(y * n + x) * stride + channel] = palette[bits];
      }
    }
  }
}

// Depth codes of level 0 (R8 bytes as they are).
function depthCodes(format, level, n) {
  if (format === "r8") return level;
  const codes = new Uint8Array(n * n);
  decodeBc4Into(level, 8, 0, n, codes, 1, 0);
  return codes;
}

function decodeBc5(level, n) {
  const out = new Uint8Array(n * n * 2);
  decodeBc4Into(level, 16, 0, n, out, 2, 0);
  decodeBc4Into(level, 16, 8, n, out, 2, 1);
  return out;
}

// BC1 as `ori_texture::decode` does it (f32 arithmetic), to RGBA8 with sRGB kept encoded.
function decodeBc1(level, n) {
  const f = Math.fround;
  const out = new Uint8Array(n * n * 4);
  const blocks = Math.ceil(n / 4);
  const toU8 = (v) => Math.floor(f(f(Math.min(Math.max(v, 0), 1) * 255) + 0.5));
  const expand = (w) => [f(((w >> 11) & 31) / 31), f(((w >> 5) & 63) / 63), f((w & 31) / 31)];
  for (let by = 0; by < blocks; by++) {
    for (let bx = 0; bx < blocks; bx++) {
      const b = (by * blocks + bx) * 8;
      const w0 = level[b] | (level[b + 1] << 8);
      const w1 = level[b + 2] | (level[b + 3] << 8);
      const c0 = expand(w0);
      const c1 = expand(w1);
      const palette = [c0, c1];
      if (w0 > w1) {
        palette.push(c0.map((c, k) => f(f(f(2 * c) + c1[k]) / 3)), c0.map((c, k) => f(f(c + f(2 * c1[k])) / 3)));
      } else {
        palette.push(c0.map((c, k) => f(f(c + c1[k]) / 2)), [0, 0, 0]);
      }
      const bits = u32At(level, b + 4);
      for (let t = 0; t < 16; t++) {
        const x = bx * 4 + (t & 3);
        const y = by * 4 + (t >> 2);
        if (x >= n || y >= n) continue;
        const c = palette[Math.floor(bits / 4 ** t) & 3];
        const o = (y * n + x) * 4;
        out[o] = toU8(c[0]);
        out[o + 1] = toU8(c[1]);
        out[o + 2] = toU8(c[2]);
        out[o + 3] = 255;
      }
    }
  }
  return out;
}

// The column grid of a map (RUNTIME.md section 7): per 8 x 8 cell the least code, 255 if none.
function columnTops(codes, n) {
  const k = Math.ceil(n / 8);
  const tops = new Uint8Array(k * k).fill(255);
  for (let row = 0; row < n; row++) {
    for (let col = 0; col < n; col++) {
      const cell = (row >> 3) * k + (col >> 3);
      const c = codes[row * n + col];
      if (c < tops[cell]) tops[cell] = c;
    }
  }
  return { k, tops };
}

// ---- Packages ------------------------------------------------------------------------------

// The search parameters recorded in `params.select` (RUNTIME.md section 7), defaults otherwise.
function recordedMarch(params) {
  const select = params && typeof params.select === "object" && params.select !== null ? params.select : {};
  const int = (v, lo, hi, d) => (v instanceof JsonNumber && !v.isFloat && v.value >= lo && v.value <= hi ? v.value : d);
  const w = select.wall_threshold;
  return {
    linearSteps: int(select.linear_steps, 1, 1024, 16),
    binarySteps: int(select.binary_steps, 0, 32, 7),
    wallThreshold: Math.fround(w instanceof JsonNumber && Number.isFinite(w.value) && w.value >= 0 ? w.value : 0.25),
  };
}

// A version-1 package: `{manifest, march, maps}`; each map holds level 0 of its three
// textures, the depth codes and the column grid.
function readPackage(bytes) {
  const { json, payload } = frame(bytes, [1]);
  const manifest = manifestOf(parseCanonicalJson(json));
  const parts = [];
  manifest.impostors.forEach((imp, i) => {
    for (const map of ["depth", "normal", "albedo"]) {
      parts.push({ what: `impostor ${i} ${map}`, offset: imp[map].offset, length: imp[map].length, ref: imp[map], i, map });
    }
  });
  checkPacked(bytes, payload, parts);
  // Per texture in file order: its hash, then its KTX2 (as the Rust reader).
  const n = manifest.resolution;
  const levels = parts.map((p) => {
    const file = partOf(bytes, p.ref);
    if (hex(blake3(file)) !== p.ref.blake3) {
      throw new OriError("HashMismatch", `impostor ${p.i} ${p.map}: its blake3 does not match the manifest`);
    }
    return ktx2Level0(file, p.ref.format, n, `impostor ${p.i} ${p.map}`);
  });
  const maps = manifest.impostors.map((imp, i) => {
    const [depth, normal, albedo] = levels.slice(3 * i, 3 * i + 3);
    const codes = depthCodes(manifest.depth_format, depth, n);
    return { depth, normal, albedo, codes, columns: columnTops(codes, n) };
  });
  return { version: 1, manifest, march: recordedMarch(manifest.params), maps };
}

// A hierarchy (version 2): `{manifest, nodes}` with every node package read.
function readHierarchy(bytes) {
  const { json, payload } = frame(bytes, [2]);
  const f = fields(parseCanonicalJson(json), ["format_version", "tool", "source", "split", "target_px", "nodes"], "hierarchy manifest");
  const m = {
    format_version: integer(f.format_version, "format_version", 0xffffffff),
    tool: str(f.tool, "tool"),
    split: str(f.split, "split"),
    target_px: float(f.target_px, "target_px", false),
  };
  const source = fields(f.source, ["name", "blake3"], "source");
  m.source = { name: str(source.name, "source.name"), blake3: str(source.blake3, "source.blake3") };
  if (m.format_version !== 2) bad("format_version must be 2");
  if (m.tool === "") bad("tool is empty");
  if (m.split !== "octree" && m.split !== "kd") bad(`split ${m.split} is not octree or kd`);
  if (!(m.target_px > 0)) bad("target_px must be > 0");
  if (!Array.isArray(f.nodes) || f.nodes.length < 1 || f.nodes.length > 8192) bad("1 to 8192 nodes allowed");
  const count = f.nodes.length;
  const parent = new Array(count).fill(-1);
  m.nodes = f.nodes.map((v, i) => {
    const node = fields(v, ["bounds", "children", "package"], `node ${i}`);
    if (!Array.isArray(node.bounds) || node.bounds.length !== 2) bad(`node ${i}: bounds must be [min, max]`);
    const bounds = node.bounds.map((b, k) => floats(b, 3, `node ${i} bounds[${k}]`, false));
    if (![0, 1, 2].every((k) => bounds[0][k] <= bounds[1][k])) bad(`node ${i}: bounds min > max`);
    if (!Array.isArray(node.children)) bad(`node ${i}: children must be an array`);
    const children = node.children.map((c) => integer(c, `node ${i} children`, 0xffffffff));
    for (const c of children) {
      if (c <= i || c >= count) bad(`node ${i}: child ${c} is not after it and in the tree`);
      if (parent[c] !== -1) bad(`node ${c} has two parents`);
      parent[c] = i;
    }
    const p = fields(node.package, ["offset", "length", "blake3"], `node ${i} package`);
    const pkg = { offset: u64(p.offset, `node ${i} offset`), length: u64(p.length, `node ${i} length`), blake3: str(p.blake3, `node ${i} blake3`) };
    if (!isHashHex(pkg.blake3)) bad(`node ${i} package blake3 is not 64 lowercase hex digits`);
    return { bounds, children, package: pkg };
  });
  for (let i = 1; i < count; i++) if (parent[i] === -1) bad(`node ${i} is nobody's child`);
  for (let i = 1; i < count; i++) {
    const [lo, hi] = m.nodes[i].bounds;
    const [plo, phi] = m.nodes[parent[i]].bounds;
    if (![0, 1, 2].every((k) => lo[k] >= plo[k] && hi[k] <= phi[k])) bad(`node ${i} is not inside its parent's cell`);
  }
  checkPacked(bytes, payload, m.nodes.map((n, i) => ({ what: `node ${i} package`, offset: n.package.offset, length: n.package.length })));
  const nodes = m.nodes.map((n, i) => {
    const data = partOf(bytes, n.package);
    if (hex(blake3(data)) !== n.package.blake3) bad(`node ${i} package is corrupt: its blake3 does not match the manifest`);
    let pkg;
    try {
      pkg = readPackage(data);
    } catch (e) {
      bad(`node ${i} package: ${e.message}`);
    }
    if (pkg.manifest.source.name !== m.source.name || pkg.manifest.source.blake3 !== m.source.blake3) {
      bad(`node ${i} package names another source`);
    }
    return pkg;
  });
  return { version: 2, manifest: m, nodes };
}

// Either version: `readPackage` or `readHierarchy` by the header's version.
function readAnyPackage(bytes) {
  return headerVersion(bytes) === 2 ? readHierarchy(bytes) : readPackage(bytes);
}

// ---- Directions (RUNTIME.md section 2) -----------------------------------------------------

// RUNTIME.md section 1's normalize: each component divided by the length; a zero vector is
// returned as it is (`normalize0` of section 4).
function normalize0(a) {
  const len = Math.sqrt(dot3(a, a));
  return len > 0 ? [a[0] / len, a[1] / len, a[2] / len] : a;
}

// The 320 table directions, bit for bit: level 2 of the geodesic icosahedron.
function tableDirections() {
  const phi = 0.5 * (1.0 + Math.sqrt(5.0));
  const raw = [];
  for (let shape = 0; shape < 3; shape++) {
    for (const s1 of [1.0, -1.0]) {
      for (const s2 of [1.0, -1.0]) {
        raw.push(shape === 0 ? [0.0, s1, s2 * phi] : shape === 1 ? [s1, s2 * phi, 0.0] : [s1 * phi, 0.0, s2]);
      }
    }
  }
  const unitV = raw.map(normalize0);
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const adjacent = (i, j) => dot3(sub(raw[i], raw[j]), sub(raw[i], raw[j])) < 5.0;
  let faces = [];
  for (let i = 0; i < 12; i++) {
    for (let j = i + 1; j < 12; j++) {
      for (let k = j + 1; k < 12; k++) {
        if (adjacent(i, j) && adjacent(j, k) && adjacent(i, k)) {
          const [a, b, c] = [unitV[i], unitV[j], unitV[k]];
          const outward = dot3(cross3(sub(b, a), sub(c, a)), add(add(a, b), c)) > 0.0;
          faces.push(outward ? [a, b, c] : [a, c, b]);
        }
      }
    }
  }
  for (let level = 0; level < 2; level++) {
    const next = [];
    for (const [a, b, c] of faces) {
      const ab = normalize0(add(a, b));
      const bc = normalize0(add(b, c));
      const ca = normalize0(add(c, a));
      next.push([a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]);
    }
    faces = next;
  }
  return faces.map(([a, b, c]) => normalize0(add(add(a, b), c)));
}

// Computed once: every package shares the table's directions.
const TABLE_DIRECTIONS = tableDirections();

// RUNTIME.md section 10.1: the entry for unit view direction `w` (lowest index on ties).
function nearestEntry(directions, w) {
  let best = 0;
  let bestDot = -Infinity;
  for (let t = 0; t < directions.length; t++) {
    const d = directions[t];
    const x = (d[0] * w[0] + d[1] * w[1]) + d[2] * w[2];
    if (x > bestDot) {
      best = t;
      bestDot = x;
    }
  }
  return best;
}
