//! One job run as an action in a folder laid out as `ori_graph`'s action module says: what a
//! remote-execution worker runs (`ori run-action DIR`), with none of the build's state.

use std::path::Path;

use ori_graph::{ActionJob, ContentHash, INPUTS_DIR, JOB_FILE, LEFT_FILE, OUTPUTS_DIR, run_action};

use crate::stages::Registry;

/// The largest description read (parameters are a few kilobytes).
const MAX_JOB_BYTES: u64 = 1 << 20;
/// The largest input blob read (a mesh at the ingest limits is far smaller).
const MAX_INPUT_BYTES: u64 = 1 << 32;

/// Run the job described in `dir`: read `job.json` and the input blobs it names, run its
/// stage, and write its outputs and what it left into `dir/outputs`. The error names the file
/// or the stage's problem.
pub fn run_folder(dir: &Path) -> Result<(), String> {
    let job_path = dir.join(JOB_FILE);
    let text = read_bounded(&job_path, MAX_JOB_BYTES)?;
    let job: ActionJob = serde_json::from_slice(&text)
        .map_err(|e| format!("{}: not an action description: {e}", job_path.display()))?;
    let registry = Registry::new(ori_mesh::Limits::default());
    let stage = registry
        .by_name(&job.stage)
        .ok_or_else(|| format!("{}: no stage `{}`", job_path.display(), job.stage))?;
    let inputs = dir.join(INPUTS_DIR);
    let read = |hash: &ContentHash| {
        read_bounded(&inputs.join(hash.to_hex()), MAX_INPUT_BYTES).map_err(std::io::Error::other)
    };
    let done =
        run_action(stage.as_ref(), &job, &read).map_err(|e| format!("{}: {e}", job.asset))?;
    let out = dir.join(OUTPUTS_DIR);
    let write = |name: &str, bytes: &[u8]| {
        let path = out.join(name);
        std::fs::write(&path, bytes).map_err(|e| format!("{}: cannot write: {e}", path.display()))
    };
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    for (name, bytes) in &done.outputs {
        write(name, bytes)?;
    }
    let left = serde_json::to_vec(&done.left).map_err(|e| e.to_string())?;
    write(LEFT_FILE, &left)
}

fn read_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, String> {
    let size = std::fs::metadata(path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .len();
    if size > limit {
        return Err(format!(
            "{}: {size} bytes, more than the {limit} an action reads",
            path.display()
        ));
    }
    std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    /// A `views` job (it needs only the mesh) laid out as a farm lays it out.
    fn folder(job: &serde_json::Value, inputs: &[(&str, &[u8])]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(JOB_FILE), job.to_string()).unwrap();
        std::fs::create_dir(dir.path().join(INPUTS_DIR)).unwrap();
        for (name, bytes) in inputs {
            std::fs::write(dir.path().join(INPUTS_DIR).join(name), bytes).unwrap();
        }
        dir
    }

    #[test]
    fn a_folder_with_a_wrong_description_or_input_says_which() {
        let not_json = folder(&serde_json::json!("x"), &[]);
        let e = run_folder(not_json.path()).unwrap_err();
        assert!(e.contains("job.json: not an action description"), "{e}");

        let job = |stage: &str, inputs: BTreeMap<String, ContentHash>| {
            serde_json::to_value(ActionJob {
                stage: stage.into(),
                stage_version: 1,
                asset: "a.obj".into(),
                params: serde_json::json!({}),
                inputs,
                hashed: BTreeMap::new(),
            })
            .unwrap()
        };
        let unknown = folder(&job("polish", BTreeMap::new()), &[]);
        let e = run_folder(unknown.path()).unwrap_err();
        assert!(e.contains("no stage `polish`"), "{e}");

        // An input whose bytes are not the ones its hash names.
        let registry = Registry::new(ori_mesh::Limits::default());
        let views = registry.by_name("views").unwrap();
        let hash = ContentHash::of(b"mesh");
        let mut wrong = job("views", BTreeMap::from([("mesh".to_string(), hash)]));
        wrong["stage_version"] = views.version().into();
        let dir = folder(&wrong, &[(&hash.to_hex(), b"not the mesh")]);
        let e = run_folder(dir.path()).unwrap_err();
        assert!(
            e.contains("a.obj: input `mesh`: its bytes do not match"),
            "{e}"
        );
        assert!(!dir.path().join(OUTPUTS_DIR).exists());
    }
}
