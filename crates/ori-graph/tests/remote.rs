//! The graph with a remote cache, through an in-memory [`RemoteStore`]: reuse across builders,
//! verification of downloads, an unavailable server, read-only mode, cached-only runs.

use std::collections::HashMap;
use std::fs;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use ori_graph::{
    Build, Cache, ContentHash, Graph, Input, JobContext, JobSpec, Namespace, Observer, Outcome,
    RemoteCache, RemoteDigest, RemoteError, RemoteMode, RemoteStore, RunOptions, Stage, StageError,
    run,
};
use serde_json::json;

/// Reverses its input; counts its runs.
struct Reverse {
    runs: AtomicUsize,
    input: &'static str,
}

impl Stage for Reverse {
    fn name(&self) -> &'static str {
        if self.input == "source" {
            "first"
        } else {
            "second"
        }
    }
    fn version(&self) -> u32 {
        1
    }
    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        self.runs.fetch_add(1, Ordering::SeqCst);
        let mut bytes = ctx.input(self.input)?;
        bytes.reverse();
        // Large enough for the HEAD-before-PUT path.
        bytes.extend(std::iter::repeat_n(b'.', 70_000));
        ctx.output("out", bytes);
        Ok(())
    }
}

type Objects = HashMap<(&'static str, ContentHash), Vec<u8>>;

/// A store in memory; counts requests.
#[derive(Default)]
struct Memory {
    objects: Mutex<Objects>,
    puts: AtomicUsize,
    /// The largest `limit` a download was asked with.
    largest_limit: AtomicU64,
}

/// A handle on a shared [`Memory`] (the test keeps one to look inside).
struct Shared(Arc<Memory>);

impl RemoteStore for Shared {
    fn describe(&self) -> String {
        "memory".into()
    }
    fn get(
        &self,
        ns: Namespace,
        hash: &ContentHash,
        limit: u64,
    ) -> Result<Option<Vec<u8>>, RemoteError> {
        self.0.largest_limit.fetch_max(limit, Ordering::SeqCst);
        Ok(self
            .0
            .objects
            .lock()
            .unwrap()
            .get(&(ns.segment(), *hash))
            .cloned())
    }
    fn contains(&self, ns: Namespace, hash: &ContentHash) -> Result<bool, RemoteError> {
        Ok(self
            .0
            .objects
            .lock()
            .unwrap()
            .contains_key(&(ns.segment(), *hash)))
    }
    fn put(&self, ns: Namespace, hash: &ContentHash, bytes: &[u8]) -> Result<(), RemoteError> {
        self.0.puts.fetch_add(1, Ordering::SeqCst);
        self.0
            .objects
            .lock()
            .unwrap()
            .insert((ns.segment(), *hash), bytes.to_vec());
        Ok(())
    }
}

/// A server that is down: every request fails. Counts requests.
#[derive(Default)]
struct Down {
    requests: Arc<AtomicUsize>,
}

impl RemoteStore for Down {
    fn describe(&self) -> String {
        "down".into()
    }
    fn get(&self, _: Namespace, _: &ContentHash, _: u64) -> Result<Option<Vec<u8>>, RemoteError> {
        self.requests.fetch_add(1, Ordering::SeqCst);
        Err(RemoteError::Unavailable("connection refused".into()))
    }
    fn contains(&self, _: Namespace, _: &ContentHash) -> Result<bool, RemoteError> {
        self.requests.fetch_add(1, Ordering::SeqCst);
        Err(RemoteError::Unavailable("connection refused".into()))
    }
    fn put(&self, _: Namespace, _: &ContentHash, _: &[u8]) -> Result<(), RemoteError> {
        self.requests.fetch_add(1, Ordering::SeqCst);
        Err(RemoteError::Unavailable("connection refused".into()))
    }
}

/// Collects notes (warnings).
#[derive(Default)]
struct Notes(Mutex<Vec<String>>);

impl Observer for Notes {
    fn note(&self, message: &str) {
        self.0.lock().unwrap().push(message.to_string());
    }
}

impl Notes {
    fn take(&self) -> Vec<String> {
        std::mem::take(&mut self.0.lock().unwrap())
    }
}

/// Two assets, each `first(source) -> second(out)`; a builder is a local cache.
struct Fixture {
    dir: tempfile::TempDir,
    first: Arc<Reverse>,
    second: Arc<Reverse>,
    graph: Graph,
}

impl Fixture {
    fn new() -> Fixture {
        let dir = tempfile::tempdir().unwrap();
        let first = Arc::new(Reverse {
            runs: AtomicUsize::new(0),
            input: "source",
        });
        let second = Arc::new(Reverse {
            runs: AtomicUsize::new(0),
            input: "in",
        });
        let mut graph = Graph::new();
        for name in ["a", "b"] {
            let path = dir.path().join(format!("{name}.txt"));
            fs::write(&path, format!("asset {name}")).unwrap();
            let f = graph.add(JobSpec {
                asset: name.into(),
                stage: first.clone(),
                params: json!({}),
                inputs: vec![("source".into(), Input::Source(path))],
            });
            graph.add(JobSpec {
                asset: name.into(),
                stage: second.clone(),
                params: json!({}),
                inputs: vec![(
                    "in".into(),
                    Input::Output {
                        job: f,
                        name: "out".into(),
                    },
                )],
            });
        }
        Fixture {
            dir,
            first,
            second,
            graph,
        }
    }

    fn cache(&self, name: &str) -> Cache {
        Cache::open(self.dir.path().join(name)).unwrap()
    }

    fn build<'g>(
        &'g self,
        cache: &Cache,
        remote: &Arc<RemoteCache>,
        cached_only: bool,
        notes: &'g Notes,
    ) -> Build<'g> {
        let options = RunOptions {
            threads: 2,
            remote: Some(remote.clone()),
            cached_only,
            ..RunOptions::default()
        };
        run(&self.graph, cache, &options, notes)
    }

    /// Runs of (first, second) since the last call.
    fn runs(&self) -> (usize, usize) {
        (
            self.first.runs.swap(0, Ordering::SeqCst),
            self.second.runs.swap(0, Ordering::SeqCst),
        )
    }

    fn outputs(&self, build: &Build<'_>) -> Vec<Vec<u8>> {
        self.graph
            .jobs()
            .map(|(id, _)| build.read_output(id, "out").unwrap())
            .collect()
    }
}

fn remote(store: impl RemoteStore + 'static, mode: RemoteMode) -> Arc<RemoteCache> {
    Arc::new(RemoteCache::new(
        Box::new(store),
        mode,
        RemoteDigest::Blake3,
    ))
}

#[test]
fn a_hit_downloads_only_the_outputs_no_later_job_reads_until_one_is_read() {
    let fx = Fixture::new();
    let memory = Arc::new(Memory::default());
    let notes = Notes::default();
    let writer = remote(Shared(memory.clone()), RemoteMode::ReadWrite);
    let expected = fx.outputs(&fx.build(&fx.cache("one"), &writer, false, &notes));
    fx.runs();

    let reader = remote(Shared(memory.clone()), RemoteMode::ReadOnly);
    let b = fx.build(&fx.cache("two"), &reader, false, &notes);
    assert_eq!(fx.runs(), (0, 0));
    // The second stage's outputs (read by no job) came down; the first's (read only by the
    // second, a hit) did not.
    assert_eq!(reader.stats().blobs_downloaded, 2);
    assert_eq!(fx.outputs(&b), expected);
    assert_eq!(reader.stats().blobs_downloaded, 4);
    assert_eq!(notes.take(), Vec::<String>::new());
}

#[test]
fn sha256_digests_name_every_blob_by_its_sha256_and_are_read_back() {
    use sha2::Digest as _;
    let fx = Fixture::new();
    let memory = Arc::new(Memory::default());
    let notes = Notes::default();
    let sha256 = |store, mode| {
        Arc::new(RemoteCache::new(
            Box::new(store),
            mode,
            RemoteDigest::Sha256,
        ))
    };
    let writer = sha256(Shared(memory.clone()), RemoteMode::ReadWrite);
    let expected = fx.outputs(&fx.build(&fx.cache("one"), &writer, false, &notes));
    fx.runs();
    let objects = memory.objects.lock().unwrap().clone();
    let blobs: Vec<_> = objects.iter().filter(|((ns, _), _)| *ns == "cas").collect();
    assert_eq!(blobs.len(), 4);
    for ((_, name), bytes) in blobs {
        let digest: [u8; 32] = sha2::Sha256::digest(bytes).into();
        assert_eq!(name.0, digest);
    }

    // An empty builder finds every output by its sha256 name, the lazily fetched ones too.
    let reader = sha256(Shared(memory.clone()), RemoteMode::ReadOnly);
    let b = fx.build(&fx.cache("two"), &reader, false, &notes);
    assert_eq!(fx.runs(), (0, 0));
    assert_eq!(fx.outputs(&b), expected);
    assert_eq!(reader.stats().blobs_downloaded, 4);
    assert_eq!(notes.take(), Vec::<String>::new());
    // And in a later build (a new client, knowing no names), from the names kept with the
    // local entries.
    let first = sha256(Shared(memory.clone()), RemoteMode::ReadOnly);
    fx.build(&fx.cache("three"), &first, false, &notes);
    assert_eq!(first.stats().blobs_downloaded, 2);
    let later = sha256(Shared(memory.clone()), RemoteMode::ReadOnly);
    let d = fx.build(&fx.cache("three"), &later, false, &notes);
    assert_eq!(later.stats().entries_downloaded, 0);
    assert_eq!(fx.outputs(&d), expected);
    assert_eq!(later.stats().blobs_downloaded, 2);
    assert_eq!(fx.runs(), (0, 0));
    assert_eq!(notes.take(), Vec::<String>::new());
    // A builder naming blobs by blake3 on the same server finds none of these entries.
    let other = remote(Shared(memory.clone()), RemoteMode::ReadOnly);
    fx.build(&fx.cache("four"), &other, false, &notes);
    assert_eq!(other.stats().entries_downloaded, 0);
    assert_eq!(fx.runs(), (2, 2));
}

#[test]
fn a_second_builder_reuses_everything_from_the_remote() {
    let fx = Fixture::new();
    let memory = Arc::new(Memory::default());
    let notes = Notes::default();

    let writer = remote(Shared(memory.clone()), RemoteMode::ReadWrite);
    let built = fx.build(&fx.cache("one"), &writer, false, &notes);
    assert!(built.succeeded());
    assert_eq!(fx.runs(), (2, 2));
    let expected = fx.outputs(&built);
    let up = writer.stats();
    assert_eq!((up.entries_uploaded, up.blobs_uploaded), (4, 4));
    assert_eq!(memory.objects.lock().unwrap().len(), 8);

    // Another builder, empty local cache, read-only: nothing runs, nothing is uploaded.
    let puts = memory.puts.load(Ordering::SeqCst);
    let reader = remote(Shared(memory.clone()), RemoteMode::ReadOnly);
    let b = fx.build(&fx.cache("two"), &reader, false, &notes);
    assert_eq!(fx.runs(), (0, 0));
    assert!(
        fx.graph
            .jobs()
            .all(|(id, _)| b.result(id).outcome == Outcome::Reused)
    );
    assert_eq!(fx.outputs(&b), expected);
    let down = reader.stats();
    assert_eq!((down.entries_downloaded, down.blobs_downloaded), (4, 4));
    assert_eq!(down.bytes_downloaded, up.bytes_uploaded);
    assert_eq!(memory.puts.load(Ordering::SeqCst), puts);
    assert_eq!(notes.take(), Vec::<String>::new());

    // What was downloaded is in the local cache now: the server is not asked again.
    let again = remote(Down::default(), RemoteMode::ReadOnly);
    fx.build(&fx.cache("two"), &again, false, &notes);
    assert_eq!(fx.runs(), (0, 0));
    assert!(!again.is_offline());
}

#[test]
fn damaged_remote_bytes_are_a_miss_with_a_warning_and_are_repaired() {
    let fx = Fixture::new();
    let memory = Arc::new(Memory::default());
    let notes = Notes::default();
    let b = fx.build(
        &fx.cache("one"),
        &remote(Shared(memory.clone()), RemoteMode::ReadWrite),
        false,
        &notes,
    );
    let expected = fx.outputs(&b);
    fx.runs();
    // Damage the first output of asset `a`: same length, one byte changed.
    let a_first = ContentHash::of(&expected[0]);
    {
        let mut objects = memory.objects.lock().unwrap();
        let blob = objects.get_mut(&("cas", a_first)).unwrap();
        blob[0] ^= 1;
    }
    let second = remote(Shared(memory.clone()), RemoteMode::ReadWrite);
    let b = fx.build(&fx.cache("two"), &second, false, &notes);
    // The damaged output is read by the second job only, a hit: nothing fetched it yet.
    assert_eq!((fx.runs(), notes.take().len()), ((0, 0), 0));
    assert_eq!(fx.outputs(&b), expected);
    // Reading it found the damage and ran the job that made it (the same bytes again), so
    // the next job's key is unchanged and it stays reused.
    assert_eq!(fx.runs(), (1, 0));
    let warnings = notes.take();
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[0].contains("is damaged"), "{warnings:?}");
    assert!(
        warnings[1].contains("re-running stage `first`"),
        "{warnings:?}"
    );
    assert_eq!(second.stats().corrupt, 1);
    // The rebuilt blob was uploaded again over the damaged copy.
    assert_eq!(
        ContentHash::of(&memory.objects.lock().unwrap()[&("cas", a_first)]),
        a_first
    );

    // A damaged action entry is a miss too.
    let mut keys: Vec<ContentHash> = memory
        .objects
        .lock()
        .unwrap()
        .keys()
        .filter(|(ns, _)| *ns == "ac")
        .map(|(_, k)| *k)
        .collect();
    keys.sort();
    for key in &keys {
        let mut objects = memory.objects.lock().unwrap();
        let entry = objects.get_mut(&("ac", *key)).unwrap();
        let last = entry.len() - 3;
        entry[last] ^= 1;
    }
    let third = remote(Shared(memory.clone()), RemoteMode::ReadOnly);
    let b = fx.build(&fx.cache("three"), &third, false, &notes);
    assert_eq!(fx.outputs(&b), expected);
    assert_eq!(fx.runs(), (2, 2));
    assert_eq!(notes.take().len(), 4);
    assert_eq!(third.stats().corrupt, 4);
}

/// An entry that claims a huge output (its checksum made to hold, as a hostile server can) is
/// a damaged entry: the job runs here, and nothing that size is downloaded.
#[test]
fn an_entry_claiming_a_huge_output_is_damaged_and_never_downloaded() {
    let fx = Fixture::new();
    let memory = Arc::new(Memory::default());
    let notes = Notes::default();
    let b = fx.build(
        &fx.cache("one"),
        &remote(Shared(memory.clone()), RemoteMode::ReadWrite),
        false,
        &notes,
    );
    let expected = fx.outputs(&b);
    fx.runs();
    for entry in memory
        .objects
        .lock()
        .unwrap()
        .iter_mut()
        .filter(|((ns, _), _)| *ns == "ac")
        .map(|(_, bytes)| bytes)
    {
        let text = String::from_utf8(entry.clone()).unwrap();
        let (_, json) = text.split_once('\n').unwrap();
        let mut value: serde_json::Value = serde_json::from_str(json).unwrap();
        value["outputs"]["out"]["size"] = json!(1u64 << 40);
        let json = serde_json::to_string(&value).unwrap();
        *entry = format!("{}\n{json}\n", blake3::hash(json.as_bytes()).to_hex()).into_bytes();
    }
    memory.largest_limit.store(0, Ordering::SeqCst);
    let second = remote(Shared(memory.clone()), RemoteMode::ReadOnly);
    let b = fx.build(&fx.cache("two"), &second, false, &notes);
    assert_eq!(fx.outputs(&b), expected);
    assert_eq!(fx.runs(), (2, 2));
    let warnings = notes.take();
    assert_eq!(warnings.len(), 4, "{warnings:?}");
    assert!(
        warnings
            .iter()
            .all(|w| w.contains("claims 1099511627776 bytes")),
        "{warnings:?}"
    );
    assert!(memory.largest_limit.load(Ordering::SeqCst) <= 16 << 20);
}

#[test]
fn an_unavailable_server_is_one_warning_and_one_request() {
    let fx = Fixture::new();
    let notes = Notes::default();
    let down = Down::default();
    let requests = down.requests.clone();
    let r = remote(down, RemoteMode::ReadWrite);
    let b = fx.build(&fx.cache("one"), &r, false, &notes);
    assert!(b.succeeded());
    assert_eq!(fx.runs(), (2, 2));
    let warnings = notes.take();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("remote cache down is unavailable (connection refused)"),
        "{warnings:?}"
    );
    assert!(r.is_offline());
    // Parallel jobs may have asked before the first answer came back; never more.
    assert!(requests.load(Ordering::SeqCst) <= 2);
}

#[test]
fn read_only_mode_never_uploads() {
    let fx = Fixture::new();
    let memory = Arc::new(Memory::default());
    let notes = Notes::default();
    let r = remote(Shared(memory.clone()), RemoteMode::ReadOnly);
    assert!(fx.build(&fx.cache("one"), &r, false, &notes).succeeded());
    assert_eq!(fx.runs(), (2, 2));
    assert_eq!(memory.puts.load(Ordering::SeqCst), 0);
    assert!(memory.objects.lock().unwrap().is_empty());
}

#[test]
fn a_cached_only_run_runs_nothing_and_says_what_is_missing() {
    let fx = Fixture::new();
    let memory = Arc::new(Memory::default());
    let notes = Notes::default();
    let r = remote(Shared(memory.clone()), RemoteMode::ReadOnly);
    let b = fx.build(&fx.cache("one"), &r, true, &notes);
    assert_eq!(fx.runs(), (0, 0));
    let outcomes: Vec<Outcome> = fx
        .graph
        .jobs()
        .map(|(id, _)| b.result(id).outcome.clone())
        .collect();
    assert_eq!(
        outcomes,
        [
            Outcome::NotCached,
            Outcome::Skipped,
            Outcome::NotCached,
            Outcome::Skipped
        ]
    );
    // Filled by another builder, it succeeds without running anything.
    let w = remote(Shared(memory.clone()), RemoteMode::ReadWrite);
    fx.build(&fx.cache("two"), &w, false, &notes);
    fx.runs();
    let b = fx.build(&fx.cache("one"), &r, true, &notes);
    assert!(b.succeeded());
    assert_eq!(fx.runs(), (0, 0));
}
