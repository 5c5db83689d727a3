//! Rendering in passes: to a target error or a time limit, with checkpoints, over a shard's sample
//! range, continued from an earlier state, and stopped by a cancel flag (Ctrl-C). The one sample loop
//! that `reflect render`, `reflect slurm`'s shards and the Python package call.
//!
//! Every pass renders a sample range `[a, b)` of every pixel ([`render_range`]) and is merged into the
//! state with [`Partial::merge`]; by the film's fixed dyadic tree (see [`crate::film`]) the state after
//! any sequence of passes is bit-identical to one render of the same samples. So a render resumed from
//! a checkpoint, or continued from a finished render's state ([`continuable`]) to more samples, gives
//! the bits of a single render of all of them.
//!
//! Front-ends own the words: errors are typed ([`ProgressiveError`]) and name the options by their
//! fields (`target_rel_error`, `checkpoint`), each front-end printing them in its own terms (the CLI's
//! `--target-rel-error`, Python's `target_rel_error=`).

use crate::film::{MergeError, Partial, batch_log2};
use crate::render::{RenderOptions, RenderStats, render_range};
use crate::scene::Scene;
use crate::shard::{PartialFile, PartialHeader, partial_header, read_partial, write_partial};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The fewest samples per pixel at which a target relative error is checked (an error bar from fewer
/// samples is too noisy to stop on; with one sample it does not exist).
pub const MIN_TARGET_SPP: u64 = 16;

/// The default interval between checkpoint saves.
pub const DEFAULT_CHECKPOINT_EVERY: Duration = Duration::from_secs(60);

/// Where and how often a render saves its state (a partial render file, [`crate::shard`]).
#[derive(Clone, Debug)]
pub struct Checkpoint {
    /// The file: resumed from if it exists, saved to atomically every `every` and when cancelled.
    pub path: PathBuf,
    /// Time between saves.
    pub every: Duration,
    /// The scene's `reflect:*` header attributes ([`crate::output::header_attributes`]).
    pub attributes: Vec<(String, String)>,
}

/// Options of [`render_progressive`] that are not part of the scene.
#[derive(Clone, Debug, Default)]
pub struct ProgressiveOptions {
    /// The samples to render: `[range.0, range.1)` of every pixel (a shard's range, or `[0, spp)`).
    /// `None`: `[0, scene.settings.spp)`.
    pub range: Option<(u64, u64)>,
    /// Stop once the 95th-percentile relative stderr ([`p95_rel_error`]) is at most this (> 0); the
    /// scene's spp is then the most samples to take.
    pub target_rel_error: Option<f64>,
    /// Stop after the last pass that fits in this much rendering time (the spp is then the most).
    pub time_limit: Option<Duration>,
    /// Resume from and save to this file.
    pub checkpoint: Option<Checkpoint>,
    /// The state to start from (a [`continuable`] state, or a resumed one): its range must start at
    /// `range.0` and end within the range. A checkpoint file that exists takes precedence.
    pub initial: Option<Partial>,
    /// Worker threads (`None`: rayon's global pool, all cores). The image does not depend on it.
    pub threads: Option<usize>,
    /// Draw the tile progress bar of each pass on stderr (only when it is a terminal).
    pub progress_bar: bool,
    /// Compute [`p95_rel_error`] after every pass (from [`MIN_TARGET_SPP`] on) for [`Event::Pass`],
    /// even without a target (it always is with one).
    pub estimate_each_pass: bool,
    /// Set to true (Ctrl-C) to stop within one tile: the state of the last finished pass is returned
    /// (and saved to the checkpoint).
    pub cancel: Option<Arc<AtomicBool>>,
}

/// What [`render_progressive`] reports while it runs.
#[derive(Clone, Debug)]
pub enum Event<'a> {
    /// The checkpoint file existed and was resumed from: it holds samples `[range.0, at)`.
    Resumed { path: &'a Path, at: u64, range: (u64, u64) },
    /// A pass finished.
    Pass(PassReport),
}

/// One finished pass.
#[derive(Clone, Debug)]
pub struct PassReport {
    /// 1, 2, … (this call's passes only).
    pub pass: u32,
    /// The samples `[start, end)` it rendered.
    pub start: u64,
    pub end: u64,
    /// The most samples per pixel of the render (the end of the range).
    pub cap: u64,
    /// Its render-loop time.
    pub wall: Duration,
    /// [`p95_rel_error`] of the state after the pass, when computed (a target, or
    /// [`ProgressiveOptions::estimate_each_pass`], and at least [`MIN_TARGET_SPP`] samples).
    pub rel_error: Option<Result<f64, NoEstimate>>,
}

/// Why a render stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The 95th-percentile relative stderr reached the target.
    Target,
    /// The next pass would not have fit in the time limit.
    TimeLimit,
    /// Every sample of the range was taken.
    SppCap,
}

impl Stop {
    /// The name in `render --json` (`progressive.stopped_by`) and Python's metadata.
    pub fn name(self) -> &'static str {
        match self {
            Stop::Target => "target",
            Stop::TimeLimit => "time-limit",
            Stop::SppCap => "spp-cap",
        }
    }
}

/// Why a render has no relative-error estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NoEstimate {
    /// One sample per pixel: no spread to estimate a variance from.
    #[error("one sample per pixel has no spread to estimate an error from")]
    OneSample,
    /// No object pixel has a value > 0: no relative error is defined.
    #[error("no object pixel has a value > 0")]
    NoObject,
    /// Over 5 % of the object's pixels are flagged (`stderr_flag.Y` = 1): the 95th percentile is
    /// unbounded.
    #[error("over 5 % of the object's pixels have stderr_flag.Y = 1 (infinite error bars)")]
    Flagged,
}

impl NoEstimate {
    /// The reason, in words (the text and `progressive.rel_error_unknown`).
    pub fn why(self) -> &'static str {
        match self {
            NoEstimate::OneSample => "one sample per pixel has no spread to estimate an error from",
            NoEstimate::NoObject => "no object pixel has a value > 0",
            NoEstimate::Flagged => "over 5 % of the object's pixels have stderr_flag.Y = 1 (infinite error bars)",
        }
    }
}

/// How a finished progressive render went.
#[derive(Clone, Debug)]
pub struct Finished {
    /// The state: samples `[range.0, end)`, `end` the spp reached (≤ the range's end).
    pub state: Partial,
    /// The render loop's totals over this call's passes.
    pub stats: RenderStats,
    /// Passes of this call (not those of a resumed checkpoint or a continued state).
    pub passes: u32,
    pub stop: Stop,
    /// [`p95_rel_error`] of the final state (`None` for a range that does not start at sample 0: a
    /// shard's error bars are those of the merged image).
    pub rel_error: Option<Result<f64, NoEstimate>>,
}

/// How [`render_progressive`] ended.
#[derive(Clone, Debug)]
pub enum Outcome {
    Done(Finished),
    /// Stopped through [`ProgressiveOptions::cancel`]: the state after the last finished pass (saved to
    /// the checkpoint, if there is one).
    Cancelled {
        state: Partial,
    },
}

/// What the state of a checkpoint or a continued render differs in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mismatch {
    Scene,
    Seed,
    Spp,
    Size,
    Range,
    Batches,
}

impl Mismatch {
    /// "a different scene (or scene files)", …
    pub fn what(self) -> &'static str {
        match self {
            Mismatch::Scene => "a different scene (or scene files)",
            Mismatch::Seed => "a different seed",
            Mismatch::Spp => "a different spp",
            Mismatch::Size => "a different image size",
            Mismatch::Range => "a different sample range",
            Mismatch::Batches => "a different batch size",
        }
    }
}

/// Errors of [`render_progressive`] and [`continuable`].
#[derive(Debug, thiserror::Error)]
pub enum ProgressiveError {
    /// An option out of its domain (named by its field: `target_rel_error`, `time_limit`,
    /// `checkpoint_every`, `threads`).
    #[error("{name} must be a positive number, got {value}")]
    InvalidOption { name: &'static str, value: f64 },
    /// The checkpoint file is one of another render.
    #[error("{}: is a checkpoint of {}", path.display(), mismatch.what())]
    CheckpointMismatch { path: PathBuf, mismatch: Mismatch },
    /// The state to continue is of another render (scene, seed, size, batches).
    #[error("{}: is the state of a render of {}", path.display(), mismatch.what())]
    ContinueMismatch { path: PathBuf, mismatch: Mismatch },
    /// The state to continue holds more samples than asked for.
    #[error("{}: holds {have} samples per pixel, more than the {want} asked for", path.display())]
    ContinueBeyond { path: PathBuf, have: u64, want: u64 },
    /// The state to continue does not start at sample 0 (a shard other than the first).
    #[error("{}: holds samples [{start}, {end}), not a render from sample 0", path.display())]
    ContinueNotFromZero { path: PathBuf, start: u64, end: u64 },
    /// Reading or writing a partial render file.
    #[error(transparent)]
    File(#[from] crate::Error),
    /// A thread pool could not be started.
    #[error("cannot start {threads} threads: {message}")]
    Threads { threads: usize, message: String },
    /// States that do not merge (a bug: the loop only merges adjacent ranges).
    #[error("internal: {0}")]
    Merge(String),
}

impl From<MergeError> for ProgressiveError {
    fn from(e: MergeError) -> Self {
        ProgressiveError::Merge(e.to_string())
    }
}

/// Runs `f` on a rayon pool of `threads` workers (all cores, the global pool, when `None`).
pub fn on_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T, ProgressiveError> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(ProgressiveError::InvalidOption { name: "threads", value: 0.0 }),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| ProgressiveError::Threads { threads: n, message: e.to_string() })?;
            Ok(pool.install(f))
        }
    }
}

/// The largest power of two ≤ x (x ≥ 1).
fn pow2_floor(x: u64) -> u64 {
    1 << (63 - x.max(1).leading_zeros())
}

/// The relative-error summary a target is measured by: the 95th percentile over the object's pixels
/// of the worst channel's stderr / value ([`crate::noise`]), flagged pixels counting as infinite. No
/// estimate (never 0) below two samples per pixel, when no object pixel has a value > 0, and when more
/// than 5 % of them are flagged.
pub fn p95_rel_error(state: &Partial) -> Result<f64, NoEstimate> {
    if state.end.saturating_sub(state.start) < 2 {
        return Err(NoEstimate::OneSample);
    }
    let mut s = state.clone();
    s.spp = s.end as u32;
    film_rel_error(s.finish())
}

/// [`p95_rel_error`] of a finished image: the 95th percentile of the object pixels' relative stderr
/// ([`crate::noise::summarize`]) with every flagged pixel's error taken as infinite, so that a pixel
/// whose error bar cannot be trusted never lets a render stop early.
pub fn film_rel_error(mut film: crate::film::Film) -> Result<f64, NoEstimate> {
    for p in film.pixels.iter_mut().filter(|p| p.unreliable) {
        p.stderr = [f32::INFINITY; 3];
    }
    match crate::noise::summarize(&film) {
        None => Err(NoEstimate::NoObject),
        Some(n) if n.p95.is_finite() => Ok(n.p95),
        Some(_) => Err(NoEstimate::Flagged),
    }
}

/// The sample range of shard `i` of `n` of a render of `spp` samples: `[i·spp/n, (i+1)·spp/n)`.
pub fn shard_range(i: u32, n: u32, spp: u32) -> (u64, u64) {
    split_range(i, n, (0, spp as u64))
}

/// Shard `i` of `n` of the samples `[a, b)`: `[a + i·(b−a)/n, a + (i+1)·(b−a)/n)` (a round of a
/// render in rounds, [`crate::rounds`]; [`shard_range`] is the range `[0, spp)`).
pub fn split_range(i: u32, n: u32, (a, b): (u64, u64)) -> (u64, u64) {
    let f = |k: u32| a + (k as u128 * (b - a) as u128 / n as u128) as u64;
    (f(i), f(i + 1))
}

fn check_resume(h: &PartialHeader, want: &PartialHeader) -> Option<Mismatch> {
    Some(if h.scene != want.scene {
        Mismatch::Scene
    } else if h.seed != want.seed {
        Mismatch::Seed
    } else if h.spp != want.spp {
        Mismatch::Spp
    } else if (h.width, h.height) != (want.width, want.height) {
        Mismatch::Size
    } else if h.start != want.start || h.end > want.end || h.batch_log2 != want.batch_log2 {
        Mismatch::Range
    } else {
        return None;
    })
}

/// The state of a partial render file `f` (read from `path`) as the start of a render of `scene` at
/// its spp: the file must be a render of the same scene (fingerprint, [`crate::shard::scene_fingerprint`]),
/// seed, image size and batch size, hold samples `[0, k)` with k ≤ the scene's spp (a `--state`
/// file, a checkpoint, or the first shard of a split), and is then re-labelled as a state of the
/// larger render. Which spp the file was rendered for does not matter: a sample's value does not depend
/// on it, so continuing gives the bits of one render of all the samples.
pub fn continuable(path: &Path, f: PartialFile, scene: &Scene) -> Result<Partial, ProgressiveError> {
    let s = &scene.settings;
    let mut p = f.partial;
    let replicates = crate::sampling::Sampler::replicates(s.sampler);
    let want = partial_header(scene, &Partial::empty(s.width, s.height, s.spp, batch_log2(s.spp), replicates, 0));
    let h = &f.header;
    let mismatch = |m| ProgressiveError::ContinueMismatch { path: path.to_path_buf(), mismatch: m };
    if h.scene != want.scene {
        return Err(mismatch(Mismatch::Scene));
    }
    if h.seed != want.seed {
        return Err(mismatch(Mismatch::Seed));
    }
    if (h.width, h.height) != (want.width, want.height) {
        return Err(mismatch(Mismatch::Size));
    }
    if h.batch_log2 != want.batch_log2 {
        return Err(mismatch(Mismatch::Batches));
    }
    if p.start != 0 {
        return Err(ProgressiveError::ContinueNotFromZero { path: path.to_path_buf(), start: p.start, end: p.end });
    }
    if p.end > s.spp as u64 {
        return Err(ProgressiveError::ContinueBeyond { path: path.to_path_buf(), have: p.end, want: s.spp as u64 });
    }
    p.spp = s.spp;
    Ok(p)
}

/// Reads the partial render file `path` and checks it can be continued to `scene`'s spp
/// ([`continuable`]).
pub fn read_continuable(path: &Path, scene: &Scene) -> Result<Partial, ProgressiveError> {
    let f = read_partial(path)?;
    continuable(path, f, scene)
}

fn positive(name: &'static str, v: Option<f64>, zero_ok: bool) -> Result<(), ProgressiveError> {
    match v {
        Some(v) if !v.is_finite() || v < 0.0 || (v == 0.0 && !zero_ok) => {
            Err(ProgressiveError::InvalidOption { name, value: v })
        }
        _ => Ok(()),
    }
}

/// Renders `scene` in passes (module docs). `on_event` hears of a resumed checkpoint and of every
/// finished pass (it runs on the calling thread, between passes).
///
/// Pass sizes: one pass for the whole range without a checkpoint, a target or a time limit; with a
/// checkpoint, passes of about its interval; with a target, the spp doubles from pass to pass (the
/// target is checked from [`MIN_TARGET_SPP`] on, also after the last pass); with a time limit, passes
/// that fit in the time left (the first pass is one sample, to measure the rate). Pass boundaries are
/// powers of two aligned to the state's end, so the state stays a few large blocks.
///
/// Errors: an option out of its domain, a checkpoint of another render, an unreadable or unwritable
/// checkpoint, a thread pool that cannot start.
pub fn render_progressive(
    scene: &Scene,
    opts: &ProgressiveOptions,
    on_event: &mut dyn FnMut(Event<'_>),
) -> Result<Outcome, ProgressiveError> {
    positive("target_rel_error", opts.target_rel_error, false)?;
    positive("time_limit", opts.time_limit.map(|d| d.as_secs_f64()), false)?;
    positive("checkpoint_every", opts.checkpoint.as_ref().map(|c| c.every.as_secs_f64()), true)?;
    if opts.threads == Some(0) {
        return Err(ProgressiveError::InvalidOption { name: "threads", value: 0.0 });
    }
    let s = &scene.settings;
    let range = opts.range.unwrap_or((0, s.spp as u64));
    let bl = batch_log2(s.spp);
    let replicates = crate::sampling::Sampler::replicates(s.sampler);
    let t0 = Instant::now();
    let mut state = match &opts.initial {
        Some(p) => p.clone(),
        None => Partial::empty(s.width, s.height, s.spp, bl, replicates, range.0),
    };
    let want = PartialHeader {
        end: range.1,
        ..partial_header(scene, &Partial::empty(s.width, s.height, s.spp, bl, replicates, range.0))
    };
    if let Some(ck) = &opts.checkpoint
        && ck.path.exists()
    {
        let f = read_partial(&ck.path)?;
        if let Some(mismatch) = check_resume(&f.header, &want) {
            return Err(ProgressiveError::CheckpointMismatch { path: ck.path.clone(), mismatch });
        }
        on_event(Event::Resumed { path: &ck.path, at: f.partial.end, range });
        state = f.partial;
    }
    let save = |state: &Partial| -> Result<(), ProgressiveError> {
        match &opts.checkpoint {
            Some(ck) => Ok(write_partial(&ck.path, state, &partial_header(scene, state), &ck.attributes)?),
            None => Ok(()),
        }
    };
    let cancel = opts.cancel.clone().unwrap_or_default();
    let ropts = RenderOptions { progress: opts.progress_bar, cancel: Some(cancel.clone()) };
    let every = opts.checkpoint.as_ref().map(|c| c.every);
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
        // An error bar needs samples to mean anything: the target is checked from MIN_TARGET_SPP on
        // (also after the last pass, so a cap that meets the target says so).
        if let Some(x) = opts.target_rel_error
            && cur >= MIN_TARGET_SPP
            && error_now(&state).is_ok_and(|e| e <= x)
        {
            stop = Stop::Target;
            break;
        }
        if cur >= range.1 {
            break;
        }
        let mut size = range.1 - cur;
        let budget = |secs: f64| rate.map_or(1, |r| (r * secs).max(1.0) as u64);
        // A Sobol render's error bar comes from its replicates' means over full rounds of R samples
        // (crate::film): from a round boundary on, passes are whole rounds.
        let round = replicates as u64;
        let round = if cur >= round && cur.is_multiple_of(round) { round } else { 1 };
        if let Some(every) = every {
            size = size.min(budget(every.as_secs_f64()));
        }
        if opts.target_rel_error.is_some() {
            size = size.min(cur.max(1));
        }
        if let Some(limit) = opts.time_limit {
            let left = limit.as_secs_f64() - t0.elapsed().as_secs_f64();
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
        let mut size = pow2_floor(size.max(1));
        if cur > 0 {
            size = size.min(1 << cur.trailing_zeros());
        }
        let size = size.max(round);
        let end = (cur + size).min(range.1);
        let (part, st) = on_threads(opts.threads, || render_range(scene, &ropts, cur, end))?;
        let Some(part) = part else {
            save(&state)?;
            return Ok(Outcome::Cancelled { state });
        };
        passes += 1;
        rate = Some((end - cur) as f64 / st.wall.as_secs_f64().max(1e-6));
        total.wall += st.wall;
        total.samples += st.samples;
        total.rays += st.rays;
        total.threads = st.threads;
        state = Partial::merge(vec![state, part])?;
        let estimate = (opts.estimate_each_pass || opts.target_rel_error.is_some()) && end >= MIN_TARGET_SPP;
        let rel_error = estimate.then(|| error_now(&state));
        on_event(Event::Pass(PassReport { pass: passes, start: cur, end, cap: range.1, wall: st.wall, rel_error }));
        if cancel.load(Ordering::Relaxed) {
            save(&state)?;
            return Ok(Outcome::Cancelled { state });
        }
        if let Some(every) = every
            && state.end < range.1
            && last_save.elapsed() >= every
        {
            save(&state)?;
            last_save = Instant::now();
        }
    }
    let rel_error = (state.start == 0).then(|| error_now(&state));
    Ok(Outcome::Done(Finished { state, stats: total, passes, stop, rel_error }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneFile;
    use crate::scene::build::DEFAULT_SCENE;
    use crate::shard::PartialFile;

    /// The default sphere, small, at `spp` and `seed`.
    fn scene(spp: u32, seed: u64) -> Scene {
        let mut f = SceneFile::parse(DEFAULT_SCENE).unwrap();
        (f.render.width, f.render.height, f.render.spp, f.render.seed) = (13, 9, spp, seed);
        Scene::build(f, Path::new(".")).unwrap()
    }

    fn bits(p: &Partial) -> Vec<u64> {
        p.stats.iter().flat_map(|s| s.0).map(f64::to_bits).collect()
    }

    fn plain(scene: &Scene) -> Partial {
        render_range(scene, &RenderOptions::default(), 0, scene.settings.spp as u64).0.unwrap()
    }

    fn run(scene: &Scene, opts: &ProgressiveOptions) -> (Outcome, Vec<PassReport>) {
        let mut passes = Vec::new();
        let out = render_progressive(scene, opts, &mut |e| {
            if let Event::Pass(p) = e {
                passes.push(p)
            }
        })
        .unwrap();
        (out, passes)
    }

    fn done(o: Outcome) -> Finished {
        match o {
            Outcome::Done(f) => f,
            Outcome::Cancelled { state } => panic!("cancelled at {}", state.end),
        }
    }

    #[test]
    fn passes_to_an_unreachable_target_give_the_single_render_bits() {
        let s = scene(37, 3);
        // A target no render reaches: passes that double (1, 1, 2, 4, 8, 16), then, Sobol's passes
        // being whole rounds of 16 replicates from 16 spp on, one round cut at the cap (5).
        let opts = ProgressiveOptions { target_rel_error: Some(1e-9), ..Default::default() };
        let (out, passes) = run(&s, &opts);
        let f = done(out);
        assert_eq!(f.stop, Stop::SppCap);
        let ranges: Vec<(u64, u64)> = passes.iter().map(|p| (p.start, p.end)).collect();
        assert_eq!(ranges, [(0, 1), (1, 2), (2, 4), (4, 8), (8, 16), (16, 32), (32, 37)]);
        // The error is estimated from MIN_TARGET_SPP samples on, and not before.
        assert!(passes.iter().all(|p| p.rel_error.is_some() == (p.end >= MIN_TARGET_SPP)));
        assert_eq!(f.passes, 7);
        assert_eq!(bits(&f.state), bits(&plain(&s)));
    }

    #[test]
    fn a_reachable_target_stops_at_or_below_it() {
        let s = scene(4096, 3);
        let opts = ProgressiveOptions { target_rel_error: Some(0.05), ..Default::default() };
        let f = done(run(&s, &opts).0);
        assert_eq!(f.stop, Stop::Target);
        let e = f.rel_error.unwrap().unwrap();
        assert!(e <= 0.05, "stopped at {e}");
        assert!(f.state.end < 4096 && f.state.end.is_power_of_two(), "{}", f.state.end);
        // One pass fewer would not have reached it (the loop stops at the first spp that does).
        let mut half = scene(f.state.end as u32 / 2, 3);
        half.settings.spp = f.state.end as u32 / 2;
        assert!(p95_rel_error(&plain(&half)).unwrap() > 0.05);
    }

    /// Rounds of shards (`crate::rounds`): parts of a render planned for 1024 spp, rounds [0, 32),
    /// [32, 64), [64, 100) each split 3 ways, merge to the state of a plain 100-spp render, bit for bit.
    #[test]
    fn rounds_of_split_ranges_merge_to_the_single_render_of_their_total() {
        let planned = scene(1024, 5);
        let mut parts = Vec::new();
        for round in [(0, 32), (32, 64), (64, 100)] {
            let split: Vec<(u64, u64)> = (0..3).map(|i| split_range(i, 3, round)).collect();
            assert_eq!((split[0].0, split[2].1), round);
            assert!(split.windows(2).all(|w| w[0].1 == w[1].0), "{split:?}");
            for (a, b) in split {
                parts.push(render_range(&planned, &RenderOptions::default(), a, b).0.unwrap());
            }
        }
        parts.reverse();
        let mut merged = Partial::merge(parts).unwrap();
        assert_eq!((merged.start, merged.end, merged.spp), (0, 100, 1024));
        merged.spp = 100;
        assert_eq!(bits(&merged), bits(&plain(&scene(100, 5))));
        assert_eq!(split_range(2, 4, (10, 10)), (10, 10));
        assert_eq!(shard_range(1, 4, 40), split_range(1, 4, (0, 40)));
    }

    #[test]
    fn a_continued_state_gives_the_single_render_bits() {
        let short = scene(5, 8);
        let first = plain(&short);
        let long = scene(29, 8);
        let file = PartialFile { header: partial_header(&short, &first), partial: first, attributes: Vec::new() };
        let initial = continuable(Path::new("a.exr"), file, &long).unwrap();
        assert_eq!((initial.start, initial.end, initial.spp), (0, 5, 29));
        let opts = ProgressiveOptions { initial: Some(initial), threads: Some(2), ..Default::default() };
        let (out, passes) = run(&long, &opts);
        let f = done(out);
        // Only the new samples are rendered.
        assert_eq!(passes.iter().map(|p| p.end - p.start).sum::<u64>(), 24);
        assert_eq!(bits(&f.state), bits(&plain(&long)));
        assert_eq!(f.state.finish().pixels.len(), 13 * 9);
    }

    #[test]
    fn states_of_other_renders_are_not_continued() {
        let short = scene(6, 8);
        let first = plain(&short);
        let file = |scene: &Scene, p: &Partial| PartialFile {
            header: partial_header(scene, p),
            partial: p.clone(),
            attributes: Vec::new(),
        };
        let path = Path::new("a.exr");
        let e = continuable(path, file(&short, &first), &scene(20, 9)).unwrap_err();
        assert!(matches!(e, ProgressiveError::ContinueMismatch { mismatch: Mismatch::Seed, .. }), "{e}");
        let e = continuable(path, file(&short, &first), &scene(4, 8)).unwrap_err();
        assert!(matches!(e, ProgressiveError::ContinueBeyond { have: 6, want: 4, .. }), "{e}");
        let mut other = SceneFile::parse(DEFAULT_SCENE).unwrap();
        (other.render.width, other.render.height, other.render.spp, other.render.seed) = (13, 9, 20, 8);
        other.render.max_depth = 2;
        let other = Scene::build(other, Path::new(".")).unwrap();
        let e = continuable(path, file(&short, &first), &other).unwrap_err();
        assert!(matches!(e, ProgressiveError::ContinueMismatch { mismatch: Mismatch::Scene, .. }), "{e}");
        let tail = render_range(&short, &RenderOptions::default(), 3, 6).0.unwrap();
        let e = continuable(path, file(&short, &tail), &scene(20, 8)).unwrap_err();
        assert!(matches!(e, ProgressiveError::ContinueNotFromZero { start: 3, end: 6, .. }), "{e}");
        assert!(e.to_string().starts_with("a.exr: "), "{e}");
    }

    #[test]
    fn cancelling_returns_the_state_of_the_last_finished_pass() {
        let s = scene(64, 1);
        let cancel = Arc::new(AtomicBool::new(false));
        let opts =
            ProgressiveOptions { target_rel_error: Some(1e-9), cancel: Some(cancel.clone()), ..Default::default() };
        // Cancelled from the progress callback after the third pass (samples [0, 4)).
        let mut seen = 0;
        let out = render_progressive(&s, &opts, &mut |e| {
            if let Event::Pass(p) = e {
                seen = p.pass;
                if p.pass == 3 {
                    cancel.store(true, Ordering::Relaxed);
                }
            }
        })
        .unwrap();
        assert_eq!(seen, 3);
        match out {
            Outcome::Cancelled { state } => assert_eq!((state.start, state.end), (0, 4)),
            Outcome::Done(f) => panic!("not cancelled: {} spp", f.state.end),
        }
    }

    /// Flagged pixels count as infinite in the target: 100 object pixels of relative error 0.001,
    /// 0.002, …, 0.100 have p95 0.095 (nearest rank 95); flagging the three *least* noisy moves it to
    /// 0.098 (their errors now rank last). Left out instead, it would be 0.096 (rank 93 of 97); kept
    /// at their own errors, 0.095. More than 5 % flagged: no estimate, so no target is ever reached.
    #[test]
    fn flagged_pixels_count_as_infinite_in_the_target() {
        let mut film = crate::film::Film::new(10, 10);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            let e = (i + 1) as f32 * 0.001;
            (p.rgb, p.stderr, p.stderr_own, p.mask) = ([1.0; 3], [e; 3], [e; 3], 1.0);
        }
        let err = |i: usize| ((i + 1) as f32 * 0.001) as f64;
        assert_eq!(film_rel_error(film.clone()), Ok(err(94)));
        for p in &mut film.pixels[..3] {
            p.unreliable = true;
        }
        let e = film_rel_error(film.clone()).unwrap();
        assert_eq!(e, err(97), "flagged pixels must rank above every finite error");
        // A target between the flagged-as-own (0.095) and the flagged-as-infinite (0.098) value is not reached.
        assert!(e > 0.0965);
        for p in &mut film.pixels[3..6] {
            p.unreliable = true;
        }
        assert_eq!(film_rel_error(film), Err(NoEstimate::Flagged));
    }

    #[test]
    fn options_out_of_their_domain_are_named() {
        let s = scene(4, 1);
        for (opts, name) in [
            (ProgressiveOptions { target_rel_error: Some(0.0), ..Default::default() }, "target_rel_error"),
            (ProgressiveOptions { target_rel_error: Some(f64::NAN), ..Default::default() }, "target_rel_error"),
            (ProgressiveOptions { time_limit: Some(Duration::ZERO), ..Default::default() }, "time_limit"),
            (ProgressiveOptions { threads: Some(0), ..Default::default() }, "threads"),
        ] {
            match render_progressive(&s, &opts, &mut |_| {}) {
                Err(ProgressiveError::InvalidOption { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {:?}", other.map(|_| ())),
            }
        }
    }
}
