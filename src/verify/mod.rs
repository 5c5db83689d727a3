//! `reflect verify`: render, project into SH, compare with the paper's analytic predictions, and
//! report which claims the renders confirm, with error bars (issue 4).
//!
//! One file per check family; each exposes `run(ctx) -> Result<Check, String>` (renders + analysis)
//! and cheap `evaluate`-style functions that turn measured numbers and a prediction into a
//! [`check::Check`], so unit tests can feed deliberately wrong predictions without rendering.
//! The tolerance rule (k·σ + stated approximation error) lives in [`check`].
//!
//! Options: `quick` (reduced resolution and samples, < 60 s on 2 cores), `wrong` (a hidden switch
//! that makes every check compare with a deliberately wrong prediction, e.g. Lambert × 1.05 or a
//! Phong exponent off by 20 %: the integration tests assert that each check then fails on real
//! renders), `seed`, `out` (report folder).

pub mod ambiguity;
pub mod associativity;
pub mod axial;
pub mod check;
pub mod convex_shape;
pub mod data;
pub mod directional;
pub mod factorization;
pub mod filter;
pub mod fit;
pub mod grace;
pub mod horizon;
pub mod inverse_brdf;
pub mod inverse_lighting;
pub mod inverse_specular;
pub mod irradiance9;
pub mod lambert;
pub mod microfacet_ambiguity;
pub mod mirror;
pub mod oblique;
pub mod partial_view;
pub mod phong;
pub mod picture;
pub mod plot;
pub mod positive_bound;
pub mod report;
pub mod scenes;
pub mod separation;
pub mod single_view;
pub mod subspace;
#[cfg(test)]
mod testutil;
pub mod texture_ambiguity;
pub mod torrance_sparrow;
pub mod transfer;
pub mod uniform;
pub mod uniform_factorization;

use check::Check;
use std::path::PathBuf;

/// Settings shared by every check.
#[derive(Clone, Debug)]
pub struct Ctx {
    pub quick: bool,
    /// Compare with deliberately wrong predictions (tests that every check can fail).
    pub wrong: bool,
    pub seed: u64,
    pub out: PathBuf,
    pub verbose: bool,
    /// The data folder (holds [`data::GRACE_FILE`]), resolved at run time by [`data::resolve`].
    pub data: PathBuf,
    /// Set from another thread to stop the run: renders stop at their next tile and the check
    /// then fails to run (`reflect.verify` in Python sets it on Ctrl-C); `None` never stops.
    pub cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

impl Ctx {
    /// Height of normal-probe renders (width = 2 × height).
    pub fn probe_height(&self) -> u32 {
        if self.quick { 48 } else { 96 }
    }
    /// Samples per pixel: `quick` or `full` depending on the mode.
    pub fn spp(&self, quick: u32, full: u32) -> u32 {
        if self.quick { quick } else { full }
    }
}

/// A check: its name (for `--check`), its equations, and the function that runs it.
pub struct Entry {
    pub name: &'static str,
    pub equation: &'static str,
    pub run: fn(&Ctx) -> Result<Check, String>,
}

/// All checks, in the order of issue 4.
pub const CHECKS: &[Entry] = &[
    Entry { name: lambert::NAME, equation: lambert::EQUATION, run: lambert::run },
    Entry { name: irradiance9::NAME, equation: irradiance9::EQUATION, run: irradiance9::run },
    Entry { name: phong::NAME, equation: phong::EQUATION, run: phong::run },
    Entry { name: torrance_sparrow::NAME, equation: torrance_sparrow::EQUATION, run: torrance_sparrow::run },
    Entry { name: mirror::NAME, equation: mirror::EQUATION, run: mirror::run },
    Entry { name: directional::NAME, equation: directional::EQUATION, run: directional::run },
    Entry { name: axial::NAME, equation: axial::EQUATION, run: axial::run },
    Entry { name: uniform::NAME, equation: uniform::EQUATION, run: uniform::run },
    Entry { name: associativity::NAME, equation: associativity::EQUATION, run: associativity::run },
    Entry { name: convex_shape::NAME, equation: convex_shape::EQUATION, run: convex_shape::run },
    Entry { name: single_view::NAME, equation: single_view::EQUATION, run: single_view::run },
    Entry { name: partial_view::NAME, equation: partial_view::EQUATION, run: partial_view::run },
    Entry { name: horizon::NAME, equation: horizon::EQUATION, run: horizon::run },
    Entry { name: inverse_lighting::NAME, equation: inverse_lighting::EQUATION, run: inverse_lighting::run },
    Entry { name: inverse_specular::NAME, equation: inverse_specular::EQUATION, run: inverse_specular::run },
    Entry { name: inverse_brdf::NAME, equation: inverse_brdf::EQUATION, run: inverse_brdf::run },
    Entry { name: separation::NAME, equation: separation::EQUATION, run: separation::run },
    Entry { name: factorization::NAME, equation: factorization::EQUATION, run: factorization::run },
    Entry { name: ambiguity::NAME, equation: ambiguity::EQUATION, run: ambiguity::run },
    Entry {
        name: uniform_factorization::NAME,
        equation: uniform_factorization::EQUATION,
        run: uniform_factorization::run,
    },
    Entry {
        name: microfacet_ambiguity::NAME,
        equation: microfacet_ambiguity::EQUATION,
        run: microfacet_ambiguity::run,
    },
    Entry { name: subspace::NAME, equation: subspace::EQUATION, run: subspace::run },
    Entry { name: positive_bound::NAME, equation: positive_bound::EQUATION, run: positive_bound::run },
    Entry { name: texture_ambiguity::NAME, equation: texture_ambiguity::EQUATION, run: texture_ambiguity::run },
];

/// Runs one entry, timing it and turning an error into a failed check.
///
/// Every error bar and tolerance a check uses comes from the renders' `stderr`, the renderer's bound
/// (`renderer::film::pool_heavy_tails`: the own σ raised near flagged pixels and at low spp); a noise
/// energy that is subtracted (debiasing) uses the own σ, `stderr_own` (`subspace`). No pixel is
/// excluded (dropping the pixels where a rare heavy sample landed would bias the fits). The check
/// states how many of its rendered pixels were flagged and how many the bound raised
/// ([`Check::stderr_flagged`]).
pub fn run_entry(ctx: &Ctx, e: &Entry) -> Check {
    let t = std::time::Instant::now();
    let before = scenes::stderr_flag_totals();
    let mut c = match (e.run)(ctx) {
        Ok(c) => c,
        Err(msg) => Check::failed_to_run(e.name, e.equation, msg),
    };
    let after = scenes::stderr_flag_totals();
    (c.stderr_flagged, c.stderr_pooled) = (after.0 - before.0, after.1 - before.1);
    if c.stderr_flagged > 0 || c.stderr_pooled > 0 {
        c.note(format!(
            "{} rendered pixels had stderr_flag = 1 (one rare sample dominated their own error bar); {} pixels' \
             stderr is the renderer's bound, raised above their own σ (near a flag, or at < 16 spp); none excluded",
            c.stderr_flagged, c.stderr_pooled
        ));
    }
    c.apply_family_k();
    c.seconds = t.elapsed().as_secs_f64();
    c
}

#[cfg(test)]
mod stderr_flag_tests {
    use super::*;

    fn renders_one_flagged_pixel(_: &Ctx) -> Result<Check, String> {
        let mut film = renderer::film::Film::new(3, 3);
        film.pixels[4].unreliable = true;
        film.pixels[4].stderr_own = [1.0; 3];
        renderer::film::pool_heavy_tails(&mut film, false);
        scenes::count_stderr_flags(&film);
        Ok(Check::new("flagged", "-", "a render with one flagged pixel"))
    }

    /// A check whose render has a flagged pixel says so in its report (JSON fields and a detail line).
    /// Other tests render concurrently into the same totals, so the counts are lower bounds here.
    #[test]
    fn a_check_states_its_flagged_pixels() {
        let ctx = Ctx {
            quick: true,
            wrong: false,
            seed: 0,
            out: PathBuf::new(),
            verbose: false,
            data: PathBuf::new(),
            cancel: None,
        };
        let e = Entry { name: "flagged", equation: "-", run: renders_one_flagged_pixel };
        let doc = run_entry(&ctx, &e).doc();
        assert!(doc.stderr_flagged_pixels >= 1 && doc.stderr_pooled_pixels >= 8, "{doc:?}");
        assert!(doc.details.iter().any(|d| d.contains("stderr_flag = 1")), "{:?}", doc.details);
    }
}
