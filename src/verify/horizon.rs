//! Check 11, the horizon (sec. 3.6): Phong (s = 8, k_s = 1) and Torrance–Sparrow (σ = 0.2,
//! k_s = 1) spheres with `horizon = "clamp"` and `"ignore"`, orthographic view from +x under
//! uniform lighting L = 1, as a function of the viewing angle θ_o = angle(n, ω_o).
//!
//! Under uniform lighting B(θ_o) = ∫ ρ̂ dω_i over the directions the lobe may gather: with
//! `ignore` the whole lobe (Phong: exactly k_s; TS: the half-vector integral without horizon),
//! with `clamp` only the part above the local horizon — for Phong the fraction of the cos^s lobe
//! about R (angle(R, n) = θ_o) above the horizon ([`transfer::phong_horizon_fraction`]), for TS
//! [`transfer::ts_albedo`]. The paper's simplification (sec. 3.6) is `ignore`; the departure of
//! `clamp` from it is the quantity studied.
//!
//! Each pixel's prediction averages the exact function over a 4 × 4 grid inside the pixel (the
//! camera's box filter), from tables at 1° steps (linear interpolation, error < 1e-4 below 80°).
//! Pixels are binned in 10° bins of θ_o up to 80°; per bin, the mean measured value vs the mean
//! prediction (σ = √Σσ_p² / N).
//! Wrong prediction: the `clamp` renders compared with the `ignore` prediction (the paper's
//! simplification taken as exact).

use super::Ctx;
use super::check::{Check, Plot, Row, Series};
use super::fit::Channel;
use super::picture::Picture;
use super::scenes::{Camera, Lighting, Shape, Spec, render_spec};
use super::scenes::{phong, torrance_sparrow};
use super::transfer;
use rayon::prelude::*;
use vocab::Horizon;
use vocab::scene::BrdfSection;

pub const NAME: &str = "horizon";
pub const EQUATION: &str = "sec. 3.6";
pub const S: f64 = 8.0;
pub const SIGMA: f64 = 0.2;
const EXTENT: f64 = 1.05;
const BIN_DEG: f64 = 10.0;
const MAX_DEG: f64 = 80.0;

/// A function of θ_o tabulated at 1° steps.
pub struct Table(Vec<f64>);

impl Table {
    pub fn new(f: impl Fn(f64) -> f64 + Sync) -> Table {
        Table((0..=90).into_par_iter().map(|d| f((d as f64).min(89.999).to_radians())).collect())
    }
    pub fn at(&self, theta: f64) -> f64 {
        let d = theta.to_degrees().clamp(0.0, 90.0);
        let i = (d.floor() as usize).min(89);
        let t = d - i as f64;
        self.0[i] * (1.0 - t) + self.0[i + 1] * t
    }
}

/// Per-bin (θ centre, measured mean, σ, predicted mean) of an orthographic render from +x.
/// The prediction of pixel (r, c) of the orthographic view and its mean θ_o, by a 4 × 4 box
/// average over the pixel; None for a pixel the sphere does not fully cover.
pub fn pixel_prediction(ch: &Channel, pred: &dyn Fn(f64) -> f64, r: usize, c: usize) -> Option<(f64, f64)> {
    let (w, h) = (ch.width, ch.height);
    if ch.mask[r * w + c] < 0.999 {
        return None;
    }
    let (mut p, mut tc) = (0.0, 0.0);
    for a in 0..4 {
        for b in 0..4 {
            let x = EXTENT * (2.0 * (c as f64 + (b as f64 + 0.5) / 4.0) / w as f64 - 1.0);
            let y = EXTENT * (h as f64 / w as f64) * (1.0 - 2.0 * (r as f64 + (a as f64 + 0.5) / 4.0) / h as f64);
            let q = 1.0 - x * x - y * y;
            if q <= 0.0 {
                return None;
            }
            let t = q.sqrt().min(1.0).acos();
            p += pred(t) / 16.0;
            tc += t / 16.0;
        }
    }
    Some((p, tc))
}

pub fn bins(ch: &Channel, pred: &dyn Fn(f64) -> f64) -> Vec<(f64, f64, f64, f64)> {
    let (w, h) = (ch.width, ch.height);
    let nb = (MAX_DEG / BIN_DEG) as usize;
    let mut acc = vec![(0.0, 0.0, 0.0, 0usize); nb];
    for r in 0..h {
        for c in 0..w {
            let i = r * w + c;
            let Some((p, tc)) = pixel_prediction(ch, pred, r, c) else { continue };
            let bin = (tc.to_degrees() / BIN_DEG) as usize;
            if bin >= nb {
                continue;
            }
            acc[bin].0 += ch.value[i];
            acc[bin].1 += ch.sigma[i] * ch.sigma[i];
            acc[bin].2 += p;
            acc[bin].3 += 1;
        }
    }
    acc.iter()
        .enumerate()
        .filter(|(_, a)| a.3 > 0)
        .map(|(b, a)| ((b as f64 + 0.5) * BIN_DEG, a.0 / a.3 as f64, a.1.sqrt() / a.3 as f64, a.2 / a.3 as f64))
        .collect()
}

/// The view beside the prediction per pixel (no data outside the fully covered disc and beyond
/// the binned range [`MAX_DEG`]).
fn picture(label: &str, ch: &Channel, pred: &dyn Fn(f64) -> f64, spp: u32) -> Picture {
    let (w, h) = (ch.width, ch.height);
    let mut measured = vec![f64::NAN; w * h];
    let mut predicted = vec![f64::NAN; w * h];
    for r in 0..h {
        for c in 0..w {
            if let Some((p, tc)) = pixel_prediction(ch, pred, r, c)
                && tc.to_degrees() < MAX_DEG
            {
                measured[r * w + c] = ch.value[r * w + c];
                predicted[r * w + c] = p;
            }
        }
    }
    Picture::new(
        format!("horizon_{}", label.replace(' ', "_")),
        format!("{label} sphere under uniform L = 1, orthographic {w}×{h} from +x, {spp} spp"),
        format!(
            "B(θ_o)/(k_s L) by quadrature with the {label} horizon, box-averaged over each pixel (θ_o < {MAX_DEG}°)"
        ),
        (w, h),
        measured,
        predicted,
        ch.sigma.clone(),
    )
}

pub fn evaluate_into(c: &mut Check, label: &str, bins: &[(f64, f64, f64, f64)]) {
    for &(t, m, s, p) in bins {
        c.push(Row::new(format!("{label} θo≈{t}°"), p, m, s));
    }
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let mut c =
        Check::new(NAME, EQUATION, "horizon clamp vs ignore (paper's simplification) vs viewing angle, uniform light");
    let phong_clamp = Table::new(|t| transfer::phong_horizon_fraction(S, t));
    let ts_clamp = Table::new(|t| transfer::ts_albedo(SIGMA, t, true));
    let ts_ignore = Table::new(|t| transfer::ts_albedo(SIGMA, t, false));
    let size = if ctx.quick { 96 } else { 192 };
    let mut plot_curves = vec![];
    let mut plot_points = vec![];
    // (label, BRDF, prediction, deliberately wrong prediction).
    type Case<'a> = (&'a str, BrdfSection, Box<dyn Fn(f64) -> f64 + 'a>, Box<dyn Fn(f64) -> f64 + 'a>);
    let cases: Vec<Case> = vec![
        ("phong clamp", phong(1.0, S, Horizon::Clamp), Box::new(|t| phong_clamp.at(t)), Box::new(|_| 1.0)),
        ("phong ignore", phong(1.0, S, Horizon::Ignore), Box::new(|_| 1.0), Box::new(|_| 1.0)),
        (
            "TS clamp",
            torrance_sparrow(1.0, SIGMA, Horizon::Clamp),
            Box::new(|t| ts_clamp.at(t)),
            Box::new(|t| ts_ignore.at(t)),
        ),
        (
            "TS ignore",
            torrance_sparrow(1.0, SIGMA, Horizon::Ignore),
            Box::new(|t| ts_ignore.at(t)),
            Box::new(|t| ts_ignore.at(t)),
        ),
    ];
    for (label, brdf, right, wrong) in &cases {
        let spec = Spec {
            width: size,
            height: size,
            spp: ctx.spp(32, 256),
            seed: ctx.seed,
            camera: Camera::Ortho { from: [3.0, 0.0, 0.0], up: [0.0, 0.0, 1.0], extent: EXTENT },
            lighting: Lighting::Uniform(1.0),
            shape: Shape::Sphere,
            brdf: brdf.clone(),
        };
        let ch = Channel::from_film(&render_spec(ctx, &spec)?, 0);
        let pred: &dyn Fn(f64) -> f64 = if ctx.wrong { wrong.as_ref() } else { right.as_ref() };
        let b = bins(&ch, pred);
        c.pictures.push(picture(label, &ch, pred, spec.spp));
        evaluate_into(&mut c, label, &b);
        plot_points.push(Series {
            name: format!("measured, {label}"),
            x: b.iter().map(|v| v.0).collect(),
            y: b.iter().map(|v| v.1).collect(),
            err: Some(b.iter().map(|v| v.2).collect()),
            dashed: false,
        });
        let xs: Vec<f64> = (0..=85).map(|d| d as f64).collect();
        plot_curves.push(Series {
            name: format!("predicted, {label}"),
            x: xs.clone(),
            y: xs.iter().map(|d| right(d.to_radians())).collect(),
            err: None,
            dashed: false,
        });
    }
    for d in [30.0f64, 60.0, 75.0] {
        let t = d.to_radians();
        c.note(format!(
            "θo = {d}°: Phong clamp/ignore = {:.4}, TS clamp/ignore = {:.4} (the paper's simplification overestimates B by {:.1} % / {:.1} %)",
            phong_clamp.at(t),
            ts_clamp.at(t) / ts_ignore.at(t),
            100.0 * (1.0 / phong_clamp.at(t) - 1.0),
            100.0 * (ts_ignore.at(t) / ts_clamp.at(t) - 1.0)
        ));
    }
    c.note(format!(
        "orthographic {size}×{size} from +x, uniform L = 1, {} spp, bins of {BIN_DEG}° up to {MAX_DEG}°",
        ctx.spp(32, 256)
    ));
    if ctx.wrong {
        c.note("WRONG-PREDICTION MODE: clamp renders compared with the ignore prediction");
    }
    c.plots.push(Plot {
        legend: super::check::Legend::LowerLeft,
        file: "horizon.svg".into(),
        title: "Horizon: B/(k_s L) under uniform light vs viewing angle".into(),
        x_label: "θ_o (degrees)".into(),
        y_label: "B / (k_s L)".into(),
        curves: plot_curves,
        points: plot_points,
    });
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamp_differs_from_ignore_where_it_should() {
        let t = Table::new(|t| transfer::phong_horizon_fraction(S, t));
        // Below θ_o ≈ 30° the s = 8 lobe is essentially above the horizon; at 75° it is cut a lot.
        assert!((t.at(10f64.to_radians()) - 1.0).abs() < 1e-3);
        assert!(t.at(75f64.to_radians()) < 0.8);
        // A measured clamp curve compared with the ignore prediction fails at large θ_o.
        let bins = vec![(75.0, t.at(75f64.to_radians()), 0.002, 1.0)];
        let mut bad = Check::default();
        evaluate_into(&mut bad, "x", &bins);
        assert!(!bad.passed());
        let bins = vec![(75.0, t.at(75f64.to_radians()) + 0.004, 0.002, t.at(75f64.to_radians()))];
        let mut ok = Check::default();
        evaluate_into(&mut ok, "x", &bins);
        assert!(ok.passed());
    }
}
