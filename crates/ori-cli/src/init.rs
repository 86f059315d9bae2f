//! `init`: a commented `pipeline.toml` for a new project.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

/// The repository's own configuration documents every key with its default; a new project
/// gets the same text with its assets in `assets/`.
const TEMPLATE: &str = include_str!("../../../pipeline.toml");

#[derive(clap::Args)]
pub struct Args {
    /// Where to write it.
    #[arg(long, default_value = "pipeline.toml")]
    pub config: PathBuf,
    /// Replace an existing file.
    #[arg(long)]
    pub force: bool,
}

/// The file `init` writes.
pub fn template() -> String {
    TEMPLATE
        .replacen(
            "read by `cargo xtask build-assets`",
            "read by `ori build`",
            1,
        )
        .replacen("root = \"samples\"", "root = \"assets\"", 1)
}

/// Exit status 0: written; 1: it could not be; 2: the file exists (and no `--force`).
pub fn run(args: Args) -> ExitCode {
    let path = &args.config;
    let mut options = std::fs::OpenOptions::new();
    options.write(true);
    if args.force {
        options.create(true).truncate(true);
    } else {
        options.create_new(true);
    }
    let written = options
        .open(path)
        .and_then(|mut file| file.write_all(template().as_bytes()));
    match written {
        Ok(()) => {
            println!(
                "wrote {}: put the models in assets/ beside it, then run `ori build`",
                path.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            eprintln!(
                "error: {} already exists (--force replaces it)",
                path.display()
            );
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("error: cannot write {}: {e}", path.display());
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    #[test]
    fn the_template_is_the_default_configuration_with_assets_in_assets() {
        let text = super::template();
        assert!(text.contains("`ori build`") && text.contains("root = \"assets\""));
        let config = ori_pipeline::Config::parse(Path::new("pipeline.toml"), &text).unwrap();
        let empty = ori_pipeline::Config::parse(Path::new("empty.toml"), "").unwrap();
        assert_eq!(config.assets.root, PathBuf::from("assets"));
        assert_eq!(
            (
                &config.assets.include,
                &config.cache.dir,
                &config.output.dir
            ),
            (&empty.assets.include, &empty.cache.dir, &empty.output.dir)
        );
        assert_eq!(
            config.params_for("a.glb").unwrap(),
            empty.params_for("a.glb").unwrap()
        );
    }
}
