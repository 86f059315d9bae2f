//! A throw-away S3-compatible server on 127.0.0.1 (moto, run by `tests/servers/moto_s3.py`)
//! with authentication on, one user and one bucket: for `cargo xtask bench remote --store s3`
//! and the object-store cache tests (which include this file). Needs the Python virtual
//! environment that `.ci/run` makes in `target/test-venv` (`ORI_TEST_PYTHON` names another
//! Python with moto installed). Killing the child stops the server.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// How long the server may take to start.
const START_TIMEOUT: Duration = Duration::from_secs(60);

/// A running moto server; stopped when dropped.
pub struct Moto {
    child: Option<Child>,
    /// Holds the server's standard error (its errors), for a failed start.
    _log: tempfile::TempDir,
    pub endpoint: String,
    pub access_key_id: String,
    pub secret_access_key: String,
    pub bucket: String,
}

fn workspace() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

/// The Python with moto: `ORI_TEST_PYTHON`, or the test environment `.ci/run` makes.
fn python() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("ORI_TEST_PYTHON") {
        return Ok(PathBuf::from(p));
    }
    let venv = workspace().join("target/test-venv/bin/python");
    if venv.is_file() {
        return Ok(venv);
    }
    Err(format!(
        "no Python with moto: {} is missing; make it with `python3 -m venv target/test-venv && \
         target/test-venv/bin/pip install 'moto[server]'` (.ci/run does)",
        venv.display()
    ))
}

impl Moto {
    pub fn start() -> Result<Moto, String> {
        let script = workspace().join("tests/servers/moto_s3.py");
        let log = tempfile::tempdir().map_err(|e| e.to_string())?;
        let stderr = std::fs::File::create(log.path().join("stderr")).map_err(|e| e.to_string())?;
        let mut child = Command::new(python()?)
            .arg(&script)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", script.display()))?;
        // The first line, read on a thread so that a server stuck starting fails the caller.
        let stdout = child.stdout.take().expect("piped");
        let (send, receive) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = BufReader::new(stdout).read_line(&mut line);
            let _ = send.send(line);
        });
        let line = receive.recv_timeout(START_TIMEOUT).unwrap_or_default();
        let fields: Option<serde_json::Value> = serde_json::from_str(&line).ok();
        let field = |name: &str| {
            fields
                .as_ref()
                .and_then(|f| f[name].as_str())
                .map(String::from)
        };
        match (
            field("endpoint"),
            field("access_key_id"),
            field("secret_access_key"),
            field("bucket"),
        ) {
            (Some(endpoint), Some(access_key_id), Some(secret_access_key), Some(bucket)) => {
                Ok(Moto {
                    child: Some(child),
                    _log: log,
                    endpoint,
                    access_key_id,
                    secret_access_key,
                    bucket,
                })
            }
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                let errors = std::fs::read_to_string(log.path().join("stderr")).unwrap_or_default();
                let tail = &errors[errors.len().saturating_sub(2000)..];
                Err(format!(
                    "{} did not start within {} s (is moto installed?); it printed {line:?}\n{tail}",
                    script.display(),
                    START_TIMEOUT.as_secs()
                ))
            }
        }
    }

    /// `s3://bucket/prefix`.
    pub fn url(&self, prefix: &str) -> String {
        format!("s3://{}/{prefix}", self.bucket)
    }

    /// The environment a builder needs to reach the bucket: the standard AWS variables, and
    /// no profile of the machine's user.
    pub fn env(&self, command: &mut Command) {
        self.env_with_secret(command, &self.secret_access_key);
    }

    /// [`Moto::env`] with another secret key (a wrong one, for tests).
    pub fn env_with_secret(&self, command: &mut Command, secret: &str) {
        clear_aws_env(command);
        command
            .env("AWS_ACCESS_KEY_ID", &self.access_key_id)
            .env("AWS_SECRET_ACCESS_KEY", secret)
            .env("AWS_REGION", "us-east-1")
            .env("AWS_ENDPOINT_URL", &self.endpoint)
            .env("AWS_ALLOW_HTTP", "true");
    }

    /// Kill the server (as a crash would).
    pub fn stop(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

impl Drop for Moto {
    fn drop(&mut self) {
        self.stop();
    }
}

/// No AWS setting of this machine's user reaches `command`: every `AWS_` variable removed, the
/// shared credentials and config files empty.
pub fn clear_aws_env(command: &mut Command) {
    for (key, _) in std::env::vars_os() {
        if key.to_str().is_some_and(|k| k.starts_with("AWS_")) {
            command.env_remove(key);
        }
    }
    command
        .env("AWS_SHARED_CREDENTIALS_FILE", "/dev/null")
        .env("AWS_CONFIG_FILE", "/dev/null");
}
