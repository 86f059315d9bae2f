//! Where job results are kept: action entries by job key, blobs by content hash.
//!
//! [`ResultStore`] is what a tier offers; the local [`Cache`] implements it here, a shared
//! `RemoteCache` in `remote.rs`, and `tiered.rs` puts the first in front of the second.

use crate::cache::{ActionEntry, BlobRef, Cache, ReadError};
use crate::hash::ContentHash;
use crate::outcome::Observer;

/// What a tier has under a key.
#[derive(Debug)]
pub enum Lookup<T> {
    Found(T),
    Missing,
    /// Present but failed verification, or unreadable: why, for messages.
    Damaged(String),
}

/// One tier of result storage. Everything returned is verified (blobs against their hash,
/// entries against their checksum); problems worth telling the user go to `observer`.
pub trait ResultStore: Send + Sync {
    /// Where the tier is, for messages.
    fn describe(&self) -> String;
    /// The action entry for `key`.
    fn action(&self, key: &ContentHash, observer: &dyn Observer) -> Lookup<ActionEntry>;
    /// The bytes of `blob`.
    fn blob(&self, blob: &BlobRef, observer: &dyn Observer) -> Lookup<Vec<u8>>;
    /// Keep `bytes`, which hash to `blob`.
    fn keep_blob(
        &self,
        blob: &BlobRef,
        bytes: &[u8],
        observer: &dyn Observer,
    ) -> Result<(), String>;
    /// Keep the action entry for `key` (after its blobs).
    fn keep_action(
        &self,
        key: &ContentHash,
        entry: &ActionEntry,
        observer: &dyn Observer,
    ) -> Result<(), String>;
}

fn lookup<T>(read: Result<T, ReadError>) -> Lookup<T> {
    match read {
        Ok(value) => Lookup::Found(value),
        Err(ReadError::Missing) => Lookup::Missing,
        Err(e) => Lookup::Damaged(e.to_string()),
    }
}

impl ResultStore for Cache {
    fn describe(&self) -> String {
        self.root().display().to_string()
    }

    fn action(&self, key: &ContentHash, _: &dyn Observer) -> Lookup<ActionEntry> {
        lookup(self.read_action(key))
    }

    fn blob(&self, blob: &BlobRef, _: &dyn Observer) -> Lookup<Vec<u8>> {
        lookup(self.read_blob(blob))
    }

    fn keep_blob(&self, blob: &BlobRef, bytes: &[u8], _: &dyn Observer) -> Result<(), String> {
        self.store_verified_blob(&blob.hash, bytes)
            .map_err(|e| format!("cannot write to the cache {}: {e}", self.describe()))
    }

    fn keep_action(
        &self,
        key: &ContentHash,
        entry: &ActionEntry,
        _: &dyn Observer,
    ) -> Result<(), String> {
        self.write_action(key, entry)
            .map_err(|e| format!("cannot write to the cache {}: {e}", self.describe()))
    }
}
