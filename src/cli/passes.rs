//! The command-line face of `renderer::progressive` (the sample loop beyond one plain pass: shards,
//! checkpoints, `--continue`, renders to a target error or a time limit): flags into
//! [`ProgressiveOptions`], SIGINT/SIGTERM into its cancel flag, its events and errors into lines on
//! stderr.

use super::Error;
use super::render::RenderArgs;
use renderer::film::Partial;
use renderer::progressive::{
    Checkpoint, DEFAULT_CHECKPOINT_EVERY, Event, MIN_TARGET_SPP, NoEstimate, Outcome, ProgressiveError,
    ProgressiveOptions, render_progressive,
};
use renderer::scene::Scene;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// `--shard I/N`: I < N, N ≥ 1.
pub fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let (i, n) = s.split_once('/').ok_or("expected I/N, e.g. 0/4")?;
    let i: u32 = i.trim().parse().map_err(|_| "bad shard index I")?;
    let n: u32 = n.trim().parse().map_err(|_| "bad shard count N")?;
    if n == 0 || i >= n {
        return Err(format!("need 0 ≤ I < N, got {i}/{n}"));
    }
    Ok((i, n))
}

/// `--samples A:B`: A < B.
pub fn parse_samples(s: &str) -> Result<(u64, u64), String> {
    let (a, b) = s.split_once(':').ok_or("expected A:B, e.g. 64:128")?;
    let a: u64 = a.trim().parse().map_err(|_| "bad first sample A")?;
    let b: u64 = b.trim().parse().map_err(|_| "bad end sample B")?;
    if a >= b {
        return Err(format!("need A < B, got {a}:{b}"));
    }
    Ok((a, b))
}

/// A relative error as a percentage, or "no estimate" with the reason.
pub fn percent(e: Result<f64, NoEstimate>) -> String {
    match e {
        Ok(e) => format!("{:.4} %", 100.0 * e),
        Err(why) => format!("unknown: {}", why.why()),
    }
}

/// A progressive-render error in the command's terms (its flags).
pub fn cli_error(e: ProgressiveError) -> Error {
    match e {
        ProgressiveError::InvalidOption { name: "threads", .. } => Error::new("--threads must be at least 1"),
        ProgressiveError::InvalidOption { name, value } => {
            Error::new(format!("--{} must be a positive number, got {value}", name.replace('_', "-")))
        }
        ProgressiveError::CheckpointMismatch { path, mismatch } => Error::file(
            &path,
            format!("is a checkpoint of {}; remove it or name another --checkpoint file", mismatch.what()),
        ),
        ProgressiveError::ContinueMismatch { path, mismatch } => Error::file(
            &path,
            format!(
                "--continue: is the state of a render of {}; continue it with its own scene and seed",
                mismatch.what()
            ),
        ),
        ProgressiveError::ContinueBeyond { path, have, want } => Error::file(
            &path,
            format!(
                "--continue: holds {have} samples per pixel, more than --spp {want}; ask for more samples than it has"
            ),
        ),
        ProgressiveError::ContinueNotFromZero { path, start, end } => Error::file(
            &path,
            format!(
                "--continue: holds samples [{start}, {end}), not a render from sample 0 (a shard other than 0/N); \
                 merge the parts from 0 on with reflect merge --partial, or continue shard 0's part"
            ),
        ),
        ProgressiveError::File(e) => e,
        ProgressiveError::Threads { threads, message } => {
            Error::new(format!("cannot start {threads} threads: {message}"))
        }
        ProgressiveError::Merge(m) => Error::new(format!("internal: {m}")),
    }
}

/// Runs the passes of `[range.0, range.1)` of `scene` from `initial` (a `--continue` state), resuming
/// from and saving to `a.checkpoint`, printing one line per pass of a progressive render.
pub fn run_passes(
    scene: &Scene,
    a: &RenderArgs,
    range: (u64, u64),
    initial: Option<Partial>,
    attrs: &[(String, String)],
) -> Result<Outcome, Error> {
    let progressive = a.target_rel_error.is_some() || a.time_limit.is_some();
    let cancel = Arc::new(AtomicBool::new(false));
    if a.checkpoint.is_some() {
        // SIGINT/SIGTERM: finish nothing more, save the last complete pass, exit. A second signal
        // terminates at once.
        for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            signal_hook::flag::register_conditional_shutdown(sig, 130, cancel.clone())
                .and_then(|_| signal_hook::flag::register(sig, cancel.clone()))
                .map_err(|e| Error::new(format!("cannot install the signal handler: {e}")))?;
        }
    }
    let opts = ProgressiveOptions {
        range: Some(range),
        target_rel_error: a.target_rel_error,
        time_limit: a.time_limit.map(Duration::from_secs_f64),
        checkpoint: a.checkpoint.as_ref().map(|p| Checkpoint {
            path: p.clone(),
            every: a.checkpoint_every.map_or(DEFAULT_CHECKPOINT_EVERY, Duration::from_secs_f64),
            attributes: attrs.to_vec(),
        }),
        initial,
        threads: a.threads,
        // The tile progress bar of each pass (drawn only on a terminal, cleared after the pass), as a
        // plain render draws it: shown unless --quiet (--json does not silence stderr).
        progress_bar: !a.quiet,
        estimate_each_pass: progressive && !a.quiet,
        cancel: Some(cancel),
    };
    let mut on_event = |e: Event<'_>| {
        if a.quiet {
            return;
        }
        match e {
            Event::Resumed { path, at, range } => {
                eprintln!("resuming from {} at sample {at} of [{}, {})", path.display(), range.0, range.1)
            }
            // One line per pass on stderr, whether or not stderr is a terminal.
            Event::Pass(p) if progressive => {
                let err = match p.rel_error {
                    Some(e) => {
                        let target =
                            a.target_rel_error.map(|x| format!(" (target {:.4} %)", 100.0 * x)).unwrap_or_default();
                        format!("95th-percentile relative stderr {}{target}", percent(e))
                    }
                    None => format!("error checked from {MIN_TARGET_SPP} spp on"),
                };
                eprintln!(
                    "pass {}: samples [{}, {}) in {:.2} s; {} of at most {} spp, {err}",
                    p.pass,
                    p.start,
                    p.end,
                    p.wall.as_secs_f64(),
                    p.end,
                    p.cap
                );
            }
            Event::Pass(_) => {}
        }
    };
    render_progressive(scene, &opts, &mut on_event).map_err(cli_error)
}

/// Reads the `--continue` file for a render of `scene` (see `renderer::progressive::continuable`):
/// refuses a finished image (no partial state) by name.
pub fn read_continue(path: &Path, scene: &Scene) -> Result<Partial, Error> {
    let is_partial = renderer::shard::read_partial(path);
    match is_partial {
        Ok(f) => renderer::progressive::continuable(path, f, scene).map_err(cli_error),
        Err(e) if e.message.contains(renderer::shard::PARTIAL_ATTRIBUTE) => Err(Error::file(
            path,
            "--continue: is not a render state (a finished image keeps only its pixels, not the sums a \
             continuation adds to); continue a file written by --state, a --checkpoint file or a --shard 0/N part",
        )),
        Err(e) => Err(e),
    }
}
