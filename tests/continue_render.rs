//! Issue 36: `reflect render --continue STATE --spp N` extends a render to N samples with the bits of
//! rendering N at once (from a `--state` file, a checkpoint, or a merged partial), and refuses states
//! it cannot continue: exit 2, one `error:` line naming the file, no output written, the state untouched.

mod common;

use std::path::{Path, PathBuf};

/// A small scene file (the default sphere) in `dir`.
fn scene_file(dir: &Path, spp: u32) -> PathBuf {
    let mut f = renderer::scene::SceneFile::parse(renderer::scene::build::DEFAULT_SCENE).unwrap();
    f.render.width = 19;
    f.render.height = 11;
    f.render.spp = spp;
    let p = dir.join("scene.toml");
    std::fs::write(&p, toml::to_string(&f).unwrap()).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn ok(args: &[&str]) {
    let (code, err) = common::reflect(args);
    assert_eq!(code, 0, "reflect {args:?}: {err}");
}

/// Every channel of two EXR files bit-identical.
fn assert_same_image(a: &Path, b: &Path) {
    let (x, y) = (analysis::image::read_image(a).unwrap(), analysis::image::read_image(b).unwrap());
    assert_eq!(x.channels.keys().collect::<Vec<_>>(), y.channels.keys().collect::<Vec<_>>());
    for (k, v) in &x.channels {
        let w = &y.channels[k];
        let diff = v.iter().zip(w).filter(|(p, q)| p.to_bits() != q.to_bits()).count();
        assert_eq!(diff, 0, "channel {k}: {diff} pixels differ between {} and {}", a.display(), b.display());
    }
}

#[test]
fn continued_renders_equal_the_single_render_bit_for_bit() {
    let dir = common::temp_dir("continue");
    let scene = scene_file(&dir, 8);
    let single = dir.join("single.exr");
    ok(&["render", s(&scene), "--spp", "45", "--seed", "5", "--out", s(&single), "-q"]);
    // 7 → 20 → 45 samples (ranges that are not powers of two), the state re-written at each step.
    let (a, a_state) = (dir.join("a.exr"), dir.join("a.state.exr"));
    ok(&["render", s(&scene), "--spp", "7", "--seed", "5", "--out", s(&a), "--state", s(&a_state), "-q"]);
    let (b, b_state) = (dir.join("b.exr"), dir.join("b.state.exr"));
    let cont = |from: &Path, spp: &str, out: &Path, state: &Path| {
        ok(&[
            "render",
            s(&scene),
            "--seed",
            "5",
            "--continue",
            s(from),
            "--spp",
            spp,
            "--out",
            s(out),
            "--state",
            s(state),
            "-q",
        ])
    };
    cont(&a_state, "20", &b, &b_state);
    let (c, c_state) = (dir.join("c.exr"), dir.join("c.state.exr"));
    cont(&b_state, "45", &c, &c_state);
    assert_same_image(&single, &c);
    assert_eq!(std::fs::read(&single).unwrap(), std::fs::read(&c).unwrap(), "file bytes differ");
    // The 7-sample image itself is the plain 7-sample render.
    let seven = dir.join("seven.exr");
    ok(&["render", s(&scene), "--spp", "7", "--seed", "5", "--out", s(&seven), "-q"]);
    assert_same_image(&seven, &a);
    // A merged partial of shards from 0 (reflect merge --partial) continues too.
    let parts: Vec<PathBuf> = (0..2).map(|i| dir.join(format!("p{i}.exr"))).collect();
    for (i, p) in parts.iter().enumerate() {
        ok(&["render", s(&scene), "--spp", "12", "--seed", "5", "--shard", &format!("{i}/2"), "--out", s(p), "-q"]);
    }
    let merged = dir.join("merged.exr");
    ok(&["merge", s(&parts[0]), s(&parts[1]), "--partial", "--out", s(&merged), "-q"]);
    let d = dir.join("d.exr");
    ok(&["render", s(&scene), "--seed", "5", "--continue", s(&merged), "--spp", "45", "--out", s(&d), "-q"]);
    assert_same_image(&single, &d);
    // With a target error, continuing stops where the single progressive render stops, same bits.
    let (t1, t2) = (dir.join("t1.exr"), dir.join("t2.exr"));
    let target = ["--target-rel-error", "0.2", "--spp", "256", "--seed", "5", "-q"];
    ok(&[&["render", s(&scene), "--out", s(&t1)][..], &target].concat());
    ok(&[&["render", s(&scene), "--continue", s(&a_state), "--out", s(&t2)][..], &target].concat());
    assert_same_image(&t1, &t2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn states_that_cannot_be_continued_are_refused() {
    let dir = common::temp_dir("continue-refused");
    let scene = scene_file(&dir, 8);
    let (img, state) = (dir.join("a.exr"), dir.join("a.state.exr"));
    ok(&["render", s(&scene), "--spp", "9", "--seed", "5", "--out", s(&img), "--state", s(&state), "-q"]);
    let part1 = dir.join("part1.exr");
    ok(&["render", s(&scene), "--spp", "9", "--seed", "5", "--shard", "1/2", "--out", s(&part1), "-q"]);
    let other = dir.join("other.toml");
    std::fs::write(&other, std::fs::read_to_string(&scene).unwrap().replace("width = 19", "width = 18")).unwrap();
    let before: Vec<Vec<u8>> = [&img, &state].iter().map(|p| std::fs::read(p).unwrap()).collect();
    let out = dir.join("out.exr");
    let cases: Vec<(Vec<&str>, &Path, &str)> = vec![
        (vec!["--continue", s(&state), "--spp", "4", "--seed", "5"], &state, "more than --spp 4"),
        (vec!["--continue", s(&state), "--spp", "20", "--seed", "6"], &state, "a different seed"),
        (vec!["--continue", s(&img), "--spp", "20", "--seed", "5"], &img, "not a render state"),
        (vec!["--continue", s(&part1), "--spp", "20", "--seed", "5"], &part1, "not a render from sample 0"),
        (vec!["--continue", s(&state), "--spp", "20", "--seed", "5", "--shard", "0/2"], &state, ""),
    ];
    for (args, file, why) in cases {
        let all = [&["render", s(&scene), "--out", s(&out)][..], &args].concat();
        let (code, err) = common::reflect(&all);
        assert_eq!(code, 2, "{all:?}: {err}");
        assert_eq!(err.lines().filter(|l| l.starts_with("error:")).count(), 1, "{err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        if why.is_empty() {
            assert!(err.contains("--shard"), "{err}");
        } else {
            assert!(err.contains(&file.display().to_string()) && err.contains(why), "{all:?}: {err}");
        }
        assert!(!out.exists(), "{all:?} wrote {}", out.display());
    }
    // Another scene (here another image size, which is in the fingerprint).
    let (code, err) = common::reflect(&[
        "render",
        s(&other),
        "--continue",
        s(&state),
        "--spp",
        "20",
        "--seed",
        "5",
        "--out",
        s(&out),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("a different scene") && err.trim().lines().count() == 1, "{err}");
    // The state as its own output: refused before anything is read or written.
    let (code, err) = common::reflect(&[
        "render",
        s(&scene),
        "--continue",
        s(&state),
        "--spp",
        "20",
        "--seed",
        "5",
        "--out",
        s(&state),
    ]);
    assert_eq!(code, 2, "{err}");
    let after: Vec<Vec<u8>> = [&img, &state].iter().map(|p| std::fs::read(p).unwrap()).collect();
    assert!(before == after, "a refused --continue changed its input");
    let _ = std::fs::remove_dir_all(&dir);
}
