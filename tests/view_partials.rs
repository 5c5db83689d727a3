//! Looking at a long render while it runs: `reflect png`, `analyze` and `compare` read a render's
//! state (a checkpoint, a `reflect merge --partial` of the first shards, a shard 0, a `--state` file)
//! as the image `reflect render` writes at the spp the state holds (`renderer::render_file`): the
//! same EXR bytes, the same PNG bytes, the same analyses. A state that is not a render's first
//! samples, or a corrupt one, is refused in one line naming it.

mod common;

use common::*;
use renderer::progressive::{Checkpoint, Event, Outcome, ProgressiveOptions, render_progressive};
use renderer::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// The default sphere (Lambert 0.8) under an SH light of order 1 (which `analyze` reads from the
/// header), 32², seed 5, in `dir`.
fn scene_file(dir: &Path) -> PathBuf {
    let mut f = renderer::scene::SceneFile::parse(renderer::scene::build::DEFAULT_SCENE).unwrap();
    (f.render.width, f.render.height, f.render.spp, f.render.seed) = (32, 32, 64, 5);
    f.lighting = vocab::scene::LightingSection::Sh {
        coefficients: vec![[3.0, 3.0, 3.0], [0.2, 0.0, 0.0], [0.8, 0.8, 0.6], [0.0, 0.3, 0.0]],
    };
    let p = dir.join("scene.toml");
    std::fs::write(&p, toml::to_string(&f).unwrap()).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn ok(args: &[&str]) -> String {
    let (code, err) = reflect(args);
    assert_eq!(code, 0, "reflect {args:?}: {err}");
    err
}

/// A real checkpoint: the render of `scene` to 64 spp, interrupted (as Ctrl-C does) after its fifth
/// pass, which saves the state of samples [0, 16) to `path`.
fn checkpoint(scene: &Path, path: &Path) {
    let sc = Scene::load(scene).unwrap();
    let cancel = Arc::new(AtomicBool::new(false));
    let opts = ProgressiveOptions {
        target_rel_error: Some(1e-9),
        checkpoint: Some(Checkpoint {
            path: path.to_path_buf(),
            every: std::time::Duration::from_secs(3600),
            attributes: renderer::output::header_attributes(&sc),
        }),
        cancel: Some(cancel.clone()),
        ..Default::default()
    };
    let out = render_progressive(&sc, &opts, &mut |e| {
        if let Event::Pass(p) = e
            && p.pass == 5
        {
            cancel.store(true, Ordering::Relaxed);
        }
    })
    .unwrap();
    assert!(matches!(out, Outcome::Cancelled { ref state } if state.end == 16), "cancelled after [0, 16)");
}

/// The states of this test, each with the spp it holds: a checkpoint, a shard 0, a merge of the
/// first two of three shards, and the `--state` file of a finished render.
fn states(dir: &Path, scene: &Path) -> Vec<(PathBuf, u32)> {
    let ck = dir.join("checkpoint.exr");
    checkpoint(scene, &ck);
    let shard0 = dir.join("shard0.exr");
    ok(&["render", s(scene), "--spp", "24", "--shard", "0/2", "--out", s(&shard0), "-q"]);
    let thirds: Vec<PathBuf> = (0..3).map(|i| dir.join(format!("third{i}.exr"))).collect();
    for (i, p) in thirds.iter().enumerate() {
        ok(&["render", s(scene), "--spp", "30", "--shard", &format!("{i}/3"), "--out", s(p), "-q"]);
    }
    let partial = dir.join("partial.exr");
    ok(&["merge", s(&thirds[0]), s(&thirds[1]), "--partial", "--out", s(&partial), "-q"]);
    let (done, state) = (dir.join("done.exr"), dir.join("done.state.exr"));
    ok(&["render", s(scene), "--spp", "9", "--out", s(&done), "--state", s(&state), "-q"]);
    vec![(ck, 16), (shard0, 12), (partial, 20), (state, 9)]
}

/// The finished render of `scene` at `spp`, written once per spp.
fn finished(dir: &Path, scene: &Path, spp: u32) -> PathBuf {
    let out = dir.join(format!("finished-{spp}.exr"));
    if !out.exists() {
        ok(&["render", s(scene), "--spp", &spp.to_string(), "--out", s(&out), "-q"]);
    }
    out
}

/// The image of a state, written as a render writes its image, is the finished render's file byte
/// for byte (every layer and the header, whose spp is the state's); its PNG is the finished
/// render's PNG byte for byte, at the same automatic exposure.
#[test]
fn a_state_reads_as_the_render_of_its_samples() {
    let dir = temp_dir("view-states");
    let scene = scene_file(&dir);
    for (state, spp) in states(&dir, &scene) {
        let fin = finished(&dir, &scene, spp);
        let (img, notes) = renderer::render_file::read_image_notes(&state).unwrap();
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].contains(&format!("{spp}")), "the note says the spp: {notes:?}");
        let st = renderer::render_file::state_image(&state, renderer::shard::read_partial(&state).unwrap()).unwrap();
        assert_eq!(st.spp, spp);
        let rewritten = dir.join(format!("rewritten-{spp}.exr"));
        renderer::output::write_exr(&rewritten, &st.film, &st.attributes).unwrap();
        assert!(
            std::fs::read(&rewritten).unwrap() == std::fs::read(&fin).unwrap(),
            "{}: its image's file differs from the {spp}-spp render's",
            state.display()
        );
        // What the readers get: the finished file's channels and header.
        let want = analysis::image::read_image(&fin).unwrap();
        assert_eq!(img.attributes, want.attributes, "{}", state.display());
        assert_eq!(img.channels.keys().collect::<Vec<_>>(), want.channels.keys().collect::<Vec<_>>());
        for (k, v) in &want.channels {
            let bits = |x: &[f32]| x.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&img.channels[k]), bits(v), "{}: channel {k}", state.display());
        }
        let (a, b) = (dir.join(format!("state-{spp}.png")), dir.join(format!("finished-{spp}.png")));
        let err_a = ok(&["png", s(&state), "--out", s(&a)]);
        let err_b = ok(&["png", s(&fin), "--out", s(&b)]);
        assert!(err_a.contains("note:") && err_a.contains("render state"), "the note is printed: {err_a}");
        let ev = |e: &str| e.lines().find(|l| l.contains("EV")).map(|l| l.split(": ").nth(1).unwrap().to_string());
        assert_eq!(ev(&err_a), ev(&err_b), "the same automatic exposure");
        assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(), "{}: PNG bytes differ", state.display());
        // Its error bars too: the stderr layer.
        let (a, b) = (dir.join(format!("state-{spp}-se.png")), dir.join(format!("finished-{spp}-se.png")));
        ok(&["png", s(&state), "--layer", "stderr", "--out", s(&a)]);
        ok(&["png", s(&fin), "--layer", "stderr", "--out", s(&b)]);
        assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(), "{}: stderr PNG differs", state.display());
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// `analyze` and `compare` of a state say what they say of the finished render of its samples.
#[test]
fn analyze_and_compare_of_a_state_equal_the_finished_render() {
    let dir = temp_dir("view-analyze");
    let scene = scene_file(&dir);
    let thirds: Vec<PathBuf> = (0..3).map(|i| dir.join(format!("third{i}.exr"))).collect();
    for (i, p) in thirds.iter().enumerate() {
        ok(&["render", s(&scene), "--spp", "48", "--shard", &format!("{i}/3"), "--out", s(p), "-q"]);
    }
    let partial = dir.join("partial.exr");
    ok(&["merge", s(&thirds[0]), s(&thirds[1]), "--partial", "--out", s(&partial), "-q"]);
    let fin = finished(&dir, &scene, 32);
    let other = dir.join("other.exr");
    ok(&["render", s(&scene), "--spp", "32", "--seed", "9", "--out", s(&other), "-q"]);
    // File names differ between the two runs; everything else must be the same text.
    let run = |args: &[&str], name: &Path| {
        let (code, out, err) = reflect_out(args);
        // compare exits 1 when the images disagree: a verdict, not a failure.
        assert!(code == 0 || (code == 1 && args[0] == "compare"), "{args:?}: {err}");
        (code, out.replace(s(name), "IMAGE"))
    };
    let a = run(&["analyze", s(&partial), "--lmax", "2", "--json"], &partial);
    let b = run(&["analyze", s(&fin), "--lmax", "2", "--json"], &fin);
    assert!(a.1.starts_with('{'), "analyze printed its report: {a:?}");
    assert_eq!(a, b, "analyze of the partial and of the finished render");
    let a = run(&["compare", s(&partial), s(&other), "--json"], &partial);
    let b = run(&["compare", s(&fin), s(&other), "--json"], &fin);
    assert!(a.1.contains("\"verdict\""), "compare printed its report: {a:?}");
    assert_eq!(a, b, "compare of the partial and of the finished render");
    let _ = std::fs::remove_dir_all(dir);
}

/// A state that is not a render's first samples (shard 1 of 2), and a corrupt state, are refused by
/// `png`, `analyze` and `compare`: exit 2, one line naming the file and saying why, no output.
#[test]
fn states_that_are_not_an_image_are_refused_in_one_line() {
    let dir = temp_dir("view-refused");
    let scene = scene_file(&dir);
    let shard1 = dir.join("shard1.exr");
    ok(&["render", s(&scene), "--spp", "8", "--shard", "1/2", "--out", s(&shard1), "-q"]);
    let other = finished(&dir, &scene, 4);
    let corrupt = dir.join("corrupt.exr");
    let shard0 = dir.join("shard0.exr");
    ok(&["render", s(&scene), "--spp", "8", "--shard", "0/2", "--out", s(&shard0), "-q"]);
    let bytes = std::fs::read(&shard0).unwrap();
    std::fs::write(&corrupt, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let out = dir.join("out.png");
    let report = dir.join("report");
    for (file, name, why) in [(&shard1, "shard1.exr", "samples [4, 8)"), (&corrupt, "corrupt.exr", "")] {
        assert_bad_input(&["png", s(file), "--out", s(&out)], name, why, &out);
        assert_bad_input(&["analyze", s(file), "--lmax", "2"], name, why, &out);
        assert_bad_input(&["compare", s(file), s(&other), "--report", s(&report)], name, why, &report);
        assert_bad_input(&["compare", s(&other), s(file), "--report", s(&report)], name, why, &report);
    }
    let _ = std::fs::remove_dir_all(dir);
}
