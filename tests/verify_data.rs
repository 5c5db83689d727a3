//! `reflect verify` finds its data at run time (issue 11, item 7): a bogus `REFLECT_DATA` or
//! `--data` is bad input (exit 2, one line naming the place looked at, nothing written), and a good
//! `REFLECT_DATA` works from a directory outside the checkout.

mod common;

use std::path::Path;
use std::process::Command;

/// Runs `reflect verify ARGS` in `cwd` with `REFLECT_DATA` set to `env` (or removed).
fn verify_in(cwd: &Path, env: Option<&Path>, args: &[&str]) -> (i32, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_reflect"));
    cmd.current_dir(cwd).arg("verify").args(args);
    match env {
        Some(d) => cmd.env("REFLECT_DATA", d),
        None => cmd.env_remove("REFLECT_DATA"),
    };
    let out = cmd.output().expect("run reflect");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn bogus_data_folder_is_bad_input_naming_the_places() {
    let tmp = common::temp_dir("verify-data-bogus");
    let bogus = tmp.join("no-such-data");
    let report = tmp.join("report");
    let report_arg = report.display().to_string();

    // REFLECT_DATA set, no --data: the variable is the place, and the message says so.
    let (code, err) = verify_in(&tmp, Some(&bogus), &["--quick", "--out", &report_arg]);
    assert_eq!(code, 2, "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
    let bogus_text = bogus.display().to_string();
    for needle in [bogus_text.as_str(), "(REFLECT_DATA)", "grace_probe.hdr", "--data"] {
        assert!(err.contains(needle), "'{needle}' missing from: {err}");
    }
    assert!(!report.exists(), "nothing may be written when the data is missing");

    // --data beats REFLECT_DATA: a bogus --data is reported even with a good variable.
    let good = common::grace().parent().unwrap().to_path_buf();
    let bogus_opt = tmp.join("also-missing");
    let (code, err) =
        verify_in(&tmp, Some(&good), &["--quick", "--out", &report_arg, "--data", &bogus_opt.display().to_string()]);
    assert_eq!(code, 2, "stderr: {err}");
    assert!(err.contains(&bogus_opt.display().to_string()) && err.contains("(--data)"), "{err}");
    assert!(!report.exists());
    let _ = std::fs::remove_dir_all(&tmp);
}

#[test]
fn good_reflect_data_works_outside_the_checkout() {
    let tmp = common::temp_dir("verify-data-good");
    let good = common::grace().parent().unwrap().to_path_buf();
    let report = tmp.join("report");
    // One cheap check that reads the probe (its coefficients and a render under it).
    let (code, err) =
        verify_in(&tmp, Some(&good), &["--quick", "--check", "irradiance9", "--out", &report.display().to_string()]);
    assert_eq!(code, 0, "stderr: {err}");
    assert!(report.join("report.json").is_file());
    let _ = std::fs::remove_dir_all(&tmp);
}
