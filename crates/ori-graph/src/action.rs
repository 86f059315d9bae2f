//! A job as a self-contained action, for a worker that has none of the build's state (a
//! remote-execution farm): its description ([`ActionJob`], the file [`JOB_FILE`]), its inputs
//! as files named by content hash under [`INPUTS_DIR`], and [`run_action`], which runs the
//! stage on them. A job's source file is sent like its other inputs, and so are the files
//! the stage discovers it needs (a glTF's buffers and images): those it asks for that were
//! not sent end the action with them in [`ActionLeft::wanted`], and the builder sends it
//! again with them.

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};
use std::io;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::cache::DiscoveredFile;
use crate::hash::ContentHash;
use crate::job::{Input, JobSpec};
use crate::stage::{JobContext, JobInputs, Stage, StageError};

/// The most discovered files sent with one job.
pub(crate) const MAX_ACTION_FILES: usize = 1024;

/// The description's file name, in the action's folder.
pub const JOB_FILE: &str = "job.json";
/// The folder of the input blobs, each named by its content hash (hex).
pub const INPUTS_DIR: &str = "inputs";
/// The folder the outputs are written to, each named by its output name.
pub const OUTPUTS_DIR: &str = "outputs";
/// What the stage left besides its outputs ([`ActionLeft`]), in [`OUTPUTS_DIR`].
pub const LEFT_FILE: &str = "left.json";

/// One job, described for a worker: everything its key is made of, and the asset's name for
/// messages.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActionJob {
    pub stage: String,
    pub stage_version: u32,
    pub asset: String,
    pub params: serde_json::Value,
    /// The job's inputs by name, with the content hash each is read and checked by.
    pub inputs: BTreeMap<String, ContentHash>,
    /// The inputs the stage only identifies by their hash (`Input::Hashed`): not sent.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub hashed: BTreeMap<String, ContentHash>,
    /// Of the inputs, those that are source files: the file's name, which the stage sees as
    /// its path (for its format and messages; never the builder's folders).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub sources: BTreeMap<String, String>,
    /// Discovered files sent with the action, by their path relative to the source file's
    /// folder: their content hash, or `None` for one that is not there.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub files: BTreeMap<String, Option<ContentHash>>,
    /// The build's settings the stages are made with (the loader's limits): they decide
    /// whether a job can run, never what it makes, so they are in no key.
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub settings: serde_json::Value,
}

impl ActionJob {
    /// The action of `job` whose inputs have `hashes` (in the job's order), with no
    /// discovered files yet; `None` for a source file with no file name.
    pub fn of(job: &JobSpec, hashes: &[(String, ContentHash)]) -> Option<ActionJob> {
        let (mut inputs, mut hashed, mut sources) =
            (BTreeMap::new(), BTreeMap::new(), BTreeMap::new());
        for ((name, input), (_, hash)) in job.inputs.iter().zip(hashes) {
            match input {
                Input::Source(path) => {
                    let file = path.file_name()?.to_str()?;
                    sources.insert(name.clone(), file.to_string());
                    inputs.insert(name.clone(), *hash)
                }
                Input::Hashed(_) => hashed.insert(name.clone(), *hash),
                Input::Output { .. } => inputs.insert(name.clone(), *hash),
            };
        }
        Some(ActionJob {
            stage: job.stage.name().to_string(),
            stage_version: job.stage.version(),
            asset: job.asset.clone(),
            params: job.params.clone(),
            inputs,
            hashed,
            sources,
            files: BTreeMap::new(),
            settings: serde_json::Value::Null,
        })
    }

    /// The blobs the action is sent with: its inputs and the discovered files there are.
    pub fn blobs(&self) -> BTreeSet<ContentHash> {
        let files = self.files.values().flatten();
        self.inputs.values().chain(files).copied().collect()
    }

    /// The output names an output file may have: a stage's names, never a path.
    pub fn is_output_name(name: &str) -> bool {
        !name.is_empty()
            && name != LEFT_FILE
            && name
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
    }
}

/// What an action's stage left besides its outputs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActionLeft {
    pub warnings: Vec<String>,
    /// The files the stage discovered and read (see [`JobContext::read_discovered`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub discovered: Vec<DiscoveredFile>,
    /// Discovered files the stage asked for that were not sent: the action must be sent
    /// again with them, and nothing else it left is its result.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub wanted: Vec<String>,
    /// With `wanted`: files not sent that the stage said it may read next
    /// ([`JobContext::will_read`]), to be sent with them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub will_read: Vec<String>,
}

/// What running an action gave.
#[derive(Debug)]
pub struct ActionOutputs {
    pub outputs: BTreeMap<String, Vec<u8>>,
    pub left: ActionLeft,
}

/// Run `job` with `stage` (which must be the one it names, at its version), reading inputs
/// with `read` and checking each against its hash.
pub fn run_action(
    stage: &dyn Stage,
    job: &ActionJob,
    read: &dyn Fn(&ContentHash) -> io::Result<Vec<u8>>,
) -> Result<ActionOutputs, StageError> {
    if stage.name() != job.stage || stage.version() != job.stage_version {
        return Err(StageError::Plan(format!(
            "the action is for stage `{}` version {}; this tool has version {} of `{}`",
            job.stage,
            job.stage_version,
            stage.version(),
            stage.name()
        )));
    }
    let inputs = ActionInputs {
        job,
        read,
        wanted: RefCell::new(Vec::new()),
        will_read: RefCell::new(BTreeSet::new()),
    };
    let mut ctx = JobContext::new(&job.asset, &job.params, &inputs);
    let ran = crate::stage::run_catching(stage, &mut ctx);
    let left = ctx.finish();
    let wanted = inputs.wanted.into_inner();
    if !wanted.is_empty() {
        let will_read = inputs.will_read.into_inner();
        return Ok(ActionOutputs {
            outputs: BTreeMap::new(),
            left: ActionLeft {
                will_read: will_read
                    .into_iter()
                    .filter(|w| !wanted.contains(w))
                    .collect(),
                wanted,
                ..ActionLeft::default()
            },
        });
    }
    ran?;
    if let Some(name) = left.outputs.keys().find(|n| !ActionJob::is_output_name(n)) {
        return Err(StageError::Plan(format!(
            "stage `{}` made an output named `{name}`, which cannot be a file name",
            stage.name()
        )));
    }
    Ok(ActionOutputs {
        outputs: left.outputs,
        left: ActionLeft {
            warnings: left.warnings,
            discovered: left.discovered,
            ..ActionLeft::default()
        },
    })
}

struct ActionInputs<'a> {
    job: &'a ActionJob,
    read: &'a dyn Fn(&ContentHash) -> io::Result<Vec<u8>>,
    /// Discovered files asked for but not sent.
    wanted: RefCell<Vec<String>>,
    /// Discovered files the stage may read next that were not sent (no more than a job is
    /// ever sent).
    will_read: RefCell<BTreeSet<String>>,
}

impl JobInputs for ActionInputs<'_> {
    fn source_path(&self, name: &str) -> Option<&Path> {
        self.job.sources.get(name).map(Path::new)
    }

    fn input_hash(&self, name: &str) -> Option<ContentHash> {
        let job = self.job;
        job.inputs
            .get(name)
            .or_else(|| job.hashed.get(name))
            .copied()
    }

    fn input(&self, name: &str) -> Result<Vec<u8>, StageError> {
        if self.job.hashed.contains_key(name) {
            return Err(StageError::Plan(format!(
                "input `{name}` is only hashed, never read, by stage `{}`",
                self.job.stage
            )));
        }
        let Some(hash) = self.job.inputs.get(name) else {
            return Err(StageError::Plan(format!(
                "stage `{}` has no input `{name}`",
                self.job.stage
            )));
        };
        let bytes = (self.read)(hash).map_err(|e| StageError::input(name, e))?;
        if ContentHash::of(&bytes) != *hash {
            return Err(StageError::input(
                name,
                format!("its bytes do not match its hash {}", hash.short()),
            ));
        }
        Ok(bytes)
    }

    fn read_discovered(&self, relative: &str) -> io::Result<Vec<u8>> {
        match self.job.files.get(relative) {
            Some(Some(hash)) => {
                let bytes = (self.read)(hash)?;
                if ContentHash::of(&bytes) != *hash {
                    return Err(io::Error::other(format!(
                        "{relative}: its bytes do not match its hash {}",
                        hash.short()
                    )));
                }
                Ok(bytes)
            }
            Some(None) => Err(io::Error::new(
                io::ErrorKind::NotFound,
                format!("{relative}: not found"),
            )),
            None => {
                let mut wanted = self.wanted.borrow_mut();
                if !wanted.iter().any(|w| w == relative) {
                    wanted.push(relative.to_string());
                }
                Err(io::Error::other(format!(
                    "{relative}: not sent with the action"
                )))
            }
        }
    }

    fn will_read(&self, relatives: &[String]) {
        let mut will_read = self.will_read.borrow_mut();
        for relative in relatives {
            if will_read.len() >= MAX_ACTION_FILES {
                break;
            }
            if !self.job.files.contains_key(relative) {
                will_read.insert(relative.clone());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Doubles its input `x` into output `y`, warns, and panics on request.
    struct Double;

    impl Stage for Double {
        fn name(&self) -> &'static str {
            "double"
        }
        fn version(&self) -> u32 {
            3
        }
        fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
            if ctx.params()["panic"] == true {
                panic!("asked to");
            }
            let mut x = ctx.input("x")?;
            x.extend_from_within(..);
            if let Some(include) = ctx.params()["include"].as_str().map(str::to_string) {
                match ctx.read_discovered(&include) {
                    Ok(extra) => x.extend(extra),
                    Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                    Err(e) => return Err(StageError::asset(e)),
                }
            }
            ctx.output("y", x);
            ctx.warn("doubled");
            Ok(())
        }
    }

    fn job(bytes: &[u8], params: serde_json::Value) -> ActionJob {
        ActionJob {
            stage: "double".into(),
            stage_version: 3,
            asset: "a.obj".into(),
            params,
            inputs: BTreeMap::from([("x".to_string(), ContentHash::of(bytes))]),
            hashed: BTreeMap::new(),
            sources: BTreeMap::new(),
            files: BTreeMap::new(),
            settings: serde_json::Value::Null,
        }
    }

    #[test]
    fn an_action_runs_its_stage_on_checked_inputs() {
        let job = job(b"ab", serde_json::json!({}));
        let done = run_action(&Double, &job, &|_| Ok(b"ab".to_vec())).unwrap();
        assert_eq!(done.outputs["y"], b"abab");
        assert_eq!(done.left.warnings, ["doubled"]);

        let wrong = run_action(&Double, &job, &|_| Ok(b"ax".to_vec())).unwrap_err();
        assert!(
            wrong.to_string().contains("do not match its hash"),
            "{wrong}"
        );

        let mut newer = job.clone();
        newer.stage_version = 4;
        let version = run_action(&Double, &newer, &|_| Ok(b"ab".to_vec())).unwrap_err();
        assert!(version.to_string().contains("version 4"), "{version}");

        let panics = self::job(b"ab", serde_json::json!({"panic": true}));
        let panicked = run_action(&Double, &panics, &|_| Ok(b"ab".to_vec())).unwrap_err();
        assert!(
            matches!(&panicked, StageError::Panic { what, .. } if what == "asked to"),
            "{panicked}"
        );
    }

    #[test]
    fn files_a_stage_discovers_are_asked_for_then_read_from_what_was_sent() {
        let mut job = job(b"ab", serde_json::json!({"include": "../inc.txt"}));
        let read = |hash: &ContentHash| match *hash == ContentHash::of(b"++") {
            true => Ok(b"++".to_vec()),
            false => Ok(b"ab".to_vec()),
        };
        // Not sent: asked for, and nothing else is a result.
        let asked = run_action(&Double, &job, &read).unwrap();
        assert!(asked.outputs.is_empty());
        assert_eq!(asked.left.wanted, ["../inc.txt"]);
        assert!(asked.left.warnings.is_empty());

        // Sent: read, checked and recorded.
        let hash = ContentHash::of(b"++");
        job.files.insert("../inc.txt".into(), Some(hash));
        assert_eq!(job.blobs().len(), 2);
        let done = run_action(&Double, &job, &read).unwrap();
        assert_eq!(done.outputs["y"], b"abab++");
        assert!(done.left.wanted.is_empty());
        let read_as = |path: &str, hash| DiscoveredFile {
            path: path.into(),
            hash,
        };
        assert_eq!(done.left.discovered, [read_as("../inc.txt", Some(hash))]);

        // Said to be absent: not found, and recorded as such.
        job.files.insert("../inc.txt".into(), None);
        let done = run_action(&Double, &job, &read).unwrap();
        assert_eq!(done.outputs["y"], b"abab");
        assert_eq!(done.left.discovered, [read_as("../inc.txt", None)]);

        // Sent with other bytes than its hash names: the stage sees an error.
        job.files
            .insert("../inc.txt".into(), Some(ContentHash::of(b"--")));
        let wrong = run_action(&Double, &job, &read).unwrap_err();
        assert!(
            wrong.to_string().contains("do not match its hash"),
            "{wrong}"
        );
    }

    #[test]
    fn output_names_are_plain_file_names() {
        for ok in ["mesh", "maps-2", "plt_v1"] {
            assert!(ActionJob::is_output_name(ok), "{ok}");
        }
        for bad in ["", "../x", "a/b", ".", "left.json", "a b"] {
            assert!(!ActionJob::is_output_name(bad), "{bad}");
        }
    }
}
