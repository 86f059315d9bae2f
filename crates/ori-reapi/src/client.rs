//! A blocking REAPI client: content-addressable storage (find, batch and ByteStream up and
//! down, every download checked against its digest), the action cache and `Execute`. Each
//! call blocks on a small tokio runtime of its own, so the build graph stays synchronous.

use std::collections::HashMap;
use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use bazel_remote_apis::build::bazel::remote::execution::v2::{
    ActionResult, BatchReadBlobsRequest, BatchUpdateBlobsRequest, Digest, ExecuteRequest,
    ExecuteResponse, FindMissingBlobsRequest, GetActionResultRequest, GetCapabilitiesRequest,
    ServerCapabilities, WaitExecutionRequest, action_cache_client::ActionCacheClient,
    batch_update_blobs_request, capabilities_client::CapabilitiesClient,
    content_addressable_storage_client::ContentAddressableStorageClient,
    execution_client::ExecutionClient,
};
use bazel_remote_apis::google::bytestream::{
    ReadRequest, WriteRequest, byte_stream_client::ByteStreamClient,
};
use bazel_remote_apis::google::longrunning::{Operation, operation};
use prost::Message;
use sha2::{Digest as _, Sha256};
use tonic::transport::{Channel, Endpoint};
use tonic::{Code, Status};

/// The sha256 digest of `bytes`, as the REAPI names blobs.
pub fn digest_of(bytes: &[u8]) -> Digest {
    let hash = Sha256::digest(bytes);
    Digest {
        hash: hash.iter().map(|b| format!("{b:02x}")).collect(),
        size_bytes: bytes.len() as i64,
    }
}

/// Why a call gave nothing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Error {
    /// The server cannot be reached or refuses us (down, overloaded, no permission, too slow).
    Unavailable(String),
    /// This request failed (a missing blob, an invalid answer, a failed action).
    Failed(String),
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Unavailable(why) | Error::Failed(why) => f.write_str(why),
        }
    }
}

impl From<Status> for Error {
    fn from(status: Status) -> Error {
        let mut what = format!("{:?}: {}", status.code(), status.message());
        // A transport failure says what failed only in its sources (connection refused, ...).
        let mut source = std::error::Error::source(&status);
        while let Some(cause) = source {
            what.push_str(&format!(": {cause}"));
            source = cause.source();
        }
        match status.code() {
            Code::Unavailable
            | Code::Unauthenticated
            | Code::PermissionDenied
            | Code::Unimplemented
            | Code::DeadlineExceeded
            | Code::Cancelled
            | Code::Unknown => Error::Unavailable(what),
            _ => Error::Failed(what),
        }
    }
}

/// Whether a blob of `size` bytes fits a batch of `limit` bytes with its framing.
fn fits(size: u64, limit: u64) -> bool {
    size.saturating_add(ENTRY_OVERHEAD) <= limit
}

/// The indices of blobs of `sizes`, in order, grouped into batches whose sizes (each with its
/// framing) add up to at most `limit`; a blob too large for that is a batch of its own.
pub(crate) fn batches(sizes: &[u64], limit: u64) -> Vec<Vec<usize>> {
    let mut batches: Vec<Vec<usize>> = Vec::new();
    let mut batch_bytes = 0u64;
    for (k, &size) in sizes.iter().enumerate() {
        let framed = size.saturating_add(ENTRY_OVERHEAD);
        match batches.last_mut() {
            Some(batch) if batch_bytes.saturating_add(framed) <= limit && fits(size, limit) => {
                batch.push(k);
                batch_bytes += framed;
            }
            _ => {
                batches.push(vec![k]);
                batch_bytes = framed;
            }
        }
    }
    batches
}

/// Where the server is and how to talk to it.
#[derive(Clone, Debug)]
pub struct Settings {
    /// `grpc://host:port` (plain HTTP/2).
    pub url: String,
    pub instance_name: String,
    /// Sent as `authorization: Bearer TOKEN` when set.
    pub token: Option<String>,
    /// The longest one request may take (an `Execute` waits for its action instead).
    pub timeout: Duration,
}

/// A connection to one REAPI server (a cheap handle: calls share the channel).
pub struct Client {
    runtime: Option<tokio::runtime::Runtime>,
    channel: Channel,
    settings: Settings,
    /// The server's cap on one batch call, learnt from its capabilities.
    batch_limit: AtomicU64,
}

/// The longest a connection may take to open.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(10);
/// How often a quiet connection is checked, and how long the check may take.
const KEEPALIVE: Duration = Duration::from_secs(10);
/// What one entry of a batch call takes besides its bytes (its digest and framing).
const ENTRY_OVERHEAD: u64 = 128;
/// Digests asked about in one FindMissingBlobs call.
const FIND_CHUNK: usize = 4096;
/// What batch calls carry at most when the server states no cap (its capabilities say 0).
const DEFAULT_BATCH_LIMIT: u64 = 4 << 20;
/// The bytes of one ByteStream write or read message.
const CHUNK: usize = 1 << 20;
/// What a batch call's framing and digests take besides the blobs' bytes.
const BATCH_OVERHEAD: u64 = 64 << 10;

impl Client {
    pub fn connect(settings: Settings) -> Result<Client, Error> {
        let address = settings
            .url
            .strip_prefix("grpc://")
            .ok_or_else(|| {
                Error::Failed(format!("{}: the URL must start with grpc://", settings.url))
            })?
            .trim_end_matches('/');
        let endpoint = Endpoint::from_shared(format!("http://{address}"))
            .map_err(|e| Error::Failed(format!("{}: {e}", settings.url)))?
            .connect_timeout(settings.timeout.min(CONNECT_TIMEOUT))
            // A farm that stops answering (a dropped link, not a refused one) is found out in
            // seconds, not at the end of a job's whole wait.
            .http2_keep_alive_interval(KEEPALIVE)
            .keep_alive_timeout(KEEPALIVE)
            .keep_alive_while_idle(true)
            .tcp_nodelay(true);
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("ori-reapi")
            .enable_all()
            .build()
            .map_err(|e| Error::Failed(format!("cannot start the REAPI client's runtime: {e}")))?;
        let channel = {
            let _entered = runtime.enter();
            endpoint.connect_lazy()
        };
        Ok(Client {
            runtime: Some(runtime),
            channel,
            settings,
            batch_limit: AtomicU64::new(0),
        })
    }

    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Run `work` within the request timeout (a server that does not answer in time is
    /// unavailable).
    pub(crate) fn call<T>(&self, work: impl Future<Output = Result<T, Error>>) -> Result<T, Error> {
        self.wait(self.settings.timeout, work)
            .unwrap_or_else(|limit| Err(Error::Unavailable(format!("no answer within {limit} s"))))
    }

    /// Run `work`; `Err` with the limit in seconds when it took longer.
    fn wait<T>(
        &self,
        limit: Duration,
        work: impl Future<Output = Result<T, Error>>,
    ) -> Result<Result<T, Error>, f64> {
        let runtime = self.runtime.as_ref().expect("taken only on drop");
        runtime
            .block_on(async { tokio::time::timeout(limit, work).await })
            .map_err(|_| limit.as_secs_f64())
    }

    pub(crate) fn channel(&self) -> Channel {
        self.channel.clone()
    }

    pub(crate) fn request<T>(&self, message: T) -> tonic::Request<T> {
        let mut request = tonic::Request::new(message);
        if let Some(token) = &self.settings.token
            && let Ok(value) = format!("Bearer {token}").parse()
        {
            request.metadata_mut().insert("authorization", value);
        }
        request
    }

    fn instance(&self) -> String {
        self.settings.instance_name.clone()
    }

    /// A ByteStream resource name under the instance.
    fn resource(&self, tail: String) -> String {
        match self.settings.instance_name.as_str() {
            "" => tail,
            instance => format!("{instance}/{tail}"),
        }
    }

    pub fn capabilities(&self) -> Result<ServerCapabilities, Error> {
        self.call(async {
            let mut client = CapabilitiesClient::new(self.channel.clone());
            let request = self.request(GetCapabilitiesRequest {
                instance_name: self.instance(),
            });
            Ok(client.get_capabilities(request).await?.into_inner())
        })
    }

    fn batch_limit(&self) -> u64 {
        match self.batch_limit.load(Ordering::Relaxed) {
            0 => {
                let stated = self
                    .capabilities()
                    .ok()
                    .and_then(|c| c.cache_capabilities)
                    .map_or(0, |c| c.max_batch_total_size_bytes.max(0) as u64);
                let limit = match stated {
                    0 => DEFAULT_BATCH_LIMIT,
                    n => n.min(DEFAULT_BATCH_LIMIT),
                };
                self.batch_limit.store(limit, Ordering::Relaxed);
                limit
            }
            limit => limit,
        }
    }

    /// The digests of `digests` the server lacks.
    pub fn find_missing(&self, digests: &[Digest]) -> Result<Vec<Digest>, Error> {
        let mut missing = Vec::new();
        for chunk in digests.chunks(FIND_CHUNK) {
            missing.extend(self.find_missing_few(chunk)?);
        }
        Ok(missing)
    }

    fn find_missing_few(&self, digests: &[Digest]) -> Result<Vec<Digest>, Error> {
        self.call(async {
            let mut client = ContentAddressableStorageClient::new(self.channel.clone());
            let request = self.request(FindMissingBlobsRequest {
                instance_name: self.instance(),
                blob_digests: digests.to_vec(),
                digest_function: 0,
            });
            Ok(client
                .find_missing_blobs(request)
                .await?
                .into_inner()
                .missing_blob_digests)
        })
    }

    /// Store the blobs the server lacks (small ones in batches, large ones by ByteStream).
    pub fn upload_missing(&self, blobs: &[(Digest, &[u8])]) -> Result<(), Error> {
        let digests: Vec<Digest> = blobs.iter().map(|(d, _)| d.clone()).collect();
        let missing = self.find_missing(&digests)?;
        let wanted: Vec<(Digest, &[u8])> = blobs
            .iter()
            .filter(|(d, _)| missing.contains(d))
            .cloned()
            .collect();
        self.upload(&wanted)
    }

    /// Store these blobs, whether or not the server has them.
    pub fn upload(&self, blobs: &[(Digest, &[u8])]) -> Result<(), Error> {
        let limit = self.batch_limit().saturating_sub(BATCH_OVERHEAD);
        let sizes: Vec<u64> = blobs.iter().map(|(_, b)| b.len() as u64).collect();
        for batch in batches(&sizes, limit) {
            match batch[..] {
                [k] if !fits(sizes[k], limit) => self.write(&blobs[k].0, blobs[k].1)?,
                _ => self.batch_upload(&batch.iter().map(|&k| &blobs[k]).collect::<Vec<_>>())?,
            }
        }
        Ok(())
    }

    fn batch_upload(&self, blobs: &[&(Digest, &[u8])]) -> Result<(), Error> {
        let responses = self.call(async {
            let mut client = ContentAddressableStorageClient::new(self.channel.clone());
            let request = self.request(BatchUpdateBlobsRequest {
                instance_name: self.instance(),
                requests: blobs
                    .iter()
                    .map(|(digest, bytes)| batch_update_blobs_request::Request {
                        digest: Some(digest.clone()),
                        data: bytes.to_vec(),
                        compressor: 0,
                    })
                    .collect(),
                digest_function: 0,
            });
            Ok(client.batch_update_blobs(request).await?.into_inner())
        })?;
        for response in responses.responses {
            if let Some(status) = response.status.filter(|s| s.code != 0) {
                return Err(Error::Failed(format!(
                    "upload of blob {} refused: {}",
                    response.digest.map(|d| d.hash).unwrap_or_default(),
                    status.message
                )));
            }
        }
        Ok(())
    }

    /// Store one blob by ByteStream, in chunks.
    fn write(&self, digest: &Digest, bytes: &[u8]) -> Result<(), Error> {
        let upload = format!(
            "uploads/{}/blobs/{}/{}",
            upload_id(digest),
            digest.hash,
            digest.size_bytes
        );
        let name = self.resource(upload);
        let chunks: Vec<WriteRequest> = bytes
            .chunks(CHUNK)
            .chain(bytes.is_empty().then_some(&[][..]))
            .enumerate()
            .map(|(k, chunk)| WriteRequest {
                resource_name: if k == 0 { name.clone() } else { String::new() },
                write_offset: (k * CHUNK) as i64,
                finish_write: (k + 1) * CHUNK >= bytes.len(),
                data: chunk.to_vec(),
            })
            .collect();
        let committed = self.call(async {
            let mut client = ByteStreamClient::new(self.channel.clone());
            let stream = futures::stream::iter(chunks);
            Ok(client
                .write(self.request(stream))
                .await?
                .into_inner()
                .committed_size)
        })?;
        if committed != digest.size_bytes {
            return Err(Error::Failed(format!(
                "upload of blob {}: the server committed {committed} of {} bytes",
                digest.hash, digest.size_bytes
            )));
        }
        Ok(())
    }

    /// The blob's bytes, checked against its digest; `limit`: the most bytes accepted.
    pub fn download(&self, digest: &Digest, limit: u64) -> Result<Vec<u8>, Error> {
        let mut bytes = self.download_many(std::slice::from_ref(digest), limit)?;
        Ok(bytes.pop().expect("one blob asked for"))
    }

    /// The bytes of each blob, in order, each checked against its digest; `limit`: the most
    /// bytes accepted of one. Small blobs come in as few batches as the server's limit
    /// allows (one request for a job's few outputs), large ones by ByteStream.
    pub fn download_many(&self, digests: &[Digest], limit: u64) -> Result<Vec<Vec<u8>>, Error> {
        let batch_limit = self.batch_limit().saturating_sub(BATCH_OVERHEAD);
        let mut sizes = Vec::with_capacity(digests.len());
        for digest in digests {
            let size = u64::try_from(digest.size_bytes)
                .map_err(|_| Error::Failed(format!("blob {}: negative size", digest.hash)))?;
            if size > limit {
                return Err(Error::Failed(format!(
                    "blob {}: {size} bytes, more than the {limit} accepted",
                    digest.hash
                )));
            }
            sizes.push(size);
        }
        let mut blobs: Vec<Option<Vec<u8>>> = vec![None; digests.len()];
        for batch in batches(&sizes, batch_limit) {
            match batch[..] {
                [k] if !fits(sizes[k], batch_limit) => {
                    blobs[k] = Some(self.read(&digests[k], sizes[k])?);
                }
                _ => self.batch_read(digests, &batch, &mut blobs)?,
            }
        }
        digests
            .iter()
            .zip(blobs)
            .map(|(digest, bytes)| {
                let bytes = bytes.expect("every blob read");
                match digest_of(&bytes) == *digest {
                    true => Ok(bytes),
                    false => Err(Error::Failed(format!(
                        "blob {}: the server's bytes do not match its digest",
                        digest.hash
                    ))),
                }
            })
            .collect()
    }

    /// Read the blobs `digests[k]` for each `k` of `batch` into `blobs[k]`, in one request.
    fn batch_read(
        &self,
        digests: &[Digest],
        batch: &[usize],
        blobs: &mut [Option<Vec<u8>>],
    ) -> Result<(), Error> {
        let responses = self.call(async {
            let mut client = ContentAddressableStorageClient::new(self.channel.clone());
            let request = self.request(BatchReadBlobsRequest {
                instance_name: self.instance(),
                digests: batch.iter().map(|&k| digests[k].clone()).collect(),
                acceptable_compressors: Vec::new(),
                digest_function: 0,
            });
            Ok(client.batch_read_blobs(request).await?.into_inner())
        })?;
        let key = |d: &Digest| (d.hash.clone(), d.size_bytes);
        let mut found: HashMap<(String, i64), Vec<u8>> = HashMap::new();
        for response in responses.responses {
            let Some(digest) = response.digest else {
                continue;
            };
            if let Some(status) = response.status.filter(|s| s.code != 0) {
                return Err(Error::Failed(format!(
                    "blob {}: {}",
                    digest.hash, status.message
                )));
            }
            found.insert(key(&digest), response.data);
        }
        for &k in batch {
            let bytes = found.get(&key(&digests[k])).ok_or_else(|| {
                Error::Failed(format!("blob {}: not in the answer", digests[k].hash))
            })?;
            blobs[k] = Some(bytes.clone());
        }
        Ok(())
    }

    fn read(&self, digest: &Digest, size: u64) -> Result<Vec<u8>, Error> {
        let name = self.resource(format!("blobs/{}/{}", digest.hash, digest.size_bytes));
        self.call(async {
            let mut client = ByteStreamClient::new(self.channel.clone());
            let request = self.request(ReadRequest {
                resource_name: name,
                read_offset: 0,
                read_limit: 0,
            });
            let mut stream = client.read(request).await?.into_inner();
            let mut bytes = Vec::with_capacity(size.min(64 << 20) as usize);
            while let Some(message) = stream.message().await? {
                if (bytes.len() + message.data.len()) as u64 > size {
                    return Err(Error::Failed(format!(
                        "blob {}: the server sent more than {size} bytes",
                        digest.hash
                    )));
                }
                bytes.extend_from_slice(&message.data);
            }
            Ok(bytes)
        })
    }

    /// The action cache's result for `action`, if any.
    pub fn cached_result(&self, action: &Digest) -> Result<Option<ActionResult>, Error> {
        self.call(async {
            let mut client = ActionCacheClient::new(self.channel.clone());
            let request = self.request(GetActionResultRequest {
                instance_name: self.instance(),
                action_digest: Some(action.clone()),
                inline_stdout: false,
                inline_stderr: false,
                inline_output_files: Vec::new(),
                digest_function: 0,
            });
            match client.get_action_result(request).await {
                Ok(response) => Ok(Some(response.into_inner())),
                Err(status) if status.code() == Code::NotFound => Ok(None),
                Err(status) => Err(status.into()),
            }
        })
    }

    /// Execute `action` (its command, input root and platform already stored) and wait up to
    /// `limit` for its response (longer is a failure of this action, not of the server); a
    /// dropped stream is resumed with `WaitExecution`.
    pub fn execute(&self, action: &Digest, limit: Duration) -> Result<ExecuteResponse, Error> {
        let waited = self.wait(limit, async {
            let mut client = ExecutionClient::new(self.channel.clone());
            let request = self.request(ExecuteRequest {
                instance_name: self.instance(),
                skip_cache_lookup: false,
                action_digest: Some(action.clone()),
                execution_policy: None,
                results_cache_policy: None,
                digest_function: 0,
                inline_stdout: false,
                inline_stderr: false,
                inline_output_files: Vec::new(),
            });
            let mut stream = client.execute(request).await?.into_inner();
            let mut name = String::new();
            loop {
                match stream.message().await {
                    Ok(Some(op)) => {
                        name.clone_from(&op.name);
                        if op.done {
                            return finished(op);
                        }
                    }
                    // The stream ended or broke before the operation finished: wait on it by name.
                    Ok(None) | Err(_) if !name.is_empty() => {
                        // Not at once: a server that ends every stream is not asked in a loop.
                        tokio::time::sleep(Duration::from_millis(200)).await;
                        let request = self.request(WaitExecutionRequest { name: name.clone() });
                        stream = client.wait_execution(request).await?.into_inner();
                    }
                    Ok(None) => {
                        return Err(Error::Unavailable(
                            "the server ended the execution stream before naming the operation"
                                .into(),
                        ));
                    }
                    Err(status) => return Err(status.into()),
                }
            }
        });
        waited.unwrap_or_else(|limit| Err(Error::Failed(format!("no result within {limit} s"))))
    }
}

impl Drop for Client {
    fn drop(&mut self) {
        // Dropping a runtime inside another one (a test's) panics; shutting it down does not.
        if let Some(runtime) = self.runtime.take() {
            runtime.shutdown_background();
        }
    }
}

/// The `ExecuteResponse` of a finished operation.
fn finished(op: Operation) -> Result<ExecuteResponse, Error> {
    match op.result {
        Some(operation::Result::Response(any)) => ExecuteResponse::decode(any.value.as_slice())
            .map_err(|e| {
                Error::Failed(format!(
                    "operation {}: not an ExecuteResponse: {e}",
                    op.name
                ))
            }),
        Some(operation::Result::Error(status)) => Err(Error::Failed(format!(
            "operation {}: {}",
            op.name, status.message
        ))),
        None => Err(Error::Failed(format!(
            "operation {} finished with no result",
            op.name
        ))),
    }
}

/// A fresh upload id (a name unique to this process's writes; ByteStream asks for a UUID, and
/// servers accept any unique string).
fn upload_id(digest: &Digest) -> String {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let seed = format!("{}-{}-{n}-{}", std::process::id(), digest.hash, now_nanos());
    let hash = Sha256::digest(seed.as_bytes());
    let hex: String = hash[..16].iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

fn now_nanos() -> u128 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blobs_are_batched_in_order_under_the_limit_and_large_ones_go_alone() {
        // Each blob counts its framing: two of 10 bytes fit 400, a third does not.
        let sizes = [10, 10, 10, 5000, 10];
        assert_eq!(
            batches(&sizes, 400),
            [vec![0, 1], vec![2], vec![3], vec![4]]
        );
        assert_eq!(batches(&sizes, 1 << 20), [vec![0, 1, 2, 3, 4]]);
        assert!(batches(&[], 400).is_empty());
    }
}
