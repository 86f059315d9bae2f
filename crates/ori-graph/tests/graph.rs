//! Behaviour of the build graph with small stages: reuse, invalidation, early cutoff,
//! corruption recovery, discovered files, failures, thread-count independence.

use std::fs;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use ori_graph::{
    ActionJob, ActionOutputs, Build, Cache, ContentHash, ExecuteError, Executor, Graph, Input,
    JobContext, JobId, JobSpec, Outcome, RemoteExecution, RunOptions, RunReason, Silent, Stage,
    StageError, run, run_action,
};
use serde_json::{Value, json};

/// Upper-cases its source; with `trim` it also trims whitespace. Counts its runs.
struct Upper {
    runs: AtomicUsize,
    version: u32,
}

impl Stage for Upper {
    fn name(&self) -> &'static str {
        "upper"
    }
    fn version(&self) -> u32 {
        self.version
    }
    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        self.runs.fetch_add(1, Ordering::SeqCst);
        let text = String::from_utf8(ctx.input("source")?).map_err(StageError::asset)?;
        if text.contains("FAIL") {
            return Err(StageError::asset("the text says FAIL"));
        }
        if text.contains("PANIC") {
            panic!("stage bug");
        }
        let mut out = text.to_uppercase();
        if ctx.params()["trim"] == json!(true) {
            out = out.trim().to_string();
        }
        // Optional include files, discovered while running, named before either is read
        // (with one never read, as a loader names a texture no face uses); as a model loader
        // would, it reads no further after one it cannot read.
        let includes = ["include.txt", "second.txt"].map(String::from);
        ctx.will_read(&[
            includes[0].clone(),
            includes[1].clone(),
            "unread.txt".into(),
        ]);
        for include in &includes {
            match ctx.read_discovered(include) {
                Ok(extra) => out.push_str(&String::from_utf8_lossy(&extra)),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(_) => break,
            }
        }
        ctx.output("text", out.into_bytes());
        Ok(())
    }
}

/// Counts the characters of its input, repeated `times`.
struct Count {
    runs: AtomicUsize,
}

impl Stage for Count {
    fn name(&self) -> &'static str {
        "count"
    }
    fn version(&self) -> u32 {
        1
    }
    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        self.runs.fetch_add(1, Ordering::SeqCst);
        let n = ctx.input("text")?.len() as u64 * ctx.params()["times"].as_u64().unwrap_or(1);
        ctx.output("count", n.to_string().into_bytes());
        Ok(())
    }
}

struct Fixture {
    _dir: tempfile::TempDir,
    root: std::path::PathBuf,
    cache: Cache,
    upper: Arc<Upper>,
    count: Arc<Count>,
}

impl Fixture {
    fn new() -> Fixture {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().to_path_buf();
        for name in ["a", "b", "c"] {
            fs::create_dir_all(root.join(name)).unwrap();
            fs::write(root.join(name).join("src.txt"), format!("asset {name}")).unwrap();
        }
        Fixture {
            cache: Cache::open(root.join("cache")).unwrap(),
            _dir: dir,
            root,
            upper: Arc::new(Upper {
                runs: AtomicUsize::new(0),
                version: 1,
            }),
            count: Arc::new(Count {
                runs: AtomicUsize::new(0),
            }),
        }
    }

    /// Per asset: upper(source) -> count(text). Params per asset from `params`.
    fn graph(&self, params: &dyn Fn(&str) -> (Value, Value)) -> (Graph, Vec<(JobId, JobId)>) {
        let mut graph = Graph::new();
        let mut ids = Vec::new();
        for name in ["a", "b", "c"] {
            let (up, count) = params(name);
            let u = graph.add(JobSpec {
                asset: name.into(),
                stage: self.upper.clone(),
                params: up,
                inputs: vec![(
                    "source".into(),
                    Input::Source(self.root.join(name).join("src.txt")),
                )],
            });
            let c = graph.add(JobSpec {
                asset: name.into(),
                stage: self.count.clone(),
                params: count,
                inputs: vec![(
                    "text".into(),
                    Input::Output {
                        job: u,
                        name: "text".into(),
                    },
                )],
            });
            ids.push((u, c));
        }
        (graph, ids)
    }

    fn runs(&self) -> (usize, usize) {
        (
            self.upper.runs.swap(0, Ordering::SeqCst),
            self.count.runs.swap(0, Ordering::SeqCst),
        )
    }
}

fn defaults(_: &str) -> (Value, Value) {
    (json!({"trim": false}), json!({"times": 1}))
}

fn build<'g>(fx: &Fixture, graph: &'g Graph, threads: usize) -> Build<'g> {
    run(
        graph,
        &fx.cache,
        &RunOptions {
            threads,
            dry_run: false,
            ..RunOptions::default()
        },
        &Silent,
    )
}

fn outcome(b: &Build<'_>, id: JobId) -> Outcome {
    b.result(id).outcome.clone()
}

#[test]
fn second_build_reuses_everything() {
    let fx = Fixture::new();
    let (graph, ids) = fx.graph(&defaults);
    let first = build(&fx, &graph, 2);
    assert!(first.succeeded());
    assert_eq!(fx.runs(), (3, 3));
    assert_eq!(outcome(&first, ids[0].0), Outcome::Ran(RunReason::NewJob));
    let second = build(&fx, &graph, 2);
    assert_eq!(fx.runs(), (0, 0));
    for (u, c) in ids {
        assert_eq!(outcome(&second, u), Outcome::Reused);
        assert_eq!(second.read_output(c, "count").unwrap(), b"7");
    }
}

#[test]
fn parameter_change_invalidates_exactly_the_downstream_jobs() {
    let fx = Fixture::new();
    let (graph, _) = fx.graph(&defaults);
    build(&fx, &graph, 2);
    fx.runs();
    // Change `count` for asset b only: only b's count runs.
    let (graph, ids) = fx.graph(&|n| {
        let (u, c) = defaults(n);
        (u, if n == "b" { json!({"times": 3}) } else { c })
    });
    let b = build(&fx, &graph, 2);
    assert_eq!(fx.runs(), (0, 1));
    assert_eq!(
        outcome(&b, ids[1].1),
        Outcome::Ran(RunReason::Params(vec!["times: 1 -> 3".into()]))
    );
    assert_eq!(b.read_output(ids[1].1, "count").unwrap(), b"21");
    // A change of `upper` for asset a runs a's upper and, since its output changes, a's count.
    fs::write(fx.root.join("a/src.txt"), " asset a ").unwrap();
    let (graph, ids) = fx.graph(&|n| {
        let (u, c) = defaults(n);
        (u, if n == "b" { json!({"times": 3}) } else { c })
    });
    let b = build(&fx, &graph, 2);
    assert_eq!(fx.runs(), (1, 1));
    assert_eq!(
        outcome(&b, ids[0].0),
        Outcome::Ran(RunReason::Inputs(vec!["source".into()]))
    );
    assert_eq!(
        outcome(&b, ids[0].1),
        Outcome::Ran(RunReason::Inputs(vec!["text".into()]))
    );
}

#[test]
fn identical_upstream_output_stops_the_cascade() {
    let fx = Fixture::new();
    let (graph, _) = fx.graph(&defaults);
    build(&fx, &graph, 2);
    fx.runs();
    // trim = true changes upper's key, but the sources have no surrounding whitespace, so its
    // output is the same bytes and count is reused (early cutoff).
    let (graph, ids) = fx.graph(&|_| (json!({"trim": true}), json!({"times": 1})));
    let b = build(&fx, &graph, 2);
    assert_eq!(fx.runs(), (3, 0));
    assert!(matches!(
        outcome(&b, ids[0].0),
        Outcome::Ran(RunReason::Params(_))
    ));
    assert_eq!(outcome(&b, ids[0].1), Outcome::Reused);
}

#[test]
fn stage_version_bump_reruns_that_stage() {
    let mut fx = Fixture::new();
    let (graph, _) = fx.graph(&defaults);
    build(&fx, &graph, 2);
    fx.upper = Arc::new(Upper {
        runs: AtomicUsize::new(0),
        version: 2,
    });
    let (graph, ids) = fx.graph(&defaults);
    let b = build(&fx, &graph, 2);
    assert_eq!(
        outcome(&b, ids[2].0),
        Outcome::Ran(RunReason::StageVersion { from: 1, to: 2 })
    );
    assert_eq!(
        outcome(&b, ids[2].1),
        Outcome::Reused,
        "same output, early cutoff"
    );
}

#[test]
fn corrupt_blobs_and_entries_are_rebuilt_never_used() {
    let fx = Fixture::new();
    let (graph, ids) = fx.graph(&defaults);
    let first = build(&fx, &graph, 2);
    let upper_a = first.result(ids[0].0).outputs["text"];
    let count_b = first.result(ids[1].1).outputs["count"];
    fx.runs();

    // 1. Same-size damage to a's upper output, found when its consumer reads it: the
    //    producer is re-run to regenerate it.
    let path = fx.cache.blob_path(&upper_a.hash);
    let mut bytes = fs::read(&path).unwrap();
    bytes[0] ^= 0x20;
    fs::write(&path, &bytes).unwrap();
    let (graph2, ids2) = fx.graph(&|n| {
        let (u, c) = defaults(n);
        (u, if n == "a" { json!({"times": 2}) } else { c })
    });
    let b = build(&fx, &graph2, 2);
    assert!(b.succeeded());
    assert_eq!(b.read_output(ids2[0].1, "count").unwrap(), b"14");
    assert_eq!(fx.runs(), (1, 1), "upper regenerated once, count ran once");
    assert_eq!(fs::read(&path).unwrap(), b"ASSET A");

    // 2. A truncated blob is seen without reading it: the job re-runs. (All three count
    //    jobs share that blob, "7"; whichever checks first rebuilds it for the others.)
    fs::write(fx.cache.blob_path(&count_b.hash), b"").unwrap();
    let b = build(&fx, &graph, 1);
    let corrupt = ids
        .iter()
        .filter(|(_, c)| matches!(outcome(&b, *c), Outcome::Ran(RunReason::CorruptEntry(_))))
        .count();
    assert_eq!(corrupt, 1);
    for (_, c) in &ids {
        assert_eq!(b.read_output(*c, "count").unwrap(), b"7");
    }

    // 3. A damaged action entry is reported and the job re-runs.
    let ac = fx.cache.root().join("ac");
    for shard in fs::read_dir(&ac).unwrap() {
        for entry in fs::read_dir(shard.unwrap().path()).unwrap() {
            let p = entry.unwrap().path();
            let text = fs::read_to_string(&p).unwrap();
            fs::write(&p, text.replace("\"stage\"", "\"stagE\"")).unwrap();
        }
    }
    fx.runs();
    let b = build(&fx, &graph, 2);
    assert!(b.succeeded());
    assert_eq!(fx.runs(), (3, 3));
    assert!(matches!(
        outcome(&b, ids[2].0),
        Outcome::Ran(RunReason::CorruptEntry(_))
    ));
}

#[test]
fn discovered_files_are_tracked() {
    let fx = Fixture::new();
    let (graph, ids) = fx.graph(&defaults);
    build(&fx, &graph, 2);
    fx.runs();
    let include = fx.root.join("c/include.txt");
    fs::write(&include, "+inc").unwrap();
    let b = build(&fx, &graph, 2);
    assert_eq!(
        outcome(&b, ids[2].0),
        Outcome::Ran(RunReason::Discovered(
            "new input: referenced file `include.txt` appeared".into()
        ))
    );
    assert_eq!(fx.runs(), (1, 1));
    fs::write(&include, "+INC").unwrap();
    let b = build(&fx, &graph, 2);
    assert!(matches!(
        outcome(&b, ids[2].0),
        Outcome::Ran(RunReason::Discovered(_))
    ));
    assert_eq!(b.read_output(ids[2].0, "text").unwrap(), b"ASSET C+INC");
}

#[test]
fn failures_are_contained_and_reported() {
    let fx = Fixture::new();
    fs::write(fx.root.join("a/src.txt"), "FAIL").unwrap();
    fs::write(fx.root.join("b/src.txt"), "PANIC").unwrap();
    let (graph, ids) = fx.graph(&defaults);
    let b = build(&fx, &graph, 2);
    assert!(!b.succeeded());
    assert_eq!(
        outcome(&b, ids[0].0),
        Outcome::Failed("a: the text says FAIL".into())
    );
    assert_eq!(outcome(&b, ids[0].1), Outcome::Skipped);
    match outcome(&b, ids[1].0) {
        Outcome::Failed(m) => assert!(m.contains("internal error in stage `upper` for b"), "{m}"),
        other => panic!("{other:?}"),
    }
    assert_eq!(outcome(&b, ids[2].1), Outcome::Ran(RunReason::NewJob));
    // Nothing was cached for the failures: they fail again.
    let b = build(&fx, &graph, 2);
    assert!(matches!(outcome(&b, ids[0].0), Outcome::Failed(_)));
}

#[test]
fn dry_run_reports_without_running() {
    let fx = Fixture::new();
    let (graph, ids) = fx.graph(&defaults);
    let b = run(
        &graph,
        &fx.cache,
        &RunOptions {
            threads: 1,
            dry_run: true,
            ..RunOptions::default()
        },
        &Silent,
    );
    assert_eq!(fx.runs(), (0, 0));
    assert_eq!(outcome(&b, ids[0].0), Outcome::WouldRun(RunReason::NewJob));
    assert_eq!(
        outcome(&b, ids[0].1),
        Outcome::WouldRun(RunReason::UpstreamWouldRun)
    );
    assert!(!fx.cache.root().join("ac").exists());
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let mut caches = Vec::new();
    for threads in [1, 4] {
        let fx = Fixture::new();
        let (graph, ids) = fx.graph(&defaults);
        let b = build(&fx, &graph, threads);
        let outs: Vec<_> = ids
            .iter()
            .flat_map(|(u, c)| [b.result(*u).outputs.clone(), b.result(*c).outputs.clone()])
            .collect();
        caches.push(outs);
    }
    assert_eq!(caches[0], caches[1]);
}

#[test]
fn missing_source_fails_with_its_path() {
    let fx = Fixture::new();
    fs::remove_file(fx.root.join("b/src.txt")).unwrap();
    let (graph, ids) = fx.graph(&defaults);
    let b = build(&fx, &graph, 2);
    match outcome(&b, ids[1].0) {
        Outcome::Failed(m) => {
            assert!(
                m.contains(&Path::new("b").join("src.txt").display().to_string()),
                "{m}"
            );
            assert!(m.contains("not found"), "{m}");
        }
        other => panic!("{other:?}"),
    }
}

/// A farm in this process: it copies an action's blobs, as a farm stores them, and runs the
/// action on them. Counts the actions sent and keeps every blob it was sent; with `lie`, it
/// says each stage also read `include.txt`.
struct InProcessFarm {
    stages: Vec<Arc<dyn Stage>>,
    sent: AtomicUsize,
    received: Arc<std::sync::Mutex<Vec<Vec<u8>>>>,
    lie: bool,
}

impl InProcessFarm {
    fn new(fx: &Fixture, lie: bool) -> InProcessFarm {
        InProcessFarm {
            stages: vec![fx.upper.clone(), fx.count.clone()],
            sent: AtomicUsize::new(0),
            received: Arc::default(),
            lie,
        }
    }
}

/// An observer that keeps the warnings.
#[derive(Default)]
struct Notes(std::sync::Mutex<Vec<String>>);

impl ori_graph::Observer for Notes {
    fn note(&self, message: &str) {
        self.0.lock().unwrap().push(message.to_string());
    }
}

impl Executor for InProcessFarm {
    fn describe(&self) -> String {
        "in-process farm".into()
    }
    fn max_in_flight(&self) -> usize {
        2
    }
    fn execute(
        &self,
        job: &ActionJob,
        read: &dyn Fn(&ContentHash) -> Result<Vec<u8>, StageError>,
    ) -> Result<ActionOutputs, ExecuteError> {
        self.sent.fetch_add(1, Ordering::SeqCst);
        let mut stored = std::collections::HashMap::new();
        for hash in job.blobs() {
            let bytes = read(&hash).map_err(|e| ExecuteError::Failed(e.to_string()))?;
            self.received.lock().unwrap().push(bytes.clone());
            stored.insert(hash, bytes);
        }
        let stage = self.stages.iter().find(|s| s.name() == job.stage).unwrap();
        let read = |hash: &ContentHash| {
            stored
                .get(hash)
                .cloned()
                .ok_or_else(|| std::io::Error::other("not sent"))
        };
        let mut done = run_action(stage.as_ref(), job, &read)
            .map_err(|e| ExecuteError::Failed(e.to_string()))?;
        if self.lie && done.left.wanted.is_empty() {
            done.left.discovered.push(ori_graph::DiscoveredFile {
                path: "include.txt".into(),
                hash: Some(ContentHash::of(b"made up")),
            });
        }
        Ok(done)
    }
}

#[test]
fn a_farm_is_sent_the_files_a_stage_discovers_and_its_results_are_a_local_builds() {
    let fx = Fixture::new();
    fs::write(fx.root.join("a/include.txt"), "+inc").unwrap();
    fs::write(fx.root.join("a/second.txt"), "+2").unwrap();
    let (graph, ids) = fx.graph(&defaults);
    let farm = Arc::new(RemoteExecution::new(
        Box::new(InProcessFarm::new(&fx, false)),
        json!({"setting": 1}),
    ));
    let remote_build = |cache: &Cache| {
        let options = RunOptions {
            threads: 2,
            execution: Some(farm.clone()),
            ..RunOptions::default()
        };
        run(&graph, cache, &options, &Silent)
    };
    let b = remote_build(&fx.cache);
    assert!(b.succeeded());
    // Every job ran there (the farm runs the same stages, so their counts are the farm's):
    // each `upper` twice: first asking for `include.txt` and naming `second.txt` as read
    // next, then sent both (or told they are not there).
    assert_eq!(fx.runs(), (6, 3));
    assert_eq!((farm.executed(), farm.fell_back()), (6, 0));
    for (u, c) in &ids {
        assert!(b.result(*u).ran_remotely && b.result(*c).ran_remotely);
    }
    assert_eq!(b.read_output(ids[0].0, "text").unwrap(), b"ASSET A+inc+2");
    let local_cache = Cache::open(fx.root.join("local-cache")).unwrap();
    let local = run(&graph, &local_cache, &RunOptions::default(), &Silent);
    fx.runs();
    for (u, c) in &ids {
        assert_eq!(b.result(*u).outputs, local.result(*u).outputs);
        assert_eq!(b.result(*u).discovered, local.result(*u).discovered);
        assert_eq!(b.result(*c).outputs, local.result(*c).outputs);
    }

    // The file the farm read is tracked like one read here; the job runs again, sent the
    // file its last run read from the start (one round).
    fs::write(fx.root.join("a/include.txt"), "+INC").unwrap();
    let b = remote_build(&fx.cache);
    assert!(matches!(
        outcome(&b, ids[0].0),
        Outcome::Ran(RunReason::Discovered(_))
    ));
    assert_eq!(b.read_output(ids[0].0, "text").unwrap(), b"ASSET A+INC+2");
    assert_eq!(fx.runs(), (1, 1));
    assert_eq!((farm.executed(), farm.fell_back()), (8, 0));
}

#[test]
fn a_farm_is_sent_no_file_from_outside_the_root_and_what_it_says_it_read_is_checked() {
    let fx = Fixture::new();
    let outside = tempfile::tempdir().unwrap();
    fs::write(outside.path().join("secret.txt"), "secret").unwrap();
    std::os::unix::fs::symlink(
        outside.path().join("secret.txt"),
        fx.root.join("a/include.txt"),
    )
    .unwrap();
    // A file asset b's stage names but never reads.
    std::os::unix::fs::symlink(
        outside.path().join("secret.txt"),
        fx.root.join("b/unread.txt"),
    )
    .unwrap();
    let (graph, ids) = fx.graph(&defaults);
    let sources = ori_graph::SourceRules::confined(&fx.root, 1 << 20).unwrap();
    let build_on = |farm: &Arc<RemoteExecution>, cache: &str| {
        let notes = Notes::default();
        let options = RunOptions {
            threads: 2,
            sources: sources.clone(),
            execution: Some(farm.clone()),
            ..RunOptions::default()
        };
        let cache = Cache::open(fx.root.join(cache)).unwrap();
        let b = run(&graph, &cache, &options, &notes);
        assert!(b.succeeded());
        let outputs: Vec<_> = ids.iter().map(|(u, _)| b.result(*u).clone()).collect();
        (outputs, notes.0.into_inner().unwrap())
    };

    // The links lead outside the root: the farm is not sent them, and those jobs run here,
    // where the stage is refused them too; a file named ahead is refused as one asked for
    // (a farm learns nothing from which of the names it gives are sent).
    let in_process = InProcessFarm::new(&fx, false);
    let received = in_process.received.clone();
    let farm = Arc::new(RemoteExecution::new(Box::new(in_process), Value::Null));
    let (results, notes) = build_on(&farm, "cache-1");
    assert!(!received.lock().unwrap().iter().any(|b| b == b"secret"));
    assert_eq!((farm.executed(), farm.fell_back()), (4, 2));
    assert!(!results[0].ran_remotely && !results[1].ran_remotely && results[2].ran_remotely);
    assert_eq!(notes.len(), 2, "{notes:?}");
    for file in ["include.txt", "unread.txt"] {
        let says = format!("job `upper` did not run on in-process farm: `{file}` cannot be sent");
        assert!(
            notes
                .iter()
                .any(|n| n.contains(&says) && n.contains("outside the asset root")),
            "{notes:?}"
        );
    }

    // A farm that says a stage read a file it was not sent: not believed, each job runs here.
    let liar = Arc::new(RemoteExecution::new(
        Box::new(InProcessFarm::new(&fx, true)),
        Value::Null,
    ));
    let (results, notes) = build_on(&liar, "cache-2");
    assert_eq!((liar.executed(), liar.fell_back()), (0, 6));
    assert!(results.iter().all(|r| !r.ran_remotely));
    // (All but assets a's and b's `upper`, which are not run there at all, as above.)
    let lies = notes
        .iter()
        .filter(|n| {
            n.contains("it read `include.txt`, which was not sent")
                || n.contains("it read `include.txt`, which was sent as absent")
        })
        .count();
    assert_eq!(lies, 4, "{notes:?}");
}
