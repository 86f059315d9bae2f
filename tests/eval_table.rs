//! `cargo xtask eval-table`: the held-out line, in the shape scripts parse.

mod common;

use std::process::Command;

use common::*;

/// The held-out line's N, X, Y, Z, and the worst held-out view's missed pixels with its
/// entry's subset and with all the entry's candidates.
fn held_out_line(seed: &str) -> ((usize, f64, f64, f64), (u32, u32)) {
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
    let worst = text
        .lines()
        .find(|l| l.starts_with("worst held-out view "))
        .unwrap_or_else(|| panic!("no worst-view line:\n{text}"));
    let (_, rest) = worst.split_once(": ").unwrap();
    let (drawn, rest) = rest.split_once(" pixels missed with its ").unwrap();
    let (_, rest) = rest.split_once(" impostors, ").unwrap();
    let (floor, _) = rest.split_once(" with all ").unwrap();
    (
        (
            n.parse().unwrap(),
            max.parse().unwrap(),
            avg.parse().unwrap(),
            z.parse().unwrap(),
        ),
        (drawn.parse().unwrap(), floor.parse().unwrap()),
    )
}

#[test]
fn eval_table_prints_the_held_out_figures() {
    let ((n, max, avg, z), (drawn, floor)) = held_out_line("1");
    assert_eq!(n, 3280);
    assert!(max >= avg && avg > 0.0 && max < 100.0, "{max} {avg}");
    assert!((1.0..=6.0).contains(&z), "{z}");
    // The worst view's pixels are the maximum (s0 = 64), and its entry's subset is among the
    // entry's candidates, so all of them miss no more.
    assert!(
        (100.0 * f64::from(drawn) / 4096.0 - max).abs() < 0.001,
        "{drawn} {max}"
    );
    assert!(floor <= drawn, "{floor} > {drawn}");
    // Another seed is accepted and measures as many directions.
    assert_eq!(held_out_line("7").0.0, 3280);
}
