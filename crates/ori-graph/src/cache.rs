//! The local artifact cache: content-addressed blobs plus action entries.
//!
//! Layout under the cache root (the same split as Bazel's remote cache):
//! ```text
//! cas/ab/abcd...      blob whose blake3 is abcd...
//! ac/12/1234....json  action entry of the job whose key is 1234...
//! jobs/5678....json   last run of one (asset, stage), used only to explain re-runs
//! stat-memo.json      (size, mtime, inode) -> content hash of source files
//! <memo>/V-NN.json    shards of the memo maps its users keep (`MemoMap`, version V)
//! ```
//! Every write goes to a unique temporary file that is renamed into place, so readers (and
//! other builders sharing the directory) see either nothing or a complete file. Every read is
//! verified: blobs against their hash, action entries against an embedded checksum. A file
//! that fails verification is reported and treated as absent, never used.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use crate::hash::ContentHash;

/// A stored blob: its content hash and size in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BlobRef {
    pub hash: ContentHash,
    pub size: u64,
}

/// A file a job read while running (besides its declared inputs), relative to the folder of
/// its source file, with the content hash it had (`None`: the job found it missing).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiscoveredFile {
    pub path: String,
    pub hash: Option<ContentHash>,
}

/// What a finished job left in the cache: its named outputs, the files it discovered, and the
/// warnings it printed (replayed when the job is reused).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ActionEntry {
    pub stage: String,
    pub outputs: BTreeMap<String, BlobRef>,
    pub discovered: Vec<DiscoveredFile>,
    pub warnings: Vec<String>,
    /// The outputs' names in a remote cache that names blobs by sha256 (bazel-remote
    /// compatible digests), for an entry that came from one; empty otherwise.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub remote_names: BTreeMap<String, ContentHash>,
}

/// The last run of one (asset, stage): the key and what went into it. Only used to say why a
/// job re-ran (`--explain`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    pub key: ContentHash,
    pub stage_version: u32,
    pub params: serde_json::Value,
    pub inputs: BTreeMap<String, ContentHash>,
}

/// Why a cache read gave nothing usable.
#[derive(Debug)]
pub enum ReadError {
    /// Not in the cache.
    Missing,
    /// Present but failed verification; the file has been removed.
    Corrupt { path: PathBuf, reason: String },
    /// The file system failed.
    Io { path: PathBuf, error: io::Error },
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Missing => f.write_str("not in the cache"),
            ReadError::Corrupt { path, reason } => {
                write!(f, "corrupt cache entry {} ({reason})", path.display())
            }
            ReadError::Io { path, error } => write!(f, "cannot read {}: {error}", path.display()),
        }
    }
}

/// A cache directory. Cheap to clone; safe to share between threads and processes.
#[derive(Clone, Debug)]
pub struct Cache {
    root: PathBuf,
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// The source stat memo's file name under the cache root.
pub const STAT_MEMO: &str = "stat-memo.json";

/// Write `bytes` to `path` atomically: a uniquely named temporary file in the same folder,
/// renamed over the target. Concurrent writers of the same content both succeed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    fs::create_dir_all(dir)?;
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("file");
    let tmp = dir.join(format!(
        ".{name}.tmp-{}-{}",
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = fs::write(&tmp, bytes).and_then(|()| fs::rename(&tmp, path));
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

impl Cache {
    /// Use (and create if needed) the cache at `root`.
    pub fn open(root: impl Into<PathBuf>) -> io::Result<Cache> {
        let root = root.into();
        fs::create_dir_all(&root)?;
        Ok(Cache { root })
    }

    /// The cache folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Where the blob with this hash lives.
    pub fn blob_path(&self, hash: &ContentHash) -> PathBuf {
        let hex = hash.to_hex();
        self.root.join("cas").join(&hex[..2]).join(hex)
    }

    fn action_path(&self, key: &ContentHash) -> PathBuf {
        let hex = key.to_hex();
        self.root
            .join("ac")
            .join(&hex[..2])
            .join(format!("{hex}.json"))
    }

    fn record_path(&self, identity: &ContentHash) -> PathBuf {
        self.root
            .join("jobs")
            .join(format!("{}.json", identity.to_hex()))
    }

    /// Path of the stat memo (see `sources.rs`).
    pub fn stat_memo_path(&self) -> PathBuf {
        self.root.join(STAT_MEMO)
    }

    /// Store `bytes` under their hash (a no-op when an intact copy is already there).
    pub fn put_blob(&self, bytes: &[u8]) -> io::Result<BlobRef> {
        let blob = BlobRef {
            hash: ContentHash::of(bytes),
            size: bytes.len() as u64,
        };
        if !self.blob_present(&blob) {
            write_entry(&self.blob_path(&blob.hash), bytes)?;
        }
        Ok(blob)
    }

    /// Store bytes already verified to hash to `hash` (downloaded from a remote cache).
    pub(crate) fn store_verified_blob(&self, hash: &ContentHash, bytes: &[u8]) -> io::Result<()> {
        write_entry(&self.blob_path(hash), bytes)
    }

    /// Whether a blob of the right size exists (a cheap check; contents are verified on read).
    pub fn blob_present(&self, blob: &BlobRef) -> bool {
        fs::symlink_metadata(self.blob_path(&blob.hash))
            .is_ok_and(|m| m.is_file() && m.len() == blob.size)
    }

    /// Read a blob and verify its hash. A corrupt blob is deleted and reported.
    pub fn read_blob(&self, blob: &BlobRef) -> Result<Vec<u8>, ReadError> {
        let path = self.blob_path(&blob.hash);
        let bytes = read_entry(&path)?;
        let actual = ContentHash::of(&bytes);
        if actual != blob.hash {
            let _ = fs::remove_file(&path);
            let reason = format!("content hash is {}, {} bytes", actual.short(), bytes.len());
            return Err(ReadError::Corrupt { path, reason });
        }
        Ok(bytes)
    }

    /// Remove a blob whose size is wrong so it is rewritten.
    pub fn discard_blob(&self, hash: &ContentHash) {
        let _ = remove_any(&self.blob_path(hash));
    }

    /// The action entry for `key`, verified.
    pub fn read_action(&self, key: &ContentHash) -> Result<ActionEntry, ReadError> {
        read_checked_json(&self.action_path(key))
    }

    /// Store the action entry for `key`.
    pub fn write_action(&self, key: &ContentHash, entry: &ActionEntry) -> io::Result<()> {
        write_checked_json(&self.action_path(key), entry)
    }

    /// The last run of the job with this identity, if one was recorded intact.
    pub fn read_record(&self, identity: &ContentHash) -> Option<JobRecord> {
        read_checked_json(&self.record_path(identity)).ok()
    }

    /// Remember the last run of the job with this identity.
    pub fn write_record(&self, identity: &ContentHash, record: &JobRecord) -> io::Result<()> {
        write_checked_json(&self.record_path(identity), record)
    }
}

/// JSON preceded by a line holding the blake3 of the JSON text, so any damage is detected.
/// The same bytes are stored locally and sent to a remote cache.
pub(crate) fn encode_checked_json<T: Serialize>(value: &T) -> io::Result<Vec<u8>> {
    let json = serde_json::to_string_pretty(value).map_err(io::Error::other)?;
    Ok(checked(json))
}

/// JSON text behind the line that checks it.
pub(crate) fn checked(json: String) -> Vec<u8> {
    format!("{}\n{json}\n", ContentHash::of(json.as_bytes())).into_bytes()
}

/// Check and parse what [`encode_checked_json`] wrote; the error says what is wrong.
pub(crate) fn decode_checked_json<T: for<'de> Deserialize<'de>>(bytes: &[u8]) -> Result<T, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "not UTF-8".to_string())?;
    let (check, json) = text
        .split_once('\n')
        .ok_or_else(|| "no checksum line".to_string())?;
    let json = json
        .strip_suffix('\n')
        .ok_or_else(|| "truncated".to_string())?;
    if check != ContentHash::of(json.as_bytes()).to_hex() {
        return Err("checksum mismatch".into());
    }
    serde_json::from_str(json).map_err(|e| format!("unreadable entry: {e}"))
}

fn write_checked_json<T: Serialize>(path: &Path, value: &T) -> io::Result<()> {
    write_entry(path, &encode_checked_json(value)?)
}

/// Write a cache file atomically. Whatever else stands in its place (a folder, a link, a
/// file where its folder should be) is damage: it is removed first. Errors name the file.
pub(crate) fn write_entry(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let named = |e: io::Error| io::Error::new(e.kind(), format!("{}: {e}", path.display()));
    if let Some(dir) = path.parent()
        && fs::symlink_metadata(dir).is_ok_and(|m| !m.is_dir())
    {
        fs::remove_file(dir).map_err(named)?;
    }
    if fs::symlink_metadata(path).is_ok_and(|m| !m.is_file()) {
        remove_any(path).map_err(named)?;
    }
    write_atomic(path, bytes).map_err(named)
}

fn remove_any(path: &Path) -> io::Result<()> {
    match fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => fs::remove_dir_all(path),
        Ok(_) => fs::remove_file(path),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// Read a cache file: absent is [`ReadError::Missing`]; anything but a regular file in its
/// place is damage, removed and reported as [`ReadError::Corrupt`].
fn read_entry(path: &Path) -> Result<Vec<u8>, ReadError> {
    match fs::symlink_metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Err(ReadError::Missing),
        Ok(m) if !m.is_file() => {
            let _ = remove_any(path);
            return Err(ReadError::Corrupt {
                path: path.to_path_buf(),
                reason: "not a regular file".into(),
            });
        }
        _ => {}
    }
    match fs::read(path) {
        Ok(t) => Ok(t),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Err(ReadError::Missing),
        Err(error) => Err(ReadError::Io {
            path: path.to_path_buf(),
            error,
        }),
    }
}

pub(crate) fn read_checked_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T, ReadError> {
    let bytes = read_entry(path)?;
    decode_checked_json(&bytes).map_err(|reason| {
        let _ = fs::remove_file(path);
        ReadError::Corrupt {
            path: path.to_path_buf(),
            reason,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blob_round_trip_and_corruption_is_detected() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        let blob = cache.put_blob(b"hello relief").unwrap();
        assert_eq!(cache.read_blob(&blob).unwrap(), b"hello relief");
        let path = cache.blob_path(&blob.hash);
        fs::write(&path, b"hello rel1ef").unwrap();
        assert!(cache.blob_present(&blob), "same size: only a read can tell");
        assert!(matches!(
            cache.read_blob(&blob),
            Err(ReadError::Corrupt { .. })
        ));
        assert!(!path.exists(), "a corrupt blob is removed");
        assert!(matches!(cache.read_blob(&blob), Err(ReadError::Missing)));
    }

    #[test]
    fn damaged_action_entries_are_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        let key = ContentHash::of(b"key");
        let entry = ActionEntry {
            stage: "ingest".into(),
            outputs: BTreeMap::from([("mesh".into(), cache.put_blob(b"m").unwrap())]),
            discovered: vec![],
            warnings: vec!["w".into()],
            remote_names: BTreeMap::new(),
        };
        cache.write_action(&key, &entry).unwrap();
        assert_eq!(cache.read_action(&key).unwrap(), entry);
        let path = cache.action_path(&key);
        let text = fs::read_to_string(&path).unwrap();
        for damaged in [
            text.replace("ingest", "ingesT"),
            text[..text.len() / 2].to_string(),
        ] {
            fs::write(&path, damaged).unwrap();
            assert!(matches!(
                cache.read_action(&key),
                Err(ReadError::Corrupt { .. })
            ));
        }
    }
}
