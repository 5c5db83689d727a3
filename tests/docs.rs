//! The README and the guide (`docs/`) cannot drift from the binary or from each other:
//! - the guide's command-line summary (`docs/src/reference/cli.md`, its first code block) lists, for
//!   every subcommand, exactly the long flags that `reflect … --help` lists;
//! - every `reflect …` command in a shell block of the README or the guide names a real subcommand and
//!   only flags it has;
//! - every relative link of the README and the guide points at a file that exists (and, for a page of
//!   the guide, at one of its headings), and every page of `docs/src` is in `SUMMARY.md`;
//! - user-facing text cites only what a user of the repository can see;
//! - every TOML block of the README and the guide is a scene file that parses.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every Markdown page of the guide, as (path, text). Missing files fail the test.
fn doc_pages() -> Vec<(PathBuf, String)> {
    let mut out =
        vec![(root().join("README.md"), std::fs::read_to_string(root().join("README.md")).expect("README.md"))];
    let mut dirs = vec![root().join("docs/src")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "md") {
                let text = std::fs::read_to_string(&p).unwrap();
                out.push((p, text));
            }
        }
    }
    out.sort();
    assert!(out.len() > 10, "the guide has pages: {}", out.len());
    out
}

/// The headings of a Markdown text (outside code blocks), without the `#`s.
fn headings(text: &str) -> Vec<String> {
    let mut code = false;
    let mut out = Vec::new();
    for l in text.lines() {
        if l.starts_with("```") {
            code = !code;
        } else if !code && l.starts_with('#') {
            out.push(l.trim_start_matches('#').trim().to_string());
        }
    }
    out
}

/// mdBook's anchor of a heading: lower case, alphanumerics, `-` and `_` kept, spaces as `-`, the
/// rest dropped.
fn slug(heading: &str) -> String {
    heading
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                Some(c.to_lowercase().collect::<String>())
            } else if c == ' ' {
                Some("-".to_string())
            } else {
                None
            }
        })
        .collect()
}

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

/// The guide's command-line summary (the first code block of `docs/src/reference/cli.md`), as
/// (subcommand path, flags) per command, joining continuation lines (indented) to the line they
/// continue.
fn readme_commands() -> Vec<(String, BTreeSet<String>)> {
    let page = std::fs::read_to_string(root().join("docs/src/reference/cli.md")).expect("docs/src/reference/cli.md");
    let block = page.split("```").nth(1).expect("a code block in the \"Command line\" page");
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
            assert!(line.trim().is_empty(), "CLI summary: line neither a command nor a continuation: {line:?}");
        }
    }
    cmds.into_iter().map(|(p, text)| (p, flags(&text))).collect()
}

/// Every leaf subcommand of the binary with the long flags of its `--help`.
fn leaf_subcommands() -> Vec<(String, BTreeSet<String>)> {
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
    leaves
}

#[test]
fn cli_summary_matches_help() {
    let readme = readme_commands();
    let leaves = leaf_subcommands();
    let mut problems = Vec::new();
    for (path, help_set) in &leaves {
        // A subcommand may have several README lines (e.g. the forms of `invert factor`).
        let lines: Vec<&BTreeSet<String>> = readme.iter().filter(|(p, _)| p == path).map(|(_, f)| f).collect();
        if lines.is_empty() {
            problems.push(format!("`reflect {path}` has no line in the guide's CLI summary"));
            continue;
        }
        let readme_set: BTreeSet<String> = lines.into_iter().flatten().cloned().collect();
        for f in help_set.difference(&readme_set) {
            problems.push(format!("`reflect {path}`: {f} is in --help but not in the CLI summary"));
        }
        for f in readme_set.difference(help_set) {
            problems.push(format!("`reflect {path}`: {f} is in the CLI summary but not in --help"));
        }
    }
    for (path, _) in &readme {
        if !leaves.iter().any(|(p, _)| p == path) {
            problems.push(format!("The CLI summary lists `reflect {path}`, which is not a subcommand"));
        }
    }
    assert!(problems.is_empty(), "CLI summary vs --help:\n{}", problems.join("\n"));
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

/// What a user reads (every `--help`, the README and the guide, the scene files, the Python
/// package's docstrings, the examples, the deployment example, the changelog) and the sources of the
/// crates refer only to what a user of the repository can see: no file outside it (`../shared/CONVENTIONS.md`,
/// whose content the guide's conventions page now states), no tracker issue numbers in user-facing
/// text, and every `guide "SECTION"` (or `README "SECTION"`) cited names a heading of the README or
/// the guide.
#[test]
fn user_facing_text_cites_only_what_a_user_can_see() {
    let root = root();
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
    let pages = doc_pages();
    for (p, t) in &pages {
        texts.push((p.display().to_string(), t.clone()));
    }
    let mut files = vec![root.join("deploy/k8s-indexed-job.yaml"), root.join("CHANGELOG.md")];
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
    // (README headings, guide headings): a `README "…"` citation names the first, a `guide "…"` one the second.
    let readme = root.join("README.md");
    let headings: (Vec<String>, Vec<String>) = (
        pages.iter().filter(|(p, _)| *p == readme).flat_map(|(_, t)| headings(t)).collect(),
        pages.iter().filter(|(p, _)| *p != readme).flat_map(|(_, t)| headings(t)).collect(),
    );
    let issue = |t: &str| {
        let lower = t.to_lowercase();
        ["issue ", "issues "].iter().any(|w| {
            lower.match_indices(w).any(|(i, m)| lower[i + m.len()..].starts_with(|c: char| c.is_ascii_digit()))
        })
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
            cited_sections_exist(&at, line, &headings, &mut bad);
        }
    }
    // The crates' sources (comments included) cite the guide, never a file outside the repository.
    let mut dirs: Vec<PathBuf> = ["src", "renderer", "analysis", "vocab", "python", "tests", "benches", "examples"]
        .iter()
        .map(|d| root.join(d))
        .collect();
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| ["rs", "py", "pyi", "toml"].iter().any(|k| x == *k))
                && !p.ends_with("tests/docs.rs")
            {
                let text = std::fs::read_to_string(&p).unwrap();
                for (n, line) in text.lines().enumerate() {
                    let at = format!("{}:{}: {line}", p.display(), n + 1);
                    if line.contains("CONVENTIONS") {
                        bad.push(at.clone());
                    }
                    cited_sections_exist(&at, line, &headings, &mut bad);
                }
            }
        }
    }
    assert!(bad.is_empty(), "references a user cannot see:\n{}", bad.join("\n"));
}

/// Every `guide "SECTION"` in `line` names a heading of the guide, and every `README "SECTION"` one of
/// the README: exactly (backticks aside; a page title's subtitle after a colon may be left out) when
/// the quotation closes on the line, as a prefix when it runs on to the next line. One entry in `bad`
/// per citation that does not.
fn cited_sections_exist(at: &str, line: &str, headings: &(Vec<String>, Vec<String>), bad: &mut Vec<String>) {
    for (pat, names, whose) in [
        ("README \"", &headings.0, "the README"),
        ("guide \"", &headings.1, "the guide"),
        ("guide \\\"", &headings.1, "the guide"),
    ] {
        for (i, _) in line.match_indices(pat) {
            let rest = &line[i + pat.len()..];
            // Closed by a quote (or an escaped one); a backslash ending the line continues a string.
            let end = rest.find(['"', '\\']).filter(|&k| rest[k..].trim_end() != "\\");
            let cited = rest[..end.unwrap_or(rest.len())].trim_end_matches('\\').replace('`', "");
            // A page title's subtitle after a colon may be left out ("Scale-out" for "Scale-out: shards, …").
            let found = names.iter().any(|h| {
                let h = h.replace('`', "");
                match end {
                    Some(_) => h == cited || h.strip_prefix(&cited).is_some_and(|t| t.starts_with(':')),
                    None => h.starts_with(&cited),
                }
            });
            if !found {
                bad.push(format!("{at} (no heading of {whose} is \"{cited}\")"));
            }
        }
    }
}

/// Every relative link of the README and the guide resolves: the file exists, and an anchor into a
/// page of the guide names one of its headings. Every page of `docs/src` is in `SUMMARY.md`, and every
/// page `SUMMARY.md` lists exists.
#[test]
fn links_of_the_readme_and_the_guide_resolve() {
    let pages = doc_pages();
    let anchors: BTreeMap<PathBuf, BTreeSet<String>> =
        pages.iter().map(|(p, t)| (p.clone(), headings(t).iter().map(|h| slug(h)).collect())).collect();
    let mut bad = Vec::new();
    for (page, text) in &pages {
        let mut code = false;
        for (n, line) in text.lines().enumerate() {
            if line.starts_with("```") {
                code = !code;
            }
            if code {
                continue;
            }
            for (i, _) in line.match_indices("](") {
                let target = line[i + 2..].split(')').next().unwrap_or("");
                if target.starts_with("http") || target.starts_with("mailto:") || target.is_empty() {
                    continue;
                }
                let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
                let path = if file.is_empty() { page.clone() } else { page.parent().unwrap().join(file) };
                let at = format!("{}:{}: {target}", page.display(), n + 1);
                let Ok(path) = path.canonicalize() else {
                    bad.push(format!("{at} (no such file)"));
                    continue;
                };
                if !anchor.is_empty() {
                    match anchors.iter().find(|(p, _)| p.canonicalize().ok().as_ref() == Some(&path)) {
                        Some((_, set)) if set.contains(anchor) => {}
                        _ => bad.push(format!("{at} (no heading with anchor #{anchor})")),
                    }
                }
            }
        }
    }
    let summary = std::fs::read_to_string(root().join("docs/src/SUMMARY.md")).expect("docs/src/SUMMARY.md");
    for (page, _) in &pages {
        let Ok(rel) = page.strip_prefix(root().join("docs/src")) else { continue };
        let rel = rel.display().to_string();
        if rel != "SUMMARY.md" && !summary.contains(&format!("]({rel})")) {
            bad.push(format!("docs/src/{rel} is not in SUMMARY.md"));
        }
    }
    assert!(bad.is_empty(), "broken links in the README or the guide:\n{}", bad.join("\n"));
}

/// Every `reflect …` command in a shell block (```sh, ```bash, ```console) of the README or the guide,
/// run as `reflect`, `cargo run --release --` or a path ending in `/reflect`, names a subcommand of
/// the binary and only flags that subcommand's `--help` lists.
#[test]
fn commands_in_the_readme_and_the_guide_are_real() {
    let leaves: BTreeMap<String, BTreeSet<String>> = leaf_subcommands().into_iter().collect();
    let mut bad = Vec::new();
    let mut checked = 0;
    for (page, text) in doc_pages() {
        let mut shell = false;
        let mut code = false;
        let mut joined = String::new();
        for (n, line) in text.lines().enumerate() {
            if let Some(lang) = line.strip_prefix("```") {
                shell = !code && ["sh", "bash", "console", "shell"].contains(&lang.trim());
                code = !code;
                continue;
            }
            if !shell {
                continue;
            }
            // Continuation lines end in a backslash; comments are not commands.
            let l = line.split(" #").next().unwrap_or(line);
            if let Some(head) = l.trim_end().strip_suffix('\\') {
                joined.push_str(head);
                joined.push(' ');
                continue;
            }
            joined.push_str(l);
            let cmd = std::mem::take(&mut joined);
            for segment in cmd.split(['|', ';', '&']) {
                let words: Vec<&str> = segment.split_whitespace().collect();
                let start =
                    words.iter().position(|w| *w == "reflect" || w.ends_with("/reflect")).map(|k| k + 1).or_else(
                        || words.windows(4).position(|w| w == ["cargo", "run", "--release", "--"]).map(|k| k + 4),
                    );
                let Some(start) = start else { continue };
                let rest = &words[start..];
                let path: Vec<&str> = rest
                    .iter()
                    .take_while(|w| w.chars().all(|c| c.is_ascii_lowercase()) && !w.is_empty())
                    .copied()
                    .collect();
                // The longest prefix of the words that is a subcommand (`sh project`, `invert brdf`, …).
                let Some(k) = (1..=path.len()).rev().find(|&k| leaves.contains_key(&path[..k].join(" "))) else {
                    if !path.is_empty() && !["install"].contains(&path[0]) {
                        bad.push(format!(
                            "{}:{}: `reflect {}` is not a subcommand",
                            page.display(),
                            n + 1,
                            path.join(" ")
                        ));
                    }
                    continue;
                };
                let name = path[..k].join(" ");
                let allowed = &leaves[&name];
                for w in rest {
                    if let Some(f) = w.strip_prefix("--") {
                        let f = format!("--{}", f.split('=').next().unwrap_or(f));
                        if f != "--help" && f != "--" && !allowed.contains(&f) {
                            bad.push(format!("{}:{}: `reflect {name}` has no flag {f}", page.display(), n + 1));
                        }
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 10, "only {checked} commands found in the README and the guide");
    assert!(bad.is_empty(), "commands of the README and the guide that the binary does not take:\n{}", bad.join("\n"));
}

/// Every ```toml block of the README and the guide is a scene file (or a part of one) that the scene
/// parser accepts: an example with a misspelt key or a value outside its closed set fails here.
#[test]
fn toml_blocks_of_the_readme_and_the_guide_parse() {
    let mut checked = 0;
    let mut bad = Vec::new();
    for (page, text) in doc_pages() {
        let mut block: Option<(usize, String)> = None;
        for (n, line) in text.lines().enumerate() {
            match (&mut block, line.strip_prefix("```")) {
                (None, Some(lang)) if lang.trim() == "toml" => block = Some((n + 1, String::new())),
                (Some((start, body)), Some(_)) => {
                    if let Err(e) = vocab::SceneFile::parse(body) {
                        bad.push(format!("{}:{start}: {e}", page.display()));
                    }
                    checked += 1;
                    block = None;
                }
                (Some((_, body)), None) => {
                    body.push_str(line);
                    body.push('\n');
                }
                _ => {}
            }
        }
    }
    assert!(checked >= 1, "no TOML block found in the README and the guide");
    assert!(bad.is_empty(), "TOML blocks that do not parse as scene files:\n{}", bad.join("\n"));
}
