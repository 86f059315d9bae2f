//! Source files: where they may come from, their content hashes, and a stat memo so that
//! unchanged files are not re-read.
//!
//! Every source file and every file a stage discovers is untrusted: [`SourceRules`] say it
//! must resolve, after symbolic links, inside the asset root, be a regular file (not a FIFO, a
//! device or a folder) and be no larger than a limit, and reads never take more than that
//! limit, whatever the file claims or grows to.
//!
//! A memo entry maps a path to (size, mtime, ctime, inode, hash) and is sealed with a keyed
//! hash of all of them, the path included, so an entry that was damaged or moved to another
//! path is detected, reported once and dropped (the file is simply read again). It is trusted
//! only when all four stat fields match. A file modified within the filesystem's timestamp
//! granularity of the moment it was hashed could keep its mtime, so entries younger than
//! [`RACY_WINDOW`] at save time are not memoised (git's "racily clean" rule): such a file is
//! simply re-hashed next time. A changed file is therefore always re-hashed.

use std::collections::{BTreeMap, HashMap};
use std::fs;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{LazyLock, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::cache::write_atomic;
use crate::hash::ContentHash;

/// Files modified this recently when the memo is saved are left out of it.
pub const RACY_WINDOW: Duration = Duration::from_secs(2);

/// The default largest source file: a model or a file it references.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 512 << 20;

/// What a source file must be to be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceRules {
    /// The folder every source must resolve into (canonical); `None` confines nothing.
    root: Option<PathBuf>,
    /// The largest file read, in bytes.
    pub max_file_bytes: u64,
}

impl Default for SourceRules {
    fn default() -> Self {
        SourceRules {
            root: None,
            max_file_bytes: DEFAULT_MAX_FILE_BYTES,
        }
    }
}

impl SourceRules {
    /// Sources confined to `root` (which must exist) and at most `max_file_bytes` each.
    pub fn confined(root: &Path, max_file_bytes: u64) -> io::Result<SourceRules> {
        Ok(SourceRules {
            root: Some(fs::canonicalize(root)?),
            max_file_bytes,
        })
    }

    /// The canonical root, if confined.
    pub fn root(&self) -> Option<&Path> {
        self.root.as_deref()
    }

    /// Check `path` against the rules: `Ok(None)` when there is no such file, else where it
    /// resolves to and its metadata. The error says which rule it broke, without naming where
    /// it leads.
    fn check(&self, path: &Path) -> io::Result<Option<(PathBuf, fs::Metadata)>> {
        let resolved = match fs::canonicalize(path) {
            Ok(p) => p,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e),
        };
        if let Some(root) = &self.root
            && !resolved.starts_with(root)
        {
            return Err(refused(
                "it resolves outside the asset root ([assets] root); \
                 models may only reference files inside it",
            ));
        }
        let meta = fs::metadata(&resolved)?;
        if !meta.is_file() {
            return Err(refused("it is not a regular file"));
        }
        if meta.len() > self.max_file_bytes {
            return Err(refused(&format!(
                "it is {} bytes, more than the limit of {} ([limits] max_file_mb)",
                meta.len(),
                self.max_file_bytes
            )));
        }
        Ok(Some((resolved, meta)))
    }

    /// Read a file that passes [`SourceRules::check`]: opened without blocking (a FIFO
    /// swapped in meanwhile is refused, not waited on) and never more than the limit.
    pub fn read(&self, path: &Path) -> io::Result<Vec<u8>> {
        match self.check(path)? {
            Some((resolved, _)) => self.read_resolved(&resolved),
            None => Err(io::Error::new(io::ErrorKind::NotFound, "no such file")),
        }
    }

    /// Read a path [`SourceRules::check`] resolved (the file it checked, not whatever a link
    /// in `path` points to by now).
    fn read_resolved(&self, resolved: &Path) -> io::Result<Vec<u8>> {
        let file = open_nonblocking(resolved)?;
        if !file.metadata()?.is_file() {
            return Err(refused("it is not a regular file"));
        }
        let mut bytes = Vec::new();
        file.take(self.max_file_bytes + 1).read_to_end(&mut bytes)?;
        if bytes.len() as u64 > self.max_file_bytes {
            return Err(refused(&format!(
                "it grew past the limit of {} bytes ([limits] max_file_mb) while being read",
                self.max_file_bytes
            )));
        }
        Ok(bytes)
    }
}

/// A rule a file broke, as an I/O error (never `NotFound`, which means "absent").
fn refused(why: &str) -> io::Error {
    io::Error::new(io::ErrorKind::PermissionDenied, format!("refused: {why}"))
}

#[cfg(unix)]
fn open_nonblocking(path: &Path) -> io::Result<fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    // O_NONBLOCK: opening a FIFO with no writer returns at once instead of hanging.
    const O_NONBLOCK: i32 = 0o4000;
    fs::OpenOptions::new()
        .read(true)
        .custom_flags(O_NONBLOCK)
        .open(path)
}

#[cfg(not(unix))]
fn open_nonblocking(path: &Path) -> io::Result<fs::File> {
    fs::File::open(path)
}

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
    /// [`seal`] of the path, stamp and hash.
    seal: ContentHash,
}

/// The keyed hash that binds a memo entry to its path.
fn seal(path: &Path, stamp: &Stamp, hash: &ContentHash) -> ContentHash {
    // Deriving the key once: a memo has an entry per source file.
    static SEALER: LazyLock<blake3::Hasher> =
        LazyLock::new(|| blake3::Hasher::new_derive_key("ori-graph stat memo entry v2"));
    let mut h = SEALER.clone();
    let path = path.as_os_str().as_encoded_bytes();
    h.update(&(path.len() as u64).to_le_bytes());
    h.update(path);
    h.update(&stamp.size.to_le_bytes());
    h.update(&stamp.mtime_ns.to_le_bytes());
    h.update(&stamp.ctime_ns.to_le_bytes());
    h.update(&stamp.inode.to_le_bytes());
    h.update(&hash.0);
    ContentHash(*h.finalize().as_bytes())
}

/// The memo file's intact entries, how many were dropped as damaged (an unreadable file
/// counts as one), and whether it held entries of the unsealed first version (left out).
fn load_memo(path: &Path) -> (HashMap<PathBuf, MemoEntry>, usize, bool) {
    let Ok(bytes) = fs::read(path) else {
        return (HashMap::new(), 0, false);
    };
    // Usually every entry is whole: take them in one pass, and look at each one apart only
    // when some is not.
    if let Ok(mut memo) = serde_json::from_slice::<HashMap<PathBuf, MemoEntry>>(&bytes) {
        let before = memo.len();
        memo.retain(|file, e| e.seal == seal(file, &e.stamp, &e.hash));
        let dropped = before - memo.len();
        return (memo, dropped, false);
    }
    let Ok(entries) = serde_json::from_slice::<BTreeMap<PathBuf, serde_json::Value>>(&bytes) else {
        return (HashMap::new(), 1, false);
    };
    let mut dropped = 0;
    let mut outdated = false;
    let mut memo = HashMap::new();
    for (file, value) in entries {
        // Entries of the unsealed first version are simply read again, without a warning.
        if value.get("seal").is_none() && value.get("stamp").is_some() {
            outdated = true;
            continue;
        }
        match serde_json::from_value::<MemoEntry>(value) {
            Ok(e) if e.seal == seal(&file, &e.stamp, &e.hash) => {
                memo.insert(file, e);
            }
            _ => dropped += 1,
        }
    }
    (memo, dropped, outdated)
}

/// Hashes source files, remembering results across builds in a memo file.
pub struct SourceHasher {
    memo_path: PathBuf,
    rules: SourceRules,
    memo: Mutex<HashMap<PathBuf, MemoEntry>>,
    /// Damaged entries dropped when the memo was loaded.
    dropped: usize,
    /// The memo file's version when loaded or last saved: while it is the one on disk,
    /// nobody else wrote it and saving need not read it again.
    version: Mutex<Option<FileVersion>>,
    /// Folders known to be (or not to be) their own canonical path.
    plain_folders: Mutex<HashMap<PathBuf, bool>>,
    /// Files hashed by reading them (not from the memo) during this build.
    rehashed: Mutex<u64>,
    /// Whether an entry was added, removed or dropped since loading or the last save (else
    /// saving has nothing to add).
    changed: AtomicBool,
}

impl SourceHasher {
    /// Load the memo at `memo_path` (a missing memo just means hashing anew; damaged entries
    /// are dropped and counted in [`SourceHasher::dropped`]).
    pub fn new(memo_path: PathBuf, rules: SourceRules) -> SourceHasher {
        let version = FileVersion::of(&memo_path);
        let (memo, dropped, outdated) = load_memo(&memo_path);
        SourceHasher {
            memo_path,
            rules,
            memo: Mutex::new(memo),
            dropped,
            version: Mutex::new(version),
            plain_folders: Mutex::new(HashMap::new()),
            rehashed: Mutex::new(0),
            // A memo with outdated or damaged entries is written again without them.
            changed: AtomicBool::new(outdated || dropped > 0),
        }
    }

    /// How many damaged memo entries were dropped on loading.
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    /// The warning to show when damaged entries were dropped on loading.
    pub fn damage_warning(&self) -> Option<String> {
        (self.dropped > 0).then(|| {
            format!(
                "warning: stat memo {}: {} damaged or mismatched entries dropped; those files are read again",
                self.memo_path.display(),
                self.dropped
            )
        })
    }

    /// The rules every file read through this hasher must pass.
    pub fn rules(&self) -> &SourceRules {
        &self.rules
    }

    /// Content hash of the file at `path`, or `Ok(None)` if there is no such file; an error
    /// when the file breaks a [`SourceRules`] rule or cannot be read.
    pub fn hash(&self, path: &Path) -> io::Result<Option<ContentHash>> {
        if let Some(hash) = self.unchanged(path) {
            return Ok(Some(hash));
        }
        let Some((resolved, meta)) = self.rules.check(path)? else {
            return Ok(None);
        };
        let stamp = stamp(&meta);
        if let Some(entry) = self.memo.lock().unwrap().get(path)
            && entry.stamp == stamp
        {
            return Ok(Some(entry.hash));
        }
        let hash = ContentHash::of(&self.rules.read_resolved(&resolved)?);
        *self.rehashed.lock().unwrap() += 1;
        self.remember(path, stamp, hash);
        Ok(Some(hash))
    }

    /// The memoised hash of a file that is, without resolving links, the very file (same
    /// inode, size and times) hashed under the rules before: nothing is read, so the path
    /// need not be resolved again. Only paths that name their place under the root plainly:
    /// no `..`, and a folder that is its own canonical path (no link on the way; each folder
    /// is resolved once per hasher).
    fn unchanged(&self, path: &Path) -> Option<ContentHash> {
        let plain = !path
            .components()
            .any(|c| matches!(c, std::path::Component::ParentDir));
        // A relative path names the same file as long as this process does not change
        // folders, which it never does.
        let absolute = std::path::absolute(path).ok()?;
        let inside = self
            .rules
            .root
            .as_ref()
            .is_none_or(|r| absolute.starts_with(r));
        if !plain || !inside || !self.plain_folder(absolute.parent()?) {
            return None;
        }
        let meta = fs::symlink_metadata(path).ok()?;
        if !meta.is_file() || meta.len() > self.rules.max_file_bytes {
            return None;
        }
        let memo = self.memo.lock().unwrap();
        let entry = memo.get(path)?;
        (entry.stamp == stamp(&meta)).then_some(entry.hash)
    }

    /// Whether `folder` is its own canonical path.
    fn plain_folder(&self, folder: &Path) -> bool {
        if let Some(&plain) = self.plain_folders.lock().unwrap().get(folder) {
            return plain;
        }
        let plain = fs::canonicalize(folder).is_ok_and(|c| c == folder);
        self.plain_folders
            .lock()
            .unwrap()
            .insert(folder.to_path_buf(), plain);
        plain
    }

    /// Read a file under the rules (see [`SourceRules::read`]).
    pub fn read(&self, path: &Path) -> io::Result<Vec<u8>> {
        self.rules.read(path)
    }

    /// Remember that the file at `path`, just written by this process, holds the content
    /// `hash`, so the next build need not read it (subject to the racy window, like every
    /// entry); when it cannot be looked at, it is forgotten instead.
    pub fn record(&self, path: &Path, hash: ContentHash) {
        match self.rules.check(path) {
            Ok(Some((_, meta))) => self.remember(path, stamp(&meta), hash),
            _ => self.forget(path),
        }
    }

    /// Drop what is memoised for `path` (its bytes did not match), so the next build reads it.
    pub fn forget(&self, path: &Path) {
        if self.memo.lock().unwrap().remove(path).is_some() {
            self.changed.store(true, Ordering::Relaxed);
        }
    }

    /// Record the hash of bytes just read from `path` (stat taken before the read).
    fn remember(&self, path: &Path, stamp: Stamp, hash: ContentHash) {
        let seal = seal(path, &stamp, &hash);
        self.memo
            .lock()
            .unwrap()
            .insert(path.to_path_buf(), MemoEntry { stamp, hash, seal });
        self.changed.store(true, Ordering::Relaxed);
    }

    /// How many files were read and hashed (memo misses) so far.
    pub fn rehashed(&self) -> u64 {
        *self.rehashed.lock().unwrap()
    }

    /// Write the memo back, merged with the intact entries another builder may have saved
    /// meanwhile, leaving out racily recent files. Nothing is written when no entry changed
    /// and none was dropped as damaged since loading or the last save: the file already says
    /// what the memo knows.
    pub fn save(&self) -> io::Result<()> {
        if !self.changed.swap(false, Ordering::Relaxed) {
            return Ok(());
        }
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default()
            .as_nanos() as i128;
        let mut version = self.version.lock().unwrap();
        let ours = self.memo.lock().unwrap();
        let theirs = match FileVersion::of(&self.memo_path) {
            current if current == *version => HashMap::new(),
            _ => load_memo(&self.memo_path).0,
        };
        // Ours over theirs, sorted so that the same memo is the same file.
        let mut sorted: BTreeMap<&str, &MemoEntry> = theirs
            .iter()
            .chain(ours.iter())
            .filter_map(|(path, e)| Some((path.to_str()?, e)))
            .collect();
        sorted.retain(|_, e| {
            now - e.stamp.mtime_ns.max(e.stamp.ctime_ns) > RACY_WINDOW.as_nanos() as i128
        });
        let json = serde_json::to_vec(&sorted).map_err(io::Error::other)?;
        match write_atomic(&self.memo_path, &json) {
            Ok(()) => {
                // What is on disk now is ours, less the racy entries (kept in memory).
                *version = FileVersion::of(&self.memo_path);
                Ok(())
            }
            Err(e) => {
                self.changed.store(true, Ordering::Relaxed);
                Err(e)
            }
        }
    }
}

impl std::fmt::Debug for SourceHasher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SourceHasher")
            .field("memo_path", &self.memo_path)
            .field("rules", &self.rules)
            .finish_non_exhaustive()
    }
}

/// Which version of a file is on disk: any edit, and any atomic rewrite (a new inode),
/// gives another. A memo saved by another builder since it was loaded is told this way.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileVersion(Stamp);

impl FileVersion {
    /// The version of the file at `path`; `None` when there is none.
    pub fn of(path: &Path) -> Option<FileVersion> {
        fs::metadata(path).ok().map(|m| FileVersion(stamp(&m)))
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
        let hasher = SourceHasher::new(memo.clone(), SourceRules::default());
        let first = hasher.hash(&file).unwrap().unwrap();
        hasher.save().unwrap();
        // Rewrite with the same size immediately: the racy entry was not memoised.
        fs::write(&file, b"v 1 0 0\n").unwrap();
        let hasher = SourceHasher::new(memo, SourceRules::default());
        let second = hasher.hash(&file).unwrap().unwrap();
        assert_ne!(first, second);
        assert_eq!(second, ContentHash::of(b"v 1 0 0\n"));
    }

    fn old_file(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let file = dir.join(name);
        fs::write(&file, bytes).unwrap();
        file
    }

    #[test]
    fn memo_entries_are_bound_to_their_path_and_damage_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let a = old_file(dir.path(), "a.obj", b"a");
        let b = old_file(dir.path(), "b.obj", b"b");
        // The change time cannot be set back: wait until it is not racy.
        std::thread::sleep(RACY_WINDOW + Duration::from_millis(100));
        let memo = dir.path().join("memo.json");
        let hasher = SourceHasher::new(memo.clone(), SourceRules::default());
        hasher.hash(&a).unwrap();
        hasher.hash(&b).unwrap();
        hasher.save().unwrap();
        let text = fs::read_to_string(&memo).unwrap();
        let (ha, hb) = (
            ContentHash::of(b"a").to_hex(),
            ContentHash::of(b"b").to_hex(),
        );
        let swapped = text.replace(&ha, "X").replace(&hb, &ha).replace("X", &hb);
        for (damaged, dropped) in [(swapped, 2), (text.replacen(&ha, &hb, 1), 1)] {
            fs::write(&memo, damaged).unwrap();
            let hasher = SourceHasher::new(memo.clone(), SourceRules::default());
            assert_eq!(hasher.dropped(), dropped);
            assert_eq!(hasher.hash(&a).unwrap(), Some(ContentHash::of(b"a")));
            assert_eq!(hasher.hash(&b).unwrap(), Some(ContentHash::of(b"b")));
        }
        fs::write(&memo, b"{not json").unwrap();
        assert_eq!(SourceHasher::new(memo, SourceRules::default()).dropped(), 1);
    }

    #[test]
    fn rules_confine_to_the_root_and_refuse_devices_fifos_and_large_files() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("root");
        fs::create_dir(&root).unwrap();
        fs::write(dir.path().join("outside"), b"secret").unwrap();
        fs::write(root.join("inside"), b"ok").unwrap();
        fs::write(root.join("large"), vec![0u8; 2000]).unwrap();
        let rules = SourceRules::confined(&root, 1000).unwrap();
        assert_eq!(rules.read(&root.join("inside")).unwrap(), b"ok");
        assert_eq!(rules.read(&root.join("../root/inside")).unwrap(), b"ok");
        let refused = |path: PathBuf, why: &str| {
            let e = rules.read(&path).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::PermissionDenied, "{e}");
            assert!(e.to_string().contains(why), "{e}");
        };
        refused(root.join("../outside"), "outside the asset root");
        refused(dir.path().join("outside"), "outside the asset root");
        refused(
            root.join("large"),
            "2000 bytes, more than the limit of 1000",
        );
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(dir.path().join("outside"), root.join("link")).unwrap();
            refused(root.join("link"), "outside the asset root");
            std::os::unix::fs::symlink("/dev/zero", root.join("zero")).unwrap();
            refused(root.join("zero"), "outside the asset root");
            let fifo = root.join("fifo");
            assert!(
                std::process::Command::new("mkfifo")
                    .arg(&fifo)
                    .status()
                    .unwrap()
                    .success()
            );
            refused(fifo, "not a regular file");
        }
        assert_eq!(
            rules.read(&root.join("missing")).unwrap_err().kind(),
            io::ErrorKind::NotFound
        );
        let hasher = SourceHasher::new(dir.path().join("memo.json"), rules);
        assert!(hasher.hash(&root.join("large")).is_err());
        assert_eq!(hasher.hash(&root.join("missing")).unwrap(), None);
    }

    #[test]
    fn old_files_are_memoised_and_missing_files_are_none() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.ply");
        fs::write(&file, b"ply").unwrap();
        std::thread::sleep(RACY_WINDOW + Duration::from_millis(100));
        let memo = dir.path().join("memo.json");
        let hasher = SourceHasher::new(memo.clone(), SourceRules::default());
        hasher.hash(&file).unwrap();
        assert_eq!(hasher.rehashed(), 1);
        hasher.save().unwrap();
        let hasher = SourceHasher::new(memo, SourceRules::default());
        assert_eq!(hasher.hash(&file).unwrap(), Some(ContentHash::of(b"ply")));
        assert_eq!(hasher.rehashed(), 0, "served from the memo");
        assert_eq!(hasher.hash(&dir.path().join("nope")).unwrap(), None);
    }

    #[test]
    fn a_recorded_output_is_not_read_again_and_an_unchanged_memo_is_not_rewritten() {
        let dir = tempfile::tempdir().unwrap();
        let file = old_file(dir.path(), "p.ori", b"package");
        let memo = dir.path().join("memo.json");
        let hasher = SourceHasher::new(memo.clone(), SourceRules::default());
        hasher.record(&file, ContentHash::of(b"package"));
        std::thread::sleep(RACY_WINDOW + Duration::from_millis(100));
        hasher.save().unwrap();
        let hasher = SourceHasher::new(memo.clone(), SourceRules::default());
        assert_eq!(
            hasher.hash(&file).unwrap(),
            Some(ContentHash::of(b"package"))
        );
        assert_eq!(hasher.rehashed(), 0, "served from the recorded entry");
        // The same entries laid out differently: a save that wrote would lay them out again.
        let json: serde_json::Value = serde_json::from_slice(&fs::read(&memo).unwrap()).unwrap();
        let pretty = serde_json::to_vec_pretty(&json).unwrap();
        fs::write(&memo, &pretty).unwrap();
        hasher.save().unwrap();
        assert_eq!(
            fs::read(&memo).unwrap(),
            pretty,
            "nothing changed: not saved"
        );

        // A memo holding entries of the unsealed first version is written again without them.
        let mut json: serde_json::Value =
            serde_json::from_slice(&fs::read(&memo).unwrap()).unwrap();
        json["/old/unsealed.obj"] = serde_json::json!({"stamp": {}, "hash": "00"});
        fs::write(&memo, serde_json::to_vec(&json).unwrap()).unwrap();
        let hasher = SourceHasher::new(memo.clone(), SourceRules::default());
        assert_eq!(hasher.dropped(), 0);
        hasher.save().unwrap();
        let saved: serde_json::Value = serde_json::from_slice(&fs::read(&memo).unwrap()).unwrap();
        assert!(saved.get("/old/unsealed.obj").is_none(), "{saved}");
        assert!(saved.get(file.to_str().unwrap()).is_some(), "{saved}");
    }

    #[cfg(unix)]
    #[test]
    fn a_memoised_path_whose_folder_now_leads_outside_the_root_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("root");
        fs::create_dir_all(root.join("sub")).unwrap();
        let inside = old_file(&root.join("sub"), "m.obj", b"inside");
        fs::create_dir(dir.path().join("outside")).unwrap();
        old_file(&dir.path().join("outside"), "m.obj", b"secret");
        std::thread::sleep(RACY_WINDOW + Duration::from_millis(100));
        let rules = SourceRules::confined(&root, 1000).unwrap();
        let memo = dir.path().join("memo.json");
        let hasher = SourceHasher::new(memo.clone(), rules.clone());
        assert_eq!(
            hasher.hash(&inside).unwrap(),
            Some(ContentHash::of(b"inside"))
        );
        hasher.save().unwrap();
        // The memo knows the path; the folder is swapped for a link to another one, or moved
        // out of the root and linked back (the very file, same inode and times).
        fs::rename(root.join("sub"), dir.path().join("moved")).unwrap();
        for target in ["outside", "moved"] {
            let _ = fs::remove_file(root.join("sub"));
            std::os::unix::fs::symlink(dir.path().join(target), root.join("sub")).unwrap();
            let hasher = SourceHasher::new(memo.clone(), rules.clone());
            let e = hasher.hash(&inside).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::PermissionDenied, "{target}: {e}");
        }
    }

    #[test]
    fn a_memo_another_builder_saved_meanwhile_is_merged_and_an_untouched_one_is_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (
            old_file(dir.path(), "a.obj", b"a"),
            old_file(dir.path(), "b.obj", b"b"),
        );
        std::thread::sleep(RACY_WINDOW + Duration::from_millis(100));
        let memo = dir.path().join("memo.json");
        let first = SourceHasher::new(memo.clone(), SourceRules::default());
        let second = SourceHasher::new(memo.clone(), SourceRules::default());
        first.hash(&a).unwrap();
        first.save().unwrap();
        second.hash(&b).unwrap();
        second.save().unwrap();
        let saved: serde_json::Value = serde_json::from_slice(&fs::read(&memo).unwrap()).unwrap();
        for file in [&a, &b] {
            assert!(saved.get(file.to_str().unwrap()).is_some(), "{saved}");
        }
        // Nobody wrote it since: a forgotten entry stays forgotten (not merged back in).
        let third = SourceHasher::new(memo.clone(), SourceRules::default());
        third.forget(&a);
        third.save().unwrap();
        let saved: serde_json::Value = serde_json::from_slice(&fs::read(&memo).unwrap()).unwrap();
        assert!(saved.get(a.to_str().unwrap()).is_none(), "{saved}");
        assert!(saved.get(b.to_str().unwrap()).is_some(), "{saved}");
        assert_eq!(FileVersion::of(&memo), *third.version.lock().unwrap());
    }
}
