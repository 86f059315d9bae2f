//! The remote-cache protocol over plain HTTP/1.1 (no TLS): `GET`, `PUT` and `HEAD` of
//! `{base}/cas/{hash}` for blobs and `{base}/ac/{key}` for action entries, as Bazel's HTTP
//! cache clients speak and bazel-remote or an nginx WebDAV location serve.
//!
//! Only transport lives here; what is fetched is verified by `ori_graph::RemoteCache`.

use std::time::Duration;

use ori_graph::{ContentHash, Namespace, RemoteError, RemoteStore};

/// The remote-cache protocol over plain HTTP/1.1 (no TLS), with one connection pool.
pub struct HttpStore {
    agent: ureq::Agent,
    base: String,
    authorization: Option<String>,
    timeout: Duration,
}

impl HttpStore {
    /// A store at `base` (`http://host[:port][/path]`, no trailing slash needed). `token`:
    /// sent as `Authorization: Bearer <token>`. `timeout`: for connecting, and for each whole
    /// request.
    pub fn new(base: &str, token: Option<&str>, timeout: Duration) -> HttpStore {
        let config = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_connect(Some(timeout))
            .timeout_global(Some(timeout))
            // Deterministic routing: a cache on the farm's network, never through a proxy
            // taken from the environment.
            .proxy(None)
            .max_idle_connections_per_host(32)
            .user_agent(concat!("ori/", env!("CARGO_PKG_VERSION")))
            .build();
        HttpStore {
            agent: config.into(),
            base: base.trim_end_matches('/').to_string(),
            authorization: token.map(|t| format!("Bearer {t}")),
            timeout,
        }
    }

    fn url(&self, ns: Namespace, hash: &ContentHash) -> String {
        format!("{}/{}/{}", self.base, ns.segment(), hash.to_hex())
    }

    fn with_auth<B>(&self, request: ureq::RequestBuilder<B>) -> ureq::RequestBuilder<B> {
        match &self.authorization {
            Some(a) => request.header("Authorization", a),
            None => request,
        }
    }

    /// A transport error: the server cannot be used.
    fn transport(&self, url: &str, e: ureq::Error) -> RemoteError {
        match e {
            ureq::Error::Timeout(_) => RemoteError::Unavailable(format!(
                "{url}: no answer within {} s",
                self.timeout.as_secs_f64()
            )),
            e => RemoteError::Unavailable(format!("{url}: {e}")),
        }
    }
}

/// Read a short response body to its end, so the connection goes back to the pool.
fn drain(response: &mut ureq::http::Response<ureq::Body>) {
    let _ = response
        .body_mut()
        .with_config()
        .limit(1 << 16)
        .read_to_vec();
}

impl RemoteStore for HttpStore {
    fn describe(&self) -> String {
        self.base.clone()
    }

    fn get(
        &self,
        ns: Namespace,
        hash: &ContentHash,
        limit: u64,
    ) -> Result<Option<Vec<u8>>, RemoteError> {
        let url = self.url(ns, hash);
        let mut response = self
            .with_auth(self.agent.get(&url))
            .call()
            .map_err(|e| self.transport(&url, e))?;
        match response.status().as_u16() {
            200 => {}
            404 => {
                drain(&mut response);
                return Ok(None);
            }
            status => {
                return Err(RemoteError::Unavailable(format!(
                    "GET {url}: HTTP {status}"
                )));
            }
        }
        match response
            .body_mut()
            .with_config()
            .limit(limit.saturating_add(1))
            .read_to_vec()
        {
            Ok(bytes) if bytes.len() as u64 > limit => Err(RemoteError::longer_than(limit)),
            Ok(bytes) => Ok(Some(bytes)),
            Err(ureq::Error::BodyExceedsLimit(_)) => Err(RemoteError::longer_than(limit)),
            Err(e) => Err(self.transport(&url, e)),
        }
    }

    fn contains(&self, ns: Namespace, hash: &ContentHash) -> Result<bool, RemoteError> {
        let url = self.url(ns, hash);
        let response = self
            .with_auth(self.agent.head(&url))
            .call()
            .map_err(|e| self.transport(&url, e))?;
        match response.status().as_u16() {
            200 => Ok(true),
            404 => Ok(false),
            status => Err(RemoteError::Unavailable(format!(
                "HEAD {url}: HTTP {status}"
            ))),
        }
    }

    fn put(&self, ns: Namespace, hash: &ContentHash, bytes: &[u8]) -> Result<(), RemoteError> {
        let url = self.url(ns, hash);
        let mut response = self
            .with_auth(self.agent.put(&url))
            .send(bytes)
            .map_err(|e| self.transport(&url, e))?;
        drain(&mut response);
        match response.status().as_u16() {
            200..=299 => Ok(()),
            status @ 500.. => Err(RemoteError::Unavailable(format!(
                "PUT {url}: HTTP {status}"
            ))),
            status => Err(RemoteError::Rejected(format!("PUT {url}: HTTP {status}"))),
        }
    }
}
