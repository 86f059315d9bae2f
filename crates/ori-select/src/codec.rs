//! The canonical byte layout of a [`Selection`], little-endian:
//! ```text
//! magic "ORISELT\0", u32 layout version
//! u8 rule (0 closest, 1 best), u32 M, f64 goal percent, u32 s0,
//! u32 impostor count n, u32 direction count
//! per direction: u32 coverage error (pixels), u8 count k, k x u16 impostor index
//! ```
//!
//! and of a [`HeldOut`] measure:
//! ```text
//! magic "ORIHELD\0", u32 layout version
//! u32 s0, u32 direction count, per direction: u32 coverage error (pixels), u8 impostors drawn
//! ```

use ori_artifact::{DecodeError, Layout};

use crate::{Entry, HeldOut, Rule, Selection};

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

const HELD_OUT_LAYOUT: Layout = Layout {
    kind: "held-out measure",
    magic: *b"ORIHELD\0",
    version: 1,
};

pub(crate) fn encode_held_out(h: &HeldOut) -> Vec<u8> {
    let mut w = HELD_OUT_LAYOUT.writer();
    w.reserve(8 + h.views.len() * 5);
    w.u32(h.s0);
    w.count(h.views.len());
    for &(missed, drawn) in &h.views {
        w.u32(missed);
        w.u8(u8::try_from(drawn).expect("at most 255 impostors per view"));
    }
    w.finish()
}

pub(crate) fn decode_held_out(bytes: &[u8]) -> Result<HeldOut, DecodeError> {
    let mut r = HELD_OUT_LAYOUT.reader(bytes)?;
    let s0 = r.u32()?;
    if s0 == 0 {
        return Err(r.error("s0 is 0"));
    }
    let pixels = u64::from(s0) * u64::from(s0);
    let count = r.count(5)?;
    let mut views = Vec::with_capacity(count);
    for d in 0..count {
        let missed = r.u32()?;
        if u64::from(missed) > pixels {
            return Err(r.error(format!("direction {d}: {missed} pixels missed of {pixels}")));
        }
        views.push((missed, usize::from(r.u8()?)));
    }
    r.finish()?;
    Ok(HeldOut { views, s0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_out_round_trips_and_refuses_bad_bytes() {
        let h = HeldOut {
            views: vec![(0, 2), (17, 3), (4096, 1)],
            s0: 64,
        };
        let bytes = encode_held_out(&h);
        assert_eq!(decode_held_out(&bytes), Ok(h.clone()));
        for cut in 0..bytes.len() {
            assert!(decode_held_out(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        // More missed pixels than the image has.
        let too_many = HeldOut {
            views: vec![(4097, 1)],
            s0: 64,
        };
        let err = decode_held_out(&encode_held_out(&too_many)).unwrap_err();
        assert!(
            err.to_string().contains("4097 pixels missed of 4096"),
            "{err}"
        );
        // A count that cannot fit is refused before allocating.
        let mut huge = encode_held_out(&HeldOut {
            views: vec![],
            s0: 64,
        });
        let n = huge.len();
        huge[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_held_out(&huge).is_err());
    }
}
