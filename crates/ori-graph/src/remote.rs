//! The remote cache: a shared store of blobs and action entries that several builders read
//! and (in `read-write` mode) fill, behind the local cache.
//!
//! The protocol is the HTTP remote cache that Bazel clients speak and that bazel-remote or an
//! nginx WebDAV location serve: `GET`, `PUT` and `HEAD` of `{base}/cas/{name}` for blobs and
//! `{base}/ac/{key}` for action entries (job keys, in hex). Blobs are named by their blake3
//! ([`RemoteDigest::Blake3`]), or by their sha256 ([`RemoteDigest::Sha256`]), which servers
//! that check content addresses (bazel-remote, the REAPI) require; then each action entry
//! carries its outputs' sha256 names, so a builder can fetch them. Action entries are the
//! local cache's checksummed JSON (not Bazel's `ActionResult`; bazel-remote stores them with
//! its action-cache validation off).
//!
//! The graph talks to a [`RemoteStore`] (trait object), so tests can use an in-memory store;
//! the HTTP one lives in the `ori-http-store` crate and the object-store one (S3, GCS, Azure,
//! a folder; the same layout) in `ori-object-store`, so this crate needs no network client. [`RemoteCache`] adds the policy: everything downloaded is
//! verified before use (blobs against their hash, entries against their checksum), wrong bytes
//! are a miss with a warning; the first time the server is unreachable, slow or failing, one
//! warning is printed and it is not asked again during this build; uploads are best effort.

use std::collections::{HashMap, HashSet};
use std::fmt;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use serde::{Deserialize, Serialize};

use crate::cache::{ActionEntry, BlobRef, decode_checked_json, encode_checked_json};
use crate::hash::ContentHash;
use crate::outcome::Observer;
use crate::store::{Lookup, ResultStore};

/// The two namespaces of the protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Namespace {
    /// Blobs by content hash (`cas/`).
    Cas,
    /// Action entries by job key (`ac/`).
    Ac,
}

impl Namespace {
    /// The path segment of the namespace.
    pub fn segment(self) -> &'static str {
        match self {
            Namespace::Cas => "cas",
            Namespace::Ac => "ac",
        }
    }
}

/// Why a remote request gave nothing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RemoteError {
    /// The server cannot be used (down, too slow, failing, refusing us): stop asking it.
    Unavailable(String),
    /// This upload was refused (no permission, no space); downloads may still work.
    Rejected(String),
    /// The answer cannot be what was asked for (e.g. longer than the blob): a miss.
    Invalid(String),
}

impl RemoteError {
    /// An answer longer than the `limit` bytes the caller accepts.
    pub fn longer_than(limit: u64) -> RemoteError {
        RemoteError::Invalid(format!("more than the expected {limit} bytes"))
    }
}

impl fmt::Display for RemoteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RemoteError::Unavailable(m) | RemoteError::Rejected(m) | RemoteError::Invalid(m) => {
                f.write_str(m)
            }
        }
    }
}

/// A store speaking the remote-cache protocol. Implementations must be thread-safe; the
/// caller verifies everything they return.
pub trait RemoteStore: Send + Sync {
    /// Where the store is, for messages (no credentials).
    fn describe(&self) -> String;
    /// The object's bytes, `None` when the store does not have it. `limit`: the most bytes
    /// the caller accepts (more is [`RemoteError::Invalid`]).
    fn get(
        &self,
        ns: Namespace,
        hash: &ContentHash,
        limit: u64,
    ) -> Result<Option<Vec<u8>>, RemoteError>;
    /// Whether the store has the object.
    fn contains(&self, ns: Namespace, hash: &ContentHash) -> Result<bool, RemoteError>;
    /// Store the object (replacing any copy).
    fn put(&self, ns: Namespace, hash: &ContentHash, bytes: &[u8]) -> Result<(), RemoteError>;
}

/// How blobs are named on the server.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RemoteDigest {
    /// blake3, the local cache's own hash: no extra hashing.
    #[default]
    Blake3,
    /// sha256 of the content, as bazel-remote and the REAPI check.
    Sha256,
}

/// The sha256 of `bytes`, as a name.
fn sha256(bytes: &[u8]) -> ContentHash {
    use sha2::Digest as _;
    ContentHash(sha2::Sha256::digest(bytes).into())
}

/// Whether this builder uploads what it builds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RemoteMode {
    /// Download only (developer machines): the store is never written.
    #[default]
    ReadOnly,
    /// Download, and upload the results of jobs that ran (build farm machines, CI).
    ReadWrite,
}

/// Bytes and objects moved by this client during a build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RemoteStats {
    pub entries_downloaded: u64,
    pub blobs_downloaded: u64,
    pub bytes_downloaded: u64,
    pub entries_uploaded: u64,
    pub blobs_uploaded: u64,
    pub bytes_uploaded: u64,
    /// Downloads that failed verification (each a miss and a warning).
    pub corrupt: u64,
}

#[derive(Default)]
struct Counters {
    entries_down: AtomicU64,
    blobs_down: AtomicU64,
    bytes_down: AtomicU64,
    entries_up: AtomicU64,
    blobs_up: AtomicU64,
    bytes_up: AtomicU64,
    corrupt: AtomicU64,
}

/// The most bytes accepted for an action entry (they are a few hundred bytes).
const MAX_ENTRY_BYTES: u64 = 16 << 20;
/// The most bytes a remote entry may say one output has: a forged size must not make a
/// download (and its buffer) unbounded. Results are textures and meshes, far below this.
const MAX_REMOTE_BLOB_BYTES: u64 = 4 << 30;
/// Blobs at least this large are checked with `HEAD` before upload; smaller ones are sent.
const HEAD_BEFORE_PUT: u64 = 64 << 10;

/// The remote cache of one build, shared by every graph run of that build: a store, a mode,
/// whether the store has failed (then it is not asked again), and counters.
pub struct RemoteCache {
    store: Box<dyn RemoteStore>,
    mode: RemoteMode,
    digest: RemoteDigest,
    /// sha256 names of blobs (by blake3), learnt from entries and uploads, with
    /// [`RemoteDigest::Sha256`].
    names: Mutex<HashMap<ContentHash, ContentHash>>,
    offline: AtomicBool,
    uploads_off: AtomicBool,
    /// Blobs found damaged on the server: uploaded again (without `HEAD`) once rebuilt.
    damaged: Mutex<HashSet<ContentHash>>,
    counters: Counters,
}

impl fmt::Debug for RemoteCache {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RemoteCache")
            .field("store", &self.store.describe())
            .field("mode", &self.mode)
            .finish()
    }
}

impl RemoteCache {
    /// A remote cache over `store`.
    pub fn new(store: Box<dyn RemoteStore>, mode: RemoteMode, digest: RemoteDigest) -> RemoteCache {
        RemoteCache {
            store,
            mode,
            digest,
            names: Mutex::new(HashMap::new()),
            offline: AtomicBool::new(false),
            uploads_off: AtomicBool::new(false),
            damaged: Mutex::new(HashSet::new()),
            counters: Counters::default(),
        }
    }

    /// Where the store is.
    pub fn describe(&self) -> String {
        self.store.describe()
    }

    /// The mode it was opened in.
    pub fn mode(&self) -> RemoteMode {
        self.mode
    }

    /// How it names blobs.
    pub fn digest(&self) -> RemoteDigest {
        self.digest
    }

    /// Remember the sha256 names an entry gives its outputs.
    pub(crate) fn learn_names(&self, entry: &ActionEntry) {
        if self.digest != RemoteDigest::Sha256 || entry.remote_names.is_empty() {
            return;
        }
        let mut names = self.names.lock().unwrap_or_else(|e| e.into_inner());
        for (output, blob) in &entry.outputs {
            if let Some(name) = entry.remote_names.get(output) {
                names.insert(blob.hash, *name);
            }
        }
    }

    /// The server's name for `blob`, whose bytes are `bytes`: its blake3, or its sha256
    /// (remembered, for [`RemoteCache::known_name`]).
    fn name_of(&self, blob: &BlobRef, bytes: &[u8]) -> ContentHash {
        match self.digest {
            RemoteDigest::Blake3 => blob.hash,
            RemoteDigest::Sha256 => *self
                .names
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .entry(blob.hash)
                .or_insert_with(|| sha256(bytes)),
        }
    }

    /// The server's name for `blob` without its bytes: its blake3, or the sha256 learnt from
    /// an entry or an upload (`None` when unknown).
    fn known_name(&self, blob: &BlobRef) -> Option<ContentHash> {
        match self.digest {
            RemoteDigest::Blake3 => Some(blob.hash),
            RemoteDigest::Sha256 => self
                .names
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .get(&blob.hash)
                .copied(),
        }
    }

    /// The server's name for the entry of job `key`: the key itself, or, with sha256 blob
    /// names, a key derived from it, so builders of the two modes sharing a server never
    /// take (or overwrite) each other's entries.
    fn ac_name(&self, key: &ContentHash) -> ContentHash {
        match self.digest {
            RemoteDigest::Blake3 => *key,
            RemoteDigest::Sha256 => {
                let mut h = blake3::Hasher::new();
                h.update(b"ori action entry with sha256 blob names\0");
                h.update(&key.0);
                ContentHash(*h.finalize().as_bytes())
            }
        }
    }

    /// Upload a blob (as [`ResultStore::keep_blob`]) and give its sha256 name, with
    /// [`RemoteDigest::Sha256`], for the entry that lists it.
    pub(crate) fn keep_named_blob(
        &self,
        blob: &BlobRef,
        bytes: &[u8],
        observer: &dyn Observer,
    ) -> Result<Option<ContentHash>, String> {
        self.keep_blob(blob, bytes, observer)?;
        Ok(match self.digest {
            RemoteDigest::Blake3 => None,
            RemoteDigest::Sha256 => Some(self.name_of(blob, bytes)),
        })
    }

    /// Whether the store failed during this build (and is no longer asked).
    pub fn is_offline(&self) -> bool {
        self.offline.load(Ordering::Relaxed)
    }

    /// What this client moved so far.
    pub fn stats(&self) -> RemoteStats {
        let c = &self.counters;
        let get = |a: &AtomicU64| a.load(Ordering::Relaxed);
        RemoteStats {
            entries_downloaded: get(&c.entries_down),
            blobs_downloaded: get(&c.blobs_down),
            bytes_downloaded: get(&c.bytes_down),
            entries_uploaded: get(&c.entries_up),
            blobs_uploaded: get(&c.blobs_up),
            bytes_uploaded: get(&c.bytes_up),
            corrupt: get(&c.corrupt),
        }
    }

    /// Note an unusable server once, and stop asking it.
    fn went_offline(&self, error: &RemoteError, observer: &dyn Observer) {
        if !self.offline.swap(true, Ordering::Relaxed) {
            observer.note(&format!(
                "warning: remote cache {} is unavailable ({error}); building locally for the rest of this build",
                self.describe()
            ));
        }
    }

    /// Note damaged bytes from the server: a miss, one warning each.
    fn damaged_download(&self, what: String, observer: &dyn Observer) {
        self.counters.corrupt.fetch_add(1, Ordering::Relaxed);
        observer.note(&format!(
            "warning: remote cache {}: {what}; not used, building it instead",
            self.describe()
        ));
    }

    fn note_damaged(&self, blob: &BlobRef) {
        self.damaged
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(blob.hash);
    }

    /// Whether this build still uploads (read-write, and no upload or request has failed).
    pub(crate) fn uploads_allowed(&self) -> bool {
        self.mode == RemoteMode::ReadWrite
            && !self.is_offline()
            && !self.uploads_off.load(Ordering::Relaxed)
    }

    /// Note a failed upload once: an unavailable server is not asked again, any other
    /// failure stops uploads for the rest of this build.
    pub(crate) fn upload_failed(&self, e: &RemoteError, observer: &dyn Observer) -> String {
        match e {
            RemoteError::Unavailable(_) => self.went_offline(e, observer),
            _ => {
                if !self.uploads_off.swap(true, Ordering::Relaxed) {
                    observer.note(&format!(
                        "warning: remote cache {}: upload failed ({e}); not uploading for the rest of this build",
                        self.describe()
                    ));
                }
            }
        }
        format!("remote cache {}: upload failed ({e})", self.describe())
    }

    /// Run an upload while uploads are allowed (else do nothing); a failure is noted once.
    fn upload_with(
        &self,
        observer: &dyn Observer,
        put: impl FnOnce() -> Result<(), RemoteError>,
    ) -> Result<(), String> {
        if !self.uploads_allowed() {
            return Ok(());
        }
        put().map_err(|e| self.upload_failed(&e, observer))
    }

    fn try_put_blob(&self, blob: &BlobRef, bytes: &[u8]) -> Result<(), RemoteError> {
        let name = self.name_of(blob, bytes);
        let damaged = self
            .damaged
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&blob.hash);
        if !damaged && blob.size >= HEAD_BEFORE_PUT && self.store.contains(Namespace::Cas, &name)? {
            return Ok(());
        }
        self.store.put(Namespace::Cas, &name, bytes)?;
        self.counters.blobs_up.fetch_add(1, Ordering::Relaxed);
        self.counters
            .bytes_up
            .fetch_add(bytes.len() as u64, Ordering::Relaxed);
        Ok(())
    }

    fn try_put_action(&self, key: &ContentHash, entry: &ActionEntry) -> Result<(), RemoteError> {
        let bytes = encode_checked_json(entry)
            .map_err(|e| RemoteError::Rejected(format!("cannot encode the entry: {e}")))?;
        self.store.put(Namespace::Ac, &self.ac_name(key), &bytes)?;
        self.counters.entries_up.fetch_add(1, Ordering::Relaxed);
        self.counters
            .bytes_up
            .fetch_add(bytes.len() as u64, Ordering::Relaxed);
        Ok(())
    }
}

/// The remote tier: downloads verified (damage is a miss and a warning), nothing asked once
/// the server has failed, uploads only in read-write mode.
impl ResultStore for RemoteCache {
    fn describe(&self) -> String {
        self.store.describe()
    }

    fn action(&self, key: &ContentHash, observer: &dyn Observer) -> Lookup<ActionEntry> {
        if self.is_offline() {
            return Lookup::Missing;
        }
        let bytes = match self
            .store
            .get(Namespace::Ac, &self.ac_name(key), MAX_ENTRY_BYTES)
        {
            Ok(Some(bytes)) => bytes,
            Ok(None) => return Lookup::Missing,
            Err(RemoteError::Invalid(why)) => {
                let what = format!("action entry {}: {why}", key.short());
                self.damaged_download(what.clone(), observer);
                return Lookup::Damaged(what);
            }
            Err(e) => {
                self.went_offline(&e, observer);
                return Lookup::Missing;
            }
        };
        self.counters.entries_down.fetch_add(1, Ordering::Relaxed);
        self.counters
            .bytes_down
            .fetch_add(bytes.len() as u64, Ordering::Relaxed);
        let entry = decode_checked_json::<ActionEntry>(&bytes).and_then(|entry| {
            match entry
                .outputs
                .iter()
                .find(|(_, blob)| blob.size > MAX_REMOTE_BLOB_BYTES)
            {
                Some((name, blob)) => Err(format!(
                    "output `{name}` claims {} bytes, more than the {MAX_REMOTE_BLOB_BYTES} a result may have",
                    blob.size
                )),
                None => Ok(entry),
            }
        });
        match entry {
            Ok(entry) => Lookup::Found(entry),
            Err(why) => {
                let what = format!("action entry {} is damaged ({why})", key.short());
                self.damaged_download(what.clone(), observer);
                Lookup::Damaged(what)
            }
        }
    }

    fn blob(&self, blob: &BlobRef, observer: &dyn Observer) -> Lookup<Vec<u8>> {
        if self.is_offline() {
            return Lookup::Missing;
        }
        let Some(name) = self.known_name(blob) else {
            return Lookup::Missing;
        };
        let bytes = match self.store.get(Namespace::Cas, &name, blob.size) {
            Ok(Some(bytes)) => bytes,
            Ok(None) => return Lookup::Missing,
            Err(RemoteError::Invalid(why)) => {
                self.note_damaged(blob);
                let what = format!("blob {}: {why}", blob.hash.short());
                self.damaged_download(what.clone(), observer);
                return Lookup::Damaged(what);
            }
            Err(e) => {
                self.went_offline(&e, observer);
                return Lookup::Missing;
            }
        };
        self.counters.blobs_down.fetch_add(1, Ordering::Relaxed);
        self.counters
            .bytes_down
            .fetch_add(bytes.len() as u64, Ordering::Relaxed);
        let actual = ContentHash::of(&bytes);
        if actual != blob.hash {
            self.note_damaged(blob);
            let what = format!(
                "blob {} is damaged (its {} bytes hash to {})",
                blob.hash.short(),
                bytes.len(),
                actual.short()
            );
            self.damaged_download(what.clone(), observer);
            return Lookup::Damaged(what);
        }
        Lookup::Found(bytes)
    }

    fn keep_blob(
        &self,
        blob: &BlobRef,
        bytes: &[u8],
        observer: &dyn Observer,
    ) -> Result<(), String> {
        self.upload_with(observer, || self.try_put_blob(blob, bytes))
    }

    fn keep_action(
        &self,
        key: &ContentHash,
        entry: &ActionEntry,
        observer: &dyn Observer,
    ) -> Result<(), String> {
        self.upload_with(observer, || self.try_put_action(key, entry))
    }
}
