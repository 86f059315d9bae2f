//! The build's jobs as REAPI actions: the input root holds the tool (this very binary), the
//! job's description and its input blobs; the command is `./ori run-action .`; the output is
//! the folder `outputs`. An action's digest depends only on the tool and the job, so a farm's
//! action cache answers any builder that asks for the same job with the same tool.

use std::collections::BTreeMap;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use bazel_remote_apis::build::bazel::remote::execution::v2::{
    Action, ActionResult, Command, Digest, Directory, DirectoryNode, ExecutedActionMetadata,
    FileNode, Platform, Tree, platform,
};
use ori_graph::{
    ActionJob, ActionLeft, ActionOutputs, ContentHash, ExecuteError, Executor, ExecutorTimes,
    INPUTS_DIR, JOB_FILE, LEFT_FILE, OUTPUTS_DIR, StageError,
};
use prost::Message;

use crate::client::{Client, Error, Settings, digest_of};

/// The tool's name in the input root.
pub const TOOL_FILE: &str = "ori";
/// The subcommand that runs an action's folder.
pub const RUN_ACTION: &str = "run-action";
/// The most bytes of one output accepted back.
const MAX_OUTPUT_BYTES: u64 = 1 << 32;
/// The most bytes of a failed action's standard error shown.
const MAX_STDERR_BYTES: u64 = 16 << 10;

/// The tool an action runs: the bytes of an executable and their digest.
pub struct Tool {
    pub bytes: Vec<u8>,
    pub digest: Digest,
}

impl Tool {
    pub fn new(bytes: Vec<u8>) -> Tool {
        let digest = digest_of(&bytes);
        Tool { bytes, digest }
    }

    /// The running executable (which has the `run-action` subcommand).
    pub fn current() -> Result<Tool, String> {
        let path =
            std::env::current_exe().map_err(|e| format!("cannot find this program's file: {e}"))?;
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(Tool::new(bytes))
    }
}

/// Runs jobs on a REAPI server.
pub struct ReapiExecutor {
    client: Client,
    /// Whether the farm has the tool: the first job uploads it while the others wait, so
    /// jobs started together do not each send it.
    tool_stored: std::sync::Mutex<bool>,
    gone: AtomicBool,
    /// Nanoseconds spent moving blobs, waiting on `Execute`, and running (workers' figures).
    transfer: AtomicU64,
    waiting: AtomicU64,
    running: AtomicU64,
    tool: OnceLock<Result<Tool, String>>,
    max_in_flight: usize,
    action_timeout: Duration,
}

impl ReapiExecutor {
    /// An executor on the server of `settings` that runs `tool` (`None`: this program, read
    /// when the first job is sent).
    pub fn new(
        settings: Settings,
        tool: Option<Tool>,
        max_in_flight: usize,
        action_timeout: Duration,
    ) -> Result<ReapiExecutor, String> {
        let client = Client::connect(settings).map_err(|e| e.to_string())?;
        let cell = OnceLock::new();
        if let Some(tool) = tool {
            let _ = cell.set(Ok(tool));
        }
        Ok(ReapiExecutor {
            client,
            tool_stored: std::sync::Mutex::new(false),
            gone: AtomicBool::new(false),
            transfer: AtomicU64::new(0),
            waiting: AtomicU64::new(0),
            running: AtomicU64::new(0),
            tool: cell,
            max_in_flight,
            action_timeout,
        })
    }

    /// Stop here once the farm was found unavailable: jobs already under way do not each
    /// wait out their own timeout.
    fn check_available(&self) -> Result<(), Error> {
        match self.gone.load(Ordering::Relaxed) {
            true => Err(Error::Unavailable(
                "unavailable earlier in this build".into(),
            )),
            false => Ok(()),
        }
    }

    fn tool(&self) -> Result<&Tool, ExecuteError> {
        self.tool
            .get_or_init(Tool::current)
            .as_ref()
            .map_err(|e| ExecuteError::Unavailable(e.clone()))
    }

    /// The outputs of a finished action.
    fn outputs(&self, result: &ActionResult) -> Result<ActionOutputs, Error> {
        if result.exit_code != 0 {
            let stderr = result
                .stderr_digest
                .as_ref()
                .and_then(|d| self.client.download(d, MAX_STDERR_BYTES).ok())
                .map(|b| String::from_utf8_lossy(&b).trim().to_string())
                .filter(|s| !s.is_empty())
                .unwrap_or_else(|| {
                    String::from_utf8_lossy(&result.stderr_raw)
                        .trim()
                        .to_string()
                });
            return Err(Error::Failed(format!(
                "the action exited with status {}: {stderr}",
                result.exit_code
            )));
        }
        let folder = result
            .output_directories
            .iter()
            .find(|d| d.path == OUTPUTS_DIR)
            .and_then(|d| d.tree_digest.clone())
            .ok_or_else(|| Error::Failed(format!("the result has no `{OUTPUTS_DIR}` folder")))?;
        let tree = self.client.download(&folder, MAX_OUTPUT_BYTES)?;
        let tree = Tree::decode(tree.as_slice())
            .map_err(|e| Error::Failed(format!("the `{OUTPUTS_DIR}` tree: {e}")))?;
        let root = tree.root.unwrap_or_default();
        let mut outputs = BTreeMap::new();
        let mut left = None;
        if !root.directories.is_empty() || !root.symlinks.is_empty() {
            return Err(Error::Failed(format!(
                "the `{OUTPUTS_DIR}` folder holds more than files"
            )));
        }
        let mut digests = Vec::with_capacity(root.files.len());
        for file in &root.files {
            if file.name != LEFT_FILE && !ActionJob::is_output_name(&file.name) {
                return Err(Error::Failed(format!(
                    "the result has an output named `{}`",
                    file.name
                )));
            }
            let digest = file
                .digest
                .clone()
                .ok_or_else(|| Error::Failed(format!("output `{}` has no digest", file.name)))?;
            digests.push(digest);
        }
        let blobs = self.client.download_many(&digests, MAX_OUTPUT_BYTES)?;
        for (file, bytes) in root.files.iter().zip(blobs) {
            if file.name == LEFT_FILE {
                left = Some(
                    serde_json::from_slice::<ActionLeft>(&bytes)
                        .map_err(|e| Error::Failed(format!("{OUTPUTS_DIR}/{LEFT_FILE}: {e}")))?,
                );
            } else {
                outputs.insert(file.name.clone(), bytes);
            }
        }
        let left = left
            .ok_or_else(|| Error::Failed(format!("the result has no {OUTPUTS_DIR}/{LEFT_FILE}")))?;
        Ok(ActionOutputs { outputs, left })
    }
}

/// A stored message: its bytes and digest.
fn blob<M: Message>(message: &M) -> (Digest, Vec<u8>) {
    let bytes = message.encode_to_vec();
    (digest_of(&bytes), bytes)
}

/// An action's digest and the blobs that make it up (but for the tool and the inputs).
pub struct BuiltAction {
    pub digest: Digest,
    pub blobs: Vec<(Digest, Vec<u8>)>,
}

/// The action for `job` whose input blobs are `inputs` (by content hash), run by a tool with
/// digest `tool`; the blobs listed are the action's own (description, folders, command,
/// action), besides the tool and the inputs.
pub fn build_action(
    job: &ActionJob,
    inputs: &BTreeMap<ContentHash, Digest>,
    tool: &Digest,
    timeout: Duration,
) -> BuiltAction {
    let description =
        ori_graph::canonical_json(&serde_json::to_value(job).expect("plain data")).into_bytes();
    let description_digest = digest_of(&description);
    let file = |name: &str, digest: &Digest, is_executable: bool| FileNode {
        name: name.to_string(),
        digest: Some(digest.clone()),
        is_executable,
        node_properties: None,
    };
    // Names sorted, as the protocol requires (hex hashes sort as strings).
    let inputs_dir = Directory {
        files: inputs
            .iter()
            .map(|(hash, digest)| file(&hash.to_hex(), digest, false))
            .collect(),
        ..Directory::default()
    };
    let (inputs_digest, inputs_bytes) = blob(&inputs_dir);
    let mut root_files = vec![
        file(JOB_FILE, &description_digest, false),
        file(TOOL_FILE, tool, true),
    ];
    root_files.sort_by(|a, b| a.name.cmp(&b.name));
    let root = Directory {
        files: root_files,
        directories: vec![DirectoryNode {
            name: INPUTS_DIR.to_string(),
            digest: Some(inputs_digest.clone()),
        }],
        ..Directory::default()
    };
    let (root_digest, root_bytes) = blob(&root);
    let command = Command {
        arguments: vec![
            format!("./{TOOL_FILE}"),
            RUN_ACTION.to_string(),
            ".".to_string(),
        ],
        output_paths: vec![OUTPUTS_DIR.to_string()],
        ..Command::default()
    };
    let (command_digest, command_bytes) = blob(&command);
    let action = Action {
        platform: Some(platform()),
        command_digest: Some(command_digest.clone()),
        input_root_digest: Some(root_digest.clone()),
        timeout: Some(bazel_remote_apis::google::protobuf::Duration {
            seconds: timeout.as_secs() as i64,
            nanos: 0,
        }),
        ..Action::default()
    };
    let (action_digest, action_bytes) = blob(&action);
    BuiltAction {
        digest: action_digest.clone(),
        blobs: vec![
            (description_digest, description),
            (inputs_digest, inputs_bytes),
            (root_digest, root_bytes),
            (command_digest, command_bytes),
            (action_digest.clone(), action_bytes),
        ],
    }
}

/// Where the tool runs: the operating system and processor it was built for, which workers
/// advertise as the same properties (`OSFamily`, `ISA`: the keys BuildGrid matches by
/// default), so a job never goes to a machine that cannot run it.
pub fn platform() -> Platform {
    let property = |name: &str, value: &str| platform::Property {
        name: name.to_string(),
        value: value.to_string(),
    };
    Platform {
        properties: vec![
            property("ISA", std::env::consts::ARCH),
            property("OSFamily", std::env::consts::OS),
        ],
    }
}

impl Executor for ReapiExecutor {
    fn describe(&self) -> String {
        self.client.settings().url.clone()
    }

    fn max_in_flight(&self) -> usize {
        self.max_in_flight
    }

    fn execute(
        &self,
        job: &ActionJob,
        read: &dyn Fn(&ContentHash) -> Result<Vec<u8>, StageError>,
    ) -> Result<ActionOutputs, ExecuteError> {
        let tool = self.tool()?;
        let hashes = job.blobs();
        let mut input_blobs = Vec::with_capacity(hashes.len());
        let mut inputs = BTreeMap::new();
        for hash in hashes {
            let bytes = read(&hash).map_err(|e| ExecuteError::Failed(e.to_string()))?;
            let digest = digest_of(&bytes);
            inputs.insert(hash, digest.clone());
            input_blobs.push((digest, bytes));
        }
        let action = build_action(job, &inputs, &tool.digest, self.action_timeout);
        // The tool again (asked about, not sent): a farm that dropped it gets it back.
        let mut blobs: Vec<(Digest, &[u8])> = vec![(tool.digest.clone(), &tool.bytes)];
        for (digest, bytes) in input_blobs.iter().chain(&action.blobs) {
            blobs.push((digest.clone(), bytes));
        }
        let run = || -> Result<ActionOutputs, Error> {
            self.check_available()?;
            let started = Instant::now();
            {
                let mut stored = self.tool_stored.lock().unwrap_or_else(|e| e.into_inner());
                self.check_available()?;
                if !*stored {
                    self.client
                        .upload_missing(&[(tool.digest.clone(), &tool.bytes)])?;
                    *stored = true;
                }
            }
            self.client.upload_missing(&blobs)?;
            add(&self.transfer, started.elapsed());
            // The wait covers the queue as well as the run.
            let started = Instant::now();
            let response = self
                .client
                .execute(&action.digest, self.action_timeout * 2)?;
            add(&self.waiting, started.elapsed());
            if let Some(status) = response.status.filter(|s| s.code != 0) {
                return Err(Error::Failed(format!(
                    "the server could not run it: {}",
                    status.message
                )));
            }
            let result = response
                .result
                .ok_or_else(|| Error::Failed("the response has no result".into()))?;
            if let Some(ran) = result.execution_metadata.as_ref().and_then(command_time) {
                add(&self.running, ran);
            }
            let started = Instant::now();
            let outputs = self.outputs(&result);
            add(&self.transfer, started.elapsed());
            outputs
        };
        run().map_err(|e| match e {
            Error::Unavailable(why) => {
                self.gone.store(true, Ordering::Relaxed);
                ExecuteError::Unavailable(why)
            }
            Error::Failed(why) => ExecuteError::Failed(why),
        })
    }

    fn times(&self) -> ExecutorTimes {
        let read = |n: &AtomicU64| Duration::from_nanos(n.load(Ordering::Relaxed));
        ExecutorTimes {
            transfer: read(&self.transfer),
            waiting: read(&self.waiting),
            running: read(&self.running),
        }
    }
}

fn add(total: &AtomicU64, time: Duration) {
    total.fetch_add(time.as_nanos() as u64, Ordering::Relaxed);
}

/// How long an action's command ran, from its worker's timestamps.
fn command_time(metadata: &ExecutedActionMetadata) -> Option<Duration> {
    let (start, end) = (
        metadata.execution_start_timestamp.as_ref()?,
        metadata.execution_completed_timestamp.as_ref()?,
    );
    let nanos = |t: &bazel_remote_apis::google::protobuf::Timestamp| {
        i128::from(t.seconds) * 1_000_000_000 + i128::from(t.nanos)
    };
    u64::try_from(nanos(end) - nanos(start))
        .ok()
        .map(Duration::from_nanos)
}
