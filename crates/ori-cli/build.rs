//! Gives `ori --version` the commit it was built from (`ORI_GIT_HASH`), or `unknown` outside
//! a git checkout.

use std::path::PathBuf;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

fn main() {
    let Some(hash) = git(&["rev-parse", "HEAD"]) else {
        println!("cargo:rerun-if-changed=build.rs");
        println!("cargo:rustc-env=ORI_GIT_HASH=unknown");
        return;
    };
    // A commit or checkout moves HEAD or a branch: a loose ref (under refs/heads, watched as
    // a folder, so a ref written there later counts) or packed-refs. `--git-path` finds them
    // in a worktree too. Only paths that exist are named: a missing one reruns every build.
    let watched = ["HEAD", "refs/heads", "packed-refs"]
        .iter()
        .filter_map(|path| git(&["rev-parse", "--path-format=absolute", "--git-path", path]))
        .map(PathBuf::from)
        .filter(|path| path.exists());
    for path in watched {
        println!("cargo:rerun-if-changed={}", path.display());
    }
    println!("cargo:rustc-env=ORI_GIT_HASH={hash}");
}
