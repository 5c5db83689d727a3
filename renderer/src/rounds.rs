//! Rendering to a target error across shards, in rounds: round r renders the samples
//! `[S_{r-1}, S_r)` of every pixel (split into shards anywhere), the state `[0, S_r)` of all rounds
//! so far is measured with [`p95_rel_error`](crate::progressive::p95_rel_error) (the measure of a
//! single render's target), and [`next_round`] decides whether to stop or how far the next round
//! goes. Since a sample's value depends only on its index and the seed (not on how the samples are
//! grouped, nor on the planned spp), the merged state of all rounds is the state of one render of
//! `S_r` samples, bit for bit ([`crate::film`]).
//!
//! Where the rounds run is the front-end's business (`reflect slurm render --target-rel-error`
//! submits each round as a job array and a step job that measures, decides and submits the next);
//! the arithmetic of the decision is here.

use crate::progressive::{MIN_TARGET_SPP, NoEstimate, Stop};
use std::time::Duration;

/// The limits of a render in rounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundsBudget {
    /// Stop once the 95th-percentile relative stderr is at most this (> 0).
    pub target_rel_error: f64,
    /// The most samples per pixel to take over all rounds.
    pub max_spp: u64,
    /// The most wall-clock time over all rounds (from the first submission), if any.
    pub time_limit: Option<Duration>,
    /// Round ends are multiples of this (the sampler's replicates: a Sobol render's error bar comes
    /// from whole rounds of its replicates), unless at `max_spp`.
    pub granularity: u64,
}

/// Where a render in rounds stands after a round.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundsProgress {
    /// Samples per pixel of all rounds so far (the state is `[0, done)`).
    pub done: u64,
    /// The state's [`p95_rel_error`](crate::progressive::p95_rel_error).
    pub rel_error: Result<f64, NoEstimate>,
    /// Wall-clock time since the first round was started.
    pub elapsed: Duration,
    /// The samples of the last round and its wall-clock time (submission to measurement), from which
    /// the next round's time is predicted.
    pub last_round: (u64, Duration),
}

/// What follows a round.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RoundDecision {
    /// No further round: the target is reached (`Stop::Target`), the spp budget spent
    /// (`Stop::SppCap`), or not even the smallest round fits in the time left (`Stop::TimeLimit`).
    Stop(Stop),
    /// Render the samples `[done, end)` next.
    Next { end: u64 },
}

/// `x` rounded up to a multiple of `g`.
fn round_up(x: u64, g: u64) -> u64 {
    x.div_ceil(g).saturating_mul(g)
}

/// The end of the first round: `requested` samples, at least [`MIN_TARGET_SPP`] (an error bar from
/// fewer is not worth measuring), rounded up to the granularity, at most `max_spp`.
pub fn first_round_end(requested: u64, budget: &RoundsBudget) -> u64 {
    round_up(requested.max(MIN_TARGET_SPP), budget.granularity.max(1)).min(budget.max_spp)
}

/// The decision after a round. The relative error of a mean falls as 1/√spp, so the samples that
/// reach the target are predicted as `done · (error / target)²`; the next round ends there, rounded up
/// to the granularity, but at most at twice `done` (the prediction rests on a noisy error, and an
/// overshoot would waste more than the round it saves) and at most at `max_spp`. With a time limit,
/// the round is shortened (rounded down to the granularity) to what the last round's time per sample
/// says fits in the time left, and none is started when not even one granule fits.
///
/// Without an estimate (one sample, no object pixel > 0, or over 5 % of the pixels flagged) the
/// target is not reached and the next round doubles, as a single render's passes do.
pub fn next_round(budget: &RoundsBudget, p: &RoundsProgress) -> RoundDecision {
    let g = budget.granularity.max(1);
    if p.rel_error.is_ok_and(|e| e <= budget.target_rel_error) {
        return RoundDecision::Stop(Stop::Target);
    }
    if p.done >= budget.max_spp {
        return RoundDecision::Stop(Stop::SppCap);
    }
    let doubled = p.done.max(1).saturating_mul(2);
    let predicted = match p.rel_error {
        Ok(e) => {
            let n = (p.done as f64 * (e / budget.target_rel_error).powi(2)).ceil();
            if n.is_finite() && n < u64::MAX as f64 { n as u64 } else { u64::MAX }
        }
        Err(_) => doubled,
    };
    let mut end = round_up(predicted.min(doubled), g).clamp(p.done + 1, budget.max_spp);
    if let Some(limit) = budget.time_limit {
        let (samples, wall) = p.last_round;
        let left = limit.saturating_sub(p.elapsed).as_secs_f64();
        let per_sample = wall.as_secs_f64() / samples.max(1) as f64;
        let fit =
            if per_sample > 0.0 { (left / per_sample).floor().min(u64::MAX as f64 / 2.0) as u64 } else { u64::MAX };
        let fit_end = (p.done.saturating_add(fit) / g * g).min(budget.max_spp);
        if left <= 0.0 || fit_end <= p.done {
            return RoundDecision::Stop(Stop::TimeLimit);
        }
        end = end.min(fit_end);
    }
    RoundDecision::Next { end }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn budget(max_spp: u64, time_limit: Option<u64>) -> RoundsBudget {
        RoundsBudget {
            target_rel_error: 0.01,
            max_spp,
            time_limit: time_limit.map(Duration::from_secs),
            granularity: 16,
        }
    }

    fn progress(done: u64, e: f64) -> RoundsProgress {
        RoundsProgress {
            done,
            rel_error: Ok(e),
            elapsed: Duration::from_secs(100),
            last_round: (done, Duration::from_secs(100)),
        }
    }

    #[test]
    fn the_target_stops_and_so_does_the_spp_budget() {
        assert_eq!(next_round(&budget(4096, None), &progress(64, 0.01)), RoundDecision::Stop(Stop::Target));
        assert_eq!(next_round(&budget(4096, None), &progress(64, 0.0099)), RoundDecision::Stop(Stop::Target));
        assert_eq!(next_round(&budget(64, None), &progress(64, 0.02)), RoundDecision::Stop(Stop::SppCap));
        // Reached at the budget: the target is what is said.
        assert_eq!(next_round(&budget(64, None), &progress(64, 0.005)), RoundDecision::Stop(Stop::Target));
    }

    #[test]
    fn the_next_round_is_the_predicted_spp_capped_by_doubling_and_the_budget() {
        // 1/√spp: 1.2 % at 64 spp needs 64 · 1.44 = 92.2 → 93, rounded up to 96.
        assert_eq!(next_round(&budget(4096, None), &progress(64, 0.012)), RoundDecision::Next { end: 96 });
        // 3 % needs 9 × 64: doubling caps it at 128.
        assert_eq!(next_round(&budget(4096, None), &progress(64, 0.03)), RoundDecision::Next { end: 128 });
        // The budget caps it, even where it is not a multiple of the granularity.
        assert_eq!(next_round(&budget(100, None), &progress(64, 0.03)), RoundDecision::Next { end: 100 });
        // Just above the target: at least one granule more.
        assert_eq!(next_round(&budget(4096, None), &progress(64, 0.010001)), RoundDecision::Next { end: 80 });
    }

    #[test]
    fn without_an_estimate_the_rounds_double() {
        let mut p = progress(32, 0.0);
        for why in [NoEstimate::OneSample, NoEstimate::NoObject, NoEstimate::Flagged] {
            p.rel_error = Err(why);
            assert_eq!(next_round(&budget(4096, None), &p), RoundDecision::Next { end: 64 }, "{why:?}");
        }
        assert_eq!(next_round(&budget(48, None), &p), RoundDecision::Next { end: 48 });
    }

    #[test]
    fn the_time_limit_shortens_the_round_or_stops() {
        // 64 samples took 100 s (1.5625 s each); 100 s spent of 200 leave room for 64 more.
        assert_eq!(next_round(&budget(4096, Some(200)), &progress(64, 0.03)), RoundDecision::Next { end: 128 });
        // Of 150: 32 more (50 s), rounded down to the granularity.
        assert_eq!(next_round(&budget(4096, Some(150)), &progress(64, 0.03)), RoundDecision::Next { end: 96 });
        // Of 120: 12 more fit, less than one granule of 16.
        assert_eq!(next_round(&budget(4096, Some(120)), &progress(64, 0.03)), RoundDecision::Stop(Stop::TimeLimit));
        // Time already spent.
        assert_eq!(next_round(&budget(4096, Some(90)), &progress(64, 0.03)), RoundDecision::Stop(Stop::TimeLimit));
        // The target wins over the time limit.
        assert_eq!(next_round(&budget(4096, Some(90)), &progress(64, 0.001)), RoundDecision::Stop(Stop::Target));
    }

    #[test]
    fn the_first_round_is_at_least_the_least_checked_spp_in_whole_granules() {
        assert_eq!(first_round_end(1, &budget(4096, None)), MIN_TARGET_SPP);
        assert_eq!(first_round_end(40, &budget(4096, None)), 48);
        assert_eq!(first_round_end(64, &budget(40, None)), 40);
        let independent = RoundsBudget { granularity: 1, ..budget(4096, None) };
        assert_eq!(first_round_end(40, &independent), 40);
    }
}
