//! A throw-away nginx WebDAV server on 127.0.0.1, serving the remote-cache protocol from a
//! temporary folder: for `cargo xtask bench remote` and the remote-cache tests (which include
//! this file). It runs as the current user, with its configuration, pid, logs and temporary
//! files all in its own folder, in the foreground (`master_process off`), so killing the
//! child stops it. Needs Debian's `nginx-light` (or any nginx with the DAV module).

use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A running nginx; stopped when dropped.
pub struct Nginx {
    child: Option<Child>,
    port: u16,
    dir: tempfile::TempDir,
}

/// The nginx binary: on `PATH`, or where Debian puts it.
fn binary() -> Result<PathBuf, String> {
    let on_path: Vec<PathBuf> = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).map(|d| d.join("nginx")).collect())
        .unwrap_or_default();
    on_path
        .into_iter()
        .chain([PathBuf::from("/usr/sbin/nginx")])
        .find(|p| p.is_file())
        .ok_or_else(|| {
            "nginx is not installed; install it with `apt-get install -y nginx-light` \
             (.ci/run does)"
                .to_string()
        })
}

/// nginx only switches users when started as root; then it must stay root to write our
/// temporary folder.
fn user_line(dir: &Path) -> String {
    use std::os::unix::fs::MetadataExt;
    match std::fs::metadata(dir) {
        Ok(m) if m.uid() == 0 => "user root;\n".into(),
        _ => String::new(),
    }
}

fn config(dir: &Path, port: u16) -> String {
    let d = dir.display();
    format!(
        "{user}daemon off;\nmaster_process off;\npid {d}/nginx.pid;\nerror_log {d}/error.log;\n\
         events {{ worker_connections 256; }}\n\
         http {{\n  access_log {d}/access.log;\n  client_body_temp_path {d}/tmp/body;\n\
         proxy_temp_path {d}/tmp/proxy;\n  fastcgi_temp_path {d}/tmp/fastcgi;\n\
         uwsgi_temp_path {d}/tmp/uwsgi;\n  scgi_temp_path {d}/tmp/scgi;\n\
         client_max_body_size 0;\n  keepalive_requests 100000;\n\
         server {{\n    listen 127.0.0.1:{port};\n    root {d}/root;\n\
         location / {{\n      dav_methods PUT;\n      create_full_put_path on;\n\
         dav_access user:rw;\n    }}\n  }}\n}}\n",
        user = user_line(dir),
    )
}

/// A port nobody listens on right now.
fn free_port() -> Result<u16, String> {
    let listener = TcpListener::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
    Ok(listener.local_addr().map_err(|e| e.to_string())?.port())
}

impl Nginx {
    /// Start a server on a free port and wait until it accepts connections.
    pub fn start() -> Result<Nginx, String> {
        let nginx = binary()?;
        let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
        for sub in ["root", "tmp"] {
            std::fs::create_dir_all(dir.path().join(sub)).map_err(|e| e.to_string())?;
        }
        let mut last_error = String::new();
        // Another process may take the free port before nginx binds it: try a few.
        for _ in 0..5 {
            let port = free_port()?;
            let conf = dir.path().join("nginx.conf");
            std::fs::write(&conf, config(dir.path(), port)).map_err(|e| e.to_string())?;
            let mut child = Command::new(&nginx)
                .arg("-e")
                .arg(dir.path().join("error.log"))
                .arg("-p")
                .arg(dir.path())
                .arg("-c")
                .arg(&conf)
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .map_err(|e| format!("cannot start {}: {e}", nginx.display()))?;
            let deadline = Instant::now() + Duration::from_secs(10);
            while Instant::now() < deadline {
                if let Ok(Some(status)) = child.try_wait() {
                    last_error = format!(
                        "nginx exited ({status}): {}",
                        std::fs::read_to_string(dir.path().join("error.log")).unwrap_or_default()
                    );
                    break;
                }
                if TcpStream::connect(("127.0.0.1", port)).is_ok() {
                    return Ok(Nginx {
                        child: Some(child),
                        port,
                        dir,
                    });
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = child.kill();
            let _ = child.wait();
            if last_error.is_empty() {
                last_error = "nginx did not start listening within 10 s".into();
            }
        }
        Err(last_error)
    }

    /// The URL of `base` on this server: `http://127.0.0.1:PORT/base`.
    pub fn url(&self, base: &str) -> String {
        format!("http://127.0.0.1:{}/{base}", self.port)
    }

    /// The folder the server stores `PUT` files in (`<root>/<base>/cas/<hash>`).
    pub fn root(&self) -> PathBuf {
        self.dir.path().join("root")
    }

    /// The access log (one line per request).
    pub fn access_log(&self) -> String {
        std::fs::read_to_string(self.dir.path().join("access.log")).unwrap_or_default()
    }

    /// Stop the server (its files stay until it is dropped).
    pub fn stop(&mut self) {
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

impl Drop for Nginx {
    fn drop(&mut self) {
        self.stop();
    }
}
