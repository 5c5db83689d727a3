//! Issue 12: shards merged bit-exactly, refusals, checkpoint and resume after SIGKILL/SIGTERM, and
//! renders to a target error (all through the `reflect` binary).

mod common;

use analysis::image::read_image;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn reflect(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).output().unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = reflect(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "reflect {args:?} failed: {err}");
    err
}

/// Exit 2 with one line on stderr naming `file`.
fn refused(args: &[&str], file: &Path) -> String {
    let o = reflect(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "reflect {args:?}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains(&file.display().to_string()), "{err} does not name {}", file.display());
    err
}

/// Every channel of two EXR files bit-identical.
fn assert_same_image(a: &Path, b: &Path) {
    let (x, y) = (read_image(a).unwrap(), read_image(b).unwrap());
    assert_eq!(x.channels.keys().collect::<Vec<_>>(), y.channels.keys().collect::<Vec<_>>());
    for (k, v) in &x.channels {
        let w = &y.channels[k];
        let diff = v.iter().zip(w).filter(|(p, q)| p.to_bits() != q.to_bits()).count();
        assert_eq!(diff, 0, "channel {k}: {diff} pixels differ between {} and {}", a.display(), b.display());
    }
}

/// A small scene file (the default sphere) in `dir`.
fn scene_file(dir: &Path, w: u32, h: u32, spp: u32) -> PathBuf {
    let mut f = renderer::scene::SceneFile::parse(renderer::scene::build::DEFAULT_SCENE).unwrap();
    f.render.width = w;
    f.render.height = h;
    f.render.spp = spp;
    let p = dir.join("scene.toml");
    std::fs::write(&p, toml::to_string(&f).unwrap()).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn merged_shards_equal_the_single_render_bit_for_bit() {
    let dir = common::temp_dir("shards");
    let scene = scene_file(&dir, 21, 13, 13);
    let single = dir.join("single.exr");
    ok(&["render", s(&scene), "--out", s(&single), "--quiet"]);
    for n in [1u32, 2, 3, 5, 13] {
        let parts: Vec<PathBuf> = (0..n).map(|i| dir.join(format!("n{n}-part{i}.exr"))).collect();
        for (i, p) in parts.iter().enumerate() {
            ok(&["render", s(&scene), "--shard", &format!("{i}/{n}"), "--out", s(p), "--quiet"]);
        }
        // Parts in reverse order, and (for n ≥ 3) a merge of merges.
        let merged = dir.join(format!("n{n}.exr"));
        let mut args: Vec<&str> = vec!["merge"];
        args.extend(parts.iter().rev().map(|p| s(p)));
        args.extend(["--out", s(&merged), "--quiet"]);
        ok(&args);
        assert_same_image(&single, &merged);
        if n >= 3 {
            let mid = dir.join(format!("n{n}-mid.exr"));
            ok(&["merge", s(&parts[2]), s(&parts[1]), "--partial", "--out", s(&mid), "--quiet"]);
            let merged2 = dir.join(format!("n{n}-2.exr"));
            let mut args: Vec<&str> = vec!["merge", s(&mid)];
            args.extend(parts.iter().enumerate().filter(|(i, _)| *i != 1 && *i != 2).map(|(_, p)| s(p)));
            args.extend(["--out", s(&merged2), "--quiet"]);
            ok(&args);
            assert_same_image(&single, &merged2);
        }
    }
}

/// Every sampler (`--sampler`): the same seed gives the same bits on 1 and 3 threads and from 2
/// or 3 shards merged, at an spp that is not a multiple of the lanes or of Sobol's replicates.
#[test]
fn every_sampler_is_bit_identical_across_threads_and_shards() {
    let dir = common::temp_dir("shards-samplers");
    let scene = scene_file(&dir, 17, 11, 37);
    for sampler in vocab::Sampler::ALL.iter().map(|k| k.name()) {
        let run = |out: &Path, extra: &[&str]| {
            let mut args = vec!["render", s(&scene), "--sampler", sampler, "--seed", "5", "--out", s(out), "--quiet"];
            args.extend(extra);
            ok(&args);
        };
        let single = dir.join(format!("{sampler}-t1.exr"));
        run(&single, &["--threads", "1"]);
        let t3 = dir.join(format!("{sampler}-t3.exr"));
        run(&t3, &["--threads", "3"]);
        assert_same_image(&single, &t3);
        for n in [2u32, 3] {
            let parts: Vec<PathBuf> = (0..n).map(|i| dir.join(format!("{sampler}-n{n}-{i}.exr"))).collect();
            for (i, p) in parts.iter().enumerate() {
                run(p, &["--shard", &format!("{i}/{n}")]);
            }
            let merged = dir.join(format!("{sampler}-n{n}.exr"));
            let mut args: Vec<&str> = vec!["merge"];
            args.extend(parts.iter().map(|p| s(p)));
            args.extend(["--out", s(&merged), "--quiet"]);
            ok(&args);
            assert_same_image(&single, &merged);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A mesh scene (`scenes/mesh-obj-grace.toml`: 320 triangles in the BVH, under the Grace probe):
/// the same seed gives the same bits on 1 and 3 threads and from 2, 3 or 5 shards merged, at an spp
/// that is not a multiple of the lanes, so that shards start and end inside a batch and its BVH
/// packets (a pixel's shadow and bounce rays) hold fewer rays than a whole batch's.
#[test]
fn mesh_scene_is_bit_identical_across_threads_and_shards() {
    let dir = common::temp_dir("shards-mesh");
    let scene = common::root().join("scenes/mesh-obj-grace.toml");
    for sampler in ["sobol", "sobol-single"] {
        let run = |out: &Path, extra: &[&str]| {
            let mut args = vec!["render", s(&scene), "--size", "24x24", "--spp", "37", "--seed", "5"];
            args.extend(["--sampler", sampler, "--out", s(out), "--quiet"]);
            args.extend(extra);
            ok(&args);
        };
        let single = dir.join(format!("{sampler}-t1.exr"));
        run(&single, &["--threads", "1"]);
        let t3 = dir.join(format!("{sampler}-t3.exr"));
        run(&t3, &["--threads", "3"]);
        assert_same_image(&single, &t3);
        for n in [2u32, 3, 5] {
            let parts: Vec<PathBuf> = (0..n).map(|i| dir.join(format!("{sampler}-n{n}-{i}.exr"))).collect();
            for (i, p) in parts.iter().enumerate() {
                run(p, &["--shard", &format!("{i}/{n}")]);
            }
            let merged = dir.join(format!("{sampler}-n{n}.exr"));
            let mut args: Vec<&str> = vec!["merge"];
            args.extend(parts.iter().map(|p| s(p)));
            args.extend(["--out", s(&merged), "--quiet"]);
            ok(&args);
            assert_same_image(&single, &merged);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn merge_refuses_mismatched_overlapping_and_missing_parts() {
    let dir = common::temp_dir("shard-refusals");
    let scene = scene_file(&dir, 8, 8, 8);
    let part = |name: &str, extra: &[&str]| {
        let p = dir.join(name);
        let mut args = vec!["render", s(&scene), "--out", s(&p), "--quiet"];
        args.extend(extra);
        ok(&args);
        p
    };
    let a0 = part("a0.exr", &["--shard", "0/2"]);
    let a1 = part("a1.exr", &["--shard", "1/2"]);
    let seed = part("seed.exr", &["--shard", "1/2", "--seed", "7"]);
    let spp = part("spp.exr", &["--shard", "1/2", "--spp", "16"]);
    let size = part("size.exr", &["--shard", "1/2", "--size", "8x4"]);
    let b0 = part("b0.exr", &["--shard", "0/3"]);
    let out = dir.join("out.exr");
    let o = s(&out);
    assert!(refused(&["merge", s(&a0), s(&seed), "--out", o], &seed).contains("seed"));
    assert!(refused(&["merge", s(&a0), s(&spp), "--out", o], &spp).contains("spp"));
    assert!(refused(&["merge", s(&a0), s(&size), "--out", o], &size).contains("scene"));
    assert!(refused(&["merge", s(&a0), s(&a1), s(&b0), "--out", o], &a0).contains("overlap"));
    assert!(refused(&["merge", s(&a0), "--out", o], &a0).contains("missing"));
    assert!(refused(&["merge", s(&a1), "--out", o], &a1).contains("missing"));
    assert!(refused(&["merge", s(&scene), "--out", o], &scene).contains("OpenEXR"));
    let plain = dir.join("plain.exr");
    ok(&["render", s(&scene), "--out", s(&plain), "--quiet"]);
    assert!(refused(&["merge", s(&plain), "--out", o], &plain).contains("not a partial render"));
    assert!(!out.exists(), "no output after a refusal");
    // A checkpoint of another scene is refused too.
    let ck = dir.join("ck.exr");
    std::fs::copy(&size, &ck).unwrap();
    refused(&["render", s(&scene), "--checkpoint", s(&ck), "--out", o, "--quiet"], &ck);
}

/// The process is killed (SIGKILL) at pseudo-random moments after it saved a checkpoint, four times,
/// and each run starts where the last saved checkpoint ended (the saved sample count never goes back:
/// a run that started again from sample 0 would be seen saving fewer samples first); then SIGTERM makes it
/// save and exit 130; the same command then finishes, the final image equals an uninterrupted render bit
/// for bit, and the checkpoint is gone.
#[test]
fn killed_and_resumed_render_is_bit_identical() {
    let dir = common::temp_dir("resume");
    // 1024 passes of 1 spp, each saved (--checkpoint-every 0): seconds in all, so every kill comes
    // long before the end.
    let scene = scene_file(&dir, 48, 48, 1024);
    let single = dir.join("single.exr");
    ok(&["render", s(&scene), "--out", s(&single), "--quiet"]);
    let out = dir.join("out.exr");
    let ck = dir.join("ck.exr");
    let args = ["render", s(&scene), "--out", s(&out), "--checkpoint", s(&ck), "--checkpoint-every", "0", "--quiet"];
    // The sample count a checkpoint has saved (None while there is none, or while it is being replaced).
    let saved = || renderer::shard::read_partial(&ck).ok().map(|f| f.partial.end);
    // Spawns the command and waits until it has saved a checkpoint beyond `after`.
    let run_until_saved_beyond = |after: u64| {
        let child = Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).spawn().unwrap();
        let t = std::time::Instant::now();
        loop {
            // Every checkpoint this run saves starts from the one it resumed: a run that started
            // again from sample 0 would be seen saving fewer samples on its way back.
            match saved() {
                Some(n) if n > after => break,
                Some(n) => assert!(n == after, "the checkpoint went back from sample {after} to {n}: no resume"),
                None => {}
            }
            assert!(t.elapsed().as_secs() < 120, "no checkpoint beyond sample {after} within 120 s");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        child
    };
    // Extra delays after a save from a fixed LCG: the moments differ between kills, not between runs.
    let mut x: u64 = 12345;
    let mut last = 0;
    for kill in 0..4 {
        let mut child = run_until_saved_beyond(last);
        x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        std::thread::sleep(std::time::Duration::from_millis((x >> 33) % 40));
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        assert!(!out.exists(), "kill {kill}: the render finished before it was killed; make it longer");
        let now = saved().expect("a checkpoint survives SIGKILL (it is replaced atomically)");
        assert!(now > last, "kill {kill}: the checkpoint went from sample {last} to {now}");
        last = now;
    }
    // SIGTERM once the process has saved (so its handler is installed): it saves and exits 130.
    let mut child = run_until_saved_beyond(last);
    sigterm(child.id());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "SIGTERM exits 130 after saving");
    assert!(!out.exists());
    assert!(saved().is_some_and(|n| n > last && n < 1024), "SIGTERM saved the samples done: {:?}", saved());
    ok(&args);
    assert!(!ck.exists(), "the checkpoint is removed after the final image");
    assert_same_image(&single, &out);
}

fn sigterm(pid: u32) {
    let _ = Command::new("kill").args(["-TERM", &pid.to_string()]).status();
}

/// A render to a target error stops at some spp n and equals a plain render with --spp n.
#[test]
fn target_error_render_equals_a_plain_render_of_the_spp_reached() {
    let dir = common::temp_dir("target");
    let scene = scene_file(&dir, 16, 16, 4096);
    let out = dir.join("target.exr");
    let err = ok(&["render", s(&scene), "--out", s(&out), "--target-rel-error", "0.05"]);
    let line = err.lines().find(|l| l.starts_with("progressive: ")).unwrap_or_else(|| panic!("{err}"));
    let n: u32 = line["progressive: ".len()..].split_whitespace().next().unwrap().parse().unwrap();
    assert!(line.contains("reached"), "{line}");
    assert!(n < 4096 && n.is_power_of_two(), "{line}");
    let plain = dir.join("plain.exr");
    ok(&["render", s(&scene), "--out", s(&plain), "--spp", &n.to_string(), "--quiet"]);
    assert_same_image(&plain, &out);
    // The noise line of the plain render reports a 95th percentile at or below the target.
    let e = ok(&["render", s(&scene), "--out", s(&plain), "--spp", &n.to_string()]);
    assert!(e.contains("95th percentile"), "{e}");
    // --json reports the spp reached (not the cap of 4096), the target, the passes (1, 1, 2, 4, … spp:
    // 1 + log2 n of them) and the error reached, which is at or below the target; one line per pass
    // on stderr.
    let out = Command::new(env!("CARGO_BIN_EXE_reflect"))
        .args(["render", s(&scene), "--out", s(&out), "--target-rel-error", "0.05", "--json"])
        .output()
        .unwrap();
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let p = &doc["progressive"];
    assert_eq!(doc["spp"].as_u64(), Some(n as u64), "{doc}");
    assert_eq!((p["spp_cap"].as_u64(), p["target_rel_error"].as_f64()), (Some(4096), Some(0.05)), "{doc}");
    assert_eq!(p["passes"].as_u64(), Some(1 + n.trailing_zeros() as u64), "{doc}");
    assert_eq!((p["stopped_by"].as_str(), p["target_reached"].as_bool()), (Some("target"), Some(true)), "{doc}");
    assert!(p["rel_error_p95"].as_f64().is_some_and(|e| e <= 0.05), "{doc}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().filter(|l| l.starts_with("pass ")).count() as u64, p["passes"].as_u64().unwrap(), "{err}");
}
