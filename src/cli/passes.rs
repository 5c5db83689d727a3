//! The sample loop of `reflect render` beyond one plain pass: shards (`--shard I/N`), checkpoints
//! (`--checkpoint FILE`), and renders to a target error or a time limit. Every pass renders a sample
//! range `[a, b)` of every pixel and is merged into the state with [`Partial::merge`], so the image is
//! bit-identical to one plain render of the same samples (see `renderer::film`).

use super::Error;
use super::render::{RenderArgs, with_threads};
use renderer::film::{Partial, batch_log2};
use renderer::render::{RenderOptions, RenderStats, render_range};
use renderer::sampling::Sampler;
use renderer::scene::Scene;
use renderer::shard::{PartialHeader, partial_header, read_partial, scene_fingerprint, write_partial};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

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

/// The sample range of shard `i` of `n` of a render of `spp` samples: `[i·spp/n, (i+1)·spp/n)`.
pub fn shard_range(i: u32, n: u32, spp: u32) -> (u64, u64) {
    let f = |k: u32| k as u64 * spp as u64 / n as u64;
    (f(i), f(i + 1))
}

/// The fewest samples per pixel at which `--target-rel-error` is checked.
pub const MIN_TARGET_SPP: u64 = 16;

/// Why a render to a target error or a time limit stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The 95th-percentile relative stderr reached `--target-rel-error`.
    Target,
    /// The next pass would not have fit in `--time-limit`.
    TimeLimit,
    /// Every sample up to spp (the cap) was taken.
    SppCap,
}

impl Stop {
    /// The name in `render --json` (`progressive.stopped_by`).
    pub fn name(self) -> &'static str {
        match self {
            Stop::Target => "target",
            Stop::TimeLimit => "time-limit",
            Stop::SppCap => "spp-cap",
        }
    }
}

/// How a render to a target error or a time limit went (`None` for other pass loops).
#[derive(Clone, Debug)]
pub struct Progressive {
    pub stop: Stop,
    /// The target's summary ([`p95_rel_error`]) of the final state, or why there is none.
    pub rel_error: Result<f64, NoEstimate>,
}

/// Why a render has no relative-error estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoEstimate {
    /// One sample per pixel: no spread to estimate a variance from.
    OneSample,
    /// No object pixel has a value > 0: no relative error is defined.
    NoObject,
    /// Over 5 % of the object's pixels are flagged (`stderr_flag.Y` = 1): the 95th percentile is
    /// unbounded.
    Flagged,
}

impl NoEstimate {
    /// The reason, in words, for the text and `progressive.rel_error_unknown`.
    pub fn why(self) -> &'static str {
        match self {
            NoEstimate::OneSample => "one sample per pixel has no spread to estimate an error from",
            NoEstimate::NoObject => "no object pixel has a value > 0",
            NoEstimate::Flagged => "over 5 % of the object's pixels have stderr_flag.Y = 1 (infinite error bars)",
        }
    }
}

/// How a pass loop ended.
pub enum Outcome {
    /// All samples of the range (or the target/time limit) reached: the state to write. `passes` counts
    /// the passes of this run (not those of a resumed checkpoint).
    Done { state: Partial, stats: RenderStats, passes: u32, progressive: Option<Progressive> },
    /// Stopped by SIGINT/SIGTERM; the state up to the last finished pass was saved.
    Interrupted { spp_done: u64 },
}

/// The largest power of two ≤ x (x ≥ 1).
fn pow2_floor(x: u64) -> u64 {
    1 << (63 - x.max(1).leading_zeros())
}

/// Relative-error summary used by `--target-rel-error`: the 95th percentile over the object's pixels
/// of the worst channel's stderr / value (`renderer::noise`), flagged pixels counting as infinite.
/// No estimate (never 0) below two samples per pixel, when no object pixel has a value > 0, and when
/// more than 5 % of them are flagged.
pub fn p95_rel_error(state: &Partial) -> Result<f64, NoEstimate> {
    if state.end.saturating_sub(state.start) < 2 {
        return Err(NoEstimate::OneSample);
    }
    let mut s = state.clone();
    s.spp = s.end as u32;
    let mut film = s.finish();
    for p in film.pixels.iter_mut().filter(|p| p.unreliable) {
        p.stderr = [f32::INFINITY; 3];
    }
    match renderer::noise::summarize(&film) {
        None => Err(NoEstimate::NoObject),
        Some(n) if n.p95.is_finite() => Ok(n.p95),
        Some(_) => Err(NoEstimate::Flagged),
    }
}

/// A relative error as a percentage, or "no estimate" with the reason (see [`p95_rel_error`]).
pub fn percent(e: Result<f64, NoEstimate>) -> String {
    match e {
        Ok(e) => format!("{:.4} %", 100.0 * e),
        Err(why) => format!("unknown: {}", why.why()),
    }
}

fn check_resume(ck: &Path, h: &PartialHeader, want: &PartialHeader) -> Result<(), Error> {
    let what = if h.scene != want.scene {
        "a different scene (or scene files)"
    } else if h.seed != want.seed {
        "a different seed"
    } else if h.spp != want.spp {
        "a different spp"
    } else if (h.width, h.height) != (want.width, want.height) {
        "a different image size"
    } else if h.start != want.start || h.end > want.end || h.batch_log2 != want.batch_log2 {
        "a different sample range"
    } else {
        return Ok(());
    };
    Err(Error::file(ck, format!("is a checkpoint of {what}; remove it or name another --checkpoint file")))
}

/// Runs the passes of `[range.0, range.1)` of `scene`, resuming from and saving to `a.checkpoint`.
pub fn run_passes(
    scene: &Scene,
    a: &RenderArgs,
    range: (u64, u64),
    attrs: &[(String, String)],
) -> Result<Outcome, Error> {
    let s = &scene.settings;
    let bl = batch_log2(s.spp);
    let replicates = Sampler::replicates(s.sampler);
    let progressive = a.target_rel_error.is_some() || a.time_limit.is_some();
    let every = Duration::from_secs_f64(a.checkpoint_every.unwrap_or(60.0));
    let t0 = Instant::now();
    let mut state = Partial::empty(s.width, s.height, s.spp, bl, replicates, range.0);
    let want = PartialHeader { end: range.1, ..partial_header(scene, &state) };
    let fingerprint = want.scene.clone();
    debug_assert_eq!(fingerprint, scene_fingerprint(scene));
    let cancel = Arc::new(AtomicBool::new(false));
    if let Some(ck) = &a.checkpoint {
        if ck.exists() {
            let f = read_partial(ck)?;
            check_resume(ck, &f.header, &want)?;
            if !a.quiet {
                eprintln!("resuming from {} at sample {} of [{}, {})", ck.display(), f.partial.end, range.0, range.1);
            }
            state = f.partial;
        }
        // SIGINT/SIGTERM: finish nothing more, save the last complete pass, exit. A second signal
        // terminates at once.
        for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            signal_hook::flag::register_conditional_shutdown(sig, 130, cancel.clone())
                .and_then(|_| signal_hook::flag::register(sig, cancel.clone()))
                .map_err(|e| Error::new(format!("cannot install the signal handler: {e}")))?;
        }
    }
    let save = |state: &Partial| -> Result<(), Error> {
        match &a.checkpoint {
            Some(ck) => write_partial(ck, state, &partial_header(scene, state), attrs),
            None => Ok(()),
        }
    };
    // The tile progress bar of each pass (drawn only on a terminal, cleared after the pass), as a plain
    // render draws it: shown unless --quiet (--json does not silence stderr).
    let opts = RenderOptions { progress: !a.quiet, cancel: Some(cancel.clone()) };
    let mut total = RenderStats { wall: Duration::ZERO, samples: 0, rays: 0, threads: 1, cancelled: false };
    let mut passes = 0;
    let mut last_save = Instant::now();
    // Samples per second of one pixel, from the last pass.
    let mut rate: Option<f64> = None;
    let mut stop = Stop::SppCap;
    // The target's summary of the state after the last pass, as (spp, value): computed once per pass.
    let mut error_at: Option<(u64, Result<f64, NoEstimate>)> = None;
    let mut error_now = |state: &Partial| match error_at {
        Some((end, e)) if end == state.end => e,
        _ => {
            let e = p95_rel_error(state);
            error_at = Some((state.end, e));
            e
        }
    };
    loop {
        let cur = state.end;
        // An error bar needs samples to mean anything (with 1 sample it is 0): the target is checked
        // from MIN_TARGET_SPP on (also after the last pass, so a cap that meets the target says so).
        if let Some(x) = a.target_rel_error
            && cur >= MIN_TARGET_SPP
            && error_now(&state).is_ok_and(|e| e <= x)
        {
            stop = Stop::Target;
            break;
        }
        if cur >= range.1 {
            break;
        }
        // Pass size: one plain pass without checkpoints or targets; otherwise passes that take about
        // the checkpoint interval (and fit the time limit), doubling the spp for a target error.
        let mut size = range.1 - cur;
        let budget = |secs: f64| rate.map_or(1, |r| (r * secs).max(1.0) as u64);
        // A Sobol render's error bar comes from its replicates' means over full rounds of R samples
        // (renderer::film): from a round boundary on, passes are whole rounds.
        let round = replicates as u64;
        let round = if cur >= round && cur.is_multiple_of(round) { round } else { 1 };
        if a.checkpoint.is_some() {
            size = size.min(budget(every.as_secs_f64()));
        }
        if a.target_rel_error.is_some() {
            size = size.min(cur.max(1));
        }
        if let Some(limit) = a.time_limit {
            let left = limit - t0.elapsed().as_secs_f64();
            if cur > 0 && (left <= 0.0 || budget(left) < round || rate.is_some_and(|r| r * left < round as f64)) {
                stop = Stop::TimeLimit;
                break;
            }
            if rate.is_some() {
                size = size.min(budget(left));
            } else {
                size = 1;
            }
        }
        // Keep pass boundaries aligned so the state stays a few large blocks.
        let mut size = pow2_floor(size.max(1));
        if cur > 0 {
            size = size.min(1 << cur.trailing_zeros());
        }
        let size = size.max(round);
        let end = (cur + size).min(range.1);
        let (part, st) = with_threads(a.threads, || render_range(scene, &opts, cur, end))?;
        let Some(part) = part else {
            save(&state)?;
            return Ok(Outcome::Interrupted { spp_done: state.end });
        };
        passes += 1;
        rate = Some((end - cur) as f64 / st.wall.as_secs_f64().max(1e-6));
        total.wall += st.wall;
        total.samples += st.samples;
        total.rays += st.rays;
        total.threads = st.threads;
        state = Partial::merge(vec![state, part]).map_err(|e| Error::new(format!("internal: {e}")))?;
        if progressive && !a.quiet {
            // One line per pass on stderr (unless --quiet), whether or not stderr is a terminal.
            let err = if end >= MIN_TARGET_SPP {
                let e = error_now(&state);
                let target = a.target_rel_error.map(|x| format!(" (target {:.4} %)", 100.0 * x)).unwrap_or_default();
                format!("95th-percentile relative stderr {}{target}", percent(e))
            } else {
                format!("error checked from {MIN_TARGET_SPP} spp on")
            };
            eprintln!(
                "pass {passes}: samples [{cur}, {end}) in {:.2} s; {end} of at most {} spp, {err}",
                st.wall.as_secs_f64(),
                range.1
            );
        }
        if cancel.load(Ordering::Relaxed) {
            save(&state)?;
            return Ok(Outcome::Interrupted { spp_done: state.end });
        }
        if a.checkpoint.is_some() && state.end < range.1 && last_save.elapsed() >= every {
            save(&state)?;
            last_save = Instant::now();
        }
    }
    let progressive = progressive.then(|| Progressive { stop, rel_error: error_now(&state) });
    Ok(Outcome::Done { state, stats: total, passes, progressive })
}
