//! Projection of environment maps into SH: L_lm = Σ_pixels L(ω_p) Y_lm(ω_p) ΔΩ_p with the exact
//! per-pixel solid angles of docs/src/conventions.md §2, RGB.
//!
//! - Lat-long (W × H): every row has one θ, so the sum separates: a φ-Fourier sum per row and order m,
//!   then the associated Legendre functions once per row. O(W H l_max) instead of O(W H l_max²), which
//!   makes a 2048 × 1024 map at l_max = 20 a fraction of a second. An optional per-pixel variance
//!   image propagates to per-coefficient variances Σ ΔΩ² Y² σ² (used for `normal-probe` renders).
//! - Angular map (W × W, Debevec probe): pixels with ρ > 1 skipped; the four pixels mirrored about
//!   the image axes share θ, so one evaluation of all Y_lm serves four pixels (even W).
//!
//! Rows are processed in parallel and reduced in a fixed order (results do not depend on threads).

use crate::error::{Error, Result};
use crate::image::RgbImage;
use crate::sh::{RgbCoeffs, ShBasis, index, num_coefficients};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Environment-map parameterization (docs/src/conventions.md §2), defined in `vocab`.
pub use vocab::Mapping;

/// Direction of the angular-map pixel (row, col) and its solid angle, or `None` outside the disc.
#[inline]
pub fn angular_pixel(row: usize, col: usize, w: usize) -> Option<([f64; 3], f64)> {
    let half = w as f64 / 2.0;
    let u = (col as f64 + 0.5 - half) / half;
    let v = (half - row as f64 - 0.5) / half;
    let rho = (u * u + v * v).sqrt();
    if rho > 1.0 {
        return None;
    }
    let theta = PI * rho;
    let (cp, sp) = if rho > 0.0 { (u / rho, v / rho) } else { (1.0, 0.0) };
    let st = theta.sin();
    let sinc = if theta > 0.0 { st / theta } else { 1.0 };
    let d_omega = (2.0 * PI / w as f64).powi(2) * sinc;
    Some(([st * cp, st * sp, theta.cos()], d_omega))
}

/// Projects an environment map (lat-long or angular) into RGB coefficients up to `lmax`.
pub fn project_envmap(img: &RgbImage, mapping: Mapping, lmax: usize) -> Result<Vec<[f64; 3]>> {
    match mapping {
        Mapping::LatLong => Ok(project_latlong_exact(img, lmax)),
        Mapping::Angular => {
            if img.width != img.height {
                return Err(Error::new(format!(
                    "an angular map must be square, this one is {}×{}",
                    img.width, img.height
                )));
            }
            Ok(project_angular(img, lmax))
        }
    }
}

fn project_angular(img: &RgbImage, lmax: usize) -> Vec<[f64; 3]> {
    let n = num_coefficients(lmax);
    let w = img.width;
    if w % 2 == 1 {
        return project_angular_generic(img, lmax);
    }
    let basis = ShBasis::new(lmax);
    let rules = GlRules::new();
    let half = w / 2;
    // Symmetry: the pixels (r, c), (r, W−1−c), (W−1−r, c), (W−1−r, W−1−c) have mirror-image
    // footprints, with azimuths φ, π − φ, −φ, π + φ. With A, B, C, D their radiances,
    //   Σ L ∫cos(mφ)… = ∫cos(mφ)… [(A + C) + (−1)^m (B + D)],
    //   Σ L ∫sin(mφ)… = ∫sin(mφ)… [(A − C) + (−1)^m (D − B)],
    // so one footprint integral of Y serves four pixels.
    blocked_sum(half, n, |rows| {
        let (mut yi, mut ys) = (vec![0.0; n], vec![0.0; n]);
        let mut sc = FootprintScratch::new(n);
        let mut acc = vec![0.0; 3 * n];
        for r in rows {
            let r2 = w - 1 - r;
            for c in 0..half {
                let c2 = w - 1 - c;
                let px = |rr: usize, cc: usize| img.get(rr, cc).map(|v| v as f64);
                let (a, b, cq, dq) = (px(r, c), px(r, c2), px(r2, c), px(r2, c2));
                if a == [0.0; 3] && b == [0.0; 3] && cq == [0.0; 3] && dq == [0.0; 3] {
                    continue;
                }
                if !footprint_integrals((r, c, w), &basis, &rules, &mut sc, &mut yi) {
                    continue;
                }
                let u_pos = [a[0] + cq[0], a[1] + cq[1], a[2] + cq[2]];
                let v_pos = [b[0] + dq[0], b[1] + dq[1], b[2] + dq[2]];
                let u_neg = [a[0] - cq[0], a[1] - cq[1], a[2] - cq[2]];
                let v_neg = [dq[0] - b[0], dq[1] - b[1], dq[2] - b[2]];
                for l in 0..=lmax {
                    let k0 = l * l;
                    for (i, m) in (-(l as i64)..=(l as i64)).enumerate() {
                        let k = k0 + i;
                        ys[k] = if m % 2 == 0 { yi[k] } else { -yi[k] };
                    }
                    let mid = k0 + l; // m = 0
                    let end = (l + 1) * (l + 1);
                    for ch in 0..3 {
                        let accc = &mut acc[ch * n..(ch + 1) * n];
                        let (un, vn, up, vp) = (u_neg[ch], v_neg[ch], u_pos[ch], v_pos[ch]);
                        for k in k0..mid {
                            accc[k] += yi[k] * un + ys[k] * vn;
                        }
                        for k in mid..end {
                            accc[k] += yi[k] * up + ys[k] * vp;
                        }
                    }
                }
            }
        }
        (0..n).map(|k| [acc[k], acc[n + k], acc[2 * n + k]]).collect()
    })
}

/// Per-pixel angular projection (any W, used for odd widths).
fn project_angular_generic(img: &RgbImage, lmax: usize) -> Vec<[f64; 3]> {
    let n = num_coefficients(lmax);
    let w = img.width;
    let basis = ShBasis::new(lmax);
    let rules = GlRules::new();
    blocked_sum(img.height, n, |rows| {
        let mut yi = vec![0.0; n];
        let mut sc = FootprintScratch::new(n);
        let mut acc = vec![0.0; 3 * n];
        for r in rows {
            for c in 0..w {
                let px = img.get(r, c);
                if px == [0.0; 3] || !footprint_integrals((r, c, w), &basis, &rules, &mut sc, &mut yi) {
                    continue;
                }
                for ch in 0..3 {
                    let v = px[ch] as f64;
                    for (a, yk) in acc[ch * n..(ch + 1) * n].iter_mut().zip(&yi) {
                        *a += v * yk;
                    }
                }
            }
        }
        (0..n).map(|k| [acc[k], acc[n + k], acc[2 * n + k]]).collect()
    })
}

/// Sums per-thread partial coefficient vectors (in a fixed order, so results are deterministic).
pub(crate) fn sum_parts(parts: Vec<Vec<[f64; 3]>>, n: usize) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; n];
    for p in parts {
        for k in 0..n {
            for ch in 0..3 {
                out[k][ch] += p[k][ch];
            }
        }
    }
    out
}

/// Lat-long projection by separable quadrature. With `variance` (per-pixel variance of the
/// radiance, same size), also returns the variance of each coefficient, Σ ΔΩ² Y_k² σ².
pub fn project_latlong(img: &RgbImage, variance: Option<&RgbImage>, lmax: usize) -> (RgbCoeffs, Option<RgbCoeffs>) {
    let n = num_coefficients(lmax);
    let (w, h) = (img.width, img.height);
    let nm = lmax + 1;
    // cos(mφ_c), sin(mφ_c) for every column, laid out [c][m] for a contiguous inner loop.
    let mut cos_t = vec![0.0f64; w * nm];
    let mut sin_t = vec![0.0f64; w * nm];
    for c in 0..w {
        let phi = 2.0 * PI * (c as f64 + 0.5) / w as f64;
        for m in 0..nm {
            let (s, co) = (m as f64 * phi).sin_cos();
            cos_t[c * nm + m] = co;
            sin_t[c * nm + m] = s;
        }
    }
    let basis = ShBasis::new(lmax);
    let with_var = variance.is_some();
    let parts: Vec<(RgbCoeffs, RgbCoeffs)> = (0..h)
        .into_par_iter()
        .map(|r| {
            let th_top = PI * r as f64 / h as f64;
            let th_bot = PI * (r + 1) as f64 / h as f64;
            let theta = PI * (r as f64 + 0.5) / h as f64;
            let d_omega = 2.0 * PI / w as f64 * (th_top.cos() - th_bot.cos());
            // Fourier sums of the row: C_m = Σ_c L_c cos(mφ_c), S_m = Σ_c L_c sin(mφ_c).
            let mut cs = vec![[0.0f64; 3]; nm];
            let mut ss = vec![[0.0f64; 3]; nm];
            let mut cv = vec![[0.0f64; 3]; if with_var { nm } else { 0 }];
            let mut sv = vec![[0.0f64; 3]; if with_var { nm } else { 0 }];
            let row = &img.pixels[r * w..(r + 1) * w];
            for (c, px) in row.iter().enumerate() {
                let v = [px[0] as f64, px[1] as f64, px[2] as f64];
                let ct = &cos_t[c * nm..(c + 1) * nm];
                let st = &sin_t[c * nm..(c + 1) * nm];
                for m in 0..nm {
                    for ch in 0..3 {
                        cs[m][ch] += v[ch] * ct[m];
                        ss[m][ch] += v[ch] * st[m];
                    }
                }
                if let Some(var) = variance {
                    let q = var.pixels[r * w + c];
                    for m in 0..nm {
                        for ch in 0..3 {
                            cv[m][ch] += q[ch] as f64 * ct[m] * ct[m];
                            sv[m][ch] += q[ch] as f64 * st[m] * st[m];
                        }
                    }
                }
            }
            // Y at φ = 0: Y_l,m>0 = √2 P̄_l^m(θ), Y_l,m<0 = 0; the φ dependence is in C_m, S_m.
            let y = basis.eval([theta.sin(), 0.0, theta.cos()]);
            let mut acc = vec![[0.0; 3]; n];
            let mut accv = vec![[0.0; 3]; if with_var { n } else { 0 }];
            for l in 0..=lmax {
                for m in 0..=l {
                    let p = y[index(l, m as i64)] * d_omega;
                    for ch in 0..3 {
                        acc[index(l, m as i64)][ch] += p * cs[m][ch];
                        if m > 0 {
                            acc[index(l, -(m as i64))][ch] += p * ss[m][ch];
                        }
                        if with_var {
                            accv[index(l, m as i64)][ch] += p * p * cv[m][ch];
                            if m > 0 {
                                accv[index(l, -(m as i64))][ch] += p * p * sv[m][ch];
                            }
                        }
                    }
                }
            }
            (acc, accv)
        })
        .collect();
    let mut out = vec![[0.0; 3]; n];
    let mut outv = vec![[0.0; 3]; n];
    for (a, v) in parts {
        for k in 0..n {
            for ch in 0..3 {
                out[k][ch] += a[k][ch];
                if with_var {
                    outv[k][ch] += v[k][ch];
                }
            }
        }
    }
    (out, with_var.then_some(outv))
}

/// Sums per-block partial coefficient vectors, computed in parallel in waves of at most as many
/// blocks as there are threads, in block order: the result does not depend on the thread count, and
/// at most `threads` partial vectors of length `n` exist at once (memory O(n · threads), not per row).
fn blocked_sum(items: usize, n: usize, block: impl Fn(std::ops::Range<usize>) -> Vec<[f64; 3]> + Sync) -> RgbCoeffs {
    // The partition depends on the data size only (never on the thread count).
    const MAX_BLOCKS: usize = 64;
    let len = items.div_ceil(MAX_BLOCKS).max(1);
    let ranges: Vec<std::ops::Range<usize>> = (0..items).step_by(len).map(|s| s..(s + len).min(items)).collect();
    let threads = rayon::current_num_threads().max(1);
    let mut out = vec![[0.0; 3]; n];
    for wave in ranges.chunks(threads) {
        let parts: Vec<Vec<[f64; 3]>> = wave.par_iter().map(|r| block(r.clone())).collect();
        for p in parts {
            for (o, v) in out.iter_mut().zip(&p) {
                for ch in 0..3 {
                    o[ch] += v[ch];
                }
            }
        }
    }
    out
}

/// Offset of order m in the m-major layout (for each m, the l = m..=lmax entries are contiguous).
#[inline]
fn m_offset(m: usize, lmax: usize) -> usize {
    m * (lmax + 1) - (m * m.saturating_sub(1)) / 2
}

/// Recurrence tables for the exact θ integrals of the normalized associated Legendre functions.
///
/// With P̄_l^m = K_lm P_l^m (K_lm of docs/src/conventions.md §3, no √2) and Ḡ_l^m(x) an antiderivative of
/// P̄_l^m(x), the integral over a band x₁ ≤ x ≤ x₂ (x = cosθ) is Ḡ(x₂) − Ḡ(x₁). Ḡ follows from
/// (1 − x²) dP_n^m/dx = (n + m) P_{n−1}^m − n x P_n^m and the three-term recurrence in n, integrated:
///   (n − m + 1)(n + 2) G_{n+1}^m = (n + m)(n − 1) G_{n−1}^m − (2n + 1)(1 − x²) P_n^m,   G_{m−1}^m = 0,
/// and G_m^m = ∫ P_m^m dx = −(2m−1)!! J_{m+1}(θ), J_k(θ) = ∫_0^θ sin^k t dt, itself from
///   k J_k = −sin^{k−1}θ cosθ + (k − 1) J_{k−2},   J_0 = θ, J_1 = 1 − cosθ.
/// Normalized, the factor on G_{n−1} is ≤ 1, so the upward recurrence is stable; no factorials.
struct LegendreIntegrals {
    lmax: usize,
    /// P̄ recurrence P̄_n^m = a (x P̄_{n−1}^m − b P̄_{n−2}^m), m-major.
    a: Vec<f64>,
    b: Vec<f64>,
    /// Ḡ_{n+1}^m = alpha Ḡ_{n−1}^m − beta (1 − x²) P̄_n^m, stored at the slot of n + 1, m-major.
    alpha: Vec<f64>,
    beta: Vec<f64>,
}

impl LegendreIntegrals {
    fn new(lmax: usize) -> Self {
        let len = m_offset(lmax + 1, lmax);
        let (mut a, mut b, mut alpha, mut beta) = (vec![0.0; len], vec![0.0; len], vec![0.0; len], vec![0.0; len]);
        for m in 0..=lmax {
            let o = m_offset(m, lmax);
            let mf = m as f64;
            for l in m..=lmax {
                let i = o + l - m;
                let lf = l as f64;
                if l >= m + 2 {
                    a[i] = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                    b[i] = (((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0)).sqrt();
                }
                if l > m {
                    // n = l − 1 in the recurrence for Ḡ_{n+1}.
                    let n = lf - 1.0;
                    let denom = (n - mf + 1.0) * (n + 2.0);
                    let r1 = ((2.0 * n + 3.0) / (2.0 * n + 1.0) * (n - mf + 1.0) / (n + mf + 1.0)).sqrt();
                    beta[i] = r1 * (2.0 * n + 1.0) / denom;
                    if l >= m + 2 {
                        let r2 = ((2.0 * n + 3.0) / (2.0 * n - 1.0) * (n - mf + 1.0) * (n - mf)
                            / ((n + mf + 1.0) * (n + mf)))
                            .sqrt();
                        alpha[i] = r2 * (n + mf) * (n - 1.0) / denom;
                    }
                }
            }
        }
        LegendreIntegrals { lmax, a, b, alpha, beta }
    }

    /// Ḡ_l^m at the edge of polar angle θ = π·num/den (an exact fraction of π, so that the two
    /// hemispheres are mirror images to the last bit), m-major into `g`; `p` and `j` are scratch.
    fn eval(&self, num: usize, den: usize, g: &mut [f64], p: &mut [f64], j: &mut [f64]) {
        let lmax = self.lmax;
        // x = cosθ and s = sinθ from the nearer pole, so both poles are exact (s = 0).
        let near = num.min(den - num);
        let t = PI * near as f64 / den as f64;
        let (s, c) = t.sin_cos();
        let x = if num > den - num { -c } else { c };
        let theta = PI * num as f64 / den as f64;
        // J_k(θ), k = 0..=lmax+1 (1 − cosθ = 2 sin²(θ/2) keeps J_1 accurate near θ = 0).
        j[0] = theta;
        if lmax + 1 >= 1 {
            let h = (0.5 * theta).sin();
            j[1] = 2.0 * h * h;
        }
        let mut sk = 1.0; // s^{k−1}
        for k in 2..=lmax + 1 {
            sk *= s;
            j[k] = (-sk * x + (k as f64 - 1.0) * j[k - 2]) / k as f64;
        }
        let s2 = s * s;
        let mut cm = 1.0 / (4.0 * PI).sqrt(); // K_mm (2m−1)!!
        let mut smm = cm; // P̄_m^m = K_mm (2m−1)!! s^m
        for m in 0..=lmax {
            if m > 0 {
                let f = ((2.0 * m as f64 + 1.0) / (2.0 * m as f64)).sqrt();
                cm *= f;
                smm *= f * s;
            }
            let o = m_offset(m, lmax);
            let len = lmax + 1 - m;
            let (pm, gm) = (&mut p[o..o + len], &mut g[o..o + len]);
            let (a, b) = (&self.a[o..o + len], &self.b[o..o + len]);
            let (al, be) = (&self.alpha[o..o + len], &self.beta[o..o + len]);
            pm[0] = smm;
            gm[0] = -cm * j[m + 1];
            if len > 1 {
                pm[1] = (2.0 * m as f64 + 3.0).sqrt() * x * smm;
                gm[1] = -be[1] * s2 * pm[0];
            }
            for i in 2..len {
                pm[i] = a[i] * (x * pm[i - 1] - b[i] * pm[i - 2]);
                gm[i] = al[i] * gm[i - 2] - be[i] * s2 * pm[i - 1];
            }
        }
    }
}

/// Row Fourier integrals of a lat-long map: for row r and m = 0..=lmax,
/// F_m = Σ_c L_c ∫_{column c} e^{imφ} dφ = s_m Σ_c L_c e^{imφ_c},  s_m = 2 sin(mΔ/2)/m (Δ = 2π/W, s_0 = Δ),
/// exactly (a pixel is constant in φ over its column). s_m = 0 exactly when W divides m > 0, so a
/// map constant in φ has F_m = 0 for every m ≠ 0. The sums use a real FFT of the row (O(W log W)
/// for all m at once; m ≥ W aliases to m mod W, as it must for column-constant data) or, when
/// l_max is small, direct sums.
struct RowFourier {
    w: usize,
    lmax: usize,
    /// s_m e^{iπm/W} (the half-pixel phase of φ_c = Δ(c + ½)).
    factor: Vec<(f64, f64)>,
    fft: Option<std::sync::Arc<dyn realfft::RealToComplex<f64>>>,
    /// cos, sin of m φ_c, [c][m], for the direct sums.
    table: Vec<(f64, f64)>,
}

struct RowScratch {
    input: Vec<f64>,
    spectrum: Vec<realfft::num_complex::Complex<f64>>,
    scratch: Vec<realfft::num_complex::Complex<f64>>,
}

impl RowFourier {
    fn new(w: usize, lmax: usize) -> Self {
        let nm = lmax + 1;
        let delta = 2.0 * PI / w as f64;
        let factor = (0..nm)
            .map(|m| {
                let s = if m == 0 {
                    delta
                } else if m % w == 0 {
                    0.0
                } else {
                    2.0 * (0.5 * m as f64 * delta).sin() / m as f64
                };
                let (sn, cs) = (PI * (m % (2 * w)) as f64 / w as f64).sin_cos();
                (s * cs, s * sn)
            })
            .collect();
        // Direct sums cost W·(lmax+1) per row and channel, the FFT about 2.5 W log2 W.
        let use_fft = w >= 16 && (nm as f64) > 2.5 * (w as f64).log2();
        let (fft, table) = if use_fft {
            (Some(realfft::RealFftPlanner::<f64>::new().plan_fft_forward(w)), Vec::new())
        } else {
            (None, Self::direct_table(w, lmax))
        };
        RowFourier { w, lmax, factor, fft, table }
    }

    /// e^{2πi m c / W} for every column c and m ≤ lmax, [c][m] (the half-pixel phase is in `factor`).
    fn direct_table(w: usize, lmax: usize) -> Vec<(f64, f64)> {
        let nm = lmax + 1;
        let mut t = vec![(0.0, 0.0); w * nm];
        for c in 0..w {
            for m in 0..nm {
                let k = (m * c) % w;
                let (sn, cs) = (2.0 * PI * k as f64 / w as f64).sin_cos();
                t[c * nm + m] = (cs, sn);
            }
        }
        t
    }

    fn scratch(&self) -> RowScratch {
        match &self.fft {
            Some(f) => {
                RowScratch { input: f.make_input_vec(), spectrum: f.make_output_vec(), scratch: f.make_scratch_vec() }
            }
            None => RowScratch { input: Vec::new(), spectrum: Vec::new(), scratch: Vec::new() },
        }
    }

    /// F_m of `row` for m = 0..=lmax into `out[m][ch] = (Re, Im)`.
    fn row(&self, row: &[[f32; 3]], sc: &mut RowScratch, out: &mut [[(f64, f64); 3]]) {
        let (w, nm) = (self.w, self.lmax + 1);
        match &self.fft {
            Some(f) => {
                for ch in 0..3 {
                    for (i, px) in sc.input.iter_mut().zip(row) {
                        *i = px[ch] as f64;
                    }
                    f.process_with_scratch(&mut sc.input, &mut sc.spectrum, &mut sc.scratch)
                        .expect("FFT buffers have the planned lengths");
                    for m in 0..nm {
                        // Σ_c L_c e^{+2πikc/W} = conj(X_k) = X_{W−k} for real L.
                        let k = m % w;
                        let (re, im) = if k <= w / 2 {
                            (sc.spectrum[k].re, -sc.spectrum[k].im)
                        } else {
                            (sc.spectrum[w - k].re, sc.spectrum[w - k].im)
                        };
                        let (fr, fi) = self.factor[m];
                        out[m][ch] = (fr * re - fi * im, fr * im + fi * re);
                    }
                }
            }
            None => {
                let mut sums = vec![[(0.0f64, 0.0f64); 3]; nm];
                for (c, px) in row.iter().enumerate() {
                    let t = &self.table[c * nm..(c + 1) * nm];
                    for m in 0..nm {
                        for ch in 0..3 {
                            let v = px[ch] as f64;
                            sums[m][ch].0 += v * t[m].0;
                            sums[m][ch].1 += v * t[m].1;
                        }
                    }
                }
                for m in 0..nm {
                    let (fr, fi) = self.factor[m];
                    for ch in 0..3 {
                        let (re, im) = sums[m][ch];
                        out[m][ch] = (fr * re - fi * im, fr * im + fi * re);
                    }
                }
            }
        }
    }
}

/// Exact projection of a lat-long map (docs/src/conventions.md §2) as the renderer lights with it: radiance
/// constant over each pixel's cell θ ∈ [πr/H, π(r+1)/H], φ ∈ [2πc/W, 2π(c+1)/W] (nearest pixel).
/// L_lm = Σ_pixels L_p ∫_cell Y_lm dω, with both integrals in closed form: the φ integral of
/// cos mφ / sin mφ over a column (`RowFourier`) and the θ integral of K_lm P_l^m(cosθ) sinθ over
/// a row (`LegendreIntegrals`). So every order l is the exact expansion of the piecewise-constant
/// map (no aliasing, no order limit), to rounding.
///
/// By summation by parts the sum over rows becomes a sum over the H + 1 cell edges,
/// Σ_r (Ḡ(x_r) − Ḡ(x_{r+1})) F(r) = Σ_e Ḡ(x_e) (F(e) − F(e − 1)), so each edge's Ḡ is computed once.
/// Cost O(H (W log W + l_max²)); memory O(l_max² · threads) besides the image.
pub fn project_latlong_exact(img: &RgbImage, lmax: usize) -> RgbCoeffs {
    let (w, h) = (img.width, img.height);
    let nm = lmax + 1;
    let n = num_coefficients(lmax);
    let mlen = m_offset(nm, lmax);
    let fourier = RowFourier::new(w, lmax);
    let legendre = LegendreIntegrals::new(lmax);
    blocked_sum(h + 1, n, |edges| {
        let mut sc = fourier.scratch();
        let (mut g, mut p, mut j) = (vec![0.0; mlen], vec![0.0; mlen], vec![0.0; lmax + 2]);
        let mut prev = vec![[(0.0, 0.0); 3]; nm];
        let mut cur = vec![[(0.0, 0.0); 3]; nm];
        let mut acc_c = vec![[0.0f64; 3]; mlen];
        let mut acc_s = vec![[0.0f64; 3]; mlen];
        if edges.start > 0 {
            fourier.row(&img.pixels[(edges.start - 1) * w..edges.start * w], &mut sc, &mut prev);
        }
        for e in edges {
            if e < h {
                fourier.row(&img.pixels[e * w..(e + 1) * w], &mut sc, &mut cur);
            } else {
                cur.iter_mut().for_each(|v| *v = [(0.0, 0.0); 3]);
            }
            legendre.eval(e, h, &mut g, &mut p, &mut j);
            for m in 0..nm {
                let o = m_offset(m, lmax);
                let len = lmax + 1 - m;
                let f = if m == 0 { 1.0 } else { std::f64::consts::SQRT_2 };
                let d: [(f64, f64); 3] =
                    std::array::from_fn(|ch| (f * (cur[m][ch].0 - prev[m][ch].0), f * (cur[m][ch].1 - prev[m][ch].1)));
                let gm = &g[o..o + len];
                for (a, &gv) in acc_c[o..o + len].iter_mut().zip(gm) {
                    for ch in 0..3 {
                        a[ch] += gv * d[ch].0;
                    }
                }
                if m > 0 {
                    for (a, &gv) in acc_s[o..o + len].iter_mut().zip(gm) {
                        for ch in 0..3 {
                            a[ch] += gv * d[ch].1;
                        }
                    }
                }
            }
            std::mem::swap(&mut prev, &mut cur);
        }
        let mut out = vec![[0.0; 3]; n];
        for m in 0..nm {
            let o = m_offset(m, lmax);
            for l in m..=lmax {
                out[index(l, m as i64)] = acc_c[o + l - m];
                if m > 0 {
                    out[index(l, -(m as i64))] = acc_s[o + l - m];
                }
            }
        }
        out
    })
}

/// Relative error bound asked of every Gauss–Legendre rule of the angular-map pixel quadrature.
const QUAD_TOL: f64 = 1e-15;

/// Smallest n for which the n-point Gauss–Legendre error bound
/// (kL)^{2n} (n!)⁴ / ((2n + 1) ((2n)!)³), for an integrand whose j-th derivative is at most k^j times
/// its size on an interval of length L, is below [`QUAD_TOL`].
fn gl_order(kl: f64) -> usize {
    let ln_kl = kl.max(1e-300).ln();
    let (mut ln_n, mut ln_2n) = (0.0f64, 0.0f64); // ln n!, ln (2n)!
    for n in 1..4096usize {
        let nf = n as f64;
        ln_n += nf.ln();
        ln_2n += (2.0 * nf - 1.0).ln() + (2.0 * nf).ln();
        let ln_err = 2.0 * nf * ln_kl + 4.0 * ln_n - (2.0 * nf + 1.0).ln() - 3.0 * ln_2n;
        if ln_err < QUAD_TOL.ln() {
            return n;
        }
    }
    4096
}

/// Gauss–Legendre rules by order, computed once (orders up to 64) or on demand.
struct GlRules(Vec<(Vec<f64>, Vec<f64>)>);

impl GlRules {
    fn new() -> Self {
        GlRules((1..=64).map(crate::quadrature::gauss_legendre).collect())
    }

    fn with<R>(&self, n: usize, f: impl FnOnce(&[f64], &[f64]) -> R) -> R {
        match self.0.get(n - 1) {
            Some((x, w)) => f(x, w),
            None => {
                let (x, w) = crate::quadrature::gauss_legendre(n);
                f(&x, &w)
            }
        }
    }
}

/// sin(x)/x, → 1 at 0.
#[inline]
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 { 1.0 - x * x / 6.0 } else { x.sin() / x }
}

/// Quadrature nodes (direction, solid-angle weight) of the footprint of angular-map pixel (row,
/// col) as the renderer lights with it (renderer/src/light/envmap.rs): the pixel's square of the
/// image plane (a, b) ∈ [−1, 1]² clipped to the disc ρ ≤ 1, radiance constant on it, and nothing
/// for a pixel whose centre lies outside the disc. dω = π² (sinθ/θ) da db with θ = πρ, which is
/// analytic in (a, b), so a square inside the disc takes a tensor Gauss–Legendre rule; a square cut
/// by the rim is integrated in polar coordinates (dω = π sin(πρ) dρ dφ), split at the angles of its
/// corners and of the rim's crossings of its sides, so that every piece has smooth limits. Orders
/// follow [`gl_order`] for Y_lm up to `lmax`. Weights sum to the footprint's solid angle.
fn angular_footprint(row: usize, col: usize, w: usize, lmax: usize, rules: &GlRules, nodes: &mut Vec<([f64; 3], f64)>) {
    nodes.clear();
    let s = 2.0 / w as f64;
    let (a0, b1) = (col as f64 * s - 1.0, 1.0 - row as f64 * s);
    let (a1, b0) = (a0 + s, b1 - s);
    let (am, bm) = (0.5 * (a0 + a1), 0.5 * (b0 + b1));
    if am * am + bm * bm > 1.0 {
        return;
    }
    // Y_lm of degree l varies at most ~π(l + 1) per unit of the image plane (the map stretches by
    // at most π), the Jacobian sin(πρ)/ρ by ~π more.
    let k = PI * (lmax as f64 + 2.0);
    let far = a0.abs().max(a1.abs()).powi(2) + b0.abs().max(b1.abs()).powi(2);
    if far <= 1.0 {
        let q = gl_order(k * s);
        rules.with(q, |x, wq| {
            for (xi, wi) in x.iter().zip(wq) {
                let a = am + 0.5 * s * xi;
                for (xj, wj) in x.iter().zip(wq) {
                    let b = bm + 0.5 * s * xj;
                    let rho = (a * a + b * b).sqrt();
                    let sc = PI * sinc(PI * rho); // sinθ / ρ
                    let weight = 0.25 * s * s * wi * wj * PI * PI * sinc(PI * rho);
                    nodes.push(([a * sc, b * sc, (PI * rho).cos()], weight));
                }
            }
        });
        return;
    }
    polar_footprint(a0, a1, b0, b1, lmax, rules, nodes);
}

/// The polar-coordinate quadrature of the square [a0, a1] × [b0, b1] of the image plane clipped to the
/// disc ρ ≤ 1 (see [`angular_footprint`]); clears `nodes` first.
fn polar_footprint(a0: f64, a1: f64, b0: f64, b1: f64, lmax: usize, rules: &GlRules, nodes: &mut Vec<([f64; 3], f64)>) {
    nodes.clear();
    let (am, bm) = (0.5 * (a0 + a1), 0.5 * (b0 + b1));
    let k = PI * (lmax as f64 + 2.0);
    let origin_in = a0 <= 0.0 && a1 >= 0.0 && b0 <= 0.0 && b1 >= 0.0;
    let centre = bm.atan2(am);
    let wrap = |phi: f64| {
        if origin_in {
            phi
        } else {
            let mut d = phi - centre;
            while d > PI {
                d -= 2.0 * PI;
            }
            while d < -PI {
                d += 2.0 * PI;
            }
            centre + d
        }
    };
    let corners: Vec<f64> = [(a0, b0), (a1, b0), (a0, b1), (a1, b1)]
        .iter()
        .filter(|(a, b)| *a != 0.0 || *b != 0.0)
        .map(|&(a, b)| wrap(b.atan2(a)))
        .collect();
    let (mut lo, mut hi) = if origin_in {
        (-PI, PI)
    } else {
        (
            corners.iter().copied().fold(f64::INFINITY, f64::min),
            corners.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    };
    if lo > hi {
        (lo, hi) = (hi, lo);
    }
    let mut cuts = corners.clone();
    for a in [a0, a1] {
        if a.abs() < 1.0 {
            let bb = (1.0 - a * a).sqrt();
            for b in [bb, -bb] {
                if b >= b0 && b <= b1 {
                    cuts.push(wrap(b.atan2(a)));
                }
            }
        }
    }
    for b in [b0, b1] {
        if b.abs() < 1.0 {
            let aa = (1.0 - b * b).sqrt();
            for a in [aa, -aa] {
                if a >= a0 && a <= a1 {
                    cuts.push(wrap(b.atan2(a)));
                }
            }
        }
    }
    if origin_in {
        // The seam of atan2 at ±π and the axis directions, where the exit side can change.
        cuts.extend([-PI, -0.5 * PI, 0.0, 0.5 * PI, PI]);
    }
    cuts.retain(|&p| p >= lo && p <= hi);
    cuts.push(lo);
    cuts.push(hi);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|x, y| (*x - *y).abs() < 1e-15);
    // ρ range of the ray at angle φ inside the square and the disc (slab method).
    let range = |phi: f64| -> Option<(f64, f64)> {
        let (sp, cp) = phi.sin_cos();
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (d, lo, hi) in [(cp, a0, a1), (sp, b0, b1)] {
            if d.abs() < 1e-300 {
                if lo > 0.0 || hi < 0.0 {
                    return None;
                }
            } else {
                let (u, v) = (lo / d, hi / d);
                t0 = t0.max(u.min(v));
                t1 = t1.min(u.max(v));
            }
        }
        (t1 > t0).then_some((t0, t1))
    };
    // In φ: Y's own azimuthal frequency (≤ l) plus the radial frequency times the slope of the limits.
    let k_phi = (lmax as f64 + 2.0) * (1.0 + 2.0 * PI) + 8.0;
    for piece in cuts.windows(2) {
        let (p0, p1) = (piece[0], piece[1]);
        if p1 - p0 <= 0.0 {
            continue;
        }
        let (pm, ph) = (0.5 * (p0 + p1), 0.5 * (p1 - p0));
        let n_phi = gl_order(k_phi * (p1 - p0)).max(4);
        rules.with(n_phi, |xp, wp| {
            for (xi, wi) in xp.iter().zip(wp) {
                let phi = pm + ph * xi;
                let Some((t0, t1)) = range(phi) else { continue };
                let (sp, cp) = phi.sin_cos();
                let n_rho = gl_order(k * (t1 - t0)).max(2);
                let (tm, th) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
                rules.with(n_rho, |xr, wr| {
                    for (xj, wj) in xr.iter().zip(wr) {
                        let rho = tm + th * xj;
                        let (st, ct) = (PI * rho).sin_cos();
                        nodes.push(([st * cp, st * sp, ct], ph * wi * th * wj * PI * st));
                    }
                });
            }
        });
    }
}

/// Scratch space of [`footprint_integrals`]: quadrature nodes and one evaluation of all Y_k.
struct FootprintScratch {
    nodes: Vec<([f64; 3], f64)>,
    y: Vec<f64>,
}

impl FootprintScratch {
    fn new(n: usize) -> Self {
        FootprintScratch { nodes: Vec::new(), y: vec![0.0; n] }
    }
}

/// ∫ Y_k over the footprint of angular pixel (row, col) for all k, into `yi`; false for a pixel
/// outside the disc.
fn footprint_integrals(
    (row, col, w): (usize, usize, usize),
    basis: &ShBasis,
    rules: &GlRules,
    sc: &mut FootprintScratch,
    yi: &mut [f64],
) -> bool {
    angular_footprint(row, col, w, basis.lmax(), rules, &mut sc.nodes);
    yi.iter_mut().for_each(|v| *v = 0.0);
    for &(d, wt) in sc.nodes.iter() {
        basis.eval_into(d, &mut sc.y);
        for (a, b) in yi.iter_mut().zip(sc.y.iter()) {
            *a += wt * b;
        }
    }
    !sc.nodes.is_empty()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn max_err(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |ch| (x[ch] - y[ch]).abs())).fold(0.0, f64::max)
    }

    fn random_image(w: usize, h: usize, seed: u64) -> RgbImage {
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        RgbImage { width: w, height: h, pixels: (0..w * h).map(|_| [next(), next(), next()]).collect() }
    }

    #[test]
    fn angular_symmetric_and_generic_paths_agree() {
        let img = random_image(10, 10, 3);
        let a = project_angular(&img, 8);
        let b = project_angular_generic(&img, 8);
        assert!(max_err(&a, &b) < 1e-13, "{}", max_err(&a, &b));
    }

    #[test]
    fn polar_and_tensor_rules_agree_inside_the_disc() {
        // A pixel wholly inside the disc takes the tensor rule; integrate the same square by the
        // polar rule (used for rim pixels) by pretending that its far corner is outside.
        let (w, lmax) = (9, 12);
        let basis = ShBasis::new(lmax);
        let rules = GlRules::new();
        let n = num_coefficients(lmax);
        for (row, col) in [(4, 4), (3, 5), (1, 4), (2, 2)] {
            let mut nodes = Vec::new();
            angular_footprint(row, col, w, lmax, &rules, &mut nodes);
            let mut tensor = vec![0.0; n];
            for &(d, wt) in &nodes {
                for (t, y) in tensor.iter_mut().zip(basis.eval(d)) {
                    *t += wt * y;
                }
            }
            let s = 2.0 / w as f64;
            let (a0, b1) = (col as f64 * s - 1.0, 1.0 - row as f64 * s);
            let mut polar = vec![0.0; n];
            polar_footprint(a0, a0 + s, b1 - s, b1, lmax, &rules, &mut nodes);
            for &(d, wt) in &nodes {
                for (t, y) in polar.iter_mut().zip(basis.eval(d)) {
                    *t += wt * y;
                }
            }
            for k in 0..n {
                assert!(
                    (tensor[k] - polar[k]).abs() < 1e-13,
                    "pixel ({row},{col}) k={k}: {} vs {}",
                    tensor[k],
                    polar[k]
                );
            }
        }
    }

    #[test]
    fn tiny_angular_maps_are_exact() {
        // 1×1: the whole disc is one pixel, i.e. the whole sphere: L00 = √(4π) v, all else 0.
        let img = RgbImage { width: 1, height: 1, pixels: vec![[1.0, 2.0, 3.0]] };
        let c = project_envmap(&img, Mapping::Angular, 10).unwrap();
        let s = (4.0 * PI).sqrt();
        for ch in 0..3 {
            assert!((c[0][ch] - s * (ch + 1) as f64).abs() < 1e-13, "{:?}", c[0]);
        }
        assert!(c[1..].iter().flatten().all(|v| v.abs() < 1e-13));
        // 2×2: each pixel is a quarter disc, i.e. a lune φ ∈ [φ0, φ0 + π/2] over all θ. Over a lune
        // ∫ Y00 = π/√(4π), ∫ x dω = (π/2)(sinφ1 − sinφ0), ∫ y dω = (π/2)(cosφ0 − cosφ1), ∫ z dω = 0.
        let v = [1.0f32, 2.0, 5.0, 7.0]; // rows top to bottom: (TL, TR, BL, BR)
        let img = RgbImage { width: 2, height: 2, pixels: v.iter().map(|&x| [x, x, x]).collect() };
        let c = project_envmap(&img, Mapping::Angular, 6).unwrap();
        // (value, φ0): TL is a<0, b>0 (φ ∈ [π/2, π]), TR φ ∈ [0, π/2], BL [π, 3π/2], BR [3π/2, 2π].
        let lunes = [(1.0, 0.5 * PI), (2.0, 0.0), (5.0, PI), (7.0, 1.5 * PI)];
        let k1 = (3.0 / (4.0 * PI)).sqrt();
        let (mut l00, mut lx, mut ly) = (0.0, 0.0, 0.0);
        for (val, p0) in lunes {
            let p1: f64 = p0 + 0.5 * PI;
            l00 += val * PI / (4.0 * PI).sqrt();
            lx += val * k1 * 0.5 * PI * (p1.sin() - p0.sin());
            ly += val * k1 * 0.5 * PI * (p0.cos() - p1.cos());
        }
        assert!((c[0][0] - l00).abs() < 1e-13, "{} vs {l00}", c[0][0]);
        assert!((c[index(1, -1)][0] - ly).abs() < 1e-13, "{} vs {ly}", c[index(1, -1)][0]);
        assert!(c[index(1, 0)][0].abs() < 1e-13);
        assert!((c[index(1, 1)][0] - lx).abs() < 1e-13, "{} vs {lx}", c[index(1, 1)][0]);
    }

    /// ∫ over row r, column c of Y_k, by brute-force Gauss–Legendre in θ and φ.
    fn brute_latlong(img: &RgbImage, lmax: usize, q: usize) -> RgbCoeffs {
        let (w, h) = (img.width, img.height);
        let basis = ShBasis::new(lmax);
        let (x, wq) = crate::quadrature::gauss_legendre(q);
        let mut out = vec![[0.0; 3]; num_coefficients(lmax)];
        for r in 0..h {
            for c in 0..w {
                let p = img.get(r, c);
                let (t0, t1) = (PI * r as f64 / h as f64, PI * (r + 1) as f64 / h as f64);
                let (f0, f1) = (2.0 * PI * c as f64 / w as f64, 2.0 * PI * (c + 1) as f64 / w as f64);
                for (xi, wi) in x.iter().zip(&wq) {
                    let t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * xi;
                    for (xj, wj) in x.iter().zip(&wq) {
                        let f = 0.5 * (f0 + f1) + 0.5 * (f1 - f0) * xj;
                        let wt = 0.25 * (t1 - t0) * (f1 - f0) * wi * wj * t.sin();
                        let y = basis.eval([t.sin() * f.cos(), t.sin() * f.sin(), t.cos()]);
                        for k in 0..y.len() {
                            for ch in 0..3 {
                                out[k][ch] += wt * y[k] * p[ch] as f64;
                            }
                        }
                    }
                }
            }
        }
        out
    }

    #[test]
    fn latlong_exact_matches_brute_force_pixel_integrals() {
        // Small maps (direct sums) and a 40-wide one (FFT), high orders (l > H, m > W/2).
        for (w, h, lmax) in [(2, 1, 6), (1, 2, 6), (5, 3, 9), (6, 4, 14), (40, 3, 30)] {
            let img = random_image(w, h, (w * 31 + h) as u64);
            let got = project_latlong_exact(&img, lmax);
            let want = brute_latlong(&img, lmax, 48);
            let e = max_err(&got, &want);
            assert!(e < 1e-12, "{w}×{h} lmax {lmax}: {e}");
        }
    }

    #[test]
    fn latlong_exact_fft_and_direct_sums_agree() {
        let img = random_image(64, 32, 9);
        let lmax = 40;
        let fft = RowFourier::new(64, lmax);
        assert!(fft.fft.is_some());
        let mut direct = RowFourier::new(64, 2);
        // Force the direct sums at the same lmax.
        direct = RowFourier {
            lmax,
            fft: None,
            table: RowFourier::direct_table(64, lmax),
            factor: fft.factor.clone(),
            ..direct
        };
        let (mut a, mut b) = (vec![[(0.0, 0.0); 3]; lmax + 1], vec![[(0.0, 0.0); 3]; lmax + 1]);
        let (mut s1, mut s2) = (fft.scratch(), direct.scratch());
        for r in 0..32 {
            fft.row(&img.pixels[r * 64..(r + 1) * 64], &mut s1, &mut a);
            direct.row(&img.pixels[r * 64..(r + 1) * 64], &mut s2, &mut b);
            for m in 0..=lmax {
                for ch in 0..3 {
                    assert!((a[m][ch].0 - b[m][ch].0).abs() < 1e-12 && (a[m][ch].1 - b[m][ch].1).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn latlong_constant_in_phi_has_no_m_terms() {
        for (w, h) in [(1, 2), (3, 5), (64, 32), (100, 7)] {
            let mut img = random_image(1, h, 5);
            img.pixels = img.pixels.iter().flat_map(|p| std::iter::repeat_n(*p, w)).collect();
            img.width = w;
            let c = project_latlong_exact(&img, 60);
            for (k, v) in c.iter().enumerate() {
                let (_, m) = crate::sh::lm(k);
                if m != 0 {
                    assert!(v.iter().all(|x| x.abs() < 1e-14), "{w}×{h} k={k}: {v:?}");
                }
            }
        }
    }
}
