//! The canonical byte layout of a [`Selection`], little-endian:
//! ```text
//! magic "ORISELT\0", u32 layout version
//! u8 rule (0 closest, 1 best), u32 M, f64 goal percent, u32 s0,
//! u32 impostor count n, u32 direction count
//! per direction: u32 coverage error (pixels), u8 count k, k x u16 impostor index
//! ```

use ori_artifact::{DecodeError, Layout};

use crate::{Entry, Rule, Selection};

const LAYOUT: Layout = Layout {
    kind: "selection",
    magic: *b"ORISELT\0",
    version: 1,
};

pub(crate) fn encode(sel: &Selection) -> Vec<u8> {
    let mut w = LAYOUT.writer();
    w.reserve(28 + sel.entries.len() * 12);
    let (kind, m) = match sel.rule {
        Rule::Closest(m) => (0u8, m),
        Rule::Best(m) => (1u8, m),
    };
    w.u8(kind);
    w.u32(m);
    w.f64(sel.goal_percent);
    w.u32(sel.s0);
    w.u32(sel.impostor_count);
    w.count(sel.entries.len());
    for e in &sel.entries {
        w.u32(e.missed);
        w.u8(u8::try_from(e.impostors.len()).expect("at most 255 impostors per direction"));
        for &i in &e.impostors {
            w.u16(i);
        }
    }
    w.finish()
}

pub(crate) fn decode(bytes: &[u8]) -> Result<Selection, DecodeError> {
    let mut r = LAYOUT.reader(bytes)?;
    let kind = r.u8()?;
    let m = r.u32()?;
    let rule = match kind {
        0 => Rule::Closest(m),
        1 => Rule::Best(m),
        k => return Err(r.error(format!("unknown rule code {k}"))),
    };
    let goal_percent = r.f64()?;
    let s0 = r.u32()?;
    let impostor_count = r.u32()?;
    // Every entry takes at least 5 bytes.
    let count = r.count(5)?;
    let mut entries = Vec::with_capacity(count);
    for d in 0..count {
        let missed = r.u32()?;
        let k = r.u8()? as usize;
        let mut impostors = Vec::with_capacity(k);
        for _ in 0..k {
            let i = r.u16()?;
            if u32::from(i) >= impostor_count {
                return Err(r.error(format!("direction {d}: impostor {i} of {impostor_count}")));
            }
            impostors.push(i);
        }
        entries.push(Entry { impostors, missed });
    }
    r.finish()?;
    Ok(Selection {
        rule,
        goal_percent,
        s0,
        impostor_count,
        entries,
    })
}
