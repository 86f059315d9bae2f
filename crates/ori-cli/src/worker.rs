//! `ori reapi-worker`: a bot that runs a BuildGrid farm's actions on this machine, so a
//! studio adds a machine to its farm with one command.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use ori_reapi::client::Settings;
use ori_reapi::worker::WorkerOptions;

#[derive(clap::Args)]
pub struct Args {
    /// The farm's Bots endpoint (grpc://host:port; BuildGrid serves it beside the REAPI).
    #[arg(long, value_name = "URL")]
    pub server: String,
    /// The instance name whose actions to run (empty: the server's default instance).
    #[arg(long, default_value = "")]
    pub instance_name: String,
    /// The bot's name on the server (default: the host name and this process's id).
    #[arg(long)]
    pub bot_id: Option<String>,
    /// Where actions are laid out and run (a folder per action, removed after it).
    #[arg(long, default_value = "ori-worker")]
    pub work_dir: PathBuf,
    /// The environment variable holding a bearer token, if the server wants one.
    #[arg(long, value_name = "VAR")]
    pub token_env: Option<String>,
    /// Seconds allowed for each exchange with the server.
    #[arg(long, default_value_t = 60.0)]
    pub timeout_s: f64,
}

pub fn run(args: Args) -> ExitCode {
    if let Err(why) = ori_pipeline::config::check_grpc_url(&args.server) {
        eprintln!("error: --server {:?}: {why}", args.server);
        return ExitCode::from(2);
    }
    if !(args.timeout_s > 0.0 && args.timeout_s <= 3600.0) {
        eprintln!(
            "error: --timeout-s {}: expected more than 0 and at most 3600",
            args.timeout_s
        );
        return ExitCode::from(2);
    }
    let token = match &args.token_env {
        None => None,
        Some(name) => match std::env::var(name) {
            Ok(token) if !token.is_empty() => Some(token),
            _ => {
                eprintln!("error: --token-env {name}: the environment variable is not set");
                return ExitCode::from(2);
            }
        },
    };
    let bot_id = args.bot_id.unwrap_or_else(|| {
        let host = std::fs::read_to_string("/etc/hostname").unwrap_or_default();
        format!("{}-{}", host.trim(), std::process::id())
    });
    let options = WorkerOptions {
        server: Settings {
            url: args.server,
            instance_name: args.instance_name,
            token,
            timeout: Duration::from_secs_f64(args.timeout_s),
        },
        bot_id,
        work_dir: args.work_dir,
    };
    let stop = AtomicBool::new(false);
    match ori_reapi::worker::run(&options, &stop, &|line| eprintln!("{line}")) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(1)
        }
    }
}
