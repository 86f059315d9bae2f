//! Memo maps: what earlier builds learnt (by asset name, by package hash), kept in the cache
//! folder as [`MEMO_SHARDS`] shard files, `<name>/<version>-NN.json`, each holding the entries
//! whose keys fall in it as checked JSON. A build that learns a few entries rewrites a few
//! small files, whatever the size of the catalogue; a shard another builder rewrote since this
//! one loaded it is read again and this build's changes are applied to it, so builders sharing
//! a cache merge what they learnt. A damaged shard is dropped (and removed) and only costs
//! learning its entries again. The memo's version is in the file names, so builders of two
//! versions sharing a cache keep apart and neither takes the other's files for damage.

use std::collections::BTreeMap;
use std::io;
use std::path::PathBuf;
use std::sync::Mutex;

use rayon::prelude::*;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::cache::{ReadError, checked, read_checked_json, write_entry};
use crate::hash::ContentHash;
use crate::sources::FileVersion;

/// Shard files per memo.
pub const MEMO_SHARDS: usize = 64;

/// A key of a memo map, and the shard it falls in.
pub trait MemoKey: Ord + Clone + Serialize + DeserializeOwned + Send + Sync {
    fn shard(&self) -> usize;
}

impl MemoKey for String {
    fn shard(&self) -> usize {
        // FNV-1a: the same shard on every machine and in every version.
        let hash = self.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        });
        (hash % MEMO_SHARDS as u64) as usize
    }
}

impl MemoKey for ContentHash {
    fn shard(&self) -> usize {
        usize::from(self.0[0]) % MEMO_SHARDS
    }
}

#[derive(Serialize, Deserialize)]
struct Shard<K: Ord, V> {
    entries: BTreeMap<K, V>,
}

/// A shard file's version and what it held.
type LoadedShard<K, V> = (Option<FileVersion>, Result<Shard<K, V>, ReadError>);

/// A memo map as loaded from the cache, and what this build learnt since.
pub struct MemoMap<K, V> {
    dir: PathBuf,
    /// Bumped by the memo's owner when what an entry means changes: shards of another version
    /// are not read.
    version: u32,
    loaded: BTreeMap<K, V>,
    /// Each shard's file version when loaded (`None` once this builder wrote it): while it is
    /// the one on disk, nobody else wrote it and saving need not read it again.
    versions: Mutex<Vec<Option<FileVersion>>>,
    /// New entries, and keys to forget (`None`).
    learnt: Mutex<BTreeMap<K, Option<V>>>,
    /// The damaged shards dropped on loading, each naming its file and what is wrong.
    pub damaged: Vec<String>,
}

impl<K: MemoKey, V: Clone + Serialize + DeserializeOwned + Send + Sync> MemoMap<K, V> {
    /// Load the memo in the folder `dir` (missing: empty).
    pub fn open(dir: PathBuf, version: u32) -> MemoMap<K, V> {
        let shards: Vec<LoadedShard<K, V>> = (0..MEMO_SHARDS)
            .into_par_iter()
            .map(|s| {
                let path = shard_path(&dir, version, s);
                (FileVersion::of(&path), read_checked_json(&path))
            })
            .collect();
        let mut loaded = BTreeMap::new();
        let mut versions = Vec::with_capacity(MEMO_SHARDS);
        let mut damaged = Vec::new();
        for (file, shard) in shards {
            versions.push(file);
            match shard {
                Ok(shard) => loaded.extend(shard.entries),
                Err(ReadError::Missing) => {}
                Err(e) => damaged.push(e.to_string()),
            }
        }
        MemoMap {
            dir,
            version,
            loaded,
            versions: Mutex::new(versions),
            learnt: Mutex::new(BTreeMap::new()),
            damaged,
        }
    }

    /// The entry loaded for `key`.
    pub fn get(&self, key: &K) -> Option<&V> {
        self.loaded.get(key)
    }

    /// The keys loaded.
    pub fn keys(&self) -> impl Iterator<Item = &K> {
        self.loaded.keys()
    }

    /// Learn `value` for `key` (`None`: forget it), kept by [`MemoMap::save`].
    pub fn set(&self, key: K, value: Option<V>) {
        self.learnt.lock().unwrap().insert(key, value);
    }

    /// Write every shard holding a key learnt since loading (or the last save): the entries
    /// loaded, or, when another builder rewrote the shard since, the entries on disk, with
    /// what was learnt applied. Nothing is written when nothing was learnt.
    pub fn save(&self) -> io::Result<()> {
        let mut learnt = self.learnt.lock().unwrap();
        let mut changes: BTreeMap<usize, Vec<(&K, &Option<V>)>> = BTreeMap::new();
        for (key, value) in learnt.iter() {
            changes.entry(key.shard()).or_default().push((key, value));
        }
        let mut versions = self.versions.lock().unwrap();
        let mut ours: BTreeMap<usize, BTreeMap<&K, &V>> = BTreeMap::new();
        for (key, value) in &self.loaded {
            let s = key.shard();
            if changes.contains_key(&s) {
                ours.entry(s).or_default().insert(key, value);
            }
        }
        let written: Vec<(usize, io::Result<()>)> = changes
            .par_iter()
            .map(|(&s, changed)| {
                let path = shard_path(&self.dir, self.version, s);
                let reread: BTreeMap<K, V>;
                let mut entries: BTreeMap<&K, &V> = if FileVersion::of(&path) == versions[s] {
                    ours.get(&s).cloned().unwrap_or_default()
                } else {
                    reread = match read_checked_json::<Shard<K, V>>(&path) {
                        Ok(shard) => shard.entries,
                        Err(_) => BTreeMap::new(),
                    };
                    reread.iter().collect()
                };
                for &(key, value) in changed {
                    match value {
                        Some(v) => entries.insert(key, v),
                        None => entries.remove(key),
                    };
                }
                let shard = Shard { entries };
                // Compact: memos are large and read by programs only.
                let json = serde_json::to_string(&shard).map_err(io::Error::other);
                let written = json.and_then(|json| write_entry(&path, &checked(json)));
                (s, written)
            })
            .collect();
        let mut failed = None;
        for (s, result) in written {
            // What was loaded no longer holds what this shard has: a later save reads it.
            versions[s] = None;
            if let Err(e) = result {
                failed = failed.or(Some(e));
            }
        }
        match failed {
            Some(e) => Err(e),
            None => {
                learnt.clear();
                Ok(())
            }
        }
    }
}

fn shard_path(dir: &std::path::Path, version: u32, shard: usize) -> PathBuf {
    dir.join(format!("{version}-{shard:02}.json"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(memo: &MemoMap<String, u32>) -> Vec<(String, u32)> {
        let keys = memo.keys().cloned();
        keys.map(|k| (k.clone(), *memo.get(&k).unwrap())).collect()
    }

    fn files(dir: &std::path::Path) -> Vec<(String, Option<FileVersion>)> {
        let shards = (0..MEMO_SHARDS).map(|s| shard_path(dir, 1, s));
        shards
            .map(|p| (p.display().to_string(), FileVersion::of(&p)))
            .collect()
    }

    #[test]
    fn a_save_rewrites_only_the_shards_it_changed_and_merges_another_builders() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path().join("memo");
        let first: MemoMap<String, u32> = MemoMap::open(dir.clone(), 1);
        for i in 0..500 {
            first.set(format!("asset-{i}"), Some(i));
        }
        first.save().unwrap();
        // A second save keeps what the first one wrote.
        first.set("asset-0".into(), Some(1000));
        first.save().unwrap();
        let before = files(&dir);
        assert!(
            before.iter().all(|(_, v)| v.is_some()),
            "500 keys fill every shard"
        );

        // One entry changed: one shard written.
        let memo: MemoMap<String, u32> = MemoMap::open(dir.clone(), 1);
        assert_eq!(names(&memo).len(), 500);
        assert_eq!(memo.get(&"asset-0".to_string()), Some(&1000));
        memo.set("asset-7".into(), Some(70));
        memo.save().unwrap();
        let after = files(&dir);
        let rewritten: Vec<usize> = (0..MEMO_SHARDS)
            .filter(|&s| before[s] != after[s])
            .collect();
        assert_eq!(rewritten, ["asset-7".to_string().shard()]);

        // Two builders that loaded the same memo: each one's changes survive the other's save,
        // including a forgotten key in a shard the other rewrote.
        let a: MemoMap<String, u32> = MemoMap::open(dir.clone(), 1);
        let b: MemoMap<String, u32> = MemoMap::open(dir.clone(), 1);
        a.set("asset-7".into(), None);
        a.set("new-a".into(), Some(1));
        a.save().unwrap();
        b.set("asset-7".into(), Some(700));
        b.set("new-b".into(), Some(2));
        b.save().unwrap();
        let merged: BTreeMap<String, u32> =
            names(&MemoMap::open(dir.clone(), 1)).into_iter().collect();
        assert_eq!(merged.len(), 502);
        assert_eq!(
            (merged["asset-7"], merged["new-a"], merged["new-b"]),
            (700, 1, 2)
        );

        // A damaged shard is dropped and named; another version's shards are empty.
        let damaged = shard_path(&dir, 1, "asset-1".to_string().shard());
        let mut bytes = std::fs::read(&damaged).unwrap();
        let middle = bytes.len() / 2;
        bytes[middle] ^= 1;
        std::fs::write(&damaged, bytes).unwrap();
        let memo: MemoMap<String, u32> = MemoMap::open(dir.clone(), 1);
        assert_eq!(memo.damaged.len(), 1);
        assert!(memo.damaged[0].contains(&damaged.display().to_string()));
        assert!(memo.get(&"asset-1".to_string()).is_none());
        let other = (0..500)
            .map(|i| format!("asset-{i}"))
            .find(|k| k.shard() != "asset-1".to_string().shard())
            .unwrap();
        assert!(memo.get(&other).is_some());
        let newer: MemoMap<String, u32> = MemoMap::open(dir, 2);
        assert!(newer.keys().next().is_none() && newer.damaged.is_empty());
    }
}
