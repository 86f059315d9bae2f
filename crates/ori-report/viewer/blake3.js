// BLAKE3 (32-byte output, no key) of a byte array, after the BLAKE3 paper's reference
// implementation: 1024-byte chunks of 64-byte blocks, a binary tree of chaining values.
// The package reader checks every hash in a package with it (docs/FORMAT.md).
"use strict";

const BLAKE3_IV = new Uint32Array([
  0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19,
]);
const BLAKE3_PERMUTATION = [2, 6, 3, 10, 7, 0, 4, 13, 1, 11, 12, 5, 9, 14, 15, 8];
const CHUNK_START = 1, CHUNK_END = 2, PARENT = 4, ROOT = 8;

// The compression function: the first 8 words of the output into `out` (a chaining value).
// The state and message live in locals and two scratch arrays: hashing a package is most of
// the time it takes to open one.
const BLAKE3_SCHEDULE = (() => {
  const rounds = [];
  let order = [...Array(16).keys()];
  for (let r = 0; r < 7; r++) {
    rounds.push(order);
    order = BLAKE3_PERMUTATION.map((i) => order[i]);
  }
  return rounds;
})();
const blake3State = new Uint32Array(16);

function blake3Compress(cv, m, counter, blockLen, flags, out) {
  const s = blake3State;
  s.set(cv, 0);
  s[8] = BLAKE3_IV[0];
  s[9] = BLAKE3_IV[1];
  s[10] = BLAKE3_IV[2];
  s[11] = BLAKE3_IV[3];
  s[12] = counter % 0x100000000;
  s[13] = Math.floor(counter / 0x100000000);
  s[14] = blockLen;
  s[15] = flags;
  const g = (a, b, c, d, x, y) => {
    let va = s[a], vb = s[b], vc = s[c], vd = s[d];
    va = (va + vb + x) | 0;
    vd ^= va; vd = (vd >>> 16) | (vd << 16);
    vc = (vc + vd) | 0;
    vb ^= vc; vb = (vb >>> 12) | (vb << 20);
    va = (va + vb + y) | 0;
    vd ^= va; vd = (vd >>> 8) | (vd << 24);
    vc = (vc + vd) | 0;
    vb ^= vc; vb = (vb >>> 7) | (vb << 25);
    s[a] = va; s[b] = vb; s[c] = vc; s[d] = vd;
  };
  for (let round = 0; round < 7; round++) {
    const o = BLAKE3_SCHEDULE[round];
    g(0, 4, 8, 12, m[o[0]], m[o[1]]); g(1, 5, 9, 13, m[o[2]], m[o[3]]);
    g(2, 6, 10, 14, m[o[4]], m[o[5]]); g(3, 7, 11, 15, m[o[6]], m[o[7]]);
    g(0, 5, 10, 15, m[o[8]], m[o[9]]); g(1, 6, 11, 12, m[o[10]], m[o[11]]);
    g(2, 7, 8, 13, m[o[12]], m[o[13]]); g(3, 4, 9, 14, m[o[14]], m[o[15]]);
  }
  for (let i = 0; i < 8; i++) out[i] = s[i] ^ s[i + 8];
}

// Block `index` of `bytes` from `start` (zero-padded) as 16 little-endian words.
function blake3Block(bytes, start, len, words) {
  if (len === 64) {
    for (let w = 0, i = start; w < 16; w++, i += 4) {
      words[w] = bytes[i] | (bytes[i + 1] << 8) | (bytes[i + 2] << 16) | (bytes[i + 3] << 24);
    }
    return;
  }
  words.fill(0);
  for (let i = 0; i < len; i++) words[i >> 2] |= bytes[start + i] << (8 * (i & 3));
}

// A chunk's last compression, not yet done: its input, so that the root flag can be added.
function blake3ChunkOutput(bytes, start, end, chunkIndex) {
  const cv = Uint32Array.from(BLAKE3_IV);
  const words = new Uint32Array(16);
  let at = start;
  let flags = CHUNK_START;
  while (end - at > 64) {
    blake3Block(bytes, at, 64, words);
    blake3Compress(cv, words, chunkIndex, 64, flags, cv);
    flags = 0;
    at += 64;
  }
  blake3Block(bytes, at, end - at, words);
  return { cv, words, counter: chunkIndex, blockLen: end - at, flags: flags | CHUNK_END };
}

function blake3ParentOutput(left, right) {
  const words = new Uint32Array(16);
  words.set(left, 0);
  words.set(right, 8);
  return { cv: Uint32Array.from(BLAKE3_IV), words, counter: 0, blockLen: 64, flags: PARENT };
}

function blake3ChainingValue(o) {
  const cv = new Uint32Array(8);
  blake3Compress(o.cv, o.words, o.counter, o.blockLen, o.flags, cv);
  return cv;
}

// The BLAKE3 hash of `bytes` (a Uint8Array or a subarray of one): 32 bytes.
function blake3(bytes) {
  const chunks = Math.max(1, Math.ceil(bytes.length / 1024));
  const stack = [];
  for (let c = 0; c + 1 < chunks; c++) {
    let cv = blake3ChainingValue(blake3ChunkOutput(bytes, c * 1024, c * 1024 + 1024, c));
    // Merge completed subtrees: as many as trailing zero bits of the chunk count.
    for (let total = c + 1; (total & 1) === 0; total >>= 1) {
      cv = blake3ChainingValue(blake3ParentOutput(stack.pop(), cv));
    }
    stack.push(cv);
  }
  let output = blake3ChunkOutput(bytes, (chunks - 1) * 1024, bytes.length, chunks - 1);
  while (stack.length > 0) {
    output = blake3ParentOutput(stack.pop(), blake3ChainingValue(output));
  }
  const root = new Uint32Array(8);
  blake3Compress(output.cv, output.words, 0, output.blockLen, output.flags | ROOT, root);
  const out = new Uint8Array(32);
  for (let i = 0; i < 32; i++) out[i] = (root[i >> 2] >>> (8 * (i & 3))) & 255;
  return out;
}

function blake3Hex(bytes) {
  return Array.from(blake3(bytes), (b) => b.toString(16).padStart(2, "0")).join("");
}
