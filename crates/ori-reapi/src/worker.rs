//! A BuildGrid bot: it holds a session with the server's `Bots` service, takes one lease at a
//! time, and runs its action: the input root laid out in a fresh folder, the command run
//! there (killed at the action's timeout or when the lease is cancelled), the outputs stored
//! in the server's CAS and the `ActionResult` handed back with the lease. It runs any action,
//! not only the pipeline's; every name in an input root is checked to stay inside its folder.

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use bazel_remote_apis::build::bazel::remote::execution::v2::{
    Action, ActionResult, Command, Digest, Directory, DirectoryNode, ExecutedActionMetadata,
    FileNode, OutputDirectory, OutputFile, Tree,
};
use bazel_remote_apis::google::protobuf::Any;
use bazel_remote_apis::google::rpc::Status;
use prost::Message;

use crate::bots::{
    BotSession, BotStatus, BotsClient, CreateBotSessionRequest, Device, Lease, LeaseState,
    Property, UpdateBotSessionRequest, Worker,
};
use crate::client::{Client, Error, Settings, digest_of};

const ACTION_TYPE: &str = "type.googleapis.com/build.bazel.remote.execution.v2.Action";
const DIGEST_TYPE: &str = "type.googleapis.com/build.bazel.remote.execution.v2.Digest";
const RESULT_TYPE: &str = "type.googleapis.com/build.bazel.remote.execution.v2.ActionResult";

/// The most bytes of one input blob fetched (the tool, a mesh).
const MAX_BLOB_BYTES: u64 = 1 << 32;
/// The most bytes of an action, command or folder listing.
const MAX_MESSAGE_BYTES: u64 = 16 << 20;
/// The most entries (files and folders) of one input root.
const MAX_ENTRIES: usize = 1 << 20;
/// The deepest folder of an input root.
const MAX_DEPTH: usize = 64;
/// How long a bot waits between updates while it runs a lease (well within the server's
/// session keepalive; a finished lease is reported at once).
const BEAT: Duration = Duration::from_secs(1);

/// How a worker runs.
#[derive(Clone, Debug)]
pub struct WorkerOptions {
    pub server: Settings,
    /// The bot's name on the server (unique per bot).
    pub bot_id: String,
    /// Where each lease's input root is laid out (a folder per lease, removed afterwards).
    pub work_dir: PathBuf,
}

/// The lease being run: the lease as last reported, and what its thread will leave.
struct Running {
    lease: Lease,
    cancel: Arc<AtomicBool>,
    done: std::sync::mpsc::Receiver<Result<ActionResult, LeaseError>>,
}

/// Why a lease gave no result: BuildGrid gives a lease reported `INTERNAL` to a bot again
/// (up to its attempts), and fails the action with any other code.
struct LeaseError {
    code: tonic::Code,
    message: String,
}

impl LeaseError {
    /// Worth another try (on this bot or another): inputs that did not arrive, a full disk.
    fn retry(message: impl Into<String>) -> LeaseError {
        LeaseError {
            code: tonic::Code::Internal,
            message: message.into(),
        }
    }

    /// Final: the action itself is wrong, or ran out of time.
    fn fatal(code: tonic::Code, message: impl Into<String>) -> LeaseError {
        LeaseError {
            code,
            message: message.into(),
        }
    }

    /// Final: the action cannot be run as written.
    fn invalid(message: impl std::fmt::Display) -> LeaseError {
        LeaseError::fatal(tonic::Code::InvalidArgument, message.to_string())
    }
}

impl From<String> for LeaseError {
    fn from(message: String) -> LeaseError {
        LeaseError::retry(message)
    }
}

/// Serve leases until `stop` is set; `log` is told what happens.
///
/// BuildGrid's bot protocol, as it serves it: the server names the session; every update
/// sends back the session it last returned (its `version` included), with only the states,
/// statuses and results of the leases changed; a lease arrives `ACTIVE`; a lease missing from
/// an answer was cancelled; an update waits for work while the bot is idle.
pub fn run(options: &WorkerOptions, stop: &AtomicBool, log: &dyn Fn(&str)) -> Result<(), String> {
    std::fs::create_dir_all(&options.work_dir)
        .map_err(|e| format!("{}: {e}", options.work_dir.display()))?;
    let client = Arc::new(Client::connect(options.server.clone()).map_err(|e| e.to_string())?);
    let mut session: Option<BotSession> = None;
    let mut running: Option<Running> = None;
    let mut serial = 0u64;
    while !stop.load(Ordering::Relaxed) {
        // What was sent, to send again when the server did not answer.
        let mut sent = None;
        let answer = match session.take() {
            None => create_session(&client, &options.bot_id).inspect(|created| {
                log(&format!(
                    "bot session {} on {}",
                    created.name, options.server.url
                ));
            }),
            Some(mut current) => {
                // Wait for the running lease to finish, a beat at most, then report.
                if let Some(run) = &running {
                    match run.done.recv_timeout(BEAT) {
                        Ok(result) => {
                            let lease = &mut current.leases;
                            let finished = complete(run.lease.clone(), result);
                            log(&format!("lease {}: finished", finished.id));
                            lease.retain(|l| l.id != finished.id);
                            lease.push(finished);
                            running = None;
                        }
                        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                            let lost = LeaseError::retry("the lease's thread ended");
                            current.leases.retain(|l| l.id != run.lease.id);
                            current.leases.push(complete(run.lease.clone(), Err(lost)));
                            running = None;
                        }
                    }
                }
                current.status = BotStatus::Ok as i32;
                sent = Some(current.clone());
                update_session(&client, current)
            }
        };
        let answer = match answer {
            Ok(answer) => answer,
            Err(Error::Failed(e)) => {
                // The server forgot the session (restarted, or timed it out): start anew.
                log(&format!("bot session refused: {e}; opening a new one"));
                std::thread::sleep(Duration::from_secs(1));
                continue;
            }
            Err(Error::Unavailable(e)) => {
                log(&format!(
                    "cannot reach {}: {e}; trying again",
                    options.server.url
                ));
                std::thread::sleep(Duration::from_secs(1));
                // The same update again (a finished lease's result is in it).
                session = sent;
                continue;
            }
        };
        // A running lease the server no longer lists was cancelled.
        if let Some(run) = running.take_if(|r| !answer.leases.iter().any(|l| l.id == r.lease.id)) {
            log(&format!("lease {}: cancelled", run.lease.id));
            run.cancel.store(true, Ordering::Relaxed);
        }
        for lease in &answer.leases {
            let active = lease.state == LeaseState::Active as i32;
            if active && running.is_none() {
                serial += 1;
                // Named by process too: workers may share a folder.
                let dir = (options.work_dir).join(format!("lease-{}-{serial}", std::process::id()));
                let tools = options.work_dir.join("programs");
                running = Some(start(
                    lease.clone(),
                    &client,
                    dir,
                    tools,
                    &options.bot_id,
                    log,
                ));
            }
        }
        session = Some(answer);
    }
    if let Some(run) = running {
        run.cancel.store(true, Ordering::Relaxed);
    }
    Ok(())
}

/// The bot as the server sees it: one device with this machine's platform (the properties
/// the pipeline's actions ask for), one lease at a time.
fn bot_session(bot_id: &str) -> BotSession {
    BotSession {
        bot_id: bot_id.to_string(),
        status: BotStatus::Ok as i32,
        worker: Some(Worker {
            devices: vec![Device {
                handle: bot_id.to_string(),
                properties: crate::executor::platform()
                    .properties
                    .into_iter()
                    .map(|p| Property {
                        key: p.name,
                        value: p.value,
                    })
                    .collect(),
            }],
            properties: Vec::new(),
            configs: vec![Property {
                key: "capacity".to_string(),
                value: "1".to_string(),
            }],
        }),
        ..BotSession::default()
    }
}

/// How long the server may hold an update while the bot is idle (it answers at once when
/// work comes).
const LONG_POLL: Duration = Duration::from_secs(30);

fn create_session(client: &Client, bot_id: &str) -> Result<BotSession, Error> {
    client.call(async {
        let mut bots = BotsClient::new(client.channel());
        let mut request = client.request(CreateBotSessionRequest {
            parent: client.settings().instance_name.clone(),
            bot_session: Some(bot_session(bot_id)),
        });
        request.set_timeout(LONG_POLL);
        Ok(bots.create_bot_session(request).await?)
    })
}

fn update_session(client: &Client, session: BotSession) -> Result<BotSession, Error> {
    client.call(async {
        let mut bots = BotsClient::new(client.channel());
        let mut request = client.request(UpdateBotSessionRequest {
            name: session.name.clone(),
            bot_session: Some(session),
            update_mask: None,
        });
        request.set_timeout(LONG_POLL);
        Ok(bots.update_bot_session(request).await?)
    })
}

/// Run `lease` on a thread of its own.
fn start(
    lease: Lease,
    client: &Arc<Client>,
    dir: PathBuf,
    tools: PathBuf,
    bot_id: &str,
    log: &dyn Fn(&str),
) -> Running {
    log(&format!("lease {}: running", lease.id));
    let cancel = Arc::new(AtomicBool::new(false));
    let (send, done) = std::sync::mpsc::channel();
    let payload = lease.payload.clone();
    let (client, flag, bot) = (client.clone(), cancel.clone(), bot_id.to_string());
    std::thread::spawn(move || {
        let result = match payload {
            Some(payload) => execute(&client, &payload, &dir, &tools, &bot, &flag),
            None => Err(LeaseError::fatal(
                tonic::Code::InvalidArgument,
                "the lease has no payload",
            )),
        };
        let _ = std::fs::remove_dir_all(&dir);
        let _ = send.send(result);
    });
    Running {
        lease,
        cancel,
        done,
    }
}

/// The lease, completed with `result` (or its error).
fn complete(mut lease: Lease, result: Result<ActionResult, LeaseError>) -> Lease {
    lease.state = LeaseState::Completed as i32;
    match result {
        Ok(result) => {
            lease.result = Some(Any {
                type_url: RESULT_TYPE.to_string(),
                value: result.encode_to_vec(),
            });
            lease.status = Some(Status::default());
        }
        Err(e) => {
            lease.result = None;
            lease.status = Some(Status {
                code: e.code as i32,
                message: e.message,
                details: Vec::new(),
            });
        }
    }
    lease
}

/// Run the action of `payload` in `dir`.
fn execute(
    client: &Client,
    payload: &Any,
    dir: &Path,
    tools: &Path,
    bot_id: &str,
    cancel: &AtomicBool,
) -> Result<ActionResult, LeaseError> {
    let action = match payload.type_url.as_str() {
        ACTION_TYPE => Action::decode(payload.value.as_slice()).map_err(LeaseError::invalid)?,
        DIGEST_TYPE => {
            let digest = Digest::decode(payload.value.as_slice()).map_err(LeaseError::invalid)?;
            let bytes = client
                .download(&digest, MAX_MESSAGE_BYTES)
                .map_err(|e| e.to_string())?;
            Action::decode(bytes.as_slice()).map_err(LeaseError::invalid)?
        }
        other => {
            return Err(LeaseError::invalid(format!(
                "a lease payload of type `{other}` is not an action"
            )));
        }
    };
    let digest = |digest: &Option<Digest>, what: &str| {
        digest
            .clone()
            .ok_or_else(|| LeaseError::invalid(format!("the action has no {what}")))
    };
    let both = [
        digest(&action.command_digest, "command")?,
        digest(&action.input_root_digest, "input root")?,
    ];
    let [command, root]: [Vec<u8>; 2] = client
        .download_many(&both, MAX_MESSAGE_BYTES)
        .map_err(|e| format!("the command and input root: {e}"))?
        .try_into()
        .expect("two blobs asked for");
    let command = Command::decode(command.as_slice())
        .map_err(|e| LeaseError::invalid(format!("the command: {e}")))?;
    let root = Directory::decode(root.as_slice())
        .map_err(|e| LeaseError::invalid(format!("the input root: {e}")))?;
    // The input root in `root`, the command's standard output and error beside it.
    let input_root = dir.join("root");
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(&input_root).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut entries = 0;
    let mut linked = Linked::default();
    lay_out(
        client,
        tools,
        &root,
        &input_root,
        &mut linked,
        0,
        &mut entries,
    )?;
    let workdir =
        join_relative(&input_root, &command.working_directory).map_err(LeaseError::invalid)?;
    let program = command
        .arguments
        .first()
        .ok_or_else(|| LeaseError::invalid("the command has no arguments"))?;
    let program = if program.contains('/') {
        join_relative(&workdir, program).map_err(LeaseError::invalid)?
    } else {
        PathBuf::from(program)
    };
    let started = Instant::now();
    let execution_start = timestamp();
    let timeout = action
        .timeout
        .map(|t| Duration::from_secs(t.seconds.max(0) as u64))
        .filter(|t| !t.is_zero())
        .unwrap_or(Duration::from_secs(3600));
    let stdout_path = dir.join("stdout");
    let stderr_path = dir.join("stderr");
    let file =
        |path: &Path| std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()));
    let mut run = std::process::Command::new(&program);
    // The action's environment is its own: nothing of the worker's (its token) leaks in.
    run.env_clear()
        .args(&command.arguments[1..])
        .envs(
            command
                .environment_variables
                .iter()
                .map(|v| (v.name.clone(), v.value.clone())),
        )
        .current_dir(&workdir)
        .stdin(Stdio::null())
        .stdout(file(&stdout_path)?)
        .stderr(file(&stderr_path)?);
    own_process_group(&mut run);
    let mut child = run.spawn().map_err(|e| {
        LeaseError::fatal(
            tonic::Code::FailedPrecondition,
            format!("{}: cannot start here: {e}", program.display()),
        )
    })?;
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if cancel.load(Ordering::Relaxed) || started.elapsed() > timeout {
            kill_group(&mut child);
            return Err(LeaseError::fatal(
                tonic::Code::DeadlineExceeded,
                format!("stopped after {} s", started.elapsed().as_secs()),
            ));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    // What it left running in its group is stopped too: nothing of a lease outlives it.
    kill_group(&mut child);
    let execution_completed = timestamp();
    let mut result = ActionResult {
        exit_code: status.code().unwrap_or(-1),
        ..ActionResult::default()
    };
    let mut blobs: Vec<(Digest, Vec<u8>)> = Vec::new();
    let mut store = |bytes: Vec<u8>| {
        let digest = digest_of(&bytes);
        blobs.push((digest.clone(), bytes));
        digest
    };
    result.stdout_digest = Some(store(std::fs::read(&stdout_path).unwrap_or_default()));
    result.stderr_digest = Some(store(std::fs::read(&stderr_path).unwrap_or_default()));
    #[allow(deprecated)]
    let paths: Vec<&String> = if command.output_paths.is_empty() {
        command
            .output_files
            .iter()
            .chain(&command.output_directories)
            .collect()
    } else {
        command.output_paths.iter().collect()
    };
    for path in paths {
        let full = join_relative(&workdir, path).map_err(LeaseError::invalid)?;
        let Ok(meta) = std::fs::symlink_metadata(&full) else {
            continue;
        };
        if meta.is_dir() {
            let tree = tree_of(&full, &mut store, 0)?;
            let (root, children) = tree;
            let tree = Tree {
                root: Some(root),
                children,
            };
            let digest = store(tree.encode_to_vec());
            result.output_directories.push(OutputDirectory {
                path: path.clone(),
                tree_digest: Some(digest),
                ..OutputDirectory::default()
            });
        } else if meta.is_file() {
            let bytes = std::fs::read(&full).map_err(|e| format!("{}: {e}", full.display()))?;
            result.output_files.push(OutputFile {
                path: path.clone(),
                digest: Some(store(bytes)),
                is_executable: is_executable(&meta),
                ..OutputFile::default()
            });
        }
    }
    let refs: Vec<(Digest, &[u8])> = blobs
        .iter()
        .map(|(d, b)| (d.clone(), b.as_slice()))
        .collect();
    client
        .upload_missing(&refs)
        .map_err(|e| format!("storing the outputs: {e}"))?;
    result.execution_metadata = Some(ExecutedActionMetadata {
        worker: bot_id.to_string(),
        execution_start_timestamp: Some(execution_start),
        execution_completed_timestamp: Some(execution_completed),
        ..ExecutedActionMetadata::default()
    });
    Ok(result)
}

fn timestamp() -> bazel_remote_apis::google::protobuf::Timestamp {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    bazel_remote_apis::google::protobuf::Timestamp {
        seconds: now.as_secs() as i64,
        nanos: now.subsec_nanos() as i32,
    }
}

/// Programs kept between leases.
const KEPT_PROGRAMS: usize = 4;

/// What a file was (size, modification time, read-only), to tell whether it changed.
type Stamp = (u64, std::time::SystemTime, bool);

fn stamp(path: &Path) -> Option<Stamp> {
    let meta = std::fs::metadata(path).ok()?;
    Some((
        meta.len(),
        meta.modified().ok()?,
        meta.permissions().readonly(),
    ))
}

/// The kept programs linked into a lease's folder, with what each was when linked. When the
/// lease is over, one that changed (through its link, or its mode) is forgotten, so that no
/// later lease runs it.
#[derive(Default)]
struct Linked(Vec<(PathBuf, Option<Stamp>)>);

impl Drop for Linked {
    fn drop(&mut self) {
        for (kept, then) in &self.0 {
            if stamp(kept) != *then {
                let _ = std::fs::remove_file(kept);
            }
        }
    }
}

/// Put the program of digest `digest` at `path`. Programs (the tool a build's actions run,
/// the same in all of them) are kept between leases in `tools`, read-only, the last few, and
/// linked into each lease's folder (copying a large program cost more than many a job);
/// other files are fetched for each lease.
fn place_program(
    client: &Client,
    tools: &Path,
    digest: &Digest,
    path: &Path,
    linked: &mut Linked,
) -> Result<(), LeaseError> {
    let sha256 = digest.hash.len() == 64
        && digest
            .hash
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
    if !sha256 || digest.size_bytes < 0 {
        return Err(LeaseError::invalid(format!(
            "`{}`: not a sha256 digest",
            digest.hash
        )));
    }
    let kept = tools.join(format!("{}-{}", digest.hash, digest.size_bytes));
    if stamp(&kept).is_some_and(|(_, _, readonly)| !readonly) {
        let _ = std::fs::remove_file(&kept);
    }
    if !kept.is_file() {
        std::fs::create_dir_all(tools).map_err(|e| format!("{}: {e}", tools.display()))?;
        let bytes = client
            .download(digest, MAX_BLOB_BYTES)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let partial = tools.join(format!("{}.{}.partial", digest.hash, std::process::id()));
        std::fs::write(&partial, bytes).map_err(|e| format!("{}: {e}", partial.display()))?;
        set_mode(&partial, 0o555)?;
        std::fs::rename(&partial, &kept).map_err(|e| format!("{}: {e}", kept.display()))?;
        forget_old_programs(tools, &kept);
    }
    let then = stamp(&kept);
    if std::fs::hard_link(&kept, path).is_ok() {
        linked.0.push((kept, then));
        return Ok(());
    }
    // A file system without links: a copy.
    std::fs::copy(&kept, path).map_err(|e| format!("{}: {e}", path.display()))?;
    set_mode(path, 0o755)?;
    Ok(())
}

/// Remove all but the newest [`KEPT_PROGRAMS`] programs of `tools` (never `keep`).
fn forget_old_programs(tools: &Path, keep: &Path) {
    let Ok(entries) = std::fs::read_dir(tools) else {
        return;
    };
    let mut programs: Vec<(std::time::SystemTime, PathBuf)> = entries
        .filter_map(Result::ok)
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .filter(|(_, path)| path != keep)
        .collect();
    programs.sort();
    let surplus = (programs.len() + 1).saturating_sub(KEPT_PROGRAMS);
    for (_, path) in programs.into_iter().take(surplus) {
        let _ = std::fs::remove_file(path);
    }
}

/// Write `directory`'s files and folders under `dir`.
fn lay_out(
    client: &Client,
    tools: &Path,
    directory: &Directory,
    dir: &Path,
    linked: &mut Linked,
    depth: usize,
    entries: &mut usize,
) -> Result<(), LeaseError> {
    if depth > MAX_DEPTH {
        return Err(LeaseError::invalid(format!(
            "the input root is deeper than {MAX_DEPTH} folders"
        )));
    }
    *entries += directory.files.len() + directory.directories.len();
    if *entries > MAX_ENTRIES {
        return Err(LeaseError::invalid(format!(
            "the input root has more than {MAX_ENTRIES} entries"
        )));
    }
    if !directory.symlinks.is_empty() {
        return Err(LeaseError::invalid(
            "the input root has symbolic links, which this worker does not lay out",
        ));
    }
    // The folder's files but its programs, and its folders' listings: fetched together, a
    // few MiB at a time (each group written before the next is fetched).
    let mut fetched: Vec<(PathBuf, Option<&str>)> = Vec::new();
    let mut digests = Vec::new();
    let mut named = std::collections::HashSet::new();
    let files = directory.files.iter().map(|f| {
        let kind = if f.is_executable {
            Kind::Program
        } else {
            Kind::File
        };
        (&f.name, &f.digest, kind)
    });
    let folders = (directory.directories.iter()).map(|d| (&d.name, &d.digest, Kind::Folder));
    for (name, digest, kind) in files.chain(folders) {
        let name = component(name).map_err(LeaseError::invalid)?;
        let digest = digest
            .as_ref()
            .ok_or_else(|| LeaseError::invalid(format!("{name}: no digest")))?;
        if !named.insert(name) {
            return Err(LeaseError::invalid(format!("`{name}` is named twice")));
        }
        let path = dir.join(name);
        match kind {
            Kind::Program => place_program(client, tools, digest, &path, linked)?,
            Kind::File => {
                fetched.push((path, None));
                digests.push(digest.clone());
            }
            Kind::Folder => {
                if u64::try_from(digest.size_bytes).map_or(true, |n| n > MAX_MESSAGE_BYTES) {
                    return Err(LeaseError::invalid(format!(
                        "{name}: its listing is too large"
                    )));
                }
                fetched.push((path, Some(name)));
                digests.push(digest.clone());
            }
        }
    }
    let sizes: Vec<u64> = digests.iter().map(|d| d.size_bytes.max(0) as u64).collect();
    for group in crate::client::batches(&sizes, FETCH_GROUP_BYTES) {
        let wanted: Vec<Digest> = group.iter().map(|&k| digests[k].clone()).collect();
        let blobs = client
            .download_many(&wanted, MAX_BLOB_BYTES)
            .map_err(|e| format!("{}: {e}", fetched[group[0]].0.display()))?;
        for (&k, bytes) in group.iter().zip(blobs) {
            let (path, folder) = &fetched[k];
            let Some(name) = folder else {
                std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
                continue;
            };
            std::fs::create_dir(path).map_err(|e| format!("{}: {e}", path.display()))?;
            let child = Directory::decode(bytes.as_slice())
                .map_err(|e| LeaseError::invalid(format!("{name}: {e}")))?;
            lay_out(client, tools, &child, path, linked, depth + 1, entries)?;
        }
    }
    Ok(())
}

/// The most bytes of a folder's files fetched before they are written (one larger file is
/// fetched alone).
const FETCH_GROUP_BYTES: u64 = 4 << 20;

/// What an entry of an input root folder is.
enum Kind {
    File,
    Program,
    Folder,
}

/// One name of an input root: a single path component that stays in its folder.
fn component(name: &str) -> Result<&str, String> {
    if name.is_empty() || name == "." || name == ".." || name.contains(['/', '\0']) {
        return Err(format!(
            "`{name}` is not a file name an input root may hold"
        ));
    }
    Ok(name)
}

/// `relative` (slash-separated, no `..`, not absolute) under `base`.
fn join_relative(base: &Path, relative: &str) -> Result<PathBuf, String> {
    let mut path = base.to_path_buf();
    for part in relative.split('/').filter(|p| !p.is_empty() && *p != ".") {
        path.push(component(part).map_err(|_| format!("`{relative}` leaves its folder"))?);
    }
    if relative.starts_with('/') {
        return Err(format!("`{relative}` is absolute"));
    }
    Ok(path)
}

/// The tree of the folder `dir`: its `Directory` and those of every folder below.
fn tree_of(
    dir: &Path,
    store: &mut dyn FnMut(Vec<u8>) -> Digest,
    depth: usize,
) -> Result<(Directory, Vec<Directory>), String> {
    if depth > MAX_DEPTH {
        return Err(format!("{}: too deep", dir.display()));
    }
    let mut names: Vec<(String, std::fs::Metadata)> = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))? {
        let entry = entry.map_err(|e| format!("{}: {e}", dir.display()))?;
        let meta = entry.metadata().map_err(|e| e.to_string())?;
        let name = entry
            .file_name()
            .into_string()
            .map_err(|n| format!("{}: a name that is not UTF-8: {n:?}", dir.display()))?;
        names.push((name, meta));
    }
    names.sort_by(|a, b| a.0.cmp(&b.0));
    let mut directory = Directory::default();
    let mut children = Vec::new();
    for (name, meta) in names {
        let path = dir.join(&name);
        if meta.is_dir() {
            let (sub, below) = tree_of(&path, store, depth + 1)?;
            let digest = digest_of(&sub.encode_to_vec());
            directory.directories.push(DirectoryNode {
                name,
                digest: Some(digest),
            });
            children.push(sub);
            children.extend(below);
        } else if meta.is_file() {
            let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            directory.files.push(FileNode {
                name,
                digest: Some(store(bytes)),
                is_executable: is_executable(&meta),
                node_properties: None,
            });
        }
    }
    Ok((directory, children))
}

/// Start the command in a process group of its own, so that what it starts is stopped with it.
#[cfg(unix)]
fn own_process_group(command: &mut std::process::Command) {
    use std::os::unix::process::CommandExt;
    command.process_group(0);
}

#[cfg(not(unix))]
fn own_process_group(_command: &mut std::process::Command) {}

/// Kill the command and everything in its process group, and reap it.
fn kill_group(child: &mut std::process::Child) {
    #[cfg(unix)]
    if let Ok(pid) = i32::try_from(child.id()) {
        // SAFETY: kill(2) with a negative pid signals that process group; no memory is touched.
        unsafe {
            libc::kill(-pid, libc::SIGKILL);
        }
    }
    let _ = child.kill();
    let _ = child.wait();
}

#[cfg(unix)]
fn is_executable(meta: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::PermissionsExt;
    meta.permissions().mode() & 0o111 != 0
}

#[cfg(not(unix))]
fn is_executable(_meta: &std::fs::Metadata) -> bool {
    false
}

#[cfg(unix)]
fn set_mode(path: &Path, mode: u32) -> Result<(), String> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(not(unix))]
fn set_mode(_path: &Path, _mode: u32) -> Result<(), String> {
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_program_changed_through_its_link_is_forgotten() {
        let dir = tempfile::tempdir().unwrap();
        let kept = dir.path().join("kept");
        let place = |name: &str| {
            let mut linked = Linked::default();
            let then = stamp(&kept);
            let link = dir.path().join(name);
            std::fs::hard_link(&kept, &link).unwrap();
            linked.0.push((kept.clone(), then));
            (linked, link)
        };
        std::fs::write(&kept, b"program").unwrap();
        set_mode(&kept, 0o555).unwrap();
        // A lease that only ran it: kept.
        let (linked, _link) = place("lease-1");
        drop(linked);
        assert!(kept.is_file());
        // A lease that made it writable (to write it): forgotten.
        let (linked, link) = place("lease-2");
        set_mode(&link, 0o755).unwrap();
        drop(linked);
        assert!(!kept.exists());
    }

    #[test]
    fn input_root_names_stay_in_their_folder() {
        for bad in ["", ".", "..", "a/b", "x\0"] {
            assert!(component(bad).is_err(), "{bad:?}");
        }
        let base = Path::new("/w");
        assert_eq!(join_relative(base, "a/./b").unwrap(), Path::new("/w/a/b"));
        assert_eq!(join_relative(base, "").unwrap(), Path::new("/w"));
        assert!(join_relative(base, "a/../../etc").is_err());
        assert!(join_relative(base, "/etc").is_err());
    }
}
