//! Shared evaluation of a measured per-order filter Λ_l ρ̂_l against a prediction: one row per
//! order, measured ± σ from the pixel-space fit ([`super::fit`]), with an optional stated
//! approximation error per order (for the paper's approximate formulas), and the plot series.

use super::check::{Check, Row, Series};
use super::fit::Fit;

/// Measured filter: a_l ± σ_l for l = 0..=lmax.
#[derive(Clone, Debug)]
pub struct Measured {
    pub a: Vec<f64>,
    pub sigma: Vec<f64>,
}

impl Measured {
    pub fn from_fit(f: &Fit, lmax: usize) -> Measured {
        Measured { a: f.coef[..=lmax].to_vec(), sigma: f.sigma[..=lmax].to_vec() }
    }

    pub fn series(&self, name: &str) -> Series {
        Series {
            name: name.into(),
            x: (0..self.a.len()).map(|l| l as f64).collect(),
            y: self.a.clone(),
            err: Some(self.sigma.clone()),
            dashed: false,
        }
    }
}

/// One row per order: `prefix l=L`, expected `pred[l]`, tolerance k·σ + `approx[l]`.
pub fn rows(check: &mut Check, prefix: &str, m: &Measured, pred: &[f64], approx: Option<&[f64]>, informative: bool) {
    for l in 0..m.a.len().min(pred.len()) {
        let mut r = Row::new(format!("{prefix} l={l}"), pred[l], m.a[l], m.sigma[l]);
        if let Some(a) = approx {
            r = r.approx(a[l]);
        }
        if informative {
            r = r.informative();
        }
        check.push(r);
    }
}

/// A prediction curve as a plot series.
pub fn curve(name: &str, v: &[f64]) -> Series {
    Series { name: name.into(), x: (0..v.len()).map(|l| l as f64).collect(), y: v.to_vec(), err: None, dashed: false }
}

/// A dashed prediction curve (the paper's approximate formulas).
pub fn dashed(name: &str, v: &[f64]) -> Series {
    Series { dashed: true, ..curve(name, v) }
}
