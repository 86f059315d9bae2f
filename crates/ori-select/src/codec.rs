//! The canonical byte layout of a [`Selection`], little-endian:
//! ```text
//! magic "ORISELT\0", u32 layout version
//! u8 rule (0 closest, 1 best), u32 M, f64 goal percent, u32 s0,
//! u32 impostor count n, u32 direction count
//! per direction: u32 coverage error (pixels), u8 count k, k x u16 impostor index
//! ```

use crate::{Entry, Rule, Selection};

const MAGIC: &[u8; 8] = b"ORISELT\0";
const LAYOUT_VERSION: u32 = 1;

/// Bytes that are not a valid selection table.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("invalid selection artifact: {0}")]
pub struct DecodeError(String);

pub(crate) fn encode(sel: &Selection) -> Vec<u8> {
    let mut out = Vec::with_capacity(40 + sel.entries.len() * 12);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&LAYOUT_VERSION.to_le_bytes());
    let (kind, m) = match sel.rule {
        Rule::Closest(m) => (0u8, m),
        Rule::Best(m) => (1u8, m),
    };
    out.push(kind);
    out.extend_from_slice(&m.to_le_bytes());
    out.extend_from_slice(&sel.goal_percent.to_le_bytes());
    out.extend_from_slice(&sel.s0.to_le_bytes());
    out.extend_from_slice(&sel.impostor_count.to_le_bytes());
    out.extend_from_slice(&(sel.entries.len() as u32).to_le_bytes());
    for e in &sel.entries {
        out.extend_from_slice(&e.missed.to_le_bytes());
        out.push(e.impostors.len() as u8);
        for i in &e.impostors {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

pub(crate) fn decode(bytes: &[u8]) -> Result<Selection, DecodeError> {
    let mut r = Reader { bytes, at: 0 };
    if r.take(8)? != MAGIC {
        return Err(DecodeError("bad magic".into()));
    }
    let version = r.u32()?;
    if version != LAYOUT_VERSION {
        return Err(DecodeError(format!(
            "layout version {version}, expected {LAYOUT_VERSION}"
        )));
    }
    let kind = r.take(1)?[0];
    let m = r.u32()?;
    let rule = match kind {
        0 => Rule::Closest(m),
        1 => Rule::Best(m),
        k => return Err(DecodeError(format!("unknown rule code {k}"))),
    };
    let goal_percent = f64::from_le_bytes(r.take(8)?.try_into().expect("8 bytes"));
    let s0 = r.u32()?;
    let impostor_count = r.u32()?;
    let count = r.u32()? as usize;
    // Every entry takes at least 5 bytes: check before allocating.
    if count > (bytes.len() - r.at) / 5 {
        return Err(DecodeError(format!("{count} entries cannot fit")));
    }
    let mut entries = Vec::with_capacity(count);
    for d in 0..count {
        let missed = r.u32()?;
        let k = r.take(1)?[0] as usize;
        let mut impostors = Vec::with_capacity(k);
        for _ in 0..k {
            let i = u16::from_le_bytes(r.take(2)?.try_into().expect("2 bytes"));
            if u32::from(i) >= impostor_count {
                return Err(DecodeError(format!(
                    "direction {d}: impostor {i} of {impostor_count}"
                )));
            }
            impostors.push(i);
        }
        entries.push(Entry { impostors, missed });
    }
    if r.at != bytes.len() {
        return Err(DecodeError(format!(
            "{} trailing bytes",
            bytes.len() - r.at
        )));
    }
    Ok(Selection {
        rule,
        goal_percent,
        s0,
        impostor_count,
        entries,
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| DecodeError(format!("truncated at byte {}", self.at)))?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
}
