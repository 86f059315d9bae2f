//! `pipeline.toml`: where assets are, where outputs and the cache go, and the parameters of
//! every stage, with per-asset overrides chosen by glob.

use std::path::{Path, PathBuf};

use globset::{GlobBuilder, GlobMatcher};
use serde::{Deserialize, Serialize};

use crate::PipelineError;

/// The parsed configuration. Relative paths are resolved against `base_dir` (the folder of the
/// configuration file).
#[derive(Clone, Debug)]
pub struct Config {
    /// The file it was read from, for messages.
    pub path: PathBuf,
    pub base_dir: PathBuf,
    pub assets: AssetsConfig,
    pub cache: CacheConfig,
    pub output: OutputConfig,
    pub limits: LimitsConfig,
    pub compare: CompareConfig,
    pub execution: ExecutionConfig,
    /// Stage parameters before overrides.
    stages: toml::Table,
    overrides: Vec<Override>,
    /// The file's text, to point at the line of a value found wrong later.
    text: String,
}

/// `[limits]`: how large the files a model brings may be, and what it may make the loader
/// allocate. Every model and the files it references are untrusted input.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Largest model file, and largest file it references, in MiB.
    pub max_file_mb: u64,
    /// Pixels of one decoded texture.
    pub max_texture_pixels: u64,
    /// Pixels of all the decoded textures of one model.
    pub max_total_texture_pixels: u64,
    /// Corners of one polygon.
    pub max_face_corners: usize,
    /// Triangles of one model.
    pub max_triangles: usize,
    /// Vertices of one model.
    pub max_vertices: usize,
    /// Surface area over the bounding sphere's cross-section (layers an average ray crosses).
    pub max_depth_complexity: u32,
}

impl Default for LimitsConfig {
    fn default() -> Self {
        let mesh = ori_mesh::Limits::default();
        LimitsConfig {
            max_file_mb: ori_graph::DEFAULT_MAX_FILE_BYTES >> 20,
            max_texture_pixels: mesh.max_texture_pixels,
            max_total_texture_pixels: mesh.max_total_texture_pixels,
            max_face_corners: mesh.max_face_corners,
            max_triangles: mesh.max_triangles,
            max_vertices: mesh.max_vertices,
            max_depth_complexity: mesh.max_depth_complexity,
        }
    }
}

impl LimitsConfig {
    pub(crate) fn validate(&self) -> Result<(), String> {
        let positive = [
            ("max_file_mb", self.max_file_mb),
            ("max_texture_pixels", self.max_texture_pixels),
            ("max_total_texture_pixels", self.max_total_texture_pixels),
            ("max_face_corners", self.max_face_corners as u64),
            ("max_triangles", self.max_triangles as u64),
            ("max_vertices", self.max_vertices as u64),
            ("max_depth_complexity", u64::from(self.max_depth_complexity)),
        ];
        for (key, value) in positive {
            if value == 0 {
                return Err(format!("[limits] {key} = 0: expected at least 1"));
            }
        }
        if self.max_file_mb > 1 << 20 {
            return Err(format!(
                "[limits] max_file_mb = {}: expected at most 1048576 (1 TiB)",
                self.max_file_mb
            ));
        }
        if self.max_face_corners < 3 {
            return Err(format!(
                "[limits] max_face_corners = {}: a polygon has at least 3 corners",
                self.max_face_corners
            ));
        }
        Ok(())
    }

    /// The rules for source files under the assets folder `root` (which must exist).
    pub fn source_rules(&self, root: &Path) -> Result<ori_graph::SourceRules, PipelineError> {
        ori_graph::SourceRules::confined(root, self.max_file_mb << 20)
            .map_err(|e| PipelineError::Assets(format!("assets folder {}: {e}", root.display())))
    }

    /// The loader's limits.
    pub fn mesh(&self) -> ori_mesh::Limits {
        ori_mesh::Limits {
            max_texture_pixels: self.max_texture_pixels,
            max_total_texture_pixels: self.max_total_texture_pixels,
            max_face_corners: self.max_face_corners,
            max_triangles: self.max_triangles,
            max_vertices: self.max_vertices,
            max_depth_complexity: self.max_depth_complexity,
        }
    }
}

/// `[assets]`: which files are assets.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AssetsConfig {
    /// Folder scanned for models.
    pub root: PathBuf,
    /// Globs, relative to `root`, of the files that are assets.
    pub include: Vec<String>,
    /// Globs of files to leave out even though `include` matches them.
    pub exclude: Vec<String>,
}

impl Default for AssetsConfig {
    fn default() -> Self {
        AssetsConfig {
            root: PathBuf::from("samples"),
            include: ["**/*.gltf", "**/*.glb", "**/*.obj", "**/*.ply"]
                .map(String::from)
                .to_vec(),
            exclude: Vec::new(),
        }
    }
}

/// `[cache]`: the local artifact cache, and optionally a remote one behind it.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CacheConfig {
    pub dir: PathBuf,
    /// `[cache.remote]`; none by default.
    pub remote: Option<RemoteConfig>,
}

impl Default for CacheConfig {
    fn default() -> Self {
        CacheConfig {
            dir: PathBuf::from("target/ori-cache"),
            remote: None,
        }
    }
}

/// `[cache.remote]`: a shared cache speaking the HTTP remote-cache protocol
/// (`{url}/cas/{hash}`, `{url}/ac/{key}`), consulted after the local cache.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RemoteConfig {
    /// `http://host[:port][/path]` (the HTTP cache protocol), or an object store:
    /// `s3://bucket[/prefix]`, `gs://bucket[/prefix]`, `az://container[/prefix]`,
    /// `file:///path` (settings and credentials from the environment, see
    /// `ori_object_store`).
    pub url: String,
    /// The environment variable holding a bearer token, if the server wants one.
    #[serde(default)]
    pub token_env: Option<String>,
    /// Limit in seconds for connecting and for each request; a server slower than this is
    /// treated as unavailable for the rest of the build.
    #[serde(default = "default_timeout_s")]
    pub timeout_s: f64,
    /// `"read-only"` (download only; the default) or `"read-write"` (also upload).
    #[serde(default)]
    pub mode: ori_graph::RemoteMode,
    /// How blobs are named on the server: `"blake3"` (the default) or `"sha256"` (what
    /// bazel-remote and REAPI servers check).
    #[serde(default)]
    pub digest: ori_graph::RemoteDigest,
}

fn default_timeout_s() -> f64 {
    10.0
}

impl RemoteConfig {
    /// Check the values; the message names the key at fault.
    fn validate(&self) -> Result<(), String> {
        let url = &self.url;
        let bad = |why: &str| Err(format!("[cache.remote] url = {url:?}: {why}"));
        if ori_object_store::is_object_store_url(url) {
            if let Some(name) = &self.token_env {
                return Err(format!(
                    "[cache.remote] token_env = {name:?}: only for http:// servers (object stores take their credentials from the environment)"
                ));
            }
            ori_object_store::check_url(url).map_err(|e| format!("[cache.remote] url: {e}"))?;
            return self.validate_timeout();
        }
        let Some(rest) = url.strip_prefix("http://") else {
            return if url.starts_with("https://") {
                bad(
                    "https is not supported (this client speaks plain HTTP; terminate TLS in a local proxy)",
                )
            } else {
                bad(
                    "expected http://host[:port][/path], s3://bucket[/prefix], gs://bucket[/prefix], az://container[/prefix] or file:///path",
                )
            };
        };
        let host_port = rest.split('/').next().unwrap_or("");
        if host_port.is_empty()
            || host_port.contains('@')
            || rest.contains(['?', '#'])
            || rest.chars().any(|c| c.is_whitespace() || c.is_control())
        {
            return bad("expected http://host[:port][/path] (no user, query or fragment)");
        }
        if let Some((host, port)) = host_port.rsplit_once(':')
            && !host.ends_with(']')
            && (host.is_empty() || port.parse::<u16>().is_err())
        {
            return bad("the port must be a number from 0 to 65535");
        }
        check_token_env("[cache.remote]", self.token_env.as_deref())?;
        self.validate_timeout()
    }

    fn validate_timeout(&self) -> Result<(), String> {
        if !(self.timeout_s > 0.0 && self.timeout_s <= 3600.0) {
            return Err(format!(
                "[cache.remote] timeout_s = {}: expected more than 0 and at most 3600 seconds",
                self.timeout_s
            ));
        }
        Ok(())
    }

    /// The bearer token from `token_env`, read now (`None` without `token_env`). An unset
    /// or empty variable is an error naming the key and the variable.
    pub fn token(&self) -> Result<Option<String>, String> {
        read_token("[cache.remote]", self.token_env.as_deref())
    }

    /// The remote cache this configures (reads the token, or the object store's settings).
    pub fn open(&self) -> Result<ori_graph::RemoteCache, String> {
        let timeout = std::time::Duration::from_secs_f64(self.timeout_s);
        let store: Box<dyn ori_graph::RemoteStore> =
            if ori_object_store::is_object_store_url(&self.url) {
                Box::new(
                    ori_object_store::ObjectStoreRemote::open(&self.url, timeout)
                        .map_err(|e| format!("[cache.remote] url: {e}"))?,
                )
            } else {
                let token = self.token()?;
                Box::new(ori_http_store::HttpStore::new(
                    &self.url,
                    token.as_deref(),
                    timeout,
                ))
            };
        Ok(ori_graph::RemoteCache::new(store, self.mode, self.digest))
    }
}

/// `[execution]`: where the jobs run. By default here; with `remote`, every job that reads no
/// source file runs on a REAPI build farm (BuildGrid, Buildbarn, NativeLink, ...).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExecutionConfig {
    /// `grpc://host:port` of the farm's REAPI endpoint; none by default.
    pub remote: Option<String>,
    /// The REAPI instance name (empty for the server's default instance).
    pub instance_name: String,
    /// The environment variable holding a bearer token, if the farm wants one.
    pub token_env: Option<String>,
    /// Seconds one job may run there (its queue may add as much again before it runs here
    /// instead); also the limit of every other exchange with the farm.
    pub timeout_s: f64,
    /// Jobs waiting on the farm at once.
    pub max_in_flight: usize,
}

impl Default for ExecutionConfig {
    fn default() -> Self {
        ExecutionConfig {
            remote: None,
            instance_name: String::new(),
            token_env: None,
            timeout_s: 600.0,
            max_in_flight: 8,
        }
    }
}

impl ExecutionConfig {
    fn validate(&self) -> Result<(), String> {
        if let Some(url) = &self.remote {
            check_grpc_url(url).map_err(|why| format!("[execution] remote = {url:?}: {why}"))?;
        }
        // BuildGrid refuses actions whose timeout is over its `max-execution-timeout`, 7200 s
        // by default.
        if !(self.timeout_s > 0.0 && self.timeout_s <= 7200.0) {
            return Err(format!(
                "[execution] timeout_s = {}: expected more than 0 and at most 7200 seconds",
                self.timeout_s
            ));
        }
        if !(1..=256).contains(&self.max_in_flight) {
            return Err(format!(
                "[execution] max_in_flight = {}: expected 1 to 256",
                self.max_in_flight
            ));
        }
        check_token_env("[execution]", self.token_env.as_deref())
    }

    /// The remote executor this configures, on the farm at `url` (`[execution] remote` or the
    /// command line's), whose workers load models within `limits`; reads the token.
    pub fn open(
        &self,
        url: &str,
        limits: &LimitsConfig,
    ) -> Result<ori_graph::RemoteExecution, String> {
        check_grpc_url(url).map_err(|why| format!("remote execution {url:?}: {why}"))?;
        let token = read_token("[execution]", self.token_env.as_deref())?;
        let timeout = std::time::Duration::from_secs_f64(self.timeout_s);
        let settings = ori_reapi::client::Settings {
            url: url.to_string(),
            instance_name: self.instance_name.clone(),
            token,
            timeout,
        };
        let executor =
            ori_reapi::executor::ReapiExecutor::new(settings, None, self.max_in_flight, timeout)?;
        let settings = crate::action::ActionSettings {
            limits: limits.clone(),
        };
        Ok(ori_graph::RemoteExecution::new(
            Box::new(executor),
            serde_json::to_value(settings).expect("plain data"),
        ))
    }
}

/// A `token_env` key of `section` must name an environment variable.
fn check_token_env(section: &str, name: Option<&str>) -> Result<(), String> {
    match name {
        Some(name)
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') =>
        {
            Err(format!(
                "{section} token_env = {name:?}: expected the name of an environment variable (letters, digits, _)"
            ))
        }
        _ => Ok(()),
    }
}

/// The bearer token in the variable a `token_env` key of `section` names, read now (`None`
/// without the key). An unset or empty variable is an error naming the key and the variable.
fn read_token(section: &str, name: Option<&str>) -> Result<Option<String>, String> {
    let Some(name) = name else {
        return Ok(None);
    };
    match std::env::var(name) {
        Ok(token) if !token.is_empty() => Ok(Some(token)),
        _ => Err(format!(
            "{section} token_env = {name:?}: the environment variable {name} is not set"
        )),
    }
}

/// Whether `url` is `grpc://host:port`.
pub fn check_grpc_url(url: &str) -> Result<(), String> {
    let Some(rest) = url.strip_prefix("grpc://") else {
        return Err(if url.starts_with("grpcs://") {
            "grpcs (TLS) is not supported; terminate TLS in a local proxy".into()
        } else {
            "expected grpc://host:port".into()
        });
    };
    let rest = rest.trim_end_matches('/');
    match rest.rsplit_once(':') {
        Some((host, port))
            if !host.is_empty()
                && port.parse::<u16>().is_ok()
                && !rest.contains(['/', '@', '?', '#'])
                && !rest.chars().any(|c| c.is_whitespace() || c.is_control()) =>
        {
            Ok(())
        }
        _ => Err("expected grpc://host:port".into()),
    }
}

/// `[compare]`: the HTML report's comparison of each ORI with the rival techniques at its
/// texture bytes (`cargo xtask compare`); slow, so off by default.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompareConfig {
    pub enabled: bool,
    /// Held-out directions measured (evenly spread through the 3,280).
    pub directions: usize,
}

impl Default for CompareConfig {
    fn default() -> Self {
        CompareConfig {
            enabled: false,
            directions: ori_views::HELD_OUT_REGULAR + ori_views::HELD_OUT_RANDOM,
        }
    }
}

impl CompareConfig {
    fn validate(&self) -> Result<(), String> {
        let all = ori_views::HELD_OUT_REGULAR + ori_views::HELD_OUT_RANDOM;
        if !(1..=all).contains(&self.directions) {
            return Err(format!(
                "[compare] directions = {}: expected 1 to {all}",
                self.directions
            ));
        }
        Ok(())
    }

    /// What the report is asked to compare.
    pub fn directions(&self) -> Option<usize> {
        self.enabled.then_some(self.directions)
    }
}

/// `[output]`: where the build writes its results.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    pub dir: PathBuf,
}

impl Default for OutputConfig {
    fn default() -> Self {
        OutputConfig {
            dir: PathBuf::from("target/ori-out"),
        }
    }
}

/// Parameters of every stage for one asset, after overrides.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StageParams {
    #[serde(default)]
    pub ingest: IngestParams,
    #[serde(default)]
    pub views: ori_views::ViewParams,
    /// `[place]`: the placement search after view planning.
    #[serde(default)]
    pub place: ori_place::PlaceParams,
    #[serde(default)]
    pub bake: ori_bake::BakeParams,
    #[serde(default)]
    pub select: ori_select::SelectParams,
    #[serde(default)]
    pub compress: crate::stages::compress::CompressParams,
    /// `[plt]`: the target of `bake.resolution = "auto"`.
    #[serde(default)]
    pub plt: ori_plt::PltParams,
    /// `[hierarchy]`: a tree of ORIs instead of one (off by default).
    #[serde(default)]
    pub hierarchy: crate::hierarchy::HierarchyParams,
    /// `[gate]`: the quality required of the package. Checked after the build, so no job's
    /// key or package holds it.
    #[serde(default, skip_serializing)]
    pub gate: crate::gate::GateParams,
    /// `bake.resolution = "auto"`: the build picks the resolution (see `ori_plt::auto`);
    /// `bake.resolution` then holds the default until it does.
    #[serde(skip)]
    pub auto_resolution: bool,
    /// The GPU adapter selection is measured on (`build-assets --backend gpu`); `None`: the
    /// CPU evaluator. Part of the select job's parameters, so results of different devices
    /// never share a cache entry.
    #[serde(skip)]
    pub select_device: Option<String>,
}

impl StageParams {
    /// The parameters a package records: every stage's, and whether the resolution was
    /// chosen by `auto`.
    pub fn recorded(&self) -> serde_json::Value {
        let mut json = serde_json::to_value(self).expect("parameters serialise to JSON");
        json["bake"]["resolution_auto"] = serde_json::Value::Bool(self.auto_resolution);
        let object = json.as_object_mut().expect("an object");
        if !self.auto_resolution {
            // Only the seed of the held-out directions shapes a fixed resolution's package.
            object.insert(
                "plt".into(),
                serde_json::json!({ "held_out_seed": self.plt.held_out_seed }),
            );
        }
        if !self.hierarchy.enabled {
            object.remove("hierarchy");
        }
        json
    }
}

/// `[ingest]`: mesh loading.
#[derive(Clone, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct IngestParams {
    /// Ignore the normals stored in the files and compute angle-weighted ones everywhere.
    pub recompute_normals: bool,
}

/// One `[[overrides]]` table: stage parameters for the assets its glob matches.
#[derive(Clone, Debug)]
struct Override {
    pattern: String,
    matcher: GlobMatcher,
    stages: toml::Table,
}

/// The file as written. Every other top-level table is a stage section ([`StageParams`]
/// names them), kept as a table so overrides can be merged into it key by key before the
/// whole is checked (an unknown section is reported then, with the valid ones).
#[derive(Deserialize)]
struct ConfigFile {
    #[serde(default)]
    assets: AssetsConfig,
    #[serde(default)]
    cache: CacheConfig,
    #[serde(default)]
    output: OutputConfig,
    #[serde(default)]
    limits: LimitsConfig,
    #[serde(default)]
    compare: CompareConfig,
    #[serde(default)]
    execution: ExecutionConfig,
    #[serde(default)]
    overrides: Vec<OverrideFile>,
    #[serde(flatten)]
    stages: toml::Table,
}

/// One `[[overrides]]` table as written: a glob, and stage sections like the file's.
#[derive(Deserialize)]
struct OverrideFile {
    /// Glob over asset paths relative to the assets root, e.g. `trees/**`.
    assets: String,
    #[serde(flatten)]
    stages: toml::Table,
}

/// A glob where `*` stays within one path component and `**` crosses them.
pub(crate) fn glob(pattern: &str) -> Result<GlobMatcher, globset::Error> {
    Ok(GlobBuilder::new(pattern)
        .literal_separator(true)
        .build()?
        .compile_matcher())
}

/// Whether the override's own tables set the key at `path`.
fn over_has(over: &toml::Table, path: &KeyPath) -> bool {
    let mut table = Some(over);
    for segment in &path.0 {
        let KeySegment::Key(key) = segment else {
            return false;
        };
        let Some(value) = table.and_then(|t| t.get(key)) else {
            return false;
        };
        table = value.as_table();
    }
    !path.0.is_empty()
}

/// Merge `over` into `base`: tables recursively, other values replaced.
fn merge(base: &mut toml::Table, over: &toml::Table) {
    for (key, value) in over {
        match (base.get_mut(key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            _ => {
                base.insert(key.clone(), value.clone());
            }
        }
    }
}

/// A key path into the file, for messages: `select.impostors`, `overrides[2].bake.n`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct KeyPath(Vec<KeySegment>);

#[derive(Clone, Debug, PartialEq, Eq)]
enum KeySegment {
    Key(String),
    Index(usize),
}

impl KeyPath {
    fn of(path: &serde_path_to_error::Path) -> KeyPath {
        use serde_path_to_error::Segment;
        KeyPath(
            path.iter()
                .filter_map(|s| match s {
                    Segment::Map { key } => Some(KeySegment::Key(key.clone())),
                    Segment::Seq { index } => Some(KeySegment::Index(*index)),
                    Segment::Enum { variant } => Some(KeySegment::Key(variant.clone())),
                    Segment::Unknown => None,
                })
                .collect(),
        )
    }

    /// Below `[[overrides]]` number `index` (0-based).
    fn in_override(mut self, index: usize) -> KeyPath {
        let mut path = vec![
            KeySegment::Key("overrides".into()),
            KeySegment::Index(index),
        ];
        path.append(&mut self.0);
        KeyPath(path)
    }

    /// The 1-based line and column of the value at this path in `text`, if it is written there.
    fn position_in(&self, text: &str) -> Option<(usize, usize)> {
        let document = toml::de::DeTable::parse(text).ok()?;
        let mut span = document.span();
        let mut table = Some(document.get_ref());
        let mut array: Option<&toml::de::DeArray<'_>> = None;
        for segment in &self.0 {
            let value = match segment {
                KeySegment::Key(key) => {
                    table?
                        .iter()
                        .find(|(k, _)| k.get_ref().as_ref() == key.as_str())?
                        .1
                }
                KeySegment::Index(i) => array?.get(*i)?,
            };
            span = value.span();
            table = value.get_ref().as_table();
            array = value.get_ref().as_array();
        }
        let before = &text[..span.start.min(text.len())];
        let line_start = before.rfind('\n').map_or(0, |n| n + 1);
        let column = before[line_start..].chars().count() + 1;
        Some((before.matches('\n').count() + 1, column))
    }
}

impl std::fmt::Display for KeyPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, segment) in self.0.iter().enumerate() {
            match segment {
                KeySegment::Key(k) if i == 0 => write!(f, "{k}")?,
                KeySegment::Key(k) => write!(f, ".{k}")?,
                KeySegment::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// A value that does not fit its key: the key's path and why.
#[derive(Debug)]
struct ValueError {
    key: KeyPath,
    message: String,
}

impl ValueError {
    fn plain(message: String) -> ValueError {
        ValueError {
            key: KeyPath::default(),
            message,
        }
    }

    /// The message, with the key and its place in `text` when known.
    fn describe(&self, text: &str) -> String {
        if self.key.0.is_empty() {
            return self.message.clone();
        }
        match self.key.position_in(text) {
            Some((line, column)) => format!(
                "line {line}, column {column}: `{}`: {}",
                self.key, self.message
            ),
            None => format!("`{}`: {}", self.key, self.message),
        }
    }
}

/// Deserialise stage sections and check their values; an error keeps the key path of a
/// value of the wrong type.
fn to_params_at(mut table: toml::Table) -> Result<StageParams, ValueError> {
    let bake = table.get_mut("bake").and_then(|b| b.as_table_mut());
    let auto = match bake {
        Some(bake) if bake.get("resolution").and_then(|r| r.as_str()) == Some("auto") => {
            bake.remove("resolution");
            true
        }
        _ => false,
    };
    let mut params: StageParams = serde_path_to_error::deserialize(toml::Value::Table(table))
        .map_err(|e| ValueError {
            key: KeyPath::of(e.path()),
            message: e.inner().message().to_string(),
        })?;
    params.auto_resolution = auto;
    let plain = |e: String| ValueError::plain(e);
    params.plt.validate().map_err(plain)?;
    params.views.validate().map_err(|e| plain(e.to_string()))?;
    params.place.validate().map_err(|e| plain(e.to_string()))?;
    params.bake.validate().map_err(|e| plain(e.to_string()))?;
    params.select.validate().map_err(|e| plain(e.to_string()))?;
    params.hierarchy.validate().map_err(plain)?;
    params.gate.validate().map_err(plain)?;
    Ok(params)
}

impl Config {
    /// Read and check a configuration file: unknown keys, bad globs and bad parameter values
    /// (in the base sections and in every override) are errors that name the file.
    pub fn load(path: &Path) -> Result<Config, PipelineError> {
        let text = std::fs::read_to_string(path).map_err(|e| PipelineError::Config {
            path: path.to_path_buf(),
            message: format!("cannot read: {e}"),
        })?;
        Config::parse(path, &text)
    }

    /// Parse configuration text; `path` names it in messages and gives the base folder.
    pub fn parse(path: &Path, text: &str) -> Result<Config, PipelineError> {
        let fail = |message: String| PipelineError::Config {
            path: path.to_path_buf(),
            message,
        };
        let file: ConfigFile = toml::from_str(text).map_err(|e| fail(e.to_string()))?;
        let stages = file.stages;
        to_params_at(stages.clone()).map_err(|e| fail(e.describe(text)))?;
        let mut overrides = Vec::new();
        for (i, o) in file.overrides.into_iter().enumerate() {
            let what = format!("[[overrides]] #{} (assets = {:?})", i + 1, o.assets);
            let matcher = glob(&o.assets).map_err(|e| fail(format!("{what}: {e}")))?;
            let over = o.stages;
            let mut merged = stages.clone();
            merge(&mut merged, &over);
            to_params_at(merged).map_err(|mut e| {
                // A key set by this override is written in it; others come from the base.
                if over_has(&over, &e.key) {
                    e.key = e.key.clone().in_override(i);
                }
                fail(format!("{what}: {}", e.describe(text)))
            })?;
            overrides.push(Override {
                pattern: o.assets,
                matcher,
                stages: over,
            });
        }
        if let Some(remote) = &file.cache.remote {
            remote.validate().map_err(fail)?;
        }
        file.limits.validate().map_err(fail)?;
        file.compare.validate().map_err(fail)?;
        file.execution.validate().map_err(fail)?;
        for pattern in file.assets.include.iter().chain(&file.assets.exclude) {
            glob(pattern).map_err(|e| fail(format!("[assets] pattern {pattern:?}: {e}")))?;
        }
        Ok(Config {
            path: path.to_path_buf(),
            base_dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
            assets: file.assets,
            cache: file.cache,
            output: file.output,
            limits: file.limits,
            compare: file.compare,
            execution: file.execution,
            stages,
            overrides,
            text: text.to_string(),
        })
    }

    /// Stage parameters for the asset at `relative` (its path under the assets root, with
    /// `/` separators): the base sections with every matching override applied in file order.
    /// Each override was checked alone at load; several that match one asset can still
    /// conflict together, which is an error naming the asset and the overrides.
    pub fn params_for(&self, relative: &str) -> Result<StageParams, PipelineError> {
        let mut merged = self.stages.clone();
        let matching: Vec<&Override> = self
            .overrides
            .iter()
            .filter(|o| o.matcher.is_match(relative))
            .collect();
        for o in &matching {
            merge(&mut merged, &o.stages);
        }
        to_params_at(merged).map_err(|e| {
            let patterns: Vec<String> = matching
                .iter()
                .map(|o| format!("{:?}", o.pattern))
                .collect();
            PipelineError::Config {
                path: self.path.clone(),
                message: format!(
                    "asset {relative}: the [[overrides]] that match it ({}) conflict together: {}",
                    patterns.join(", "),
                    e.describe(&self.text)
                ),
            }
        })
    }

    /// The override patterns, in file order.
    pub fn override_patterns(&self) -> impl Iterator<Item = &str> {
        self.overrides.iter().map(|o| o.pattern.as_str())
    }

    /// Resolve a configured path against the configuration's folder.
    pub fn resolve(&self, path: &Path) -> PathBuf {
        self.base_dir.join(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Config, String> {
        Config::parse(Path::new("conf/pipeline.toml"), text).map_err(|e| e.to_string())
    }

    #[test]
    fn defaults_when_empty() {
        let c = parse("").unwrap();
        assert_eq!(c.assets.root, PathBuf::from("samples"));
        assert_eq!(c.params_for("a.obj").unwrap(), StageParams::default());
        assert_eq!(
            c.resolve(&c.cache.dir),
            PathBuf::from("conf/target/ori-cache")
        );
    }

    #[test]
    fn unknown_keys_are_named_with_the_valid_ones() {
        let e = parse("[ingest]\nrecompute_normal = true\n").unwrap_err();
        assert!(e.starts_with("conf/pipeline.toml: "), "{e}");
        assert!(e.contains("unknown field `recompute_normal`"), "{e}");
        assert!(e.contains("recompute_normals"), "{e}");
        let e = parse("[baking]\nn = 3\n").unwrap_err();
        assert!(
            e.contains("unknown field `baking`") && e.contains("bake"),
            "{e}"
        );
        let e = parse("[bake]\nresolutoin = 3\n").unwrap_err();
        assert!(
            e.contains("`resolutoin`") && e.contains("resolution"),
            "{e}"
        );
        let e = parse("[[overrides]]\nassets = \"t/**\"\ningest = { nope = 1 }\n").unwrap_err();
        assert!(
            e.contains("#1") && e.contains("t/**") && e.contains("`nope`"),
            "{e}"
        );
        let e = parse("[ingest]\nrecompute_normals = 3\n").unwrap_err();
        assert!(e.contains("invalid type"), "{e}");
        let e = parse("[views]\ncount = 7\n").unwrap_err();
        assert!(e.contains("views.count = 7"), "{e}");
        let e = parse("[[overrides]]\nassets = \"*\"\nbake.supersample = 9\n").unwrap_err();
        assert!(e.contains("bake.supersample = 9"), "{e}");
    }

    #[test]
    fn overrides_apply_by_glob_in_order() {
        let c = parse(
            "[[overrides]]\nassets = \"trees/**\"\ningest.recompute_normals = true\n\
             [[overrides]]\nassets = \"trees/palm/*.glb\"\ningest.recompute_normals = false\n",
        )
        .unwrap();
        assert!(
            c.params_for("trees/oak/oak.obj")
                .unwrap()
                .ingest
                .recompute_normals
        );
        assert!(
            !c.params_for("trees/palm/p.glb")
                .unwrap()
                .ingest
                .recompute_normals
        );
        assert!(
            !c.params_for("rocks/trees/x.obj")
                .unwrap()
                .ingest
                .recompute_normals
        );
        assert!(
            c.params_for("trees/palm/deep/p.glb")
                .unwrap()
                .ingest
                .recompute_normals
        );
    }

    #[test]
    fn execution_settings_are_checked() {
        let c = parse("[execution]\nremote = \"grpc://farm:50051\"\nmax_in_flight = 4\n").unwrap();
        assert_eq!(c.execution.remote.as_deref(), Some("grpc://farm:50051"));
        assert_eq!(
            (c.execution.max_in_flight, c.execution.timeout_s),
            (4, 600.0)
        );
        for (text, says) in [
            (
                "remote = \"http://farm:50051\"",
                "expected grpc://host:port",
            ),
            (
                "remote = \"grpcs://farm:50051\"",
                "grpcs (TLS) is not supported",
            ),
            ("remote = \"grpc://farm\"", "expected grpc://host:port"),
            ("max_in_flight = 0", "expected 1 to 256"),
            ("timeout_s = 0", "expected more than 0"),
            (
                "token_env = \"A-B\"",
                "expected the name of an environment variable",
            ),
        ] {
            let e = parse(&format!("[execution]\n{text}\n"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn remote_cache_settings_are_checked() {
        let c = parse("[cache.remote]\nurl = \"http://cache.farm:8080/ori/\"\n").unwrap();
        let r = c.cache.remote.unwrap();
        assert_eq!(r.url, "http://cache.farm:8080/ori/");
        assert_eq!(r.mode, ori_graph::RemoteMode::ReadOnly);
        assert_eq!(r.timeout_s, 10.0);
        assert_eq!(r.token().unwrap(), None);
        let c = parse(
            "[cache.remote]\nurl = \"http://127.0.0.1\"\nmode = \"read-write\"\ntimeout_s = 2\n\
             token_env = \"ORI_TEST_TOKEN_THAT_IS_NOT_SET\"\n",
        )
        .unwrap();
        let r = c.cache.remote.unwrap();
        assert_eq!(r.mode, ori_graph::RemoteMode::ReadWrite);
        assert_eq!(r.timeout_s, 2.0);
        let e = r.token().unwrap_err();
        assert!(
            e.contains("token_env") && e.contains("ORI_TEST_TOKEN_THAT_IS_NOT_SET is not set"),
            "{e}"
        );
        for (text, named) in [
            ("url = \"https://c\"", "https is not supported"),
            ("url = \"ftp://c\"", "url = \"ftp://c\""),
            ("url = \"http://\"", "url = \"http://\""),
            ("url = \"http://c:port\"", "port"),
            ("url = \"http://c?x=1\"", "no user, query"),
            ("url = \"http://c\"\nmode = \"readonly\"", "`read-only`"),
            ("url = \"http://c\"\ntimeout_s = 0", "timeout_s = 0"),
            (
                "url = \"http://c\"\ntoken_env = \"A-B\"",
                "token_env = \"A-B\"",
            ),
            ("url = \"http://c\"\ntokn_env = \"A\"", "`tokn_env`"),
            ("mode = \"read-only\"", "missing field `url`"),
        ] {
            let e = parse(&format!("[cache.remote]\n{text}\n")).unwrap_err();
            assert!(e.contains(named), "{text}: {e}");
        }
    }

    #[test]
    fn bad_glob_is_an_error() {
        let e = parse("[[overrides]]\nassets = \"a/[b\"\n").unwrap_err();
        assert!(e.contains("a/[b"), "{e}");
    }
}
