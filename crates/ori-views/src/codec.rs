//! The canonical byte layout of a [`ViewPlan`], the views stage's cached artifact.
//!
//! Little-endian throughout:
//! ```text
//! magic "ORIVIEW\0", u32 layout version
//! u8 strategy (0 regular, 1 minimal, 2 perturbed), u32 direction count n
//! n x [f64; 3] directions, n x f64 entropies
//! ```
//! `f64`s are stored as their bits, so a plan round-trips exactly.

use ori_artifact::Layout;

use crate::{Strategy, ViewError, ViewPlan};

const LAYOUT: Layout = Layout {
    kind: "view plan",
    magic: *b"ORIVIEW\0",
    version: 1,
};
#[cfg(test)]
const HEADER: usize = 8 + 4 + 1 + 4;

impl ViewPlan {
    /// Serialise to the canonical byte layout (see the module docs of `codec.rs`).
    pub fn encode(&self) -> Vec<u8> {
        let mut w = LAYOUT.writer();
        w.reserve(5 + 32 * self.directions.len());
        w.u8(match self.strategy {
            Strategy::Regular => 0,
            Strategy::MinimalSampling => 1,
            Strategy::Perturbed => 2,
        });
        w.count(self.directions.len());
        for &x in self.directions.iter().flatten().chain(&self.entropies) {
            w.f64(x);
        }
        w.finish()
    }

    /// Parse bytes written by [`ViewPlan::encode`]: the exact length, finite unit directions
    /// and finite non-negative entropies, one per direction.
    pub fn decode(bytes: &[u8]) -> Result<ViewPlan, ViewError> {
        let mut r = LAYOUT.reader(bytes)?;
        let strategy = match r.u8()? {
            0 => Strategy::Regular,
            1 => Strategy::MinimalSampling,
            2 => Strategy::Perturbed,
            s => return Err(r.error(format!("unknown strategy code {s}")).into()),
        };
        // A direction and its entropy take 32 bytes.
        let n = r.count(32)?;
        let mut directions = Vec::with_capacity(n);
        for i in 0..n {
            let d = [r.f64()?, r.f64()?, r.f64()?];
            let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            // Also rejects NaN and infinities.
            if (len2 - 1.0).abs() >= 1e-9 || len2.is_nan() {
                let msg = format!("direction {i} is not a unit vector: {d:?}");
                return Err(r.error(msg).into());
            }
            directions.push(d);
        }
        let mut entropies = Vec::with_capacity(n);
        for i in 0..n {
            let h = r.f64()?;
            if !(h.is_finite() && h >= 0.0) {
                return Err(r.error(format!("entropy {i} is {h}")).into());
            }
            entropies.push(h);
        }
        r.finish()?;
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
