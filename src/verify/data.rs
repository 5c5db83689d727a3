//! Where `verify` finds its data (the Grace probe), decided at run time so an installed binary
//! works from any directory: nothing is compiled in.
//!
//! Order: `--data DIR`, then the environment variable [`ENV`], then the checkout layout
//! `../shared/data` relative to the current directory, then relative to the checkout that holds
//! the executable (`<checkout>/target/<profile>/reflect`, so `cargo run` works from any folder of
//! the checkout). An explicit choice (`--data` or [`ENV`]) is the only place looked at: a wrong
//! setting is an error naming it, never silently replaced by another copy of the data.

use std::path::{Path, PathBuf};

/// The environment variable naming the data folder.
pub const ENV: &str = "REFLECT_DATA";

/// The file `verify` needs in the data folder: the Grace Cathedral probe (angular map, RGBE).
pub const GRACE_FILE: &str = "grace_probe.hdr";

/// One place looked at: the folder and what suggested it (for the error message).
#[derive(Clone, Debug, PartialEq)]
pub struct Place {
    pub dir: PathBuf,
    pub source: &'static str,
}

/// The places to look, best first. `option` is `--data`, `env` the value of [`ENV`] (an empty
/// value counts as unset), `cwd` the current directory and `exe` the executable's path (either
/// may be unknown). An explicit `option` or `env` is the only place; otherwise the checkout
/// layouts, without duplicates.
pub fn places(option: Option<&Path>, env: Option<&Path>, cwd: Option<&Path>, exe: Option<&Path>) -> Vec<Place> {
    if let Some(d) = option {
        return vec![Place { dir: d.to_path_buf(), source: "--data" }];
    }
    if let Some(d) = env.filter(|d| !d.as_os_str().is_empty()) {
        return vec![Place { dir: d.to_path_buf(), source: ENV }];
    }
    let mut out: Vec<Place> = Vec::new();
    // `<dir>/../shared/data`, written without `..` (the parent) so the message is readable.
    let sibling = |dir: &Path| dir.parent().map(|p| p.join("shared").join("data"));
    if let Some(d) = cwd.and_then(sibling) {
        out.push(Place { dir: d, source: "../shared/data from the current directory" });
    }
    // The executable sits in `<checkout>/target/<profile>/`: its folder's grandparent is the checkout.
    if let Some(d) = exe.and_then(Path::parent).and_then(|d| d.ancestors().nth(2)).and_then(sibling)
        && !out.iter().any(|p| p.dir == d)
    {
        out.push(Place { dir: d, source: "../shared/data from the executable's checkout" });
    }
    out
}

/// The first place holding [`GRACE_FILE`]. Errors: one line naming every place looked at and what
/// is missing (the caller reports it with exit status 2).
pub fn find(places: &[Place]) -> Result<PathBuf, String> {
    if let Some(p) = places.iter().find(|p| p.dir.join(GRACE_FILE).is_file()) {
        return Ok(p.dir.clone());
    }
    let looked: Vec<String> = places.iter().map(|p| format!("{} ({})", p.dir.display(), p.source)).collect();
    Err(format!(
        "verify: data folder not found: no {GRACE_FILE} in {}; give the folder with --data DIR or {ENV}",
        if looked.is_empty() {
            "any place (no current directory or executable path)".to_string()
        } else {
            looked.join(", ")
        }
    ))
}

/// Resolves the data folder for this process: [`places`] from `option`, [`ENV`], the current
/// directory and the executable, then [`find`].
pub fn resolve(option: Option<&Path>) -> Result<PathBuf, String> {
    let env = std::env::var_os(ENV).map(PathBuf::from);
    let cwd = std::env::current_dir().ok();
    let exe = std::env::current_exe().ok();
    find(&places(option, env.as_deref(), cwd.as_deref(), exe.as_deref()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(s: &str) -> PathBuf {
        PathBuf::from(s)
    }

    #[test]
    fn option_wins_over_env_and_checkouts() {
        let pl =
            places(Some(&p("/o")), Some(&p("/e")), Some(&p("/c/main")), Some(&p("/x/main/target/release/reflect")));
        assert_eq!(pl, vec![Place { dir: p("/o"), source: "--data" }]);
    }

    #[test]
    fn env_wins_over_checkouts_and_empty_env_is_unset() {
        let pl = places(None, Some(&p("/e")), Some(&p("/c/main")), None);
        assert_eq!(pl, vec![Place { dir: p("/e"), source: ENV }]);
        let pl = places(None, Some(&p("")), Some(&p("/c/main")), None);
        assert_eq!(pl.len(), 1);
        assert_eq!(pl[0].dir, p("/c/shared/data"));
    }

    #[test]
    fn checkout_layouts_cwd_then_executable_without_duplicates() {
        let pl = places(None, None, Some(&p("/c/main")), Some(&p("/x/main/target/release/reflect")));
        let dirs: Vec<_> = pl.iter().map(|p| p.dir.clone()).collect();
        assert_eq!(dirs, vec![p("/c/shared/data"), p("/x/shared/data")]);
        // `cargo run` from the repo root: both say the same folder, listed once.
        let pl = places(None, None, Some(&p("/x/main")), Some(&p("/x/main/target/release/reflect")));
        assert_eq!(pl.len(), 1);
    }

    #[test]
    fn find_takes_the_first_place_with_the_probe() {
        let tmp = std::env::temp_dir().join(format!("reflect-data-find-{}", std::process::id()));
        let (a, b) = (tmp.join("a"), tmp.join("b"));
        std::fs::create_dir_all(&a).unwrap();
        std::fs::create_dir_all(&b).unwrap();
        std::fs::write(b.join(GRACE_FILE), b"").unwrap();
        let pl = [Place { dir: a.clone(), source: "first" }, Place { dir: b.clone(), source: "second" }];
        assert_eq!(find(&pl).unwrap(), b);
        std::fs::write(a.join(GRACE_FILE), b"").unwrap();
        assert_eq!(find(&pl).unwrap(), a);
        std::fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn missing_data_names_every_place_on_one_line() {
        let pl = places(None, None, Some(&p("/nonexistent-c/main")), Some(&p("/nonexistent-x/main/target/release/r")));
        let e = find(&pl).unwrap_err();
        assert!(!e.contains('\n'), "{e}");
        for needle in ["/nonexistent-c/shared/data", "/nonexistent-x/shared/data", GRACE_FILE, "--data", ENV] {
            assert!(e.contains(needle), "{needle} missing from: {e}");
        }
    }
}
