//! `cargo xtask eval-table`: the held-out line, in the shape scripts parse.

mod common;

use std::process::Command;

use common::*;

fn held_out_line(seed: &str) -> (usize, f64, f64, f64) {
    let model = shared_models().join("stanford/bunny/bunny_npm_lowres.obj");
    let out = Command::new(EXE)
        .args([
            "eval-table",
            "--s0",
            "64",
            "--place-moves",
            "0",
            "--held-out-seed",
            seed,
        ])
        .arg(&model)
        .output()
        .unwrap();
    let text = ok(&out);
    let line = text
        .lines()
        .find(|l| l.starts_with("held-out ("))
        .unwrap_or_else(|| panic!("no held-out line:\n{text}"));
    // held-out (N directions): coverage error max X%, avg Y%, impostors per view Z
    let rest = line.strip_prefix("held-out (").unwrap();
    let (n, rest) = rest
        .split_once(" directions): coverage error max ")
        .unwrap();
    let (max, rest) = rest.split_once("%, avg ").unwrap();
    let (avg, z) = rest.split_once("%, impostors per view ").unwrap();
    (
        n.parse().unwrap(),
        max.parse().unwrap(),
        avg.parse().unwrap(),
        z.parse().unwrap(),
    )
}

#[test]
fn eval_table_prints_the_held_out_figures() {
    let (n, max, avg, z) = held_out_line("1");
    assert_eq!(n, 3280);
    assert!(max >= avg && avg > 0.0 && max < 100.0, "{max} {avg}");
    assert!((1.0..=6.0).contains(&z), "{z}");
    // Another seed is accepted and measures as many directions.
    assert_eq!(held_out_line("7").0, 3280);
}
