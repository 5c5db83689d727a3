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

/// A folder holding an `sbatch` that queues its job (`ID ARGS… SCRIPT` in `queue` beside it) and
/// prints its id, as `sbatch --parsable` does; [`run_queue`] then runs the jobs as Slurm would.
fn queueing_sbatch(dir: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let script = bin.join("sbatch");
    let b = s(&bin);
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\nn=$(($(cat {b}/next 2>/dev/null || echo 100) + 1))\necho $n > {b}/next\n\
             echo \"$n $*\" >> {b}/queue\necho $n\n"
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    bin
}

/// Runs the queued jobs in order (a job's `--dependency=afterok:ID` must have run), every task of an
/// array (`#SBATCH --array=0-M`), until the queue is empty; jobs the jobs submit are queued too.
/// Returns the number of jobs run.
fn run_queue(bin: &Path, path: &str) -> usize {
    let mut done = std::collections::HashSet::new();
    let mut k = 0;
    loop {
        let queue = std::fs::read_to_string(bin.join("queue")).unwrap_or_default();
        let Some(line) = queue.lines().nth(k) else { return k };
        let words: Vec<&str> = line.split_whitespace().collect();
        let (id, script) = (words[0], Path::new(words[words.len() - 1]));
        for w in &words {
            if let Some(dep) = w.strip_prefix("--dependency=afterok:") {
                assert!(done.contains(dep), "job {id} depends on {dep}, which has not run");
            }
        }
        let text = std::fs::read_to_string(script).unwrap();
        let array = text.lines().find_map(|l| l.strip_prefix("#SBATCH --array=0-")).map(|m| m.parse::<u32>().unwrap());
        let tasks: Vec<Option<u32>> = match array {
            Some(m) => (0..=m).map(Some).collect(),
            None => vec![None],
        };
        for t in tasks {
            let mut c = Command::new("sh");
            c.arg(script).env("PATH", path);
            if let Some(i) = t {
                c.env("SLURM_ARRAY_TASK_ID", i.to_string());
            }
            let o = c.output().unwrap();
            assert!(
                o.status.success(),
                "job {id} {} (task {t:?}): {}{}",
                script.display(),
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            );
        }
        done.insert(id.to_string());
        k += 1;
    }
}

/// A render to a target error in rounds: 3 tasks a round, a first round of 32 spp whose error
/// (17.8 % at the 95th percentile, seed 3) is above the 8.5 % target, so the step jobs submit
/// rounds of doubling samples until the merged state reaches it (64 spp: 11.6 %, 128 spp: 8.0 %). The image is the
/// single render of the total spp byte for byte, every round continues the samples of the ones
/// before, and a step run again does nothing twice.
#[test]
fn rounds_of_shards_reach_the_target_and_merge_to_the_single_render() {
    let dir = common::temp_dir("slurm-rounds");
    let mut f = renderer::scene::SceneFile::parse(renderer::scene::build::DEFAULT_SCENE).unwrap();
    (f.render.width, f.render.height, f.render.spp, f.render.seed) = (24, 16, 4, 3);
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, toml::to_string(&f).unwrap()).unwrap();
    let bin = queueing_sbatch(&dir);
    let final_ = dir.join("final.exr");
    let path = format!("{}:{}", s(&bin), std::env::var("PATH").unwrap_or_default());
    let o = Command::new(env!("CARGO_BIN_EXE_reflect"))
        .args(["slurm", "render", s(&scene), "--tasks", "3", "--out", s(&final_), "--spp", "1024"])
        .args(["--target-rel-error", "0.085", "--first-round-spp", "32"])
        .env("PATH", &path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!final_.exists(), "no image before the rounds ran");
    let jobs = run_queue(&bin, &path);
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("final.slurm/rounds.json")).unwrap()).unwrap();
    let rounds = plan["rounds"].as_array().unwrap();
    assert_eq!(jobs, 2 * rounds.len(), "an array and a step job per round");
    let ranges: Vec<(u64, u64)> =
        rounds.iter().map(|r| (r["start"].as_u64().unwrap(), r["end"].as_u64().unwrap())).collect();
    assert_eq!(ranges, [(0, 32), (32, 64), (64, 128)], "rounds that continue each other, doubling");
    let decisions: Vec<&str> = rounds.iter().map(|r| r["measured"]["decision"].as_str().unwrap()).collect();
    assert_eq!(decisions, ["next", "next", "target"]);
    let errors: Vec<f64> = rounds.iter().map(|r| r["measured"]["rel_error_p95"].as_f64().unwrap()).collect();
    assert!(errors[..2].iter().all(|&e| e > 0.085) && errors[2] <= 0.085, "{errors:?}");

    // The merged image is the single render of the total spp, and its measured error that render's.
    let single = dir.join("single.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_reflect"))
        .args(["render", s(&scene), "--spp", "128", "--out", s(&single), "-q"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let image = std::fs::read(&final_).unwrap();
    assert!(image == std::fs::read(&single).unwrap(), "the rounds' image differs from the single render");
    let single_partial = {
        let mut sc = renderer::scene::Scene::load(&scene).unwrap();
        sc.settings.spp = 128;
        renderer::render::render_range(&sc, &Default::default(), 0, 128).0.unwrap()
    };
    assert_eq!(errors[2], renderer::progressive::p95_rel_error(&single_partial).unwrap());

    // Step 1 and the last step run again (a requeued job): nothing is submitted, nothing rewritten.
    let queue = std::fs::read_to_string(bin.join("queue")).unwrap();
    let state1 = std::fs::read(dir.join("final.slurm/state-1.exr")).unwrap();
    for r in [1, 2] {
        let o =
            Command::new("sh").arg(dir.join(format!("final.slurm/step-{r}.sh"))).env("PATH", &path).output().unwrap();
        assert!(o.status.success());
        assert!(String::from_utf8_lossy(&o.stdout).contains("nothing to do"), "{o:?}");
    }
    assert_eq!(std::fs::read_to_string(bin.join("queue")).unwrap(), queue, "a step run again submitted a job");
    assert!(std::fs::read(dir.join("final.slurm/state-1.exr")).unwrap() == state1);
    assert!(std::fs::read(&final_).unwrap() == image);
    let _ = std::fs::remove_dir_all(dir);
}

/// A step job whose round's parts are missing (its array failed, or it was run by hand too early)
/// fails in one line naming the part, writes nothing and leaves the round undecided; `--samples`
/// beyond the spp is refused.
#[test]
fn a_step_without_its_parts_names_them_and_writes_nothing() {
    let dir = common::temp_dir("slurm-rounds-missing");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, renderer::scene::build::DEFAULT_SCENE).unwrap();
    let bin = queueing_sbatch(&dir);
    let path = format!("{}:{}", s(&bin), std::env::var("PATH").unwrap_or_default());
    let final_ = dir.join("final.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_reflect"))
        .args(["slurm", "render", s(&scene), "--tasks", "2", "--out", s(&final_), "--target-rel-error", "0.05"])
        .env("PATH", &path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let jobs = dir.join("final.slurm");
    let plan = std::fs::read(jobs.join("rounds.json")).unwrap();
    let o = Command::new("sh").arg(jobs.join("step-0.sh")).env("PATH", &path).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: ") && err.contains("r0-part-0.exr"), "{err}");
    assert!(!jobs.join("state-0.exr").exists() && !final_.exists());
    assert!(std::fs::read(jobs.join("rounds.json")).unwrap() == plan, "the plan changed");
    let o = Command::new(env!("CARGO_BIN_EXE_reflect"))
        .args(["render", s(&scene), "--spp", "64", "--samples", "32:96", "--out", s(&dir.join("p.exr"))])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.starts_with("error: --samples 32:96 ends beyond the render's 64 spp") && err.lines().count() == 1,
        "{err}"
    );
    assert!(!dir.join("p.exr").exists());
    let _ = std::fs::remove_dir_all(dir);
}
