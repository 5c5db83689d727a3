//! Noise summary of a render: how far each object pixel's mean may be from its expectation,
//! relative to its value, so a user can render "to a stated noise level".
//!
//! Per pixel with `mask > 0` (at least one sample hit an object), the relative standard error is
//! the worst channel's σ_c / v_c over the channels with v_c > 0 (σ_c the `stderr` layer, v_c the
//! pixel mean). Object pixels that are black in every channel are exact (every sample was 0, so
//! σ = 0) and have no relative error: they are counted apart and left out. Background pixels
//! (mask = 0) are left out: their value is the environment, not the object.
//!
//! Percentiles are nearest-rank: the q-quantile of n sorted values x_1 ≤ … ≤ x_n is x_⌈qn⌉.

use crate::film::Film;

/// Median and 95th percentile of the per-pixel relative standard error over the object's pixels.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct NoiseSummary {
    /// Object pixels (mask > 0) that entered the summary (value > 0 in some channel).
    pub pixels: usize,
    /// Object pixels black in every channel, left out.
    pub black: usize,
    /// Median relative standard error (a fraction: 0.01 = 1 %).
    pub median: f64,
    /// 95th percentile of the relative standard error (a fraction).
    pub p95: f64,
}

/// Relative standard error of one pixel: max over channels with value > 0 of stderr / value, or
/// None when every channel is ≤ 0.
pub fn relative_stderr(rgb: [f32; 3], stderr: [f32; 3]) -> Option<f64> {
    rgb.iter()
        .zip(stderr)
        .filter(|(v, _)| **v > 0.0)
        .map(|(v, s)| s as f64 / *v as f64)
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))))
}

/// Nearest-rank q-quantile (q in (0, 1]) of sorted values; None for an empty slice.
pub fn nearest_rank(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let k = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    Some(sorted[k - 1])
}

/// The summary of `film`, or None when no object pixel has a value > 0 (nothing was hit, or the
/// object is black).
pub fn summarize(film: &Film) -> Option<NoiseSummary> {
    let mut rel = Vec::new();
    let mut black = 0;
    for p in film.pixels.iter().filter(|p| p.mask > 0.0) {
        match relative_stderr(p.rgb, p.stderr) {
            Some(r) => rel.push(r),
            None => black += 1,
        }
    }
    rel.sort_by(f64::total_cmp);
    Some(NoiseSummary { pixels: rel.len(), black, median: nearest_rank(&rel, 0.5)?, p95: nearest_rank(&rel, 0.95)? })
}

impl std::fmt::Display for NoiseSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "noise over {} object pixels (mask > 0{}): relative standard error (worst channel) median {:.3} %, 95th \
             percentile {:.3} %",
            self.pixels,
            if self.black > 0 { format!("; {} black pixels left out", self.black) } else { String::new() },
            100.0 * self.median,
            100.0 * self.p95
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Pixel;

    fn px(v: [f32; 3], se: [f32; 3], mask: f32) -> Pixel {
        Pixel { rgb: v, stderr: se, stderr_own: se, normal: [0.0, 0.0, 1.0], mask, unreliable: false }
    }

    #[test]
    fn nearest_rank_quantiles() {
        let x: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(nearest_rank(&x, 0.5), Some(50.0));
        assert_eq!(nearest_rank(&x, 0.95), Some(95.0));
        assert_eq!(nearest_rank(&x[..1], 0.95), Some(1.0));
        assert_eq!(nearest_rank(&x[..3], 0.5), Some(2.0));
        assert_eq!(nearest_rank(&[], 0.5), None);
    }

    #[test]
    fn worst_channel_and_black_pixels() {
        // Values exact in binary, so the ratios are exact: 0.25, 0.125, 0.125.
        assert_eq!(relative_stderr([2.0, 4.0, 1.0], [0.5, 0.5, 0.125]), Some(0.25));
        // A zero channel does not divide by zero; an all-black pixel has no relative error.
        assert_eq!(relative_stderr([0.0, 4.0, 0.0], [0.0, 1.0, 0.0]), Some(0.25));
        assert_eq!(relative_stderr([0.0; 3], [0.0; 3]), None);
    }

    /// A film built so that the answer is known in closed form: 200 object pixels whose relative
    /// errors are i/200 (i = 1…200) in the worst channel, in shuffled order, plus background
    /// pixels with a huge relative error and black object pixels, which must not count.
    #[test]
    fn summary_of_a_known_film() {
        let mut film = Film::new(20, 12);
        let mut order: Vec<usize> = (1..=200).collect();
        // Deterministic shuffle (multiplicative step coprime with 200).
        order = (0..200).map(|k| order[(k * 73) % 200]).collect();
        for (slot, i) in order.into_iter().enumerate() {
            let r = i as f32 / 200.0;
            // Value 2 in G, worst channel G; the other channels are less noisy.
            film.pixels[slot] = px([1.0, 2.0, 4.0], [0.5 * r, 2.0 * r, 0.1 * r], 0.5 + (slot % 2) as f32 * 0.5);
        }
        for slot in 200..230 {
            film.pixels[slot] = px([1.0; 3], [100.0; 3], 0.0); // background: ignored
        }
        for slot in 230..240 {
            film.pixels[slot] = px([0.0; 3], [0.0; 3], 1.0); // black object pixels
        }
        let s = summarize(&film).unwrap();
        assert_eq!(s.pixels, 200);
        assert_eq!(s.black, 10);
        // Nearest rank: the 100th and 190th smallest of i/200.
        assert!((s.median - 100.0 / 200.0).abs() < 1e-6, "{s:?}");
        assert!((s.p95 - 190.0 / 200.0).abs() < 1e-6, "{s:?}");
        let line = s.to_string();
        assert!(line.contains("median 50.000 %") && line.contains("95th percentile 95.000 %"), "{line}");
        assert!(line.contains("10 black pixels left out"), "{line}");
    }

    #[test]
    fn nothing_hit_gives_no_summary() {
        let film = Film::new(4, 4);
        assert_eq!(summarize(&film), None);
    }
}
