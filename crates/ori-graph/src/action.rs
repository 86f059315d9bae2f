//! A job as a self-contained action, for a worker that has none of the build's state (a
//! remote-execution farm): its description ([`ActionJob`], the file [`JOB_FILE`]), its inputs
//! as files named by content hash under [`INPUTS_DIR`], and [`run_action`], which runs the
//! stage on them. A job that reads source files is not an action: it runs where they are.

use std::collections::BTreeMap;
use std::io;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::hash::ContentHash;
use crate::job::{Input, JobSpec};
use crate::stage::{JobContext, JobInputs, Stage, StageError};

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
}

impl ActionJob {
    /// The action of `job` whose inputs have `hashes` (in the job's order), or `None` when the
    /// job reads a source file (it may also discover others next to it).
    pub fn of(job: &JobSpec, hashes: &[(String, ContentHash)]) -> Option<ActionJob> {
        let (mut inputs, mut hashed) = (BTreeMap::new(), BTreeMap::new());
        for ((name, input), (_, hash)) in job.inputs.iter().zip(hashes) {
            match input {
                Input::Source(_) => return None,
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
        })
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
    let inputs = ActionInputs { job, read };
    let mut ctx = JobContext::new(&job.asset, &job.params, &inputs, None);
    let ran = crate::stage::run_catching(stage, &mut ctx);
    let left = ctx.finish();
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
        },
    })
}

struct ActionInputs<'a> {
    job: &'a ActionJob,
    read: &'a dyn Fn(&ContentHash) -> io::Result<Vec<u8>>,
}

impl JobInputs for ActionInputs<'_> {
    fn source_path(&self, _name: &str) -> Option<&Path> {
        None
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

    fn read_file(&self, path: &Path) -> io::Result<Vec<u8>> {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            format!("{}: an action reads no source files", path.display()),
        ))
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
    fn output_names_are_plain_file_names() {
        for ok in ["mesh", "maps-2", "plt_v1"] {
            assert!(ActionJob::is_output_name(ok), "{ok}");
        }
        for bad in ["", "../x", "a/b", ".", "left.json", "a b"] {
            assert!(!ActionJob::is_output_name(bad), "{bad}");
        }
    }
}
