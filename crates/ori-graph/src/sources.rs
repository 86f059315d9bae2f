//! Content hashes of source files, with a stat memo so unchanged files are not re-read.
//!
//! A memo entry maps an absolute path to (size, mtime, ctime, inode, hash). It is trusted only
//! when all four stat fields match. A file modified within the filesystem's timestamp
//! granularity of the moment it was hashed could keep its mtime, so entries younger than
//! [`RACY_WINDOW`] at save time are not memoised (git's "racily clean" rule): such a file is
//! simply re-hashed next time. A changed file is therefore always re-hashed.

use std::collections::BTreeMap;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::cache::write_atomic;
use crate::hash::ContentHash;

/// Files modified this recently when the memo is saved are left out of it.
pub const RACY_WINDOW: Duration = Duration::from_secs(2);

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
struct Stamp {
    size: u64,
    mtime_ns: i128,
    ctime_ns: i128,
    inode: u64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct MemoEntry {
    stamp: Stamp,
    hash: ContentHash,
}

/// Hashes source files, remembering results across builds in a memo file.
pub struct SourceHasher {
    memo_path: PathBuf,
    memo: Mutex<BTreeMap<PathBuf, MemoEntry>>,
    /// Files hashed by reading them (not from the memo) during this build.
    rehashed: Mutex<u64>,
}

impl SourceHasher {
    /// Load the memo at `memo_path` (a missing or unreadable memo just means hashing anew).
    pub fn new(memo_path: PathBuf) -> SourceHasher {
        let memo = fs::read(&memo_path)
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default();
        SourceHasher {
            memo_path,
            memo: Mutex::new(memo),
            rehashed: Mutex::new(0),
        }
    }

    /// Content hash of the file at `path`, or `Ok(None)` if there is no such file.
    pub fn hash(&self, path: &Path) -> io::Result<Option<ContentHash>> {
        let meta = match fs::metadata(path) {
            Ok(m) => m,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e),
        };
        if !meta.is_file() {
            return Ok(None);
        }
        let stamp = stamp(&meta);
        if let Some(entry) = self.memo.lock().unwrap().get(path)
            && entry.stamp == stamp
        {
            return Ok(Some(entry.hash));
        }
        let hash = ContentHash::of(&fs::read(path)?);
        *self.rehashed.lock().unwrap() += 1;
        self.remember(path, stamp, hash);
        Ok(Some(hash))
    }

    /// Record the hash of bytes just read from `path` (stat taken before the read).
    fn remember(&self, path: &Path, stamp: Stamp, hash: ContentHash) {
        self.memo
            .lock()
            .unwrap()
            .insert(path.to_path_buf(), MemoEntry { stamp, hash });
    }

    /// How many files were read and hashed (memo misses) so far.
    pub fn rehashed(&self) -> u64 {
        *self.rehashed.lock().unwrap()
    }

    /// Write the memo back, merged with entries another builder may have saved meanwhile,
    /// leaving out racily recent files.
    pub fn save(&self) -> io::Result<()> {
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default()
            .as_nanos() as i128;
        let mut merged: BTreeMap<PathBuf, MemoEntry> = fs::read(&self.memo_path)
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default();
        let ours = self.memo.lock().unwrap();
        merged.extend(ours.iter().map(|(k, v)| (k.clone(), v.clone())));
        merged.retain(|_, e| {
            now - e.stamp.mtime_ns.max(e.stamp.ctime_ns) > RACY_WINDOW.as_nanos() as i128
        });
        let json = serde_json::to_vec(&merged).map_err(io::Error::other)?;
        write_atomic(&self.memo_path, &json)
    }
}

#[cfg(unix)]
fn stamp(meta: &fs::Metadata) -> Stamp {
    use std::os::unix::fs::MetadataExt;
    Stamp {
        size: meta.len(),
        mtime_ns: meta.mtime() as i128 * 1_000_000_000 + meta.mtime_nsec() as i128,
        ctime_ns: meta.ctime() as i128 * 1_000_000_000 + meta.ctime_nsec() as i128,
        inode: meta.ino(),
    }
}

#[cfg(not(unix))]
fn stamp(meta: &fs::Metadata) -> Stamp {
    let ns = |t: io::Result<SystemTime>| {
        t.ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos() as i128)
    };
    Stamp {
        size: meta.len(),
        mtime_ns: ns(meta.modified()),
        ctime_ns: ns(meta.created()),
        inode: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_size_edit_within_the_same_second_is_seen() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.obj");
        let memo = dir.path().join("memo.json");
        fs::write(&file, b"v 0 0 0\n").unwrap();
        let hasher = SourceHasher::new(memo.clone());
        let first = hasher.hash(&file).unwrap().unwrap();
        hasher.save().unwrap();
        // Rewrite with the same size immediately: the racy entry was not memoised.
        fs::write(&file, b"v 1 0 0\n").unwrap();
        let hasher = SourceHasher::new(memo);
        let second = hasher.hash(&file).unwrap().unwrap();
        assert_ne!(first, second);
        assert_eq!(second, ContentHash::of(b"v 1 0 0\n"));
    }

    #[test]
    fn old_files_are_memoised_and_missing_files_are_none() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.ply");
        fs::write(&file, b"ply").unwrap();
        std::thread::sleep(RACY_WINDOW + Duration::from_millis(100));
        let memo = dir.path().join("memo.json");
        let hasher = SourceHasher::new(memo.clone());
        hasher.hash(&file).unwrap();
        assert_eq!(hasher.rehashed(), 1);
        hasher.save().unwrap();
        let hasher = SourceHasher::new(memo);
        assert_eq!(hasher.hash(&file).unwrap(), Some(ContentHash::of(b"ply")));
        assert_eq!(hasher.rehashed(), 0, "served from the memo");
        assert_eq!(hasher.hash(&dir.path().join("nope")).unwrap(), None);
    }
}
