//! `reflect slurm render SCENE --tasks N --out FINAL.exr [--partition P] [--time T] [--dry-run]
//! [--wait] [-- EXTRA_SBATCH_ARGS…]`: renders a scene on a Slurm cluster as a job array of N shard
//! tasks (`reflect render --shard $SLURM_ARRAY_TASK_ID/N`) and a merge job that runs after all of
//! them succeeded (`--dependency=afterok`, `--kill-on-invalid-dep=yes` so that a failed shard fails
//! the merge instead of leaving it pending). The scripts, logs and parts go to `FINAL.slurm/` next to
//! the output, which must be on a file system every node sees.
//!
//! Each shard task checkpoints (`--checkpoint FINAL.slurm/ckpt-I.exr`, every `--checkpoint-every`
//! seconds and on the SIGTERM of a preemption or time limit) and is requeueable (`#SBATCH --requeue`,
//! logs appended): a requeued task runs the same command, which resumes from its checkpoint, so a
//! preempted shard loses at most one pass and the merge is still bit-identical to a single render.
//!
//! With `--target-rel-error X`, the render runs in rounds (`renderer::rounds`): round r is a job
//! array over the samples `[S_{r-1}, S_r)` and a step job (`reflect slurm step DIR --round r`) that
//! merges the state of the rounds so far, measures its 95th-percentile relative error and either
//! writes the image or submits round r + 1. `DIR/rounds.json` records the plan and every round, so
//! that a step run again does nothing twice.

use super::Error;
use super::outputs::Format;
use super::render::{RenderArgs, load_scene, parse_threads};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

#[derive(clap::Subcommand, Debug, Clone)]
pub enum SlurmCommand {
    /// Render a scene as a job array of shards and a merge job (or, with --target-rel-error, in rounds).
    Render(SlurmRenderArgs),
    /// The job that ends a round of a render in rounds: merge, measure, then finish or submit the next round.
    Step(SlurmStepArgs),
}

#[derive(clap::Args, Debug, Clone)]
pub struct SlurmStepArgs {
    /// The job folder of a render in rounds (FINAL.slurm/, holding rounds.json).
    pub dir: PathBuf,
    /// The round that has just finished (0, 1, …).
    #[arg(long)]
    pub round: usize,
}

#[derive(clap::Args, Debug, Clone)]
pub struct SlurmRenderArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Number of shard tasks (at most the spp).
    #[arg(long)]
    pub tasks: u32,
    /// The merged image (OpenEXR); scripts, logs and parts go to OUT's stem + `.slurm/` beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// Slurm partition (sbatch --partition).
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit of each task (sbatch --time, e.g. 1:00:00).
    #[arg(long)]
    pub time: Option<String>,
    /// Threads per task (sbatch --cpus-per-task and reflect --threads) [default: the site's default].
    #[arg(long, value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Samples per pixel (overrides render.spp); with --target-rel-error, the most to take over all rounds.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Random seed (overrides render.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Seconds between a shard task's checkpoint saves (it also saves on SIGTERM, and a requeued task
    /// resumes from its checkpoint).
    #[arg(long, default_value_t = 600.0)]
    pub checkpoint_every: f64,
    /// Render in rounds until the 95th percentile of the object pixels' relative standard error (worst
    /// channel) of the merged image is at most X: each round a job array, then a step job that merges,
    /// measures and submits the next round (about (error / X)² times the samples so far, at most double).
    #[arg(long)]
    pub target_rel_error: Option<f64>,
    /// With --target-rel-error: submit no round that would end more than SECS seconds after the
    /// first was submitted (predicted from the last round's time per sample).
    #[arg(long, requires = "target_rel_error")]
    pub time_limit: Option<f64>,
    /// With --target-rel-error: samples per pixel of the first round (at least 16, whole rounds of the
    /// Sobol sampler's 16 replicates).
    #[arg(long, default_value_t = 64, requires = "target_rel_error")]
    pub first_round_spp: u64,
    /// Print the two job scripts and the sbatch commands; submit nothing, write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Block until the merge job has finished (exit 1 if it failed).
    #[arg(long)]
    pub wait: bool,
    /// Further sbatch options for both jobs, after `--` (e.g. -- --account=proj --qos=normal).
    #[arg(last = true)]
    pub sbatch_args: Vec<String>,
}

/// `s` quoted for a POSIX shell.
pub(super) fn sh_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

pub(super) fn abs(p: &Path) -> Result<PathBuf, Error> {
    std::path::absolute(p).map_err(|e| Error::file(p, format!("cannot make the path absolute: {e}")))
}

/// The shard-array and merge scripts.
fn scripts(a: &SlurmRenderArgs, exe: &Path, scene: &Path, dir: &Path, out: &Path) -> (String, String) {
    let q = |p: &Path| sh_quote(&p.to_string_lossy());
    let mut head = String::new();
    if let Some(p) = &a.partition {
        head += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &a.time {
        head += &format!("#SBATCH --time={t}\n");
    }
    let mut overrides = String::new();
    if let Some(n) = a.threads {
        head += &format!("#SBATCH --cpus-per-task={n}\n");
        overrides += &format!(" --threads {n}");
    }
    if let Some(s) = a.spp {
        overrides += &format!(" --spp {s}");
    }
    if let Some(s) = a.seed {
        overrides += &format!(" --seed {s}");
    }
    let shard = format!(
        "#!/bin/sh\n#SBATCH --job-name=reflect-shard\n#SBATCH --array=0-{last}\n#SBATCH --output={log}\n\
         #SBATCH --open-mode=append\n#SBATCH --requeue\n{head}\
         # One shard of the render: samples [I·spp/N, (I+1)·spp/N) of every pixel. Its state is saved to\n\
         # ckpt-I.exr every {every} s and on SIGTERM (preemption, time limit); a requeued task resumes from it.\n\
         exec {exe} render {scene} --shard \"$SLURM_ARRAY_TASK_ID/{n}\" --out {dir}/part-\"$SLURM_ARRAY_TASK_ID\".exr \
         --checkpoint {dir}/ckpt-\"$SLURM_ARRAY_TASK_ID\".exr --checkpoint-every {every}{overrides}\n",
        last = a.tasks - 1,
        n = a.tasks,
        every = a.checkpoint_every,
        log = dir.join("shard-%a.log").display(),
        exe = q(exe),
        scene = q(scene),
        dir = q(dir),
    );
    let merge = format!(
        "#!/bin/sh\n#SBATCH --job-name=reflect-merge\n#SBATCH --output={log}\n{head_merge}\
         # Merge the shards into the image a single render writes (bit-identical).\n\
         exec {exe} merge {dir}/part-*.exr --out {out}\n",
        log = dir.join("merge.log").display(),
        head_merge = a.partition.as_ref().map(|p| format!("#SBATCH --partition={p}\n")).unwrap_or_default(),
        exe = q(exe),
        dir = q(dir),
        out = q(out),
    );
    (shard, merge)
}

pub(super) fn sbatch(args: &[String], script: &Path) -> Result<String, Error> {
    let out = Command::new("sbatch")
        .args(args)
        .arg(script)
        .output()
        .map_err(|e| Error::new(format!("cannot run sbatch (is Slurm installed and on PATH?): {e}")))?;
    let stdout = String::from_utf8_lossy(&out.stdout).trim().to_string();
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let err = err.lines().next().unwrap_or("").trim();
        return Err(Error::file(script, format!("sbatch failed ({}): {err}", out.status)));
    }
    // --parsable prints "jobid" or "jobid;cluster".
    Ok(stdout.lines().last().unwrap_or("").split(';').next().unwrap_or("").to_string())
}

pub fn run(c: SlurmCommand) -> Result<ExitCode, Error> {
    let a = match c {
        SlurmCommand::Render(a) if a.target_rel_error.is_some() => return super::rounds::start(a),
        SlurmCommand::Render(a) => a,
        SlurmCommand::Step(a) => return super::rounds::step(a),
    };
    super::render::scene_inputs(Some(&a.scene)).output("--out", &a.out, Format::Exr).check()?;
    // Refuse a bad scene here, not in N failed tasks.
    let ra = RenderArgs { scene: Some(a.scene.clone()), spp: a.spp, seed: a.seed, quiet: true, ..Default::default() };
    let scene = load_scene(&ra)?;
    if a.tasks == 0 || a.tasks > scene.settings.spp {
        return Err(Error::new(format!(
            "--tasks must be between 1 and the spp ({}), got {}",
            scene.settings.spp, a.tasks
        )));
    }
    if !a.checkpoint_every.is_finite() || a.checkpoint_every < 0.0 {
        return Err(Error::new(format!("--checkpoint-every must be finite and ≥ 0, got {}", a.checkpoint_every)));
    }
    let out = abs(&a.out)?;
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "render".into());
    let dir = out.with_file_name(format!("{stem}.slurm"));
    let exe = std::env::current_exe().map_err(|e| Error::new(format!("cannot find the reflect executable: {e}")))?;
    let scene_path = abs(&a.scene)?;
    let (shard, merge) = scripts(&a, &exe, &scene_path, &dir, &out);
    let (shard_path, merge_path) = (dir.join("shard.sh"), dir.join("merge.sh"));
    let mut merge_args: Vec<String> = vec!["--parsable".into(), "--kill-on-invalid-dep=yes".into()];
    if a.wait {
        merge_args.push("--wait".into());
    }
    if a.dry_run {
        println!("# {}\n{shard}", shard_path.display());
        println!("# {}\n{merge}", merge_path.display());
        let extra: String = a.sbatch_args.iter().map(|s| format!(" {}", sh_quote(s))).collect();
        println!("# submit:\nJOB=$(sbatch --parsable{extra} {})", sh_quote(&shard_path.to_string_lossy()));
        println!(
            "sbatch {} --dependency=afterok:$JOB{extra} {}",
            merge_args.join(" "),
            sh_quote(&merge_path.to_string_lossy())
        );
        return Ok(ExitCode::SUCCESS);
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::file(&dir, format!("cannot create the job folder: {e}")))?;
    // Parts and checkpoints of an earlier submission (maybe with another N) would overlap the new ones.
    if let Ok(rd) = std::fs::read_dir(&dir) {
        for e in rd.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if (n.starts_with("part-") || n.starts_with("ckpt-")) && n.ends_with(".exr") {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    for (p, text) in [(&shard_path, &shard), (&merge_path, &merge)] {
        std::fs::write(p, text).map_err(|e| Error::file(p, format!("cannot write the job script: {e}")))?;
    }
    let mut shard_args = vec!["--parsable".to_string()];
    shard_args.extend(a.sbatch_args.iter().cloned());
    let array = sbatch(&shard_args, &shard_path)?;
    println!("submitted shard array job {array} ({} tasks)", a.tasks);
    merge_args.push(format!("--dependency=afterok:{array}"));
    merge_args.extend(a.sbatch_args.iter().cloned());
    match sbatch(&merge_args, &merge_path) {
        Ok(id) if a.wait => {
            println!("merge job {id} finished: wrote {}", out.display());
            Ok(ExitCode::SUCCESS)
        }
        Ok(id) => {
            println!("submitted merge job {id} (after array {array}); the image will be {}", out.display());
            Ok(ExitCode::SUCCESS)
        }
        Err(e) if a.wait => Err(Error::new(format!(
            "{e}; see {} and {}",
            dir.join("merge.log").display(),
            dir.join("shard-*.log").display()
        ))),
        Err(e) => Err(e),
    }
}
