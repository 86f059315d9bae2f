//! `ori run-action DIR`: one job of a build, run from a folder that holds its description and
//! input blobs (what a remote-execution worker runs; not a command for people).

use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    /// The action's folder: job.json and inputs/; the outputs go to outputs/.
    pub dir: PathBuf,
}

pub fn run(args: Args) -> ExitCode {
    match ori_pipeline::action::run_folder(&args.dir) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(1)
        }
    }
}
