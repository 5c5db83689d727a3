//! The files a command reads and writes, checked in one place before any work: every output must
//! have its format's extension, and no output may be one of the command's inputs or another of
//! its outputs.
//!
//! Two paths are the same file when they name the same (device, inode) where the file exists
//! (symlinks followed, hard links included: `same_file`), else when their absolute paths agree
//! after resolving the symlinks of the existing parent folder and the `.`/`..` components
//! (`./a.exr` and `a.exr`, `d/../a.exr`).

use super::Error;
use same_file::Handle;
use std::path::{Component, Path, PathBuf};

/// What an output file holds, hence the extension its path must end in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// OpenEXR (`.exr`): images, partial renders, checkpoints, lat-long maps.
    Exr,
    /// PNG (`.png`): previews.
    Png,
    /// JSON (`.json`).
    Json,
    /// HTML (`.html`): the verify report.
    Html,
    /// Markdown (`.md`): the verify report.
    Markdown,
}

impl Format {
    fn extension(self) -> &'static str {
        match self {
            Format::Exr => "exr",
            Format::Png => "png",
            Format::Json => "json",
            Format::Html => "html",
            Format::Markdown => "md",
        }
    }

    fn what(self) -> &'static str {
        match self {
            Format::Exr => "an OpenEXR file",
            Format::Png => "a PNG file",
            Format::Json => "a JSON file",
            Format::Html => "an HTML file",
            Format::Markdown => "a Markdown file",
        }
    }
}

/// The inputs and outputs of one command invocation, each with the flag (or role) that names it.
#[derive(Debug, Default)]
pub struct Files {
    inputs: Vec<(String, PathBuf)>,
    outputs: Vec<(String, PathBuf, Format)>,
}

impl Files {
    pub fn new() -> Self {
        Self::default()
    }

    /// A file the command reads, `what` naming it in messages ("the scene", "part").
    pub fn input(mut self, what: impl Into<String>, path: impl AsRef<Path>) -> Self {
        self.inputs.push((what.into(), path.as_ref().to_path_buf()));
        self
    }

    /// Files the command reads, all with the same role.
    pub fn inputs<P: AsRef<Path>>(mut self, what: &str, paths: impl IntoIterator<Item = P>) -> Self {
        for p in paths {
            self = self.input(what, p);
        }
        self
    }

    /// A file the command writes, `flag` the option naming it (`--out`).
    pub fn output(mut self, flag: impl Into<String>, path: impl AsRef<Path>, format: Format) -> Self {
        self.outputs.push((flag.into(), path.as_ref().to_path_buf(), format));
        self
    }

    /// Refuses a wrong extension, an output that is an input, and two outputs that are one file;
    /// the error names the flag(s) and both paths (or the extension).
    pub fn check(&self) -> Result<(), Error> {
        for (flag, p, f) in &self.outputs {
            let ext = p.extension().and_then(|e| e.to_str());
            if !ext.is_some_and(|e| e.eq_ignore_ascii_case(f.extension())) {
                let got = ext.map_or("it has no extension".to_string(), |e| format!("it ends in .{e}"));
                return Err(Error::file(p, format!("{flag} must end in .{} ({}); {got}", f.extension(), f.what())));
            }
        }
        let inputs: Vec<Identity> = self.inputs.iter().map(|(_, p)| Identity::of(p)).collect();
        let outputs: Vec<Identity> = self.outputs.iter().map(|(_, p, _)| Identity::of(p)).collect();
        for (i, (flag, p, _)) in self.outputs.iter().enumerate() {
            for (j, (flag2, p2, _)) in self.outputs.iter().enumerate().take(i) {
                if outputs[i] == outputs[j] {
                    return Err(Error::new(format!(
                        "{flag2} {} and {flag} {} are the same file: each output needs a path of its own",
                        p2.display(),
                        p.display()
                    )));
                }
            }
            if let Some(k) = inputs.iter().position(|q| *q == outputs[i]) {
                let (what, q) = &self.inputs[k];
                return Err(Error::new(format!(
                    "{flag} {} is the same file as {what} {}: an output never overwrites an input",
                    p.display(),
                    q.display()
                )));
            }
        }
        Ok(())
    }
}

/// The identity of a path: the open file's (device, inode) where it exists, else its normalised
/// absolute path.
#[derive(Debug, PartialEq, Eq)]
enum Identity {
    File(Handle),
    Path(PathBuf),
}

impl Identity {
    fn of(p: &Path) -> Identity {
        match Handle::from_path(p) {
            Ok(h) => Identity::File(h),
            Err(_) => Identity::Path(normalised(p)),
        }
    }
}

/// `p` absolute, through the canonical form of its nearest existing ancestor, with `.` and `..`
/// resolved.
fn normalised(p: &Path) -> PathBuf {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut clean = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                clean.pop();
            }
            c => clean.push(c),
        }
    }
    // Canonicalise the longest existing prefix (symlinked folders), keep the rest as written.
    let mut rest = Vec::new();
    let mut head = clean.as_path();
    loop {
        if let Ok(c) = head.canonicalize() {
            return rest.iter().rev().fold(c, |acc: PathBuf, n| acc.join(n));
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                head = parent;
            }
            _ => return clean,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_file_by_path_link_and_extension() {
        let d = super::super::test_path("outputs", "x");
        let d = d.parent().unwrap().to_path_buf();
        let a = d.join("a.exr");
        std::fs::write(&a, b"x").unwrap();
        // `./a.exr` style and `d/sub/../a.exr` are the same existing file.
        let dotted = d.join(".").join("a.exr");
        assert!(Files::new().input("the scene", &a).output("--out", &dotted, Format::Exr).check().is_err());
        let sub = d.join("sub");
        std::fs::create_dir_all(&sub).unwrap();
        let up = sub.join("..").join("a.exr");
        assert!(Files::new().input("the scene", &a).output("--out", &up, Format::Exr).check().is_err());
        // A hard link is the same file under another name.
        let hard = d.join("hard.exr");
        let _ = std::fs::remove_file(&hard);
        std::fs::hard_link(&a, &hard).unwrap();
        let e = Files::new().input("part", &a).output("--out", &hard, Format::Exr).check().unwrap_err().to_string();
        assert!(e.contains(&*hard.to_string_lossy()) && e.contains(&*a.to_string_lossy()), "{e}");
        // Two outputs that do not exist yet, one through `..`.
        let n1 = d.join("new.exr");
        let n2 = sub.join("..").join("new.exr");
        let e = Files::new().output("--checkpoint", &n1, Format::Exr).output("--out", &n2, Format::Exr).check();
        assert!(e.unwrap_err().to_string().contains("--checkpoint"));
        // Different files pass; a wrong extension is named.
        assert!(Files::new().input("the scene", &a).output("--out", &n1, Format::Exr).check().is_ok());
        let e = Files::new().output("--png", d.join("s.toml"), Format::Png).check().unwrap_err().to_string();
        assert!(e.contains(".png") && e.contains(".toml") && e.contains("--png"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn symlinks_are_followed() {
        let d = super::super::test_path("outputs-link", "x");
        let d = d.parent().unwrap().to_path_buf();
        let a = d.join("scene.toml");
        std::fs::write(&a, b"x").unwrap();
        let l = d.join("link.png");
        let _ = std::fs::remove_file(&l);
        std::os::unix::fs::symlink(&a, &l).unwrap();
        assert!(Files::new().input("the scene", &a).output("--png", &l, Format::Png).check().is_err());
        // A symlinked folder, the output not existing yet.
        let ld = d.join("linkdir");
        let _ = std::fs::remove_file(&ld);
        std::os::unix::fs::symlink(&d, &ld).unwrap();
        let e = Files::new()
            .output("--out", d.join("o.exr"), Format::Exr)
            .output("--checkpoint", ld.join("o.exr"), Format::Exr)
            .check();
        assert!(e.is_err());
    }
}
