//! `reflect slurm render … --target-rel-error X` and `reflect slurm step DIR --round R`: a render to a
//! target error on Slurm, in rounds (the decisions are `renderer::rounds`'). Round r is a job array
//! `round-r.sh` whose task I renders shard I of the round's samples `[a, b)` (`reflect render --spp
//! MAX --samples a:b --shard I/N`, every part a partial render of the same planned spp, MAX, so that
//! all of them merge), and a step job `step-r.sh` after it (`--dependency=afterok`) that runs
//! `reflect slurm step DIR --round r`: it merges the previous state `state-(r−1).exr` with the
//! round's parts into `state-r.exr` (samples `[0, b)`), measures its 95th-percentile relative error
//! and writes the image (`FINAL.exr`, the bits of `reflect render --spp b`) or submits round r + 1.
//!
//! `DIR/rounds.json` is the plan and the record of every round (its samples, job ids, the measured
//! error and the decision). A step finds its round decided there and does nothing (a step job
//! requeued or run again by hand); every file a step writes is new (`state-r.exr`, the next round's
//! scripts) or the final image, never one of its inputs.

use super::Error;
use super::merge::{Merged, merge_parts};
use super::outputs::Format;
use super::render::{RenderArgs, load_scene};
use super::slurm::{SlurmRenderArgs, SlurmStepArgs, abs, sbatch, sh_quote};
use renderer::progressive::{NoEstimate, Stop, p95_rel_error};
use renderer::rounds::{RoundDecision, RoundsBudget, RoundsProgress, first_round_end, next_round};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// The plan's file in the job folder.
const PLAN: &str = "rounds.json";

/// `DIR/rounds.json`: what every round runs, and what each did.
#[derive(Serialize, Deserialize, Debug, Clone)]
struct Plan {
    scene: PathBuf,
    out: PathBuf,
    exe: PathBuf,
    tasks: u32,
    /// The most samples per pixel: the planned spp of every part.
    max_spp: u32,
    seed: Option<u64>,
    threads: Option<usize>,
    checkpoint_every: f64,
    partition: Option<String>,
    time: Option<String>,
    sbatch_args: Vec<String>,
    target_rel_error: f64,
    time_limit_seconds: Option<f64>,
    /// Round ends are multiples of it (the sampler's replicates).
    granularity: u64,
    /// When round 0 was submitted (seconds since the Unix epoch).
    started: f64,
    rounds: Vec<Round>,
}

#[derive(Serialize, Deserialize, Debug, Clone)]
struct Round {
    /// Its samples `[start, end)`.
    start: u64,
    end: u64,
    /// Its array's tasks (at most the plan's, at most its samples).
    tasks: u32,
    submitted: Option<f64>,
    array_job: Option<String>,
    step_job: Option<String>,
    /// Set by its step job.
    measured: Option<Measured>,
}

#[derive(Serialize, Deserialize, Debug, Clone)]
struct Measured {
    /// When the step measured (seconds since the Unix epoch).
    at: f64,
    rel_error_p95: Option<f64>,
    rel_error_unknown: Option<String>,
    /// `next`, or why the render stopped (`target`, `spp-cap`, `time-limit`).
    decision: String,
}

fn now() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64())
}

fn plan_path(dir: &Path) -> PathBuf {
    dir.join(PLAN)
}

fn read_plan(dir: &Path) -> Result<Plan, Error> {
    let p = plan_path(dir);
    let text = std::fs::read_to_string(&p)
        .map_err(|e| Error::file(&p, format!("cannot read the plan of a render in rounds: {e}")))?;
    serde_json::from_str(&text).map_err(|e| Error::file(&p, format!("is not a plan of a render in rounds: {e}")))
}

/// Writes the plan atomically (a temporary file, then a rename), so that a reader never sees half.
fn write_plan(dir: &Path, plan: &Plan) -> Result<(), Error> {
    let p = plan_path(dir);
    let tmp = dir.join(format!(".{PLAN}.tmp"));
    let text = serde_json::to_string_pretty(plan).map_err(|e| Error::new(format!("internal: {e}")))?;
    std::fs::write(&tmp, text + "\n").map_err(|e| Error::file(&tmp, format!("cannot write the plan: {e}")))?;
    std::fs::rename(&tmp, &p).map_err(|e| Error::file(&p, format!("cannot write the plan: {e}")))
}

fn part_path(dir: &Path, r: usize, i: u32) -> PathBuf {
    dir.join(format!("r{r}-part-{i}.exr"))
}

fn state_path(dir: &Path, r: usize) -> PathBuf {
    dir.join(format!("state-{r}.exr"))
}

fn budget(plan: &Plan) -> RoundsBudget {
    RoundsBudget {
        target_rel_error: plan.target_rel_error,
        max_spp: plan.max_spp as u64,
        time_limit: plan.time_limit_seconds.map(Duration::from_secs_f64),
        granularity: plan.granularity,
    }
}

/// The `#SBATCH` lines of the partition, time and threads.
fn sbatch_head(plan: &Plan, threads: bool) -> String {
    let mut head = String::new();
    if let Some(p) = &plan.partition {
        head += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &plan.time {
        head += &format!("#SBATCH --time={t}\n");
    }
    if let (true, Some(n)) = (threads, plan.threads) {
        head += &format!("#SBATCH --cpus-per-task={n}\n");
    }
    head
}

/// The array and step scripts of round `r`.
fn scripts(plan: &Plan, dir: &Path, r: usize) -> (String, String) {
    let q = |p: &Path| sh_quote(&p.to_string_lossy());
    let round = &plan.rounds[r];
    let mut overrides = format!(" --spp {}", plan.max_spp);
    if let Some(s) = plan.seed {
        overrides += &format!(" --seed {s}");
    }
    if let Some(n) = plan.threads {
        overrides += &format!(" --threads {n}");
    }
    let array = format!(
        "#!/bin/sh\n#SBATCH --job-name=reflect-round{r}\n#SBATCH --array=0-{last}\n#SBATCH --output={log}\n\
         #SBATCH --open-mode=append\n#SBATCH --requeue\n{head}\
         # Round {r} of a render to a target error: shard I of the samples [{a}, {b}) of every pixel,\n\
         # checkpointed to r{r}-ckpt-I.exr every {every} s and on SIGTERM (a requeued task resumes from it).\n\
         exec {exe} render {scene}{overrides} --samples {a}:{b} --shard \"$SLURM_ARRAY_TASK_ID/{n}\" \
         --out {dir}/r{r}-part-\"$SLURM_ARRAY_TASK_ID\".exr --checkpoint {dir}/r{r}-ckpt-\"$SLURM_ARRAY_TASK_ID\".exr \
         --checkpoint-every {every}\n",
        last = round.tasks - 1,
        n = round.tasks,
        a = round.start,
        b = round.end,
        every = plan.checkpoint_every,
        log = dir.join(format!("round{r}-%a.log")).display(),
        head = sbatch_head(plan, true),
        exe = q(&plan.exe),
        scene = q(&plan.scene),
        dir = q(dir),
    );
    let step = format!(
        "#!/bin/sh\n#SBATCH --job-name=reflect-step{r}\n#SBATCH --output={log}\n#SBATCH --open-mode=append\n{head}\
         # Merge the rounds so far, measure the error; write the image or submit round {next}.\n\
         exec {exe} slurm step {dir} --round {r}\n",
        log = dir.join(format!("step{r}.log")).display(),
        head = sbatch_head(&Plan { time: None, ..plan.clone() }, false),
        next = r + 1,
        exe = q(&plan.exe),
        dir = q(dir),
    );
    (array, step)
}

/// Writes round `r`'s scripts, submits its array and its step job, and records the job ids.
fn submit_round(plan: &mut Plan, dir: &Path, r: usize) -> Result<(String, String), Error> {
    let (array, step) = scripts(plan, dir, r);
    let (array_path, step_path) = (dir.join(format!("round-{r}.sh")), dir.join(format!("step-{r}.sh")));
    for (p, text) in [(&array_path, &array), (&step_path, &step)] {
        std::fs::write(p, text).map_err(|e| Error::file(p, format!("cannot write the job script: {e}")))?;
    }
    plan.rounds[r].submitted = Some(now());
    let mut args = vec!["--parsable".to_string()];
    args.extend(plan.sbatch_args.iter().cloned());
    let array_id = sbatch(&args, &array_path)?;
    plan.rounds[r].array_job = Some(array_id.clone());
    write_plan(dir, plan)?;
    let mut args: Vec<String> =
        vec!["--parsable".into(), "--kill-on-invalid-dep=yes".into(), format!("--dependency=afterok:{array_id}")];
    args.extend(plan.sbatch_args.iter().cloned());
    let step_id = sbatch(&args, &step_path)?;
    plan.rounds[r].step_job = Some(step_id.clone());
    write_plan(dir, plan)?;
    Ok((array_id, step_id))
}

/// `reflect slurm render … --target-rel-error X`: plans the rounds and submits the first.
pub fn start(a: SlurmRenderArgs) -> Result<ExitCode, Error> {
    let target = a.target_rel_error.unwrap_or_default();
    super::render::scene_inputs(Some(&a.scene)).output("--out", &a.out, Format::Exr).check()?;
    for (name, v) in [("--target-rel-error", Some(target)), ("--time-limit", a.time_limit)] {
        if let Some(v) = v.filter(|v| !v.is_finite() || *v <= 0.0) {
            return Err(Error::new(format!("{name} must be a positive number, got {v}")));
        }
    }
    if !a.checkpoint_every.is_finite() || a.checkpoint_every < 0.0 {
        return Err(Error::new(format!("--checkpoint-every must be finite and ≥ 0, got {}", a.checkpoint_every)));
    }
    let ra = RenderArgs { scene: Some(a.scene.clone()), spp: a.spp, seed: a.seed, quiet: true, ..Default::default() };
    let scene = load_scene(&ra)?;
    if a.tasks == 0 {
        return Err(Error::new("--tasks must be at least 1, got 0"));
    }
    let out = abs(&a.out)?;
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "render".into());
    let dir = out.with_file_name(format!("{stem}.slurm"));
    let exe = std::env::current_exe().map_err(|e| Error::new(format!("cannot find the reflect executable: {e}")))?;
    let mut plan = Plan {
        scene: abs(&a.scene)?,
        out: out.clone(),
        exe,
        tasks: a.tasks,
        max_spp: scene.settings.spp,
        seed: a.seed,
        threads: a.threads,
        checkpoint_every: a.checkpoint_every,
        partition: a.partition.clone(),
        time: a.time.clone(),
        sbatch_args: a.sbatch_args.clone(),
        target_rel_error: target,
        time_limit_seconds: a.time_limit,
        granularity: renderer::sampling::Sampler::replicates(scene.settings.sampler) as u64,
        started: now(),
        rounds: Vec::new(),
    };
    let end = first_round_end(a.first_round_spp, &budget(&plan));
    plan.rounds.push(Round {
        start: 0,
        end,
        tasks: a.tasks.min(end as u32),
        submitted: None,
        array_job: None,
        step_job: None,
        measured: None,
    });
    if a.dry_run {
        let (array, step) = scripts(&plan, &dir, 0);
        println!("# {}\n{array}", dir.join("round-0.sh").display());
        println!("# {}\n{step}", dir.join("step-0.sh").display());
        let extra: String = a.sbatch_args.iter().map(|s| format!(" {}", sh_quote(s))).collect();
        println!("# submit:\nJOB=$(sbatch --parsable{extra} {})", sh_quote(&dir.join("round-0.sh").to_string_lossy()));
        println!(
            "sbatch --parsable --kill-on-invalid-dep=yes --dependency=afterok:$JOB{extra} {}",
            sh_quote(&dir.join("step-0.sh").to_string_lossy())
        );
        println!(
            "# each step job writes and submits the next round's two scripts the same way, into {}",
            dir.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::file(&dir, format!("cannot create the job folder: {e}")))?;
    clear_earlier(&dir);
    let (array, step) = submit_round(&mut plan, &dir, 0)?;
    println!(
        "submitted round 0 (samples [0, {end}), {} tasks): array job {array}, step job {step}; target {:.4} %, at most {} spp",
        plan.rounds[0].tasks,
        100.0 * target,
        plan.max_spp
    );
    if !a.wait {
        println!(
            "the step jobs submit further rounds; {} records them; the image will be {}",
            plan_path(&dir).display(),
            out.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    wait(&dir)
}

/// Removes the files of an earlier submission into `dir` (its parts would be merged with the new ones).
fn clear_earlier(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else { return };
    for e in rd.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        let round_file = n.starts_with('r') && (n.contains("-part-") || n.contains("-ckpt-"));
        let ours = (n.ends_with(".exr")
            && (n.starts_with("part-") || n.starts_with("ckpt-") || round_file || n.starts_with("state-")))
            || n == PLAN;
        if ours {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Whether Slurm still holds job `id` pending or running.
fn job_alive(id: &str) -> bool {
    let Ok(o) = Command::new("squeue").args(["-h", "-j", id, "-o", "%T"]).output() else { return false };
    let state = String::from_utf8_lossy(&o.stdout);
    o.status.success()
        && state.lines().any(|l| {
            matches!(l.trim(), "PENDING" | "RUNNING" | "CONFIGURING" | "COMPLETING" | "REQUEUED" | "SUSPENDED")
        })
}

/// `--wait`: follows the rounds until one decides to stop (exit 0) or a step job ends without
/// deciding (its round's array failed, or the step did: exit 2 naming its log).
fn wait(dir: &Path) -> Result<ExitCode, Error> {
    let mut gone_once = false;
    loop {
        std::thread::sleep(Duration::from_secs(1));
        let plan = read_plan(dir)?;
        let r = plan.rounds.len() - 1;
        let last = &plan.rounds[r];
        if let Some(m) = &last.measured
            && m.decision != "next"
        {
            println!(
                "finished after {} rounds, {} spp ({}): wrote {}",
                plan.rounds.len(),
                last.end,
                m.decision,
                plan.out.display()
            );
            return Ok(ExitCode::SUCCESS);
        }
        let Some(step) = &last.step_job else { continue };
        if last.measured.is_none() && !job_alive(step) {
            // The plan is written before the job ends: look once more before concluding.
            if gone_once {
                return Err(Error::new(format!(
                    "round {r}'s step job {step} ended without measuring the round; see {} and {}",
                    dir.join(format!("step{r}.log")).display(),
                    dir.join(format!("round{r}-*.log")).display()
                )));
            }
            gone_once = true;
        } else {
            gone_once = false;
        }
    }
}

/// `reflect slurm step DIR --round R`.
pub fn step(a: SlurmStepArgs) -> Result<ExitCode, Error> {
    let dir = &a.dir;
    let mut plan = read_plan(dir)?;
    let r = a.round;
    let Some(round) = plan.rounds.get(r).cloned() else {
        return Err(Error::file(plan_path(dir), format!("has {} rounds, no round {r}", plan.rounds.len())));
    };
    if let Some(m) = &round.measured {
        // Run again (a requeued job, or by hand): the round is decided. A next round whose
        // submission did not go through is submitted now.
        if m.decision == "next" && plan.rounds.get(r + 1).is_some_and(|n| n.step_job.is_none()) {
            let (array, step) = submit_round(&mut plan, dir, r + 1)?;
            println!("submitted round {} (array job {array}, step job {step})", r + 1);
        } else {
            println!("round {r} was measured already ({}); nothing to do", m.decision);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let mut inputs: Vec<PathBuf> = (0..round.tasks).map(|i| part_path(dir, r, i)).collect();
    if r > 0 {
        inputs.insert(0, state_path(dir, r - 1));
    }
    let Merged { mut partial, header, attributes, first, last } = merge_parts(&inputs)?;
    if partial.start != 0 {
        return Err(Error::file(&first, format!("starts at sample {}, not 0", partial.start)));
    }
    if partial.end != round.end {
        return Err(Error::file(
            &last,
            format!("ends at sample {}, not at round {r}'s end {}", partial.end, round.end),
        ));
    }
    let state = state_path(dir, r);
    renderer::shard::write_partial(&state, &partial, &header, &attributes)?;
    let rel_error = p95_rel_error(&partial);
    let t = now();
    let progress = RoundsProgress {
        done: round.end,
        rel_error,
        elapsed: Duration::from_secs_f64((t - plan.started).max(0.0)),
        last_round: (
            round.end - round.start,
            Duration::from_secs_f64((t - round.submitted.unwrap_or(plan.started)).max(0.0)),
        ),
    };
    let decision = next_round(&budget(&plan), &progress);
    let error_text = super::passes::percent(rel_error);
    plan.rounds[r].measured = Some(Measured {
        at: t,
        rel_error_p95: rel_error.ok(),
        rel_error_unknown: rel_error.err().map(|w: NoEstimate| w.why().to_string()),
        decision: match decision {
            RoundDecision::Next { .. } => "next".into(),
            RoundDecision::Stop(s) => s.name().into(),
        },
    });
    match decision {
        RoundDecision::Next { end } => {
            let tasks = plan.tasks.min((end - round.end) as u32);
            plan.rounds.push(Round {
                start: round.end,
                end,
                tasks,
                submitted: None,
                array_job: None,
                step_job: None,
                measured: None,
            });
            write_plan(dir, &plan)?;
            let (array, step) = submit_round(&mut plan, dir, r + 1)?;
            println!(
                "round {r}: {} spp, 95th-percentile relative stderr {error_text} (target {:.4} %); \
                 submitted round {} (samples [{}, {end}), {tasks} tasks): array job {array}, step job {step}",
                round.end,
                100.0 * plan.target_rel_error,
                r + 1,
                round.end
            );
        }
        RoundDecision::Stop(stop) => {
            // The image of the samples [0, end): what `reflect render --spp end` writes.
            partial.spp = round.end as u32;
            let file = renderer::shard::PartialFile { header, partial, attributes };
            let image = renderer::render_file::state_image(&state, file)?;
            renderer::output::stage_exr(&plan.out, &image.film, &image.attributes)?.commit()?;
            write_plan(dir, &plan)?;
            let why = match stop {
                Stop::Target => format!("reached the target {:.4} %", 100.0 * plan.target_rel_error),
                Stop::SppCap => format!(
                    "at the most spp, {}; target {:.4} % not reached",
                    plan.max_spp,
                    100.0 * plan.target_rel_error
                ),
                Stop::TimeLimit => format!(
                    "the next round would not fit in the time limit; target {:.4} % not reached",
                    100.0 * plan.target_rel_error
                ),
            };
            println!(
                "round {r}: {} spp, 95th-percentile relative stderr {error_text}: {why}; wrote {}",
                round.end,
                plan.out.display()
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
