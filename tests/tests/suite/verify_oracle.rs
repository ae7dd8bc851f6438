//! Every reference-vector file copied into the repository (`tests/data/oracle/*.json`) goes
//! through `evogs verify` (`evogs_verify::verify::verify_file`): every row must pass. A file of
//! unknown kind, a malformed file (missing field, wrong shape), invalid JSON and a missing
//! file each give an error that names the file (and the JSON path where it applies).

use evogs_tests::oracle_files;
use evogs_verify::verify::{Kind, VerifyError, verify_file, verify_value};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

#[test]
fn verify_every_reference_file() {
    let files = oracle_files();
    assert!(files.len() >= 10, "reference files found: {files:?}");
    let mut kinds = Vec::new();
    for f in &files {
        let report = verify_file(f).unwrap_or_else(|e| panic!("{e}"));
        println!("{report}\n");
        assert!(
            report.passed(),
            "{}: failed rows: {:?}",
            f.display(),
            report.failures().collect::<Vec<_>>()
        );
        assert!(report.rows.len() >= 6, "{}: too few rows", f.display());
        kinds.push(report.kind);
    }
    for k in [
        Kind::Projection,
        Kind::Raster,
        Kind::Ode,
        Kind::OdeAdaptive,
        Kind::So3,
        Kind::Se3,
        Kind::Metrics,
    ] {
        assert!(kinds.contains(&k), "no {k} file among the reference files");
    }
}

fn load(name: &str) -> Value {
    let path = evogs_tests::oracle_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{e}"));
    serde_json::from_str(&text).expect("valid JSON")
}

/// Writes `text` to a fresh temporary file and returns its path.
fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("evogs-verify-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let path = dir.join(name);
    std::fs::write(&path, text).expect("temporary file");
    path
}

#[test]
fn unknown_and_malformed_files_give_errors_naming_them() {
    // Unknown kind.
    let path = temp_file("mystery.json", r#"{"schema_version": 1, "foo": [1, 2]}"#);
    let e = verify_file(&path).expect_err("unknown kind");
    let msg = e.to_string();
    assert!(matches!(e, VerifyError::UnknownKind { .. }), "{msg}");
    assert!(msg.contains("mystery.json") && msg.contains("foo"), "{msg}");

    // Not JSON.
    let path = temp_file("broken.json", "{\"case\": [1, 2");
    let e = verify_file(&path).expect_err("invalid JSON");
    assert!(matches!(e, VerifyError::Json { .. }), "{e}");
    assert!(e.to_string().contains("broken.json"), "{e}");

    // Missing file.
    let e = verify_file(Path::new("/nonexistent/evogs/missing.json")).expect_err("missing");
    assert!(matches!(e, VerifyError::Read(_)), "{e}");
    assert!(e.to_string().contains("missing.json"), "{e}");

    // A missing field in a projection file: the error names the JSON path.
    let mut v = load("projection_shared_case00.json");
    v["case"]["outputs"]
        .as_object_mut()
        .expect("outputs")
        .remove("radii");
    let e = verify_value(Path::new("cut.json"), &v).expect_err("missing field");
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            VerifyError::Malformed {
                kind: Kind::Projection,
                ..
            }
        ),
        "{msg}"
    );
    assert!(
        msg.contains("cut.json") && msg.contains("case.outputs.radii"),
        "{msg}"
    );

    // A wrong shape in an SO(3) file.
    let mut v = load("so3_shared_cases.json");
    v["rotvec_cases"][3]["Jl"] = json!([[1.0, 0.0], [0.0, 1.0]]);
    let e = verify_value(Path::new("shape.json"), &v).expect_err("wrong shape");
    let msg = e.to_string();
    assert!(
        msg.contains("shape.json") && msg.contains("rotvec_cases[3].Jl") && msg.contains("[3, 3]"),
        "{msg}"
    );

    // A wrong shape in an SE(3) file.
    let mut v = load("se3_shared_cases.json");
    v["cases"][2]["Jl"] = json!([[1.0, 0.0], [0.0, 1.0]]);
    let e = verify_value(Path::new("se3shape.json"), &v).expect_err("wrong shape");
    let msg = e.to_string();
    assert!(
        msg.contains("se3shape.json") && msg.contains("cases[2].Jl") && msg.contains("[6, 6]"),
        "{msg}"
    );

    // An unknown ODE method is a failing row, not an error and not skipped.
    let mut v = load("ode_shared_linear_seed0.json");
    v["case"]["runs"][0]["results"][0]["method"] = json!("dopri5");
    let r = verify_value(Path::new("method.json"), &v).expect("a report");
    assert!(!r.passed(), "unknown method must fail");
    assert!(
        r.failures().any(|row| row.quantity.contains("dopri5")),
        "{r}"
    );
}

#[test]
fn a_wrong_reference_value_fails_its_row() {
    // The checks can fail: perturb one reference number per kind beyond its tolerance.
    let cases: [(&str, &[&str], f64); 6] = [
        (
            "projection_shared_case03.json",
            &["case", "outputs", "means_cam"],
            1e-8,
        ),
        (
            "raster_shared_00_basic_sh0.json",
            &["case", "outputs", "render_alpha"],
            1e-9,
        ),
        ("ode_shared_mlp_seed0.json", &["case", "runs"], 1e-9),
        ("so3_shared_cases.json", &["rotvec_cases"], 1e-12),
        ("se3_shared_cases.json", &["cases"], 1e-11),
        ("metrics_shared_cases.json", &["cases"], 1e-11),
    ];
    for (file, path, delta) in cases {
        let mut v = load(file);
        let mut node = &mut v;
        for k in path {
            node = &mut node[*k];
        }
        // Descend to the first number and perturb it.
        let target = first_number(node).expect("a number");
        *target = json!(target.as_f64().expect("number") + delta);
        let r = verify_value(Path::new(file), &v).expect("a report");
        assert!(
            !r.passed(),
            "{file}: a perturbation of {delta} went unnoticed\n{r}"
        );
        println!("{file}: perturbed entry caught: {:?}", r.failures().next());
    }
}

/// The first number inside `v` (depth first), skipping strings and booleans.
fn first_number(v: &mut Value) -> Option<&mut Value> {
    match v {
        Value::Number(_) => Some(v),
        Value::Array(a) => a.iter_mut().find_map(first_number),
        Value::Object(o) => {
            // Prefer computed quantities over inputs: skip `inputs`, `x_init`, `rotvec`, …
            let skip = [
                "inputs",
                "x_init",
                "c",
                "theta",
                "A",
                "t0",
                "t1",
                "n_steps",
                "rotvec",
                "angle",
                "img1",
                "img2",
                "shape_hwc",
                "q",
                "omega",
                "dt",
                "xi",
                "other_xi",
                "point",
            ];
            o.iter_mut()
                .filter(|(k, _)| !skip.contains(&k.as_str()))
                .find_map(|(_, x)| first_number(x))
        }
        _ => None,
    }
}
