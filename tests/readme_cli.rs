//! The README's command-line summary cannot drift from the binary: for every subcommand, the long
//! flags `reflect … --help` lists and the flags on that subcommand's lines of the README's
//! "Command line" block are the same set, and every subcommand has a line there; and user-facing text
//! cites only what a user of the repository can see.

use std::collections::BTreeSet;
use std::process::Command;

/// Runs `reflect ARGS --help` and returns its stdout.
fn help(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).arg("--help").output().expect("run reflect");
    assert!(out.status.success(), "reflect {args:?} --help failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("help is UTF-8")
}

/// Long flags (`--name`) in a text, without `--help` and `--version` (clap adds them everywhere).
fn flags(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let b = text.as_bytes();
    let mut i = 0;
    while let Some(p) = text[i..].find("--") {
        let start = i + p + 2;
        let mut end = start;
        while end < b.len() && (b[end].is_ascii_alphanumeric() || b[end] == b'-') {
            end += 1;
        }
        // A flag starts with a letter (not `---`, not a `--` separator).
        if end > start && b[start].is_ascii_alphabetic() {
            let f = &text[start..end];
            if f != "help" && f != "version" {
                out.insert(format!("--{f}"));
            }
        }
        i = end.max(start);
    }
    out
}

/// The flags of the options section of a clap help text (the description lines are excluded, so
/// that a flag mentioned in prose does not count).
fn help_flags(text: &str) -> BTreeSet<String> {
    let opts = text.split_once("Options:").map(|(_, o)| o).unwrap_or("");
    let decl: String = opts
        .lines()
        .filter_map(|l| {
            let t = l.trim_start();
            // Option declarations: "-q, --quiet", "--out <OUT>"; anything else is description.
            (t.starts_with("--") || (t.starts_with('-') && t.get(2..4) == Some(", ")))
                .then(|| t.split("  ").next().unwrap_or(t).to_string())
        })
        .collect::<Vec<_>>()
        .join("\n");
    flags(&decl)
}

/// Subcommand names of a clap help text ("Commands:" section), without `help`.
fn subcommands(text: &str) -> Vec<String> {
    let Some((_, rest)) = text.split_once("Commands:") else { return vec![] };
    rest.lines()
        .skip(1.min(rest.lines().count()))
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect()
}

/// The README's "Command line" code block, as (subcommand path, flags) per command, joining
/// continuation lines (indented) to the line they continue.
fn readme_commands() -> Vec<(String, BTreeSet<String>)> {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).expect("README.md");
    let section = readme.split_once("## Command line").expect("README has a \"Command line\" section").1;
    let block = section.split("```").nth(1).expect("a code block in the \"Command line\" section");
    let mut cmds: Vec<(String, String)> = Vec::new();
    for line in block.lines().skip(1) {
        if let Some(rest) = line.strip_prefix("reflect ") {
            // The subcommand path: the leading lower-case words before any argument.
            let path: Vec<&str> = rest
                .split_whitespace()
                .take_while(|w| w.chars().all(|c| c.is_ascii_lowercase()) && !w.is_empty())
                .collect();
            cmds.push((path.join(" "), rest.to_string()));
        } else if line.starts_with(' ') && !line.trim().is_empty() {
            cmds.last_mut().expect("a continuation line follows a command line").1.push_str(line);
        } else {
            assert!(line.trim().is_empty(), "README CLI block: line neither a command nor a continuation: {line:?}");
        }
    }
    cmds.into_iter().map(|(p, text)| (p, flags(&text))).collect()
}

#[test]
fn readme_cli_block_matches_help() {
    let readme = readme_commands();
    // Every leaf subcommand of the binary, found from the help texts themselves.
    let mut leaves = Vec::new();
    let mut todo: Vec<Vec<String>> = vec![vec![]];
    while let Some(path) = todo.pop() {
        let args: Vec<&str> = path.iter().map(String::as_str).collect();
        let text = help(&args);
        let subs = subcommands(&text);
        if subs.is_empty() {
            leaves.push((path.join(" "), help_flags(&text)));
        } else {
            for s in subs {
                let mut p = path.clone();
                p.push(s);
                todo.push(p);
            }
        }
    }
    leaves.sort();
    assert!(leaves.len() >= 8, "found only {} subcommands: {leaves:?}", leaves.len());
    let mut problems = Vec::new();
    for (path, help_set) in &leaves {
        // A subcommand may have several README lines (e.g. the forms of `invert factor`).
        let lines: Vec<&BTreeSet<String>> = readme.iter().filter(|(p, _)| p == path).map(|(_, f)| f).collect();
        if lines.is_empty() {
            problems.push(format!("`reflect {path}` has no line in the README's CLI block"));
            continue;
        }
        let readme_set: BTreeSet<String> = lines.into_iter().flatten().cloned().collect();
        for f in help_set.difference(&readme_set) {
            problems.push(format!("`reflect {path}`: {f} is in --help but not in the README"));
        }
        for f in readme_set.difference(help_set) {
            problems.push(format!("`reflect {path}`: {f} is in the README but not in --help"));
        }
    }
    for (path, _) in &readme {
        if !leaves.iter().any(|(p, _)| p == path) {
            problems.push(format!("README's CLI block lists `reflect {path}`, which is not a subcommand"));
        }
    }
    assert!(problems.is_empty(), "README CLI block vs --help:\n{}", problems.join("\n"));
}

#[test]
fn flag_extraction() {
    assert_eq!(
        flags("[--brdf B --s S] --lmax L [--json] ---x -- --9 --theta-o"),
        ["--brdf", "--s", "--lmax", "--json", "--theta-o"].iter().map(|s| s.to_string()).collect()
    );
    let help = "Usage: x\n\nOptions:\n      --out <OUT>\n          Output (see --not-a-flag)\n  -q, --quiet\n          Quiet\n  -h, --help\n";
    assert_eq!(help_flags(help), ["--out", "--quiet"].iter().map(|s| s.to_string()).collect());
}

/// What a user reads (every `--help`, README.md, the scene files, the Python package's docstrings,
/// the examples, the deployment example) refers only to what a user of the repository can see: no
/// private contract (`CONVENTIONS`), tracker issue numbers or files that do not exist, and every
/// `README "SECTION"` it cites names a heading of README.md.
#[test]
fn user_facing_text_cites_only_what_a_user_can_see() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut texts: Vec<(String, String)> = Vec::new();
    let mut todo: Vec<Vec<String>> = vec![vec![]];
    while let Some(path) = todo.pop() {
        let args: Vec<&str> = path.iter().map(String::as_str).collect();
        let text = help(&args);
        for s in subcommands(&text) {
            todo.push(path.iter().cloned().chain([s]).collect());
        }
        texts.push((format!("reflect {} --help", path.join(" ")), text));
    }
    let mut files = vec![root.join("README.md"), root.join("deploy/k8s-indexed-job.yaml")];
    for dir in ["scenes", "python/reflect", "python/src", "examples", "examples/python", "benches", "benches/peers"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap_or_else(|e| panic!("{dir}: {e}")) {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| ["toml", "py", "pyi", "rs"].iter().any(|k| x == *k)) {
                files.push(p);
            }
        }
    }
    for f in files {
        texts.push((f.display().to_string(), std::fs::read_to_string(&f).unwrap()));
    }
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let headings: Vec<&str> =
        readme.lines().filter_map(|l| l.strip_prefix('#')).map(|l| l.trim_start_matches('#').trim()).collect();
    let issue = |t: &str| {
        let lower = t.to_lowercase();
        lower.match_indices("issue ").any(|(i, m)| lower[i + m.len()..].starts_with(|c: char| c.is_ascii_digit()))
    };
    let mut bad = Vec::new();
    for (name, text) in &texts {
        for (n, line) in text.lines().enumerate() {
            let at = format!("{name}:{}: {line}", n + 1);
            if ["CONVENTIONS", "scenes/README", "PEERS.md", "HELPERS.md"].iter().any(|w| line.contains(w))
                || issue(line)
            {
                bad.push(at.clone());
            }
            // `README "SECTION"` (a section name may continue on the next line: checked as a prefix).
            for (i, _) in line.match_indices("README \"") {
                let cited = line[i + 8..].split('"').next().unwrap_or("");
                if !headings.iter().any(|h| h.trim_matches('`').starts_with(cited) || h.starts_with(cited)) {
                    bad.push(format!("{at} (no README heading starts with \"{cited}\")"));
                }
            }
        }
    }
    assert!(bad.is_empty(), "references a user cannot see:\n{}", bad.join("\n"));
}
