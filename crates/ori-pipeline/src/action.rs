//! One job run as an action in a folder laid out as `ori_graph`'s action module says: what a
//! remote-execution worker runs (`ori run-action DIR`), with none of the build's state.

use std::path::Path;

use ori_graph::{ActionJob, ContentHash, INPUTS_DIR, JOB_FILE, LEFT_FILE, OUTPUTS_DIR, run_action};
use serde::{Deserialize, Serialize};

use crate::config::LimitsConfig;
use crate::stages::Registry;

/// The build's settings an action carries ([`ActionJob::settings`]): the stages a worker
/// runs load models within the builder's `[limits]`, not the worker's defaults.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActionSettings {
    pub limits: LimitsConfig,
}

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
    let settings = match &job.settings {
        serde_json::Value::Null => ActionSettings::default(),
        value => serde_json::from_value::<ActionSettings>(value.clone())
            .map_err(|e| e.to_string())
            .and_then(|s| s.limits.validate().map(|()| s))
            .map_err(|e| format!("{}: the action's settings: {e}", job_path.display()))?,
    };
    let registry = Registry::new(settings.limits.mesh());
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
                sources: BTreeMap::new(),
                files: BTreeMap::new(),
                settings: serde_json::Value::Null,
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

    /// An `ingest` action on `model`, sent alone (no discovered files) as `source`, and the
    /// model's bytes.
    fn ingest_action(
        model: &Path,
        asset: &str,
        source: &str,
        settings: serde_json::Value,
    ) -> (ActionJob, Vec<u8>) {
        let bytes = std::fs::read(model).unwrap();
        let registry = Registry::new(ori_mesh::Limits::default());
        let params = crate::stages::ingest::IngestJob::new(model, &Default::default());
        let job = ActionJob {
            stage: "ingest".into(),
            stage_version: registry.by_name("ingest").unwrap().version(),
            asset: asset.into(),
            params: serde_json::to_value(&params).unwrap(),
            inputs: BTreeMap::from([("source".to_string(), ContentHash::of(&bytes))]),
            hashed: BTreeMap::new(),
            sources: BTreeMap::from([("source".to_string(), source.to_string())]),
            files: BTreeMap::new(),
            settings,
        };
        (job, bytes)
    }

    #[test]
    fn a_gltf_sent_alone_asks_for_its_buffer_and_names_the_image_it_will_read() {
        let model = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/models/gltf/Avocado/glTF/Avocado.gltf");
        let (job, bytes) =
            ingest_action(&model, "avocado", "Avocado.gltf", serde_json::Value::Null);
        let registry = Registry::new(ori_mesh::Limits::default());
        let ingest = registry.by_name("ingest").unwrap();
        let read = |_: &ContentHash| Ok(bytes.clone());
        let done = run_action(ingest.as_ref(), &job, &read).unwrap();
        // The loader stops at the buffer, but has named the base-colour image too (not the
        // normal or roughness images, which it never reads).
        assert_eq!(done.left.wanted, ["Avocado.bin"]);
        assert_eq!(done.left.will_read, ["Avocado_baseColor.png"]);
        assert!(done.outputs.is_empty());
    }

    #[test]
    fn a_model_is_loaded_within_the_limits_the_action_carries() {
        let model =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../samples/bunny/bunny_npm_lowres.obj");
        let hash = ContentHash::of(&std::fs::read(&model).unwrap());
        let action = |settings| ingest_action(&model, "bunny", "bunny.obj", settings);
        let run = |settings| {
            let (job, bytes) = action(settings);
            let job = serde_json::to_value(job).unwrap();
            let dir = folder(&job, &[(&hash.to_hex(), &bytes)]);
            let ran = run_folder(dir.path());
            (ran, dir)
        };
        let (ran, dir) = run(serde_json::Value::Null);
        ran.unwrap();
        assert!(dir.path().join(OUTPUTS_DIR).join("mesh").is_file());

        let strict = ActionSettings {
            limits: LimitsConfig {
                max_triangles: 100,
                ..LimitsConfig::default()
            },
        };
        let (ran, _dir) = run(serde_json::to_value(strict).unwrap());
        let e = ran.unwrap_err();
        assert!(e.contains("[limits] max_triangles"), "{e}");

        let (ran, _dir) = run(serde_json::json!({"limits": {"max_triangles": 0}}));
        let e = ran.unwrap_err();
        assert!(
            e.contains("the action's settings: [limits] max_triangles = 0"),
            "{e}"
        );
    }
}
