//! The remote-cache protocol on an object store: blobs at `{prefix}/cas/{name}` and action
//! entries at `{prefix}/ac/{key}`, the layout of the HTTP cache, in a bucket or a folder:
//!
//! - `s3://bucket[/prefix]`: Amazon S3 or any S3-compatible store (MinIO, Ceph, R2, a GCS
//!   bucket through its S3 interface). Settings from the standard variables:
//!   `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`, `AWS_SESSION_TOKEN`, `AWS_REGION`,
//!   `AWS_ENDPOINT_URL`, `AWS_ALLOW_HTTP=true` for a plain-http endpoint; without keys in the
//!   environment, the profile `AWS_PROFILE` (or `default`) of the shared credentials file,
//!   then the instance's or container's role.
//! - `gs://bucket[/prefix]`: Google Cloud Storage (`GOOGLE_SERVICE_ACCOUNT`,
//!   `GOOGLE_APPLICATION_CREDENTIALS`, or the machine's account).
//! - `az://container[/prefix]`: Azure Blob Storage (`AZURE_STORAGE_ACCOUNT_NAME`,
//!   `AZURE_STORAGE_ACCOUNT_KEY` or a SAS token, ...).
//! - `file:///path`: a folder, e.g. a shared mount.
//!
//! Only transport lives here; what is fetched is verified by `ori_graph::RemoteCache`. The
//! graph calls the store from its worker threads, so each call blocks on a small runtime of
//! our own.

use std::future::Future;
use std::time::Duration;

use futures::StreamExt as _;
use object_store::aws::AmazonS3ConfigKey;
use object_store::azure::AzureConfigKey;
use object_store::gcp::GoogleConfigKey;
use object_store::path::Path;
use object_store::{ClientConfigKey, ObjectStore, PutPayload, RetryConfig};
use ori_graph::{ContentHash, Namespace, RemoteError, RemoteStore};

mod aws_profile;

/// A remote cache in a bucket (or folder) of an object store.
pub struct ObjectStoreRemote {
    store: Box<dyn ObjectStore>,
    prefix: Path,
    /// The URL as configured, for messages.
    url: String,
    /// The URL of the bucket's (or folder's) root, to which object paths are appended.
    root: String,
    kind: Kind,
    timeout: Duration,
    /// Taken on drop, to shut down without waiting for blocking work (a hung mount).
    runtime: Option<tokio::runtime::Runtime>,
}

/// The schemes this crate opens, with the shape each expects.
const SCHEMES: [(&str, Kind, &str); 4] = [
    ("s3", Kind::S3, "s3://bucket[/prefix]"),
    ("gs", Kind::Gcs, "gs://bucket[/prefix]"),
    ("az", Kind::Azure, "az://container[/prefix]"),
    ("file", Kind::Folder, "file:///absolute/path"),
];

/// Largest buffer reserved ahead of a download, whatever size the store announces.
const MAX_RESERVE: u64 = 8 << 20;

/// Longest server message quoted in a warning.
const MAX_MESSAGE: usize = 300;

/// Whether `url` names an object store this crate opens (by its scheme).
pub fn is_object_store_url(url: &str) -> bool {
    SCHEMES
        .iter()
        .any(|(scheme, ..)| url.split_once("://").is_some_and(|(s, _)| s == *scheme))
}

/// Check an object-store URL's shape without opening anything: the scheme, a bucket (or an
/// absolute path), a valid prefix, and no credentials, query or fragment. Messages never
/// repeat a URL that holds credentials.
pub fn check_url(url: &str) -> Result<(), String> {
    parse(url).map(|_| ())
}

/// The kinds of store a URL's scheme names.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    S3,
    Gcs,
    Azure,
    Folder,
}

/// What a URL names: the kind of store, the parsed URL and the prefix inside the bucket.
fn parse(url: &str) -> Result<(Kind, url::Url, Path), String> {
    let scheme = url.split_once("://").map_or("", |(s, _)| s);
    let Some(&(_, kind, expected)) = SCHEMES.iter().find(|(s, ..)| *s == scheme) else {
        return Err(format!(
            "{url:?}: expected s3://bucket[/prefix], gs://bucket[/prefix], az://container[/prefix] or file:///path"
        ));
    };
    let parsed = url::Url::parse(url).map_err(|e| format!("expected {expected}: {e}"))?;
    if !parsed.username().is_empty() || parsed.password().is_some() {
        return Err(
            "no user or password in the URL (credentials come from the environment)".to_string(),
        );
    }
    // Not repeated: a query may hold a signature (an Azure SAS token).
    if parsed.query().is_some() || parsed.fragment().is_some() {
        return Err(format!(
            "expected {expected}, with no query or fragment (credentials come from the environment)"
        ));
    }
    let host = parsed.host_str().unwrap_or("");
    if let Kind::Folder = kind {
        if !host.is_empty() {
            return Err(format!("{url:?}: expected {expected}"));
        }
        return Ok((kind, parsed, Path::default()));
    }
    if host.is_empty() {
        return Err(format!("{url:?}: expected {expected}"));
    }
    let prefix = Path::parse(parsed.path().trim_matches('/'))
        .map_err(|e| format!("{url:?}: the prefix is not a valid object path: {e}"))?;
    Ok((kind, parsed, prefix))
}

impl ObjectStoreRemote {
    /// The store at `url` (see the crate's documentation for the schemes and settings).
    /// `timeout`: for connecting, and for each request with its retries. Errors name what
    /// is wrong with the URL or the settings.
    pub fn open(url: &str, timeout: Duration) -> Result<ObjectStoreRemote, String> {
        let (kind, parsed, prefix) = parse(url)?;
        // Set key by key: the builders' client options also hold what the environment set
        // (`AWS_ALLOW_HTTP`, a proxy), which replacing the options would drop. The client's
        // own limits are a backstop at twice ours: `run` bounds each call by the timeout.
        let millis = format!("{}ms", (timeout * 2).as_millis().max(1));
        let client = [
            (ClientConfigKey::Timeout, millis.as_str()),
            (ClientConfigKey::ConnectTimeout, millis.as_str()),
            (
                ClientConfigKey::UserAgent,
                concat!("ori/", env!("CARGO_PKG_VERSION")),
            ),
        ];
        // A few quick retries for the throttling answers clouds give under load, all within
        // the timeout, so a server that is gone costs one timeout, not minutes of backoff.
        let retry = RetryConfig {
            max_retries: 3,
            retry_timeout: timeout,
            ..RetryConfig::default()
        };
        let store: Box<dyn ObjectStore> = match kind {
            Kind::S3 => {
                let builder = client.iter().fold(
                    aws_profile::with_profile_credentials(
                        object_store::aws::AmazonS3Builder::from_env(),
                    )?,
                    |b, (key, value)| b.with_config(AmazonS3ConfigKey::Client(*key), *value),
                );
                let builder = builder.with_url(url).with_retry(retry);
                let allow_http = AmazonS3ConfigKey::Client(ClientConfigKey::AllowHttp);
                let truthy = |v: &str| {
                    ["1", "true", "on", "yes", "y"].contains(&v.to_ascii_lowercase().as_str())
                };
                if builder
                    .get_config_value(&AmazonS3ConfigKey::Endpoint)
                    .is_some_and(|e| e.starts_with("http://"))
                    && !builder
                        .get_config_value(&allow_http)
                        .is_some_and(|v| truthy(&v))
                {
                    return Err(
                        "the endpoint (AWS_ENDPOINT_URL) is plain http: set AWS_ALLOW_HTTP=true to allow it"
                            .to_string(),
                    );
                }
                Box::new(builder.build().map_err(|e| settings(url, e))?)
            }
            Kind::Gcs => {
                let builder = client.iter().fold(
                    object_store::gcp::GoogleCloudStorageBuilder::from_env(),
                    |b, (key, value)| b.with_config(GoogleConfigKey::Client(*key), *value),
                );
                let builder = builder.with_url(url).with_retry(retry);
                Box::new(builder.build().map_err(|e| settings(url, e))?)
            }
            Kind::Azure => {
                let builder = client.iter().fold(
                    object_store::azure::MicrosoftAzureBuilder::from_env(),
                    |b, (key, value)| b.with_config(AzureConfigKey::Client(*key), *value),
                );
                let builder = builder.with_url(url).with_retry(retry);
                Box::new(builder.build().map_err(|e| settings(url, e))?)
            }
            Kind::Folder => {
                let folder = parsed
                    .to_file_path()
                    .map_err(|()| format!("{url:?}: expected file:///absolute/path"))?;
                // Never created here: a missing mount must not become a folder on the local
                // disk. Uploads create the folders below it.
                if !folder.is_dir() {
                    return Err(format!(
                        "{url:?}: {} is not a folder (create it, or mount the shared one)",
                        folder.display()
                    ));
                }
                let store = object_store::local::LocalFileSystem::new_with_prefix(&folder)
                    .map_err(|e| settings(url, e))?;
                Box::new(store)
            }
        };
        let root = match parsed.host_str() {
            Some(host) if !host.is_empty() => format!("{}://{host}", parsed.scheme()),
            _ => url.trim_end_matches('/').to_string(),
        };
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("ori-object-store")
            .enable_all()
            .build()
            .map_err(|e| format!("cannot start the object store's runtime: {e}"))?;
        Ok(ObjectStoreRemote {
            store,
            prefix,
            url: url.to_string(),
            root,
            kind,
            timeout,
            runtime: Some(runtime),
        })
    }

    fn location(&self, ns: Namespace, hash: &ContentHash) -> Path {
        self.prefix
            .child(ns.segment())
            .child(hash.to_hex().as_str())
    }

    /// Run one request, retries included, to its end within the timeout.
    fn run<T>(
        &self,
        request: Request,
        location: &Path,
        work: impl Future<Output = Result<T, object_store::Error>>,
    ) -> Result<T, Failure> {
        let runtime = self.runtime.as_ref().expect("taken only on drop");
        match runtime.block_on(async { tokio::time::timeout(self.timeout, work).await }) {
            Ok(Ok(value)) => Ok(value),
            // A store without the bucket answers "not found" for every object in it.
            Ok(Err(e @ object_store::Error::NotFound { .. }))
                if e.to_string().contains("NoSuchBucket") =>
            {
                Err(Failure::Error(RemoteError::Unavailable(format!(
                    "{request} {}: no such bucket",
                    self.describe_location(location)
                ))))
            }
            Ok(Err(object_store::Error::NotFound { .. })) => Err(Failure::NotFound),
            Ok(Err(e)) => Err(Failure::Error(self.describe_error(request, location, e))),
            Err(_) => Err(Failure::Error(RemoteError::Unavailable(format!(
                "{request} {}: no answer within {} s",
                self.describe_location(location),
                self.timeout.as_secs_f64()
            )))),
        }
    }

    fn describe_location(&self, location: &Path) -> String {
        format!("{}/{location}", self.root)
    }

    fn describe_error(
        &self,
        request: Request,
        location: &Path,
        e: object_store::Error,
    ) -> RemoteError {
        let at = format!("{request} {}", self.describe_location(location));
        match e {
            object_store::Error::Unauthenticated { .. }
            | object_store::Error::PermissionDenied { .. } => {
                let hint = match self.kind {
                    Kind::S3 => {
                        " (check AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY and the bucket's policy)"
                    }
                    Kind::Gcs => " (check GOOGLE_SERVICE_ACCOUNT or the machine's account)",
                    Kind::Azure => " (check AZURE_STORAGE_ACCOUNT_NAME and its key or token)",
                    Kind::Folder => " (check the folder's permissions)",
                };
                let message = format!(
                    "{at}: the store refused our credentials{hint}: {}",
                    one_line(&e)
                );
                // Refused downloads make the store useless for this build; a refused upload
                // leaves downloads working (a read-only key on a read-write builder).
                if request == Request::Put {
                    RemoteError::Rejected(message)
                } else {
                    RemoteError::Unavailable(message)
                }
            }
            // An upload the store declines (a condition, a name taken) leaves downloads working.
            e @ (object_store::Error::Precondition { .. }
            | object_store::Error::AlreadyExists { .. })
                if request == Request::Put =>
            {
                RemoteError::Rejected(format!("{at}: {}", one_line(&e)))
            }
            e => RemoteError::Unavailable(format!("{at}: {}", one_line(&e))),
        }
    }
}

/// The error on one short line. A server's error body (XML, which may quote the request's
/// signing details) is cut to its `<Code>`.
fn one_line(e: &object_store::Error) -> String {
    let text = e.to_string();
    let (head, code) = match text.find('<') {
        Some(i) => {
            let code = text[i..]
                .split_once("<Code>")
                .and_then(|(_, rest)| rest.split_once("</Code>"))
                .filter(|(code, _)| code.len() <= 64)
                .map(|(code, _)| format!(" ({code})"))
                .unwrap_or_default();
            (&text[..i], code)
        }
        None => (text.as_str(), String::new()),
    };
    let mut head: String = head.split_whitespace().collect::<Vec<_>>().join(" ");
    if head.len() > MAX_MESSAGE {
        let cut = (0..=MAX_MESSAGE)
            .rev()
            .find(|&i| head.is_char_boundary(i))
            .unwrap_or(0);
        head.truncate(cut);
        head.push_str("...");
    }
    format!("{}{code}", head.trim_end_matches(':'))
}

/// The requests of the protocol, for messages.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Request {
    Get,
    Head,
    Put,
}

impl std::fmt::Display for Request {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Request::Get => "GET",
            Request::Head => "HEAD",
            Request::Put => "PUT",
        })
    }
}

/// A builder's error, naming the URL it was given (checked to hold no credentials).
fn settings(url: &str, e: object_store::Error) -> String {
    format!("{url:?}: {}", one_line(&e))
}

/// How one request ended, other than with what was asked for.
enum Failure {
    NotFound,
    Error(RemoteError),
}

impl RemoteStore for ObjectStoreRemote {
    fn describe(&self) -> String {
        self.url.clone()
    }

    fn get(
        &self,
        ns: Namespace,
        hash: &ContentHash,
        limit: u64,
    ) -> Result<Option<Vec<u8>>, RemoteError> {
        let location = self.location(ns, hash);
        let read = async {
            let result = self.store.get(&location).await?;
            if result.meta.size > limit {
                return Ok(Err(RemoteError::longer_than(limit)));
            }
            // Read as it streams, never more than the limit, whatever the store claimed.
            let mut bytes = Vec::with_capacity(result.meta.size.min(MAX_RESERVE) as usize);
            let mut stream = result.into_stream();
            while let Some(chunk) = stream.next().await {
                let chunk = chunk?;
                if (bytes.len() + chunk.len()) as u64 > limit {
                    return Ok(Err(RemoteError::longer_than(limit)));
                }
                bytes.extend_from_slice(&chunk);
            }
            Ok(Ok(bytes))
        };
        match self.run(Request::Get, &location, read) {
            Ok(Ok(bytes)) => Ok(Some(bytes)),
            Ok(Err(invalid)) => Err(invalid),
            Err(Failure::NotFound) => Ok(None),
            Err(Failure::Error(e)) => Err(e),
        }
    }

    fn contains(&self, ns: Namespace, hash: &ContentHash) -> Result<bool, RemoteError> {
        let location = self.location(ns, hash);
        match self.run(Request::Head, &location, self.store.head(&location)) {
            Ok(_) => Ok(true),
            Err(Failure::NotFound) => Ok(false),
            Err(Failure::Error(e)) => Err(e),
        }
    }

    fn put(&self, ns: Namespace, hash: &ContentHash, bytes: &[u8]) -> Result<(), RemoteError> {
        let location = self.location(ns, hash);
        let payload = PutPayload::from(bytes.to_vec());
        match self.run(Request::Put, &location, self.store.put(&location, payload)) {
            Ok(_) => Ok(()),
            // A store that says "not found" to an upload has no such bucket.
            Err(Failure::NotFound) => Err(RemoteError::Unavailable(format!(
                "PUT {}: no such bucket or container",
                self.describe_location(&location)
            ))),
            Err(Failure::Error(e)) => Err(e),
        }
    }
}

impl Drop for ObjectStoreRemote {
    fn drop(&mut self) {
        // Blocking file work stuck on a hung mount must not hang the build's end.
        if let Some(runtime) = self.runtime.take() {
            runtime.shutdown_background();
        }
    }
}
