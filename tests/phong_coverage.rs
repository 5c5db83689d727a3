//! Issue 16: coverage of the printed error bars on Phong spheres, one view and two opposite views.
//! `scenes/phong-grace.toml` (k_s = 1, s = 32) with `horizon = "ignore"` (so Phong's closed form,
//! eq. 43, is the exact filter), 64² at 16 spp, independent sampler; front from (3, 0, 1) with seed
//! i, back from (−3, 0, −1) with seed 100 + i; `--lmax 4`.
//!
//! - `reflect invert lighting FRONT [BACK] --lmax 4 --json`: every L_lm of an order reported
//!   `recovered` against `reflect sh project ../shared/data/grace_latlong.exr --lmax 4`; an order
//!   reported `undetermined` / `ill-conditioned` / `unobservable` ("cannot be determined from these
//!   views") is counted as such, not as a miss.
//! - `reflect analyze FRONT [BACK] --lighting SCENE --lmax 4 --json` (full measurement only: 3 s a
//!   call): every order's filter estimate against Phong's closed form Λ_l ρ̂_l (eq. 43).
//!
//! Full measurement (`cargo test --release --test phong_coverage -- --ignored --nocapture`, 20
//! seeds, 2026-12-01; the table is in guide "Partial views: coverage on Phong spheres"): the
//! filter orders cover at the nominal rate — |z| < 1 for 67.7 % (one view) and 63.7 % (two views),
//! < 2 for 99.7 % / 100 % (nominal 68.3 %, 95.4 %) — and the recovered L_lm a little wide, 88.8 %
//! / 76.3 % at 1σ, 100 % / 99.0 % at 2σ. The noise part is the per-pixel σ with the bound near
//! flagged pixels applied at load, never scaled by χ²/ν: scaled by √(χ²/ν) (≈ 34 in R: most visible
//! pixels flagged at 16 spp under Grace, χ²/ν ≈ 10⁴) the bars were 3–10× too wide (95–99 % at 1σ).
//! One view recovers 40 of 100 orders (l = 0, 1 in most seeds), two views 93 of 100.
//!
//! CI version (`phong_lighting_error_bars_cover_over_4_seeds`, 6 s): 4 seeds, `invert lighting`
//! only. Tolerance: the channels share their paths and the coefficients of one fit correlate, so the
//! effective number of independent comparisons is taken as n = the recovered orders summed over
//! seeds (one per order and seed, not per coefficient and channel); the binomial standard error of a
//! coverage p is √(p(1 − p)/n). The 1σ and 2σ rates must not fall below nominal by more than 3 of
//! those (bars too wide are conservative, not wrong): measured n = 8 for one view, 19 for two, so
//! ≥ 18.9 % / 73.2 % and ≥ 36.3 % / 81.0 % (measured
//! 85.4 / 100 % and 87.5 / 98.2 %). Planted error: the bars divided by 6 give 2σ rates 39.6 % and
//! 32.6 % (2026-12-06), below those bounds.

mod common;
use common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};

const LMAX: usize = 4;
const S: f64 = 32.0;
/// The planted error of the CI version: error bars this many times too narrow (the one-view
/// L_00 was 28 of its σ off). Six, not three: with one view's 8 effective comparisons the 2σ bound
/// is 73 %, and honest bars divided by 3 (|z| < 2/3, probability 0.50 each) still reach it by chance
/// 14 % of the time, as they did once the light samples were compensated (2026-12-06: 75 %);
/// divided by 6 (probability 0.26 each) 0.5 % of the time.
const PLANTED_DIVISOR: f64 = 6.0;

/// Per view set: comparisons, |z| < 1, < 2, < 3, coefficients of undetermined orders, orders seen.
#[derive(Default, Debug, Clone)]
struct Tally {
    n: usize,
    within: [usize; 3],
    /// |z| < 2 with the planted error: the bars divided by [`PLANTED_DIVISOR`].
    planted: usize,
    undetermined: usize,
    orders_recovered: usize,
    orders_total: usize,
    worst: f64,
}

impl Tally {
    fn add(&mut self, z: f64) {
        self.n += 1;
        for (k, w) in self.within.iter_mut().enumerate() {
            *w += (z.abs() < (k + 1) as f64) as usize;
        }
        self.worst = self.worst.max(z.abs());
    }
    fn rate(&self, k: usize) -> f64 {
        self.within[k] as f64 / self.n.max(1) as f64
    }
    fn line(&self, what: &str) -> String {
        format!(
            "{what}: {} comparisons, |z| < 1/2/3: {:.1} / {:.1} / {:.1} % (nominal 68.3 / 95.4 / 99.7), largest |z| {:.2}; \
             {} of {} orders recovered, {} coefficients × channels in orders not determined (not counted)",
            self.n,
            100.0 * self.rate(0),
            100.0 * self.rate(1),
            100.0 * self.rate(2),
            self.worst,
            self.orders_recovered,
            self.orders_total,
            self.undetermined
        )
    }
}

fn scenes(dir: &Path) -> (PathBuf, PathBuf) {
    let text = std::fs::read_to_string(root().join("scenes/phong-grace.toml"))
        .unwrap()
        .replace("horizon = \"clamp\"", "horizon = \"ignore\"")
        .replace("\"../../shared/data/", &format!("\"{}/", root().join("../shared/data").display()));
    assert!(text.contains("horizon = \"ignore\"") && text.contains("s = 32.0"));
    let front = dir.join("front.toml");
    std::fs::write(&front, &text).unwrap();
    let back = dir.join("back.toml");
    std::fs::write(&back, text.replace("from = [3.0, 0.0, 1.0]", "from = [-3.0, 0.0, -1.0]")).unwrap();
    (front, back)
}

fn render(dir: &Path, scene: &Path, seed: u64, name: &str) -> String {
    let out = dir.join(name);
    let (code, _, err) = reflect_out(&[
        "render",
        scene.to_str().unwrap(),
        "--seed",
        &seed.to_string(),
        "--size",
        "64x64",
        "--spp",
        "16",
        "--sampler",
        "independent",
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(code, 0, "{err}");
    out.to_str().unwrap().to_string()
}

fn json(args: &[&str]) -> Value {
    let (code, out, err) = reflect_out(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap()
}

/// The map's L_lm, l ≤ [`LMAX`], as `sh project` prints them.
fn truth() -> Vec<[f64; 3]> {
    let map = root().join("../shared/data/grace_latlong.exr");
    let doc = json(&["sh", "project", map.to_str().unwrap(), "--lmax", &LMAX.to_string(), "--json"]);
    doc["coefficients"].as_array().unwrap().iter().map(|c| [0, 1, 2].map(|ch| c[ch].as_f64().unwrap())).collect()
}

/// Runs `seeds` seeds; returns [one view, two views] tallies of the lighting and (with `filter`) of
/// the filter.
fn measure(seeds: u64, filter: bool) -> ([[Tally; 4]; 2], [[Tally; 4]; 2]) {
    let dir = temp_dir(&format!("phong-coverage-{seeds}"));
    let (front, back) = scenes(&dir);
    let truth = truth();
    let closed = analysis::transfer::phong::phong(S, LMAX);
    let (mut light, mut filt) = (<[[Tally; 4]; 2]>::default(), <[[Tally; 4]; 2]>::default());
    let lmax = LMAX.to_string();
    for s in 1..=seeds {
        let f = render(&dir, &front, s, &format!("f{s}.exr"));
        let b = render(&dir, &back, s + 100, &format!("b{s}.exr"));
        for (case, imgs) in [vec![f.as_str()], vec![f.as_str(), b.as_str()]].iter().enumerate() {
            let mut args = vec!["invert", "lighting"];
            args.extend(imgs);
            args.extend(["--lmax", &lmax, "--json"]);
            let doc = json(&args);
            let t = &mut light[case];
            for o in doc["orders"].as_array().unwrap() {
                let l = o["l"].as_u64().unwrap() as usize;
                let recovered = o["status"] == "recovered";
                for tc in t.iter_mut() {
                    tc.orders_total += 1;
                    tc.orders_recovered += recovered as usize;
                }
                for k in l * l..(l + 1) * (l + 1) {
                    for ch in 0..3 {
                        if !recovered {
                            t[0].undetermined += 1;
                            t[ch + 1].undetermined += 1;
                            continue;
                        }
                        let e = doc["coefficients"][k][ch].as_f64().unwrap();
                        let se = doc["stderr"][k][ch].as_f64().unwrap();
                        for i in [0, ch + 1] {
                            t[i].add((e - truth[k][ch]) / se);
                            t[i].planted += (((e - truth[k][ch]) / se * PLANTED_DIVISOR).abs() < 2.0) as usize;
                        }
                    }
                }
            }
            if !filter {
                continue;
            }
            let mut args = vec!["analyze"];
            args.extend(imgs);
            args.extend(["--lighting", front.to_str().unwrap(), "--lmax", &lmax, "--json"]);
            let doc = json(&args);
            let t = &mut filt[case];
            for o in doc["filter"].as_array().unwrap() {
                let l = o["l"].as_u64().unwrap() as usize;
                for ch in 0..3 {
                    for i in [0, ch + 1] {
                        t[i].orders_total += 1;
                        if o["status"][ch] != "determined" {
                            t[i].undetermined += 1;
                            continue;
                        }
                        t[i].orders_recovered += 1;
                        let e = o["estimate"][ch].as_f64().unwrap();
                        t[i].add((e - closed[l]) / o["stderr"][ch].as_f64().unwrap());
                    }
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    (light, filt)
}

/// Lower bounds on the 1σ and 2σ rates for `n` effective comparisons (3 binomial standard errors).
fn bounds(n: usize) -> (f64, f64) {
    let n = n.max(1) as f64;
    (0.683 - 3.0 * (0.683f64 * 0.317 / n).sqrt(), 0.954 - 3.0 * (0.954f64 * 0.046 / n).sqrt())
}

#[test]
fn phong_lighting_error_bars_cover_over_4_seeds() {
    let seeds = 4;
    let (light, _) = measure(seeds, false);
    for (case, tc) in light.iter().enumerate() {
        let what = format!("{} view(s), invert lighting", case + 1);
        let t = &tc[0];
        eprintln!("{}", t.line(&what));
        assert!(t.orders_recovered > 0, "{what}: no order recovered");
        let n_eff = t.orders_recovered;
        let (b1, b2) = bounds(n_eff);
        assert!(t.rate(0) >= b1, "{what}: 1σ coverage {} below {b1} (n_eff {n_eff})", t.rate(0));
        assert!(t.rate(1) >= b2, "{what}: 2σ coverage {} below {b2} (n_eff {n_eff})", t.rate(1));
        // Able to fail: the bars divided by PLANTED_DIVISOR.
        let planted = t.planted as f64 / t.n.max(1) as f64;
        eprintln!(
            "{what}: with the bars / {PLANTED_DIVISOR} the 2σ rate is {:.1} % (bound {:.1} %)",
            100.0 * planted,
            100.0 * b2
        );
        assert!(planted < b2, "{what}: bars / {PLANTED_DIVISOR} still pass ({planted})");
    }
    // Two opposite views determine more orders than one.
    assert!(light[1][0].orders_recovered > light[0][0].orders_recovered, "{}", light[1][0].line("two views"));
}

/// The full measurement stated in the guide: 20 seeds, lighting and filter, one and two views.
#[test]
#[ignore = "the coverage measurement: 20 seeds, about 5 minutes; run with --ignored --nocapture"]
fn phong_coverage_over_20_seeds() {
    let (light, filt) = measure(20, true);
    for (what, tallies) in [("invert lighting L_lm vs sh project", &light), ("analyze filter vs eq. 43", &filt)] {
        for (case, tc) in tallies.iter().enumerate() {
            for (t, ch) in tc.iter().zip(["RGB", "R", "G", "B"]) {
                eprintln!("{}", t.line(&format!("{} view(s), {what}, {ch}", case + 1)));
            }
        }
    }
}
