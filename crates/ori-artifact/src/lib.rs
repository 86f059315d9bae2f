//! The byte layout shared by every cached intermediate artifact (mesh, view plan, relief
//! maps, selection table, PLT, compressed textures):
//!
//! ```text
//! 8-byte magic naming the type, u32 layout version, then the type's fields
//! ```
//!
//! Little-endian throughout; `f32`/`f64` are stored as their bits, so values round-trip
//! exactly; a string is a `u32` byte length and UTF-8 bytes.
//!
//! A cache entry may be damaged or hostile, so a [`Reader`] checks every read against the
//! bytes that remain, [`Reader::count`] refuses a count the remaining bytes cannot hold before
//! anything is allocated, and [`Reader::finish`] refuses trailing bytes.
//!
//! This crate knows no artifact type: each type's crate writes its own fields.

/// Bytes that are not a valid artifact of the expected type.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("invalid {kind} artifact: {detail}")]
pub struct DecodeError {
    /// The artifact type, as its [`Layout`] names it.
    pub kind: &'static str,
    pub detail: String,
}

/// What identifies one artifact type's bytes.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Named in decode errors ("relief-map", "selection", ...).
    pub kind: &'static str,
    pub magic: [u8; 8],
    /// Raised whenever the fields change.
    pub version: u32,
}

impl Layout {
    /// Start an artifact: the magic and the version.
    pub fn writer(&self) -> Writer {
        let mut w = Writer(Vec::new());
        w.bytes(&self.magic);
        w.u32(self.version);
        w
    }

    /// Start reading `bytes`, checking the magic and the version.
    pub fn reader<'a>(&self, bytes: &'a [u8]) -> Result<Reader<'a>, DecodeError> {
        let mut r = Reader {
            kind: self.kind,
            bytes,
            at: 0,
        };
        if bytes.get(..8) != Some(&self.magic[..]) {
            return Err(r.error("bad magic"));
        }
        r.at = 8;
        let version = r.u32()?;
        if version != self.version {
            return Err(r.error(format!(
                "layout version {version}, expected {}",
                self.version
            )));
        }
        Ok(r)
    }
}

/// Appends little-endian fields after a [`Layout`]'s header.
pub struct Writer(Vec<u8>);

impl Writer {
    pub fn reserve(&mut self, additional: usize) {
        self.0.reserve(additional);
    }
    pub fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
    pub fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    pub fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn i32(&mut self, v: i32) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn f32(&mut self, v: f32) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn f64(&mut self, v: f64) {
        self.bytes(&v.to_le_bytes());
    }
    /// A count or length of at most `u32::MAX`.
    ///
    /// # Panics
    /// When `n` does not fit in a `u32`: no artifact this pipeline writes comes near it.
    pub fn count(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("an artifact count fits in a u32"));
    }
    /// `u32` byte length, then the UTF-8 bytes.
    pub fn string(&mut self, s: &str) {
        self.count(s.len());
        self.bytes(s.as_bytes());
    }
    /// `u64` byte length, then the bytes.
    pub fn blob(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.bytes(b);
    }
    pub fn finish(self) -> Vec<u8> {
        self.0
    }
}

/// Bounds-checked little-endian reads after a [`Layout`]'s header.
pub struct Reader<'a> {
    kind: &'static str,
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// A decode error for this artifact type.
    pub fn error(&self, detail: impl Into<String>) -> DecodeError {
        DecodeError {
            kind: self.kind,
            detail: detail.into(),
        }
    }

    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }

    pub fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| self.error(format!("truncated at byte {}", self.at)))?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], DecodeError> {
        Ok(self.take(N)?.try_into().expect("take returns N bytes"))
    }
    pub fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take(1)?[0])
    }
    pub fn u16(&mut self) -> Result<u16, DecodeError> {
        self.array().map(u16::from_le_bytes)
    }
    pub fn u32(&mut self) -> Result<u32, DecodeError> {
        self.array().map(u32::from_le_bytes)
    }
    pub fn i32(&mut self) -> Result<i32, DecodeError> {
        self.array().map(i32::from_le_bytes)
    }
    pub fn u64(&mut self) -> Result<u64, DecodeError> {
        self.array().map(u64::from_le_bytes)
    }
    pub fn f32(&mut self) -> Result<f32, DecodeError> {
        self.array().map(f32::from_le_bytes)
    }
    pub fn f64(&mut self) -> Result<f64, DecodeError> {
        self.array().map(f64::from_le_bytes)
    }

    /// A `u32` count of items that take at least `min_bytes_each` bytes each (at least 1),
    /// refused when the remaining bytes cannot hold that many: safe to allocate for.
    pub fn count(&mut self, min_bytes_each: usize) -> Result<usize, DecodeError> {
        let n = self.u32()? as usize;
        if n > self.remaining() / min_bytes_each.max(1) {
            return Err(self.error(format!("count {n} cannot fit in the artifact")));
        }
        Ok(n)
    }

    /// `count` groups of `N` little-endian `f32`s.
    pub fn f32_arrays<const N: usize>(
        &mut self,
        count: usize,
    ) -> Result<Vec<[f32; N]>, DecodeError> {
        let len = count.checked_mul(N * 4);
        let raw = self.take(len.ok_or_else(|| self.error("size overflows"))?)?;
        Ok(raw
            .chunks_exact(N * 4)
            .map(|c| {
                std::array::from_fn(|k| {
                    f32::from_le_bytes(c[k * 4..k * 4 + 4].try_into().expect("4 bytes"))
                })
            })
            .collect())
    }

    /// `count` groups of `N` bytes.
    pub fn byte_arrays<const N: usize>(
        &mut self,
        count: usize,
    ) -> Result<Vec<[u8; N]>, DecodeError> {
        let len = count.checked_mul(N);
        let raw = self.take(len.ok_or_else(|| self.error("size overflows"))?)?;
        Ok(raw
            .chunks_exact(N)
            .map(|c| c.try_into().expect("N bytes"))
            .collect())
    }

    /// A string written by [`Writer::string`].
    pub fn string(&mut self) -> Result<String, DecodeError> {
        let n = self.count(1)?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| self.error("string is not UTF-8"))
    }

    /// A blob written by [`Writer::blob`].
    pub fn blob(&mut self) -> Result<&'a [u8], DecodeError> {
        let n = self.u64()?;
        let n = usize::try_from(n).map_err(|_| self.error(format!("blob of {n} bytes")))?;
        self.take(n)
    }

    /// The end: refuses trailing bytes.
    pub fn finish(self) -> Result<(), DecodeError> {
        match self.remaining() {
            0 => Ok(()),
            n => Err(self.error(format!("{n} trailing bytes"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEST: Layout = Layout {
        kind: "test",
        magic: *b"ORITEST\0",
        version: 3,
    };

    fn sample() -> Vec<u8> {
        let mut w = TEST.writer();
        w.u8(7);
        w.u16(0xBEEF);
        w.i32(-1);
        w.f64(-0.5);
        w.string("é");
        w.blob(&[1, 2, 3]);
        w.finish()
    }

    #[test]
    fn round_trips_and_refuses_every_damage() {
        let bytes = sample();
        assert_eq!(&bytes[..12], b"ORITEST\0\x03\0\0\0");
        let mut r = TEST.reader(&bytes).unwrap();
        assert_eq!(r.u8().unwrap(), 7);
        assert_eq!(r.u16().unwrap(), 0xBEEF);
        assert_eq!(r.i32().unwrap(), -1);
        assert_eq!(r.f64().unwrap(), -0.5);
        assert_eq!(r.string().unwrap(), "é");
        assert_eq!(r.blob().unwrap(), &[1, 2, 3]);
        r.finish().unwrap();

        let read_all = |b: &[u8]| -> Result<(), DecodeError> {
            let mut r = TEST.reader(b)?;
            let _ = (
                r.u8()?,
                r.u16()?,
                r.i32()?,
                r.f64()?,
                r.string()?,
                r.blob()?,
            );
            r.finish()
        };
        for n in 0..bytes.len() {
            assert!(read_all(&bytes[..n]).is_err(), "prefix of {n} bytes read");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        let e = read_all(&longer).unwrap_err();
        assert_eq!(e.to_string(), "invalid test artifact: 1 trailing bytes");
        let mut other = bytes.clone();
        other[8] = 2;
        let e = read_all(&other).unwrap_err();
        assert_eq!(e.detail, "layout version 2, expected 3");
        other[0] = b'X';
        assert_eq!(read_all(&other).unwrap_err().detail, "bad magic");
    }

    #[test]
    fn counts_are_checked_before_allocation() {
        let mut w = TEST.writer();
        w.u32(u32::MAX);
        w.bytes(&[0; 8]);
        let bytes = w.finish();
        let mut r = TEST.reader(&bytes).unwrap();
        assert!(r.count(1).is_err());
        let mut w = TEST.writer();
        w.u32(2);
        w.bytes(&[0; 8]);
        let bytes = w.finish();
        assert_eq!(TEST.reader(&bytes).unwrap().count(4).unwrap(), 2);
        assert!(TEST.reader(&bytes).unwrap().count(5).is_err());
        let mut w = TEST.writer();
        w.u64(u64::MAX);
        let bytes = w.finish();
        assert!(TEST.reader(&bytes).unwrap().blob().is_err());
    }
}
