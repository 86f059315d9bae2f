//! A throw-away BuildGrid farm on 127.0.0.1: PostgreSQL (its scheduler's database) and a
//! BuildGrid 0.4.4 server with a disk CAS, an action cache and the SQL scheduler, in a
//! temporary folder; and workers (`reapi-worker` of the binary given). For `cargo xtask bench
//! remote-exec` and `tests/remote_exec.rs` (which includes this file). Needs the Python
//! virtual environment `.ci/run` makes in `target/buildgrid-venv` (`ORI_BUILDGRID_VENV` names
//! another) and Debian's PostgreSQL server (`ORI_PG_BIN` names another folder of its
//! programs). Dropping it stops everything.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// How long the server may take to start.
const START_TIMEOUT: Duration = Duration::from_secs(120);

/// A running farm.
pub struct BuildGrid {
    dir: tempfile::TempDir,
    pg_bin: PathBuf,
    server: Option<Child>,
    workers: Vec<Child>,
    /// `grpc://127.0.0.1:PORT`.
    pub url: String,
    /// The bearer token the server wants (`start_with_token`), which its workers are given.
    pub token: Option<String>,
}

/// The variable a token-wanting farm's workers read their token from.
const TOKEN_VAR: &str = "ORI_FARM_TOKEN";

fn workspace() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

fn venv() -> Result<PathBuf, String> {
    let venv = std::env::var_os("ORI_BUILDGRID_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("target/buildgrid-venv"));
    if venv.join("bin/bgd").is_file() {
        return Ok(venv);
    }
    Err(format!(
        "no BuildGrid: {} is missing; make it with `python3 -m venv target/buildgrid-venv && \
         target/buildgrid-venv/bin/pip install buildgrid==0.4.4 psycopg2-binary` (.ci/run does)",
        venv.join("bin/bgd").display()
    ))
}

fn pg_bin() -> Result<PathBuf, String> {
    let dir = std::env::var_os("ORI_PG_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/lib/postgresql/15/bin"));
    if dir.join("initdb").is_file() {
        return Ok(dir);
    }
    Err(format!(
        "no PostgreSQL server: {} is missing; install Debian's `postgresql` (.ci/run does)",
        dir.join("initdb").display()
    ))
}

fn free_port() -> Result<u16, String> {
    let listener = TcpListener::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
    Ok(listener.local_addr().map_err(|e| e.to_string())?.port())
}

/// Run `program` as the `postgres` user (the server refuses to run as root).
fn as_postgres(program: &Path) -> Command {
    let mut command = Command::new("runuser");
    command.args(["-u", "postgres", "--"]).arg(program);
    command
}

fn run(command: &mut Command, what: &str) -> Result<(), String> {
    let output = command
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{what}: {e}"))?;
    if output.status.success() {
        return Ok(());
    }
    Err(format!(
        "{what} failed: {}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    ))
}

impl BuildGrid {
    pub fn start() -> Result<BuildGrid, String> {
        BuildGrid::start_as(None)
    }

    /// A farm whose every request must carry a bearer token: a JWT signed with a secret of
    /// its own (HS256, valid for a day; the server reads the secret from a file), in `token`.
    #[allow(dead_code)] // tests/remote_exec.rs
    pub fn start_with_token() -> Result<BuildGrid, String> {
        BuildGrid::start_as(Some("a secret of the test farm"))
    }

    fn start_as(jwt_secret: Option<&str>) -> Result<BuildGrid, String> {
        let (venv, pg_bin) = (venv()?, pg_bin()?);
        let dir = tempfile::Builder::new()
            .prefix("ori-buildgrid")
            .tempdir()
            .map_err(|e| e.to_string())?;
        let root = dir.path();
        let (pg_port, port) = (free_port()?, free_port()?);
        let data = root.join("pg");
        std::fs::create_dir_all(&data).map_err(|e| e.to_string())?;
        // The postgres user must reach its folder.
        run(
            Command::new("chmod").arg("755").arg(root),
            "chmod of the farm's folder",
        )?;
        run(
            Command::new("chown")
                .arg("-R")
                .arg("postgres:postgres")
                .arg(&data),
            "chown of the database folder",
        )?;
        run(
            as_postgres(&pg_bin.join("initdb"))
                .arg("-D")
                .arg(&data)
                .args(["-U", "postgres", "-A", "trust", "-E", "UTF8", "--no-sync"]),
            "initdb",
        )?;
        let settings = format!(
            "listen_addresses = '127.0.0.1'\nport = {pg_port}\nunix_socket_directories = '{}'\n\
             fsync = off\nsynchronous_commit = off\nfull_page_writes = off\nmax_connections = 200\n",
            data.display()
        );
        let conf = data.join("postgresql.conf");
        let mut text = std::fs::read_to_string(&conf).map_err(|e| e.to_string())?;
        text.push_str(&settings);
        std::fs::write(&conf, text).map_err(|e| e.to_string())?;
        let mut farm = BuildGrid {
            pg_bin: pg_bin.clone(),
            dir,
            server: None,
            workers: Vec::new(),
            url: format!("grpc://127.0.0.1:{port}"),
            token: None,
        };
        let root = farm.dir.path().to_path_buf();
        run(
            as_postgres(&pg_bin.join("pg_ctl"))
                .arg("-D")
                .arg(&data)
                .arg("-l")
                .arg(data.join("server.log"))
                .args(["-w", "-t", "60", "start"]),
            "pg_ctl start",
        )?;
        run(
            as_postgres(&pg_bin.join("psql")).args([
                "-h",
                "127.0.0.1",
                "-p",
                &pg_port.to_string(),
                "-U",
                "postgres",
                "-q",
                "-c",
                "CREATE ROLE bgd LOGIN PASSWORD 'bgd'",
                "-c",
                "CREATE DATABASE bgd OWNER bgd",
            ]),
            "creating the database",
        )?;
        let database = format!("postgresql+psycopg2://bgd:bgd@127.0.0.1:{pg_port}/bgd");
        run(
            Command::new(venv.join("bin/bgd")).args(["migrate", "apply", &database]),
            "bgd migrate apply",
        )?;
        let config = root.join("bgd.yml");
        let mut text = server_config(port, &database, &root.join("cas"));
        if let Some(secret) = jwt_secret {
            let open = "authorization:\n  method: none\n";
            let secret_file = root.join("jwt-secret");
            std::fs::write(&secret_file, secret).map_err(|e| e.to_string())?;
            let jwt = format!(
                "authorization:\n  method: jwt\n  algorithm: hs256\n  secret: \"{}\"\n",
                secret_file.display()
            );
            if !text.contains(open) {
                return Err(format!("tests/servers/buildgrid.yml has no `{open}`"));
            }
            text = text.replace(open, &jwt);
            let token = Command::new(venv.join("bin/python"))
                .args([
                    "-c",
                    "import jwt, sys, time; \
                     print(jwt.encode({'exp': int(time.time()) + 86400}, sys.argv[1], 'HS256'))",
                    secret,
                ])
                .output()
                .map_err(|e| format!("making a token: {e}"))?;
            if !token.status.success() {
                return Err(format!(
                    "making a token: {}",
                    String::from_utf8_lossy(&token.stderr)
                ));
            }
            farm.token = Some(String::from_utf8_lossy(&token.stdout).trim().to_string());
        }
        std::fs::write(&config, text).map_err(|e| e.to_string())?;
        std::fs::create_dir_all(root.join("cas")).map_err(|e| e.to_string())?;
        let log = std::fs::File::create(root.join("bgd.log")).map_err(|e| e.to_string())?;
        let server = Command::new(venv.join("bin/bgd"))
            .args(["server", "start"])
            .arg(&config)
            .stdin(Stdio::null())
            .stdout(log.try_clone().map_err(|e| e.to_string())?)
            .stderr(log)
            .spawn()
            .map_err(|e| format!("bgd server start: {e}"))?;
        farm.server = Some(server);
        farm.wait_ready(port)?;
        Ok(farm)
    }

    /// Wait until the server accepts connections.
    fn wait_ready(&mut self, port: u16) -> Result<(), String> {
        let started = Instant::now();
        loop {
            if let Some(server) = &mut self.server
                && let Ok(Some(status)) = server.try_wait()
            {
                return Err(format!("bgd exited ({status}): {}", self.log_tail()));
            }
            if std::net::TcpStream::connect(("127.0.0.1", port)).is_ok() {
                return Ok(());
            }
            if started.elapsed() > START_TIMEOUT {
                return Err(format!(
                    "bgd did not listen within {} s: {}",
                    START_TIMEOUT.as_secs(),
                    self.log_tail()
                ));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The end of the server's log, for errors.
    pub fn log_tail(&self) -> String {
        let log = std::fs::read_to_string(self.dir.path().join("bgd.log")).unwrap_or_default();
        log[log.len().saturating_sub(3000)..].to_string()
    }

    /// Start a worker: `tool reapi-worker` on this farm, its folder inside the farm's.
    #[allow(dead_code)] // tests/remote_exec.rs
    pub fn add_worker(&mut self, tool: &Path) -> Result<(), String> {
        self.add_worker_on(tool, Command::new(tool))
    }

    /// Start a worker as `add_worker` does, with `command` (the tool, or a wrapper that runs
    /// it, such as `taskset`).
    pub fn add_worker_on(&mut self, tool: &Path, mut command: Command) -> Result<(), String> {
        let n = self.workers.len();
        let dir = self.dir.path().join(format!("worker-{n}"));
        let log = std::fs::File::create(self.dir.path().join(format!("worker-{n}.log")))
            .map_err(|e| e.to_string())?;
        command.args(["reapi-worker", "--server", &self.url]);
        if let Some(token) = &self.token {
            command
                .args(["--token-env", TOKEN_VAR])
                .env(TOKEN_VAR, token);
        }
        let child = command
            .arg("--bot-id")
            .arg(format!("worker-{n}"))
            .arg("--work-dir")
            .arg(dir)
            .stdin(Stdio::null())
            .stdout(log.try_clone().map_err(|e| e.to_string())?)
            .stderr(log)
            .spawn()
            .map_err(|e| format!("{} reapi-worker: {e}", tool.display()))?;
        self.workers.push(child);
        Ok(())
    }

    /// The log of worker `n`.
    #[allow(dead_code)] // tests/remote_exec.rs
    pub fn worker_log(&self, n: usize) -> String {
        std::fs::read_to_string(self.dir.path().join(format!("worker-{n}.log"))).unwrap_or_default()
    }

    /// Kill worker `n` (as a crash would).
    #[allow(dead_code)] // tests/remote_exec.rs
    pub fn kill_worker(&mut self, n: usize) {
        let _ = self.workers[n].kill();
        let _ = self.workers[n].wait();
    }

    /// Kill the server (as a crash would); the workers and the database stay.
    pub fn kill_server(&mut self) {
        if let Some(mut server) = self.server.take() {
            let _ = server.kill();
            let _ = server.wait();
        }
    }
}

impl Drop for BuildGrid {
    fn drop(&mut self) {
        for worker in &mut self.workers {
            let _ = worker.kill();
            let _ = worker.wait();
        }
        self.kill_server();
        let _ = as_postgres(&self.pg_bin.join("pg_ctl"))
            .arg("-D")
            .arg(self.dir.path().join("pg"))
            .args(["-m", "immediate", "stop"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
    }
}

/// The server's configuration: `tests/servers/buildgrid.yml` with its placeholders filled.
fn server_config(port: u16, database: &str, cas: &Path) -> String {
    include_str!("../../tests/servers/buildgrid.yml")
        .replace("${PORT}", &port.to_string())
        .replace("${DATABASE}", database)
        .replace("${CAS}", &cas.display().to_string())
}
