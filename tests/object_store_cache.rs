//! End-to-end tests of the remote cache in an S3 bucket: a real S3-compatible server (moto,
//! `tests/servers/moto_s3.py`) on 127.0.0.1 with authentication on, reached through the
//! standard AWS variables. `.ci/run` installs moto in `target/test-venv`; without it these
//! tests fail, saying how to install it.

mod common;
#[path = "../xtask/src/moto.rs"]
mod moto;

use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::*;
use futures::TryStreamExt as _;
use moto::Moto;
use object_store::ObjectStore as _;
use object_store::path::Path as ObjectPath;

const SAMPLES: [&str; 2] = ["bunny", "box-vertex-colors"];

fn server() -> Moto {
    Moto::start().unwrap_or_else(|e| panic!("cannot start the test's S3 server: {e}"))
}

fn remote(url: &str, mode: &str, digest: &str) -> String {
    format!(
        "[cache.remote]\nurl = \"{url}\"\nmode = \"{mode}\"\ntimeout_s = 5\ndigest = \"{digest}\"\n"
    )
}

/// A build with its own local cache and output folder (`cache-NAME`, `out-NAME`), reaching
/// the bucket.
fn build_command(p: &Project, s: &Moto, name: &str) -> Command {
    let mut command = Command::new(EXE);
    command
        .args(["build-assets", "--no-report", "--config"])
        .arg(p.path("pipeline.toml"))
        .arg("--cache")
        .arg(p.path(&format!("cache-{name}")))
        .arg("--out")
        .arg(p.path(&format!("out-{name}")))
        .env("CI", "1");
    s.env(&mut command);
    command
}

fn build_as(p: &Project, s: &Moto, name: &str) -> Output {
    build_command(p, s, name).output().unwrap()
}

/// The bucket, read and written directly (as another tool or an attacker would).
struct Bucket {
    store: object_store::aws::AmazonS3,
    runtime: tokio::runtime::Runtime,
}

impl Bucket {
    fn new(s: &Moto) -> Bucket {
        let store = object_store::aws::AmazonS3Builder::new()
            .with_bucket_name(&s.bucket)
            .with_region("us-east-1")
            .with_endpoint(&s.endpoint)
            .with_allow_http(true)
            .with_access_key_id(&s.access_key_id)
            .with_secret_access_key(&s.secret_access_key)
            .build()
            .unwrap();
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .unwrap();
        Bucket { store, runtime }
    }

    /// Every object's key.
    fn keys(&self) -> Vec<String> {
        self.runtime.block_on(async {
            let metas: Vec<_> = self.store.list(None).try_collect().await.unwrap();
            metas.iter().map(|m| m.location.to_string()).collect()
        })
    }

    /// Every object: (key, bytes), sorted by key.
    fn objects(&self) -> Vec<(String, Vec<u8>)> {
        self.runtime.block_on(async {
            let mut metas: Vec<_> = self.store.list(None).try_collect().await.unwrap();
            metas.sort_by(|a, b| a.location.cmp(&b.location));
            let mut out = Vec::new();
            for meta in metas {
                let bytes = self.store.get(&meta.location).await.unwrap();
                out.push((
                    meta.location.to_string(),
                    bytes.bytes().await.unwrap().to_vec(),
                ));
            }
            out
        })
    }

    fn put(&self, key: &str, bytes: Vec<u8>) {
        self.runtime.block_on(async {
            self.store
                .put(&ObjectPath::from(key), bytes.into())
                .await
                .unwrap();
        });
    }
}

/// Every object under `prefix` is a blob named by `name_of` its bytes or an action entry
/// whose checksum holds. Returns (blobs, entries).
fn check_bucket(
    bucket: &Bucket,
    prefix: &str,
    name_of: impl Fn(&[u8]) -> String,
) -> (usize, usize) {
    let (mut blobs, mut entries) = (0, 0);
    for (key, bytes) in bucket.objects() {
        let rest = key
            .strip_prefix(&format!("{prefix}/"))
            .unwrap_or_else(|| panic!("{key} is outside {prefix}/"));
        match rest.split_once('/') {
            Some(("cas", name)) => {
                assert_eq!(name_of(&bytes), name, "{key}");
                blobs += 1;
            }
            Some(("ac", _)) => {
                check_entry(bytes, &key);
                entries += 1;
            }
            _ => panic!("unexpected object {key}"),
        }
    }
    (blobs, entries)
}

fn blake3_hex(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest as _;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// One builder fills the bucket; a second machine with an empty local cache runs nothing and
/// makes the same release; a read-only builder that runs jobs uploads nothing.
#[test]
fn a_bucket_filled_by_one_builder_serves_another_that_runs_nothing() {
    let s = server();
    let bucket = Bucket::new(&s);
    let p = Project::new(&SAMPLES);
    p.config(&remote(&s.url("farm/ori"), "read-write", "blake3"));
    let cold = build_as(&p, &s, "a");
    let t = ok(&cold);
    assert_eq!(ran_all(&cold), [2; 8], "{t}");
    assert!(remote_warnings(&cold).is_empty(), "{t}");
    assert!(remote_line(&cold).contains("uploaded 16 entries"), "{t}");
    let (blobs, entries) = check_bucket(&bucket, "farm/ori", blake3_hex);
    assert_eq!(entries, 16);
    assert!(blobs > 14, "{blobs}");

    let warm = build_as(&p, &s, "b");
    let t = ok(&warm);
    assert_eq!(ran_all(&warm), [0; 8], "{t}");
    assert!(remote_line(&warm).contains("downloaded 16 entries"), "{t}");
    same_release(
        &tree(&p.path("out-a")),
        &tree(&p.path("out-b")),
        "from the bucket",
    );

    // Read-only: a texture setting runs the compress and package jobs, which upload nothing.
    let before = bucket.objects();
    p.config(&format!(
        "{}[compress]\nquality = \"fast\"\n",
        remote(&s.url("farm/ori"), "read-only", "blake3")
    ));
    let out = build_as(&p, &s, "c");
    let t = ok(&out);
    assert_eq!((ran(&out, "compress"), ran(&out, "package")), (2, 2), "{t}");
    assert_eq!(ran(&out, "bake"), 0, "{t}");
    assert!(remote_line(&out).contains("(read-only)"), "{t}");
    assert!(
        remote_line(&out).contains("uploaded 0 entries, 0 blobs"),
        "{t}"
    );
    assert!(
        bucket.objects() == before,
        "a read-only builder changed the bucket"
    );
}

/// With sha256 names, a damaged object is a miss with a warning, the job runs again and its
/// result is uploaded over the damaged copy; wrong keys cost one warning naming them.
#[test]
fn a_damaged_object_is_repaired_and_wrong_keys_are_one_clear_warning() {
    let s = server();
    let bucket = Bucket::new(&s);
    let p = Project::new(&SAMPLES);
    p.config(&remote(&s.url("cache"), "read-write", "sha256"));
    ok(&build_as(&p, &s, "a"));
    let (blobs, _) = check_bucket(&bucket, "cache", sha256_hex);
    assert!(blobs > 14, "{blobs}");

    // Damage the bunny's package: same length, one byte changed.
    let package = std::fs::read(p.path("out-a/bunny/bunny_npm_lowres.ori")).unwrap();
    let key = format!("cache/cas/{}", sha256_hex(&package));
    let mut damaged = package.clone();
    damaged[100] ^= 0x20;
    bucket.put(&key, damaged);

    let out = build_as(&p, &s, "b");
    let t = ok(&out);
    assert_eq!(ran_all(&out), [0, 0, 0, 0, 0, 0, 0, 1], "{t}");
    let warnings = remote_warnings(&out);
    assert_eq!(warnings.len(), 1, "{t}");
    assert!(warnings[0].contains("is damaged"), "{t}");
    same_release(&tree(&p.path("out-a")), &tree(&p.path("out-b")), "damaged");
    check_bucket(&bucket, "cache", sha256_hex);

    // Wrong keys: one warning that says so, and a local build of the same release.
    let mut wrong = build_command(&p, &s, "c");
    s.env_with_secret(&mut wrong, "not-the-secret");
    let out = wrong.output().unwrap();
    let t = ok(&out);
    assert_eq!(ran_all(&out), [2; 8], "{t}");
    let warnings = remote_warnings(&out);
    assert_eq!(warnings.len(), 1, "{t}");
    assert!(
        warnings[0].contains("refused our credentials")
            && warnings[0].contains("AWS_SECRET_ACCESS_KEY")
            && !warnings[0].contains("not-the-secret"),
        "{t}"
    );
    same_release(
        &tree(&p.path("out-a")),
        &tree(&p.path("out-c")),
        "wrong keys",
    );
}

/// The server killed while a build uploads: one warning, every job built locally, the same
/// release as without a server.
#[test]
fn a_server_killed_mid_build_leaves_one_warning_and_a_local_build() {
    let mut s = server();
    let bucket = Bucket::new(&s);
    let p = Project::new(&SAMPLES);
    p.config(&remote(&s.url("cache"), "read-write", "blake3"));
    let child: Child = build_command(&p, &s, "a")
        .args(["-j", "1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    while !bucket.keys().iter().any(|k| k.contains("/ac/")) {
        assert!(Instant::now() < deadline, "nothing uploaded in 120 s");
        std::thread::sleep(Duration::from_millis(20));
    }
    s.stop();
    let out = child.wait_with_output().unwrap();
    let t = ok(&out);
    assert_eq!(ran_all(&out), [2; 8], "{t}");
    let warnings = remote_warnings(&out);
    assert_eq!(warnings.len(), 1, "{t}");
    assert!(warnings[0].contains("is unavailable"), "{t}");
    assert!(
        remote_line(&out).contains("unavailable during the build"),
        "{t}"
    );
    let plain = Project::new(&SAMPLES);
    ok(&plain.build(&[]));
    same_release(&tree(&plain.path("out")), &tree(&p.path("out-a")), "killed");

    // The server gone before the build: the same.
    let out = build_as(&p, &s, "b");
    let t = ok(&out);
    assert_eq!(ran_all(&out), [2; 8], "{t}");
    assert_eq!(remote_warnings(&out).len(), 1, "{t}");
    same_release(&tree(&plain.path("out")), &tree(&p.path("out-b")), "down");
}

/// An endpoint that accepts connections and never answers costs one timeout, then the build
/// goes on locally.
#[test]
fn an_endpoint_that_never_answers_times_out_once() {
    let silent = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let p = Project::new(&["box-vertex-colors"]);
    p.config("[cache.remote]\nurl = \"s3://bucket/cache\"\ntimeout_s = 1\n");
    let mut command = Command::new(EXE);
    command
        .args(["build-assets", "--no-report", "--config"])
        .arg(p.path("pipeline.toml"))
        .env("CI", "1");
    moto::clear_aws_env(&mut command);
    command
        .env("AWS_ACCESS_KEY_ID", "id")
        .env("AWS_SECRET_ACCESS_KEY", "secret")
        .env("AWS_REGION", "us-east-1")
        .env(
            "AWS_ENDPOINT_URL",
            format!("http://{}", silent.local_addr().unwrap()),
        )
        .env("AWS_ALLOW_HTTP", "1");
    let start = Instant::now();
    let out = command.output().unwrap();
    let t = ok(&out);
    assert_eq!(ran_all(&out), [1; 8], "{t}");
    let warnings = remote_warnings(&out);
    assert_eq!(warnings.len(), 1, "{t}");
    assert!(warnings[0].contains("no answer within 1 s"), "{t}");
    assert!(start.elapsed() < Duration::from_secs(60), "{t}");
}

/// Object-store URLs are checked before anything runs; the message names the key.
#[test]
fn bad_object_store_settings_stop_the_build_naming_the_key() {
    let p = Project::new(&["box-vertex-colors"]);
    for (config, expected) in [
        ("url = \"s3://\"", "expected s3://bucket[/prefix]"),
        (
            "url = \"s3://key:secret@bucket\"",
            "credentials come from the environment",
        ),
        ("url = \"ftp://host/cache\"", "s3://bucket[/prefix]"),
        (
            "url = \"s3://bucket\"\ntoken_env = \"T\"",
            "token_env = \"T\": only for http://",
        ),
    ] {
        p.config(&format!("[cache.remote]\n{config}\n"));
        let out = p.build(&[]);
        assert_eq!(out.status.code(), Some(2), "{config}: {}", text(&out));
        assert!(
            text(&out).contains("[cache.remote]") && text(&out).contains(expected),
            "{config}: {}",
            text(&out)
        );
        assert!(!text(&out).contains("secret@"), "{}", text(&out));
    }
    // A plain-http endpoint is used only when the user allows it.
    p.config("[cache.remote]\nurl = \"s3://bucket\"\n");
    let mut command = Command::new(EXE);
    command
        .args(["build-assets", "--no-report", "--config"])
        .arg(p.path("pipeline.toml"));
    moto::clear_aws_env(&mut command);
    let out = command
        .env("AWS_ENDPOINT_URL", "http://127.0.0.1:9")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(
        text(&out).contains("set AWS_ALLOW_HTTP=true"),
        "{}",
        text(&out)
    );
}
