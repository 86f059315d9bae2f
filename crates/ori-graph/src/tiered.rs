//! The local cache in front of an optional remote one ([`Tiered`]): all the scheduler
//! (`run.rs`) talks to. It reads through (a blob missing locally is fetched and kept) and
//! keeps what ran in both tiers (blobs first, then the entry, so the remote tier never lists
//! an entry whose blobs it lacks; the local one may, for blobs the scheduler fetches lazily).

use std::io;
use std::sync::Arc;

use crate::cache::{ActionEntry, BlobRef, Cache, ReadError};
use crate::hash::ContentHash;
use crate::outcome::Observer;
use crate::remote::{RemoteCache, RemoteError};
use crate::store::{Lookup, ResultStore};

/// The local cache in front of an optional remote one: what a run reads and writes through.
pub struct Tiered {
    local: Cache,
    remote: Option<Arc<RemoteCache>>,
    /// Whether blobs may be fetched into the local tier (not in a dry run, which writes
    /// nothing).
    fetch: bool,
}

impl Tiered {
    pub fn new(local: Cache, remote: Option<Arc<RemoteCache>>, fetch: bool) -> Tiered {
        Tiered {
            local,
            remote,
            fetch,
        }
    }

    /// The local tier (for what only it keeps: job records, the stat memo).
    pub fn local(&self) -> &Cache {
        &self.local
    }

    /// The entry for `key` in the local tier.
    pub fn local_action(&self, key: &ContentHash, observer: &dyn Observer) -> Lookup<ActionEntry> {
        self.local.action(key, observer)
    }

    /// The entry for `key` in the remote tier, not yet kept locally: the caller checks it
    /// like a local one first, then [`Tiered::adopt`]s it.
    pub fn remote_action(
        &self,
        key: &ContentHash,
        observer: &dyn Observer,
    ) -> Option<(ActionEntry, String)> {
        let remote = self.remote.as_ref()?;
        match remote.action(key, observer) {
            Lookup::Found(entry) => Some((entry, remote.describe())),
            Lookup::Missing | Lookup::Damaged(_) => None,
        }
    }

    /// Remember the remote names an entry gives its outputs, to fetch them later.
    pub fn learn_remote_names(&self, entry: &ActionEntry) {
        if let Some(remote) = &self.remote {
            remote.learn_names(entry);
        }
    }

    /// Keep in the local tier an entry found in the remote one (its blobs are already here).
    pub fn adopt(
        &self,
        key: &ContentHash,
        entry: &ActionEntry,
        observer: &dyn Observer,
    ) -> Result<(), String> {
        self.local.keep_action(key, entry, observer)
    }

    /// Whether `blob` is in the local tier, fetching it from the remote one if need be. A
    /// local copy of the wrong size is removed.
    pub fn ensure_blob(&self, blob: &BlobRef, observer: &dyn Observer) -> bool {
        if self.local.blob_present(blob) || self.fetch_blob(blob, observer) {
            return true;
        }
        self.local.discard_blob(&blob.hash);
        false
    }

    /// Fetch `blob` from the remote tier into the local one; whether it is now there.
    fn fetch_blob(&self, blob: &BlobRef, observer: &dyn Observer) -> bool {
        let Some(remote) = self.remote.as_ref().filter(|_| self.fetch) else {
            return false;
        };
        let Lookup::Found(bytes) = remote.blob(blob, observer) else {
            return false;
        };
        match self.local.keep_blob(blob, &bytes, observer) {
            Ok(()) => true,
            Err(e) => {
                observer.note(&format!("warning: {e}"));
                false
            }
        }
    }

    /// The bytes of `blob`: the local copy, or, when that is missing or damaged, the remote
    /// one (kept locally). The error is the local tier's.
    pub fn blob(&self, blob: &BlobRef, observer: &dyn Observer) -> Result<Vec<u8>, ReadError> {
        let damage = match self.local.read_blob(blob) {
            Ok(bytes) => return Ok(bytes),
            Err(e @ ReadError::Io { .. }) => return Err(e),
            Err(e) => e,
        };
        if self.fetch_blob(blob, observer)
            && let Ok(bytes) = self.local.read_blob(blob)
        {
            return Ok(bytes);
        }
        Err(damage)
    }

    /// Keep a stage's output in the local tier.
    pub fn put_output(&self, bytes: &[u8]) -> io::Result<BlobRef> {
        self.local.put_blob(bytes)
    }

    /// Keep a job that ran: its blobs (read from the local tier, where they are already) in
    /// the remote one, its entry in the local tier, then its entry in the remote one, so the
    /// server never lists an entry whose blobs it lacks. The entry kept in both carries the
    /// remote names of the blobs uploaded. Uploads are best effort: a failure is one warning
    /// for the build and stops them; nothing is read when nothing is uploaded.
    pub fn keep(
        &self,
        key: &ContentHash,
        entry: &ActionEntry,
        observer: &dyn Observer,
    ) -> Result<(), String> {
        let remote = self.remote.as_ref().filter(|r| r.uploads_allowed());
        let mut entry = entry.clone();
        let uploaded = match remote {
            Some(remote) => self.upload_blobs(remote, &mut entry, observer),
            None => false,
        };
        self.local.keep_action(key, &entry, observer)?;
        if let Some(remote) = remote.filter(|_| uploaded) {
            let _ = remote.keep_action(key, &entry, observer);
        }
        Ok(())
    }

    /// Upload the entry's blobs, noting their remote names in it; whether all went up.
    fn upload_blobs(
        &self,
        remote: &RemoteCache,
        entry: &mut ActionEntry,
        observer: &dyn Observer,
    ) -> bool {
        for (name, blob) in &entry.outputs {
            let bytes = match self.local.read_blob(blob) {
                Ok(bytes) => bytes,
                Err(e) => {
                    let e = RemoteError::Rejected(format!("cannot read the local copy: {e}"));
                    remote.upload_failed(&e, observer);
                    return false;
                }
            };
            match remote.keep_named_blob(blob, &bytes, observer) {
                Ok(Some(remote_name)) => {
                    entry.remote_names.insert(name.clone(), remote_name);
                }
                Ok(None) => {}
                Err(_) => return false,
            }
        }
        true
    }
}
