//! `reflect slurm render`'s job scripts without a cluster: `sbatch` is a stand-in on PATH that records
//! its arguments, and the scripts are run by `sh` as Slurm would run them (SLURM_ARRAY_TASK_ID set).
//! A shard task checkpoints and is requeueable; a task "preempted" after its first pass (its
//! checkpoint left behind, as SIGTERM leaves it) resumes from the checkpoint when run again, and the
//! merge is the single render's file byte for byte.

mod common;

use renderer::progressive::{Checkpoint, Event, Outcome, ProgressiveOptions, render_progressive, shard_range};
use renderer::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A folder holding an `sbatch` that appends its arguments to `sbatch.log` beside it and prints a job id.
fn fake_sbatch(dir: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let script = bin.join("sbatch");
    std::fs::write(&script, format!("#!/bin/sh\necho \"$@\" >> {}/sbatch.log\necho 4242\n", s(&bin))).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    bin
}

/// Runs `sh script` with the task id (None: the merge job); returns its stderr (the job's log).
fn run_job(script: &Path, task: Option<u32>) -> String {
    let mut c = Command::new("sh");
    c.arg(script);
    if let Some(i) = task {
        c.env("SLURM_ARRAY_TASK_ID", i.to_string());
    }
    let o = c.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{} (task {task:?}): {err}", script.display());
    err
}

/// Leaves behind what a preempted shard task leaves: its checkpoint, holding the samples of its
/// first pass only (the render cancelled after it, as SIGTERM cancels it).
fn preempted_checkpoint(scene: &Path, shard: (u32, u32), path: &Path) -> u64 {
    let sc = Scene::load(scene).unwrap();
    let range = shard_range(shard.0, shard.1, sc.settings.spp);
    let cancel = Arc::new(AtomicBool::new(false));
    let opts = ProgressiveOptions {
        range: Some(range),
        checkpoint: Some(Checkpoint {
            path: path.to_path_buf(),
            every: std::time::Duration::from_secs(3600),
            attributes: renderer::output::header_attributes(&sc),
        }),
        cancel: Some(cancel.clone()),
        ..Default::default()
    };
    let out = render_progressive(&sc, &opts, &mut |e| {
        if let Event::Pass(_) = e {
            cancel.store(true, Ordering::Relaxed);
        }
    })
    .unwrap();
    let Outcome::Cancelled { state } = out else { panic!("not cancelled") };
    assert!(state.end > range.0 && state.end < range.1, "a checkpoint inside the shard: {range:?} {}", state.end);
    state.end
}

#[test]
fn a_preempted_shard_resumes_from_its_checkpoint_and_the_merge_is_the_single_render() {
    let dir = common::temp_dir("slurm-scripts");
    let mut f = renderer::scene::SceneFile::parse(renderer::scene::build::DEFAULT_SCENE).unwrap();
    (f.render.width, f.render.height, f.render.spp, f.render.seed) = (24, 16, 40, 3);
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, toml::to_string(&f).unwrap()).unwrap();
    let bin = fake_sbatch(&dir);
    let final_ = dir.join("final.exr");
    let path = format!("{}:{}", s(&bin), std::env::var("PATH").unwrap_or_default());
    let o = Command::new(env!("CARGO_BIN_EXE_reflect"))
        .args(["slurm", "render", s(&scene), "--tasks", "4", "--out", s(&final_), "--checkpoint-every", "30"])
        .env("PATH", &path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let jobs = dir.join("final.slurm");
    let (shard_sh, merge_sh) = (jobs.join("shard.sh"), jobs.join("merge.sh"));
    let log = std::fs::read_to_string(bin.join("sbatch.log")).unwrap();
    assert!(log.contains("--dependency=afterok:4242"), "the merge waits for the array: {log}");
    // Task 1 was preempted after its first pass: its checkpoint is there when it runs again.
    let ck = jobs.join("ckpt-1.exr");
    let at = preempted_checkpoint(&scene, (1, 4), &ck);
    for i in 0..4 {
        let err = run_job(&shard_sh, Some(i));
        if i == 1 {
            assert!(err.contains(&format!("resuming from {} at sample {at}", s(&ck))), "task 1 resumed: {err}");
        } else {
            assert!(!err.contains("resuming"), "task {i} had no checkpoint: {err}");
        }
    }
    assert!(!ck.exists(), "a finished shard removes its checkpoint (the merge must not see it)");
    // Slurm requeues the task (a preemption, a node failure) with the same command, appending to its log.
    let shard_text = std::fs::read_to_string(&shard_sh).unwrap();
    for line in ["#SBATCH --requeue", "#SBATCH --open-mode=append", "--checkpoint-every 30"] {
        assert!(shard_text.contains(line), "{line:?} in the shard script:\n{shard_text}");
    }
    assert!(shard_text.contains("ckpt-\"$SLURM_ARRAY_TASK_ID\".exr"), "a checkpoint per task:\n{shard_text}");

    run_job(&merge_sh, None);
    let single = dir.join("single.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_reflect")).args(["render", s(&scene), "--out", s(&single), "-q"]).output();
    assert!(o.unwrap().status.success());
    assert!(
        std::fs::read(&final_).unwrap() == std::fs::read(&single).unwrap(),
        "the merge differs from the single render"
    );
    let _ = std::fs::remove_dir_all(dir);
}
