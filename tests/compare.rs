//! `cargo xtask compare`: the JSON it writes, its pictures and its refusals.

mod common;

use std::process::Command;

use common::*;

#[test]
fn compare_writes_one_row_per_technique_asked_for() {
    let model = shared_models().join("stanford/bunny/bunny_npm_lowres.obj");
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("compare.json");
    let pictures = dir.path().join("pictures");
    let out = Command::new(EXE)
        .args([
            "compare",
            "--budget-bytes",
            "820000",
            "--techniques",
            "relief-box,simplified-mesh,ori",
            "--directions",
            "12",
        ])
        .arg(&model)
        .arg("--json")
        .arg(&json)
        .arg("--pictures")
        .arg(&pictures)
        .output()
        .unwrap();
    let text = ok(&out);
    assert!(text.contains("relief-box"), "{text}");
    let value: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(value["budget_bytes"], 820000);
    assert_eq!(value["directions"], 12);
    let rows = value["rows"].as_array().unwrap();
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r["technique"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["relief-box", "simplified-mesh", "ori"]);
    for row in rows {
        let bytes = row["bytes"].as_u64().unwrap();
        for key in [
            "coverage_error_avg_percent",
            "coverage_error_max_percent",
            "inverse_coverage_avg_percent",
            "p_dif_avg",
            "drawn_per_view",
        ] {
            assert!(row[key].as_f64().is_some(), "{key} in {row}");
        }
        // The low-resolution bunny's whole mesh fits; the textures fill the budget.
        if row["technique"] == "simplified-mesh" {
            assert!(bytes < 820_000, "{row}");
            assert_eq!(row["drawn"], "triangles");
        } else {
            assert!(bytes.abs_diff(820_000) * 20 <= 820_000, "{row}");
            assert_eq!(row["drawn"], "quads");
        }
    }
    // The ORI is 20 maps of 128 x 128 at this budget.
    assert_eq!(rows[2]["bytes"], 20 * 128 * 128 * 5 / 2);
    for k in 0..4 {
        assert!(pictures.join(format!("view-{k}.png")).is_file(), "view-{k}");
    }
}

#[test]
fn compare_refuses_unknown_techniques_and_budgets_no_ori_fits() {
    let model = shared_models().join("stanford/bunny/bunny_npm_lowres.obj");
    for args in [
        vec!["--techniques", "impostor-soup"],
        vec!["--budget-bytes", "1000"],
    ] {
        let out = Command::new(EXE)
            .arg("compare")
            .args(&args)
            .arg(&model)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("impostor-soup") || err.contains("--budget-bytes 1000"),
            "{err}"
        );
    }
}
