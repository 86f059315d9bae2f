//! The canonical byte layout of a [`ViewPlan`], the views stage's cached artifact.
//!
//! Little-endian throughout:
//! ```text
//! magic "ORIVIEW\0", u32 layout version
//! u8 strategy (0 regular, 1 minimal, 2 perturbed), u32 direction count n
//! n x [f64; 3] directions, n x f64 entropies
//! ```
//! `f64`s are stored as their bits, so a plan round-trips exactly.

use crate::{Strategy, ViewError, ViewPlan};

const MAGIC: &[u8; 8] = b"ORIVIEW\0";
const LAYOUT_VERSION: u32 = 1;
const HEADER: usize = 8 + 4 + 1 + 4;

impl ViewPlan {
    /// Serialise to the canonical byte layout (see the module docs of `codec.rs`).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER + 32 * self.directions.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&LAYOUT_VERSION.to_le_bytes());
        out.push(match self.strategy {
            Strategy::Regular => 0,
            Strategy::MinimalSampling => 1,
            Strategy::Perturbed => 2,
        });
        out.extend_from_slice(&(self.directions.len() as u32).to_le_bytes());
        for x in self.directions.iter().flatten().chain(&self.entropies) {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out
    }

    /// Parse bytes written by [`ViewPlan::encode`]: the exact length, finite unit directions
    /// and finite non-negative entropies, one per direction.
    pub fn decode(bytes: &[u8]) -> Result<ViewPlan, ViewError> {
        let bad = |msg: String| ViewError::Decode(msg);
        if bytes.len() < HEADER || &bytes[..8] != MAGIC {
            return Err(bad("bad magic".into()));
        }
        let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        let version = u32_at(8);
        if version != LAYOUT_VERSION {
            return Err(bad(format!(
                "layout version {version}, expected {LAYOUT_VERSION}"
            )));
        }
        let strategy = match bytes[12] {
            0 => Strategy::Regular,
            1 => Strategy::MinimalSampling,
            2 => Strategy::Perturbed,
            s => return Err(bad(format!("unknown strategy code {s}"))),
        };
        let n = u32_at(13) as usize;
        // Checked against the actual length before anything is allocated.
        if (bytes.len() - HEADER) as u64 != 32 * n as u64 {
            return Err(bad(format!(
                "{} bytes of data for {n} directions (expected {})",
                bytes.len() - HEADER,
                32 * n as u64
            )));
        }
        let mut values = bytes[HEADER..]
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")));
        let directions: Vec<[f64; 3]> = (0..n)
            .map(|_| std::array::from_fn(|_| values.next().expect("length checked")))
            .collect();
        let entropies: Vec<f64> = values.collect();
        for (i, d) in directions.iter().enumerate() {
            let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            // Also rejects NaN and infinities.
            let unit = (len2 - 1.0).abs() < 1e-9;
            if !unit {
                return Err(bad(format!("direction {i} is not a unit vector: {d:?}")));
            }
        }
        if let Some(i) = entropies.iter().position(|h| !(h.is_finite() && *h >= 0.0)) {
            return Err(bad(format!("entropy {i} is {}", entropies[i])));
        }
        Ok(ViewPlan {
            strategy,
            directions,
            entropies,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> ViewPlan {
        ViewPlan {
            strategy: Strategy::Perturbed,
            directions: vec![
                [0.0, 0.0, 1.0],
                crate::directions::normalize([0.1, -0.7, 0.3]),
            ],
            entropies: vec![0.0, 5.123456789012345],
        }
    }

    #[test]
    fn round_trips_exactly() {
        let p = plan();
        let bytes = p.encode();
        assert_eq!(bytes.len(), HEADER + 64);
        assert_eq!(ViewPlan::decode(&bytes).unwrap(), p);
    }

    #[test]
    fn rejects_damage() {
        let bytes = plan().encode();
        assert!(ViewPlan::decode(&bytes[..bytes.len() - 1]).is_err());
        assert!(ViewPlan::decode(&[]).is_err());
        let mut b = bytes.clone();
        b[0] = b'X';
        assert!(ViewPlan::decode(&b).is_err());
        let mut b = bytes.clone();
        b[12] = 9;
        assert!(ViewPlan::decode(&b).is_err());
        let mut b = bytes.clone();
        b[13..17].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(ViewPlan::decode(&b).is_err());
        let mut b = bytes.clone();
        b[HEADER..HEADER + 8].copy_from_slice(&2.0f64.to_le_bytes());
        assert!(ViewPlan::decode(&b).is_err());
        let mut b = bytes;
        let at = HEADER + 48;
        b[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(ViewPlan::decode(&b).is_err());
    }
}
