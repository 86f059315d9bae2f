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
    let hash = git(&["rev-parse", "HEAD"]);
    if let (Some(hash), Some(git_dir)) = (&hash, git(&["rev-parse", "--absolute-git-dir"])) {
        // A new commit or checkout moves HEAD or the branch it names (a loose ref, or
        // packed-refs). Only paths that exist are named: a missing one reruns every build.
        let git_dir = PathBuf::from(git_dir);
        let mut watched = vec![git_dir.join("HEAD")];
        if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
            watched.push(git_dir.join(branch));
        }
        watched.push(git_dir.join("packed-refs"));
        for path in watched.iter().filter(|p| p.exists()) {
            println!("cargo:rerun-if-changed={}", path.display());
        }
        println!("cargo:rustc-env=ORI_GIT_HASH={hash}");
    } else {
        println!("cargo:rerun-if-changed=build.rs");
        println!("cargo:rustc-env=ORI_GIT_HASH=unknown");
    }
}
