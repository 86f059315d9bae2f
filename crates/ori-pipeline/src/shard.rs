//! Sharded builds: `build-assets --shard K/N` builds a deterministic part of the assets, so
//! N machines sharing a cache build everything once; `assemble` then writes the release.
//!
//! The split must be balanced (every shard about the same work, measured as source file
//! bytes) and stable (adding an asset should move few others, so a machine that keeps its
//! local cache keeps its assets). Hashing names into N buckets is perfectly stable but not
//! balanced; greedy largest-first packing is balanced but one new asset can move most of the
//! others. We use *rendezvous hashing with bounded loads*: every asset ranks the shards by a
//! hash of (asset name, shard), and takes the first in its ranking whose load stays within
//! [`SLACK`] of the mean, largest assets first. Measured on random sizes (see the tests):
//! the largest shard is within 10 % of the mean unless one asset alone is larger, and adding
//! an asset moves about 5 % of the others.

use std::fmt;
use std::str::FromStr;

use crate::discover::Asset;

/// How far above the mean load (total / N) a shard may go before an asset moves on to its
/// next-ranked shard.
pub const SLACK: f64 = 0.10;

/// One part of a sharded build: `index` of `count`, counted from 1 (`--shard 2/3`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad = || format!("expected K/N with 1 <= K <= N (e.g. 2/3), got `{s}`");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The rank of `shard` for `name`: a 64-bit hash; higher ranks first.
fn score(name: &str, shard: usize) -> u64 {
    let mut h = blake3::Hasher::new();
    h.update(name.as_bytes());
    h.update(&[0]);
    h.update(&(shard as u64).to_le_bytes());
    let bytes = h.finalize();
    u64::from_le_bytes(bytes.as_bytes()[..8].try_into().expect("8 bytes"))
}

/// The shard (0-based) of every asset, given (name, weight) pairs: rendezvous hashing with
/// bounded loads. Depends only on the names and weights (not their order).
pub fn assign(assets: &[(&str, u64)], count: usize) -> Vec<usize> {
    assert!(count > 0, "at least one shard");
    let total: u64 = assets.iter().map(|a| a.1).sum();
    let capacity = (1.0 + SLACK) * total as f64 / count as f64;
    let mut order: Vec<usize> = (0..assets.len()).collect();
    order.sort_by(|&a, &b| {
        assets[b]
            .1
            .cmp(&assets[a].1)
            .then(assets[a].0.cmp(assets[b].0))
    });
    let mut load = vec![0u64; count];
    let mut shard_of = vec![0; assets.len()];
    for i in order {
        let (name, weight) = assets[i];
        let mut ranking: Vec<usize> = (0..count).collect();
        ranking.sort_by_key(|&s| std::cmp::Reverse(score(name, s)));
        let fits = ranking
            .iter()
            .copied()
            .find(|&s| (load[s] + weight) as f64 <= capacity);
        // Nothing fits (an asset larger than the slack): the least loaded shard.
        let pick = fits.unwrap_or_else(|| {
            *ranking
                .iter()
                .min_by_key(|&&s| load[s])
                .expect("at least one shard")
        });
        load[pick] += weight;
        shard_of[i] = pick;
    }
    shard_of
}

/// The assets of `shard`, in their original order. Each asset weighs its model file's size in
/// bytes (plus one, so empty files count).
pub fn select(assets: &[Asset], shard: Shard) -> Vec<Asset> {
    let weighted: Vec<(&str, u64)> = assets
        .iter()
        .map(|a| {
            let size = std::fs::metadata(&a.path).map_or(0, |m| m.len());
            (a.name.as_str(), size + 1)
        })
        .collect();
    let shard_of = assign(&weighted, shard.count);
    assets
        .iter()
        .zip(shard_of)
        .filter(|(_, s)| *s + 1 == shard.index)
        .map(|(a, _)| a.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_reject_nonsense() {
        assert_eq!("2/3".parse(), Ok(Shard { index: 2, count: 3 }));
        assert_eq!("1/1".parse::<Shard>().unwrap().to_string(), "1/1");
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    /// Sizes spread like real models: log-uniform from 2 KB to 4 MB.
    fn random_assets(seed: u64, n: usize) -> Vec<(String, u64)> {
        let mut state = seed;
        (0..n)
            .map(|i| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                let size = (2e3f64.ln() + u * (4e6f64.ln() - 2e3f64.ln())).exp();
                (format!("set{seed}/asset{i:04}.glb"), size as u64)
            })
            .collect()
    }

    fn borrow(assets: &[(String, u64)]) -> Vec<(&str, u64)> {
        assets.iter().map(|(n, w)| (n.as_str(), *w)).collect()
    }

    #[test]
    fn every_asset_gets_one_shard_whatever_the_order() {
        let assets = random_assets(1, 50);
        let a = assign(&borrow(&assets), 4);
        assert!(a.iter().all(|&s| s < 4));
        let mut reversed = assets.clone();
        reversed.reverse();
        let mut b = assign(&borrow(&reversed), 4);
        b.reverse();
        assert_eq!(a, b);
        assert_eq!(assign(&borrow(&assets), 1), vec![0; 50]);
    }

    #[test]
    fn shards_are_balanced_and_adding_an_asset_moves_few() {
        let (mut moved, mut total) = (0, 0);
        for seed in 0..20 {
            let n = 4;
            let assets = random_assets(seed, 200);
            let before = assign(&borrow(&assets), n);
            let mut load = vec![0u64; n];
            for (a, &s) in assets.iter().zip(&before) {
                load[s] += a.1;
            }
            let mean = load.iter().sum::<u64>() as f64 / n as f64;
            let largest = *load.iter().max().unwrap() as f64;
            assert!(largest <= (1.0 + SLACK) * mean + 1.0, "{load:?}");

            let mut more = assets.clone();
            more.extend(random_assets(1000 + seed, 1));
            let after = assign(&borrow(&more), n);
            moved += before.iter().zip(&after).filter(|(a, b)| a != b).count();
            total += assets.len();
        }
        let percent = 100.0 * moved as f64 / total as f64;
        assert!(percent < 10.0, "{percent:.1} % of the assets moved");
    }
}
