//! `reflect … --json` as a JSON value, and the JSON type of a value, for the tests that pin the
//! commands' JSON schemas (`json_schema`, `report_schema`).

use serde_json::Value;
use std::process::Command;

/// Runs `reflect ARGS` (which must print one JSON document and exit 0) and parses its stdout.
pub fn reflect_json(args: &[&str]) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).output().expect("run reflect");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "reflect {args:?}: {stderr}");
    serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("reflect {args:?}: bad JSON ({e}): {stdout}"))
}

/// The JSON type of `v`: "null", "bool", "number", "string", "array" or "object".
pub fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "bool",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    }
}

/// Asserts that every top-level key of `doc` is named (as `` `key` ``) in the section of the guide's JSON
/// reference (docs/src/reference/json.md) headed `` ## `reflect COMMAND` ``: a key added to a document
/// must be documented there.
pub fn assert_documented(command: &str, doc: &Value) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/src/reference/json.md");
    let page = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let heading = format!("## `reflect {command}`");
    let start = page.find(&heading).unwrap_or_else(|| panic!("{path}: no section {heading}"));
    let body = &page[start + heading.len()..];
    let section = &body[..body.find("\n## ").unwrap_or(body.len())];
    let obj = doc.as_object().unwrap_or_else(|| panic!("reflect {command}: the document is not an object"));
    let missing: Vec<&String> = obj.keys().filter(|k| !section.contains(&format!("`{k}`"))).collect();
    assert!(missing.is_empty(), "{path}, section {heading}: keys of the document not documented: {missing:?}");
}
