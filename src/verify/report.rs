//! Reporting: the typed [`Report`] (its `Display` is the table on stdout — check, equation,
//! expected, measured, tolerance, pass/fail of the deciding row with the largest |Δ|/tolerance;
//! serialized, it is the JSON document of docs/src/conventions.md §7), and the report folder: `report.md`,
//! `report.html` (a summary table with pass/fail colours, then per check the pictures of its renders
//! — measured, predicted, z map, see [`super::picture`] —, its plots and every row), `report.json`,
//! the SVG plots and the PNG pictures.

use super::check::{Check, CheckDoc, FAMILY_ROWS, K_SIGMA, Row, RowDoc};
use super::{picture, plot};
use serde::Serialize;
use std::fmt::Write;
use std::path::Path;

fn fmt(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e-3 && v.abs() < 1e4 {
        format!("{v:.5}")
    } else {
        format!("{v:.3e}")
    }
}

/// The document of `reflect verify --json` (and `report.json`): every check's typed result and the
/// run's settings. Its `Display` is the one-line-per-check table printed on stdout.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Report {
    pub checks: Vec<CheckDoc>,
    /// Every check passed.
    pub passed: bool,
    /// Run with `--quick` (reduced resolution and samples).
    pub quick: bool,
    /// k of the k·σ rule for checks with at most [`FAMILY_ROWS`] noisy deciding rows.
    pub k_sigma: f64,
    /// Wall time of the whole run, seconds.
    pub seconds: f64,
}

impl Report {
    pub fn new(checks: &[Check], quick: bool, seconds: f64) -> Report {
        Report {
            checks: checks.iter().map(Check::doc).collect(),
            passed: checks.iter().all(Check::passed),
            quick,
            k_sigma: K_SIGMA,
            seconds,
        }
    }
}

/// The JSON document of [`Report`] as a `serde_json::Value`, for callers that walk it generically
/// (the Python package converts it to Python objects).
pub fn json(checks: &[Check], quick: bool, seconds: f64) -> serde_json::Value {
    serde_json::to_value(Report::new(checks, quick, seconds)).unwrap_or(serde_json::Value::Null)
}

/// |Δ|/tolerance of a row (∞ for a difference with zero tolerance).
fn ratio(r: &RowDoc) -> f64 {
    match (r.measured, r.expected, r.tolerance) {
        (Some(m), Some(e), Some(t)) if t > 0.0 => (m - e).abs() / t,
        (Some(m), Some(e), Some(_)) if m == e => 0.0,
        _ => f64::INFINITY,
    }
}

/// The deciding row with the largest |Δ|/tolerance (the one the table shows).
fn worst(c: &CheckDoc) -> Option<&RowDoc> {
    c.rows.iter().filter(|r| !r.informative).max_by(|a, b| ratio(a).total_cmp(&ratio(b)))
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), fmt)
}

fn result_word(c: &CheckDoc) -> &'static str {
    match (c.passed, c.errored) {
        (true, _) => "PASS",
        (false, true) => "ERROR",
        (false, false) => "FAIL",
    }
}

impl std::fmt::Display for Report {
    /// The one-line-per-check table: the deciding row with the largest |Δ|/tolerance of each check.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Columns as wide as the longest name and equation (at least 17 and 20), so they line up.
        let nw = self.checks.iter().map(|c| c.name.chars().count()).chain([17]).max().unwrap_or(17);
        let ew = self.checks.iter().map(|c| c.equation.chars().count()).chain([20]).max().unwrap_or(20);
        writeln!(
            f,
            "{:<nw$} {:<ew$} {:>12} {:>12} {:>11} {:>11}  {:<6} worst row",
            "check", "equation", "expected", "measured", "σ", "tolerance", "result"
        )?;
        for c in &self.checks {
            let v = result_word(c);
            match (worst(c), &c.error) {
                (_, Some(e)) => writeln!(
                    f,
                    "{:<nw$} {:<ew$} {:>12} {:>12} {:>11} {:>11}  {v:<6} error: {}",
                    c.name,
                    c.equation,
                    "-",
                    "-",
                    "-",
                    "-",
                    e.lines().next().unwrap_or("")
                )?,
                (Some(r), None) => writeln!(
                    f,
                    "{:<nw$} {:<ew$} {:>12} {:>12} {:>11} {:>11}  {v:<6} {} ({} rows)",
                    c.name,
                    c.equation,
                    opt(r.expected),
                    opt(r.measured),
                    opt(r.sigma),
                    opt(r.tolerance),
                    r.label,
                    c.rows.iter().filter(|r| !r.informative).count()
                )?,
                (None, None) => writeln!(
                    f,
                    "{:<nw$} {:<ew$} {:>12} {:>12} {:>11} {:>11}  {v:<6} nothing compared",
                    c.name, c.equation, "-", "-", "-", "-"
                )?,
            }
        }
        let failed = self.checks.iter().filter(|c| !c.passed).count();
        writeln!(
            f,
            "{} checks, {} passed, {} failed (tolerance = kσ + stated approximation error + f32 floor; k = {K_SIGMA}, \
             Šidák-corrected in checks with more than {FAMILY_ROWS} noisy rows)",
            self.checks.len(),
            self.checks.len() - failed,
            failed
        )
    }
}

/// What a row's result cell says, and its CSS class: deciding rows pass or FAIL; informative
/// rows say so (and whether they fall within the tolerance), never "FAIL".
fn row_result(r: &Row) -> (&'static str, String) {
    match (&r.outside_range, r.informative, r.passed()) {
        (Some(range), _, _) => ("range", format!("info: approximation outside its stated range ({range})")),
        (None, true, true) => ("info", "info: within tolerance".into()),
        (None, true, false) => ("info", "info: outside tolerance (does not decide)".into()),
        (None, false, true) => ("pass", "pass".into()),
        (None, false, false) => ("fail", "FAIL".into()),
    }
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// The z colour scale, stated in words.
fn z_scale_text() -> String {
    format!(
        "z = (measured − predicted)/σ per pixel; ColorBrewer RdBu: blue z < 0 (render darker than predicted), white 0, \
         red z > 0 (brighter), saturated at |z| = {}; transparent: no data",
        picture::Z_SCALE
    )
}

fn picture_caption(p: &picture::Picture) -> String {
    let z = p.z_stats();
    format!(
        "{}. Predicted: {}. Measured and predicted: one linear grey scale, black = {}, white = {} (radiance). z over \
         {} pixels: mean {:+.2}, rms {:.2}, max |z| {:.1}, {:.2} % above 3 (0.27 % for Gaussian noise).",
        p.title,
        p.model,
        fmt(p.grey_scale().0),
        fmt(p.grey_scale().1),
        z.pixels,
        z.mean,
        z.rms,
        z.max_abs,
        100.0 * z.frac_above_3
    )
}

fn mode(quick: bool) -> &'static str {
    if quick { "--quick" } else { "default" }
}

fn rule_text() -> String {
    format!(
        "Tolerance of every row: |measured − expected| ≤ k·σ + approximation error (stated per row, only where the \
         paper's formula is an approximation or a quadrature is involved) + f32 floor (noise-free renders), with \
         k = {K_SIGMA}; a check with more than {FAMILY_ROWS} noisy deciding rows uses the Šidák-corrected k that keeps \
         its false-alarm rate at that of {FAMILY_ROWS} rows at {K_SIGMA}σ (1.9e-3; stated in its notes). Informative \
         rows are reported but do not decide the verdict."
    )
}

/// How a check bears on the paper's claims, for the verdict paragraph.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Standing {
    /// Every deciding row within k·σ (+ f32 floor): the claim holds to the noise.
    Holds,
    /// Passes, but some deciding row needs a stated approximation error (the paper's formula is
    /// itself an approximation), or an informative row is outside its tolerance (a formula used
    /// outside its range of validity): the claim holds within a stated range.
    HoldsWithinRange,
    Fails,
}

fn standing(c: &Check) -> Standing {
    if !c.passed() {
        Standing::Fails
    } else if c.rows.iter().any(|r| (!r.informative && r.approx > 0.0) || (r.informative && !r.passed())) {
        Standing::HoldsWithinRange
    } else {
        Standing::Holds
    }
}

/// The one-paragraph verdict that opens report.md and report.html (plain text, check names in
/// backquotes).
pub fn verdict(checks: &[Check]) -> String {
    let names = |st: Standing| -> Vec<String> {
        checks.iter().filter(|c| standing(c) == st).map(|c| format!("`{}` ({})", c.name, c.equation)).collect()
    };
    let list = |v: Vec<String>| if v.is_empty() { "none".to_string() } else { v.join(", ") };
    let failed: Vec<String> = checks
        .iter()
        .filter(|c| standing(c) == Standing::Fails)
        .map(|c| match (&c.error, c.worst()) {
            (Some(e), _) => format!("`{}` ({}; could not run: {})", c.name, c.equation, e.lines().next().unwrap_or("")),
            (None, Some(r)) => {
                format!("`{}` ({}; worst row {}: |Δ|/tolerance = {:.2})", c.name, c.equation, r.label, r.ratio())
            }
            (None, None) => format!("`{}` ({}; nothing compared)", c.name, c.equation),
        })
        .collect();
    let n_fail = failed.len();
    format!(
        "Verdict: {} of {} checks pass. Hold to the noise (every deciding row within k·σ): {}. Hold within a stated \
         range (a deciding row allows the stated error of an approximate formula, or an informative row shows the \
         formula outside its range of validity; the rows and notes state the range): {}. Fail: {}.",
        checks.len() - n_fail,
        checks.len(),
        list(names(Standing::Holds)),
        list(names(Standing::HoldsWithinRange)),
        list(failed)
    )
}

/// `report.md`: the summary table, then per check its pictures, plots, notes and every row.
pub fn markdown(checks: &[Check], quick: bool, seconds: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# reflect verify — report\n");
    let _ = writeln!(s, "{}\n", verdict(checks));
    let _ = writeln!(s, "Mode: {}. Wall time {seconds:.1} s. {}\n", mode(quick), rule_text());
    let rep = Report::new(checks, quick, seconds);
    let _ =
        writeln!(s, "| check | equation | result | worst deciding row | expected | measured | \\|Δ\\|/tol | time |");
    let _ = writeln!(s, "|---|---|---|---|--:|--:|--:|--:|");
    for c in &rep.checks {
        let w = worst(c);
        let _ = writeln!(
            s,
            "| [{}](#{}) | {} | **{}** | {} | {} | {} | {} | {:.1} s |",
            c.name,
            c.name,
            c.equation,
            result_word(c),
            cell(&w.map_or_else(|| c.error.clone().unwrap_or_default(), |r| r.label.clone())),
            opt(w.and_then(|r| r.expected)),
            opt(w.and_then(|r| r.measured)),
            w.map_or("-".into(), |r| format!("{:.2}", ratio(r))),
            c.seconds
        );
    }
    let failed = rep.checks.iter().filter(|c| !c.passed).count();
    let _ = writeln!(s, "\n{} checks, {} passed, {failed} failed.\n", rep.checks.len(), rep.checks.len() - failed);
    for c in checks {
        let _ = writeln!(s, "<a id=\"{}\"></a>\n## {} ({}) — {}\n", c.name, c.name, c.equation, result_word(&c.doc()));
        if !c.description.is_empty() {
            let _ = writeln!(s, "{}\n", c.description);
        }
        if let Some(e) = &c.error {
            let _ = writeln!(s, "**Could not run:** {e}\n");
        }
        for p in &c.pictures {
            let [m, pr, z] = p.files();
            let _ = writeln!(s, "| measured | predicted | z |\n|---|---|---|\n| ![]({m}) | ![]({pr}) | ![]({z}) |\n");
            let _ = writeln!(s, "{}\n", picture_caption(p));
        }
        if !c.pictures.is_empty() {
            let _ = writeln!(s, "![z colour scale]({}) {}\n", picture::Z_SCALE_FILE, z_scale_text());
        }
        for p in &c.plots {
            let _ = writeln!(s, "![{}]({})\n", p.title, p.file);
        }
        let deciding: Vec<&Row> = c.rows.iter().filter(|r| !r.informative).collect();
        if !deciding.is_empty() {
            let zmax = deciding.iter().filter(|r| r.sigma > 0.0).map(|r| r.deviation() / r.sigma).fold(0.0, f64::max);
            let _ = writeln!(
                s,
                "- {} deciding rows, {} pass; largest |Δ|/tolerance = {:.2}; largest |Δ|/σ = {:.2} (rows with σ > 0); \
                 {} informative rows",
                deciding.len(),
                deciding.iter().filter(|r| r.passed()).count(),
                c.worst().map(Row::ratio).unwrap_or(0.0),
                zmax,
                c.rows.len() - deciding.len()
            );
        }
        for d in &c.details {
            let _ = writeln!(s, "- {d}");
        }
        let _ = writeln!(s, "- time: {:.2} s\n", c.seconds);
        if !c.rows.is_empty() {
            let _ = writeln!(
                s,
                "| row | expected | measured | σ | approx + floor | tolerance | \\|Δ\\|/tol | result |\n|---|--:|--:|--:|--:|--:|--:|---|"
            );
            for r in &c.rows {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {:.2} | {} |",
                    cell(&r.label),
                    fmt(r.expected),
                    fmt(r.measured),
                    fmt(r.sigma),
                    fmt(r.approx + r.floor),
                    fmt(r.tolerance()),
                    r.ratio(),
                    cell(&row_result(r).1)
                );
            }
            s.push('\n');
        }
    }
    s
}

/// `name` → <code>name</code> (the verdict is written with Markdown backquotes).
fn md_code_to_html(s: &str) -> String {
    let mut out = String::new();
    for (i, part) in s.split('`').enumerate() {
        if i % 2 == 1 {
            let _ = write!(out, "<code>{part}</code>");
        } else {
            out.push_str(part);
        }
    }
    out
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

const CSS: &str = "body{font-family:sans-serif;max-width:1320px;margin:auto;padding:0 12px;color:#222}\
table{border-collapse:collapse;margin:6px 0}td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px;vertical-align:top}\
th{background:#eee}td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}\
table.summary{width:100%}table.summary td.label{word-break:break-word}\
td.pass,span.pass{background:#d4efd4;color:#075e07;font-weight:bold}\
td.fail,span.fail{background:#f7c9c9;color:#9b0000;font-weight:bold}\
td.error,span.error{background:#ffe0a8;color:#7a4a00;font-weight:bold}\
td.info{color:#666}td.range{color:#7a4a00;background:#fff3dc}tr.informative td{color:#666}\
span.pass,span.fail,span.error{padding:0 6px;border-radius:3px}\
.pics{display:flex;flex-wrap:wrap;gap:10px;margin:8px 0}.pics figure{margin:0}\
.pics img{background:repeating-conic-gradient(#ddd 0 25%,#fff 0 50%) 0 0/16px 16px;border:1px solid #ccc;display:block}\
.pics figcaption{font-size:12px;text-align:center}p.caption{font-size:12px;margin:2px 0 14px 0;color:#444}\
.scale{font-size:12px;display:flex;align-items:center;gap:6px;margin:4px 0}.scale img{width:256px;height:12px;border:1px solid #999}\
.plots{display:flex;flex-wrap:wrap;gap:8px}.plots img{width:calc(50% - 8px);min-width:420px}\
details summary{cursor:pointer;font-size:13px;margin:4px 0}\
p.verdict{font-size:15px;border-left:4px solid #888;padding-left:8px}";

/// `report.html`: a summary table with pass/fail colours, then per check the pictures of its
/// renders (measured, predicted, z map), its plots, notes and every row.
pub fn html(checks: &[Check], quick: bool, seconds: f64) -> String {
    let mut s = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>reflect verify</title><style>{CSS}</style></head><body>\n"
    );
    let _ = writeln!(s, "<h1>reflect verify</h1><p class=\"verdict\">{}</p>", md_code_to_html(&esc(&verdict(checks))));
    let _ = writeln!(s, "<p>Mode: {}; wall time {seconds:.1} s. {}</p>", mode(quick), esc(&rule_text()));
    let rep = Report::new(checks, quick, seconds);
    let _ = writeln!(
        s,
        "<table class=\"summary\"><tr><th>check</th><th>equation</th><th>claim</th><th>result</th>\
         <th>worst deciding row</th><th>expected</th><th>measured</th><th>|Δ|/tol</th><th>time</th></tr>"
    );
    for c in &rep.checks {
        let w = worst(c);
        let v = result_word(c);
        let _ = writeln!(
            s,
            "<tr><td><a href=\"#{}\">{}</a></td><td>{}</td><td class=\"label\">{}</td><td class=\"{}\">{v}</td>\
             <td class=\"label\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
             <td class=\"num\">{:.1} s</td></tr>",
            esc(&c.name),
            esc(&c.name),
            esc(&c.equation),
            esc(&c.description),
            v.to_lowercase(),
            esc(&w.map_or_else(|| c.error.clone().unwrap_or_default(), |r| r.label.clone())),
            opt(w.and_then(|r| r.expected)),
            opt(w.and_then(|r| r.measured)),
            w.map_or("-".into(), |r| format!("{:.2}", ratio(r))),
            c.seconds
        );
    }
    let failed = rep.checks.iter().filter(|c| !c.passed).count();
    let _ = writeln!(
        s,
        "</table><p>{} checks, {} passed, {failed} failed. |Δ|/tol below 1 passes.</p>",
        rep.checks.len(),
        rep.checks.len() - failed
    );
    for (c, d) in checks.iter().zip(&rep.checks) {
        let v = result_word(d);
        let _ = writeln!(
            s,
            "<h2 id=\"{}\">{} ({}) <span class=\"{}\">{v}</span></h2><p>{}</p>",
            esc(&c.name),
            esc(&c.name),
            esc(&c.equation),
            v.to_lowercase(),
            esc(&c.description)
        );
        if let Some(e) = &c.error {
            let _ = writeln!(s, "<p class=\"fail\">Could not run: {}</p>", esc(e));
        }
        for p in &c.pictures {
            let [m, pr, z] = p.files();
            let _ = writeln!(s, "<div class=\"pics\">");
            for (f, what) in [(&m, "measured"), (&pr, "predicted"), (&z, "z = (measured − predicted)/σ")] {
                let _ = writeln!(
                    s,
                    "<figure><img src=\"{}\" alt=\"{} {}\"><figcaption>{}</figcaption></figure>",
                    esc(f),
                    esc(&p.title),
                    what,
                    what
                );
            }
            let _ = writeln!(s, "</div><p class=\"caption\">{}</p>", esc(&picture_caption(p)));
        }
        if !c.pictures.is_empty() {
            let _ = writeln!(
                s,
                "<div class=\"scale\">z: −{0}<img src=\"{1}\" alt=\"z colour scale\">+{0} &nbsp; {2}</div>",
                picture::Z_SCALE,
                picture::Z_SCALE_FILE,
                esc(&z_scale_text())
            );
        }
        if !c.plots.is_empty() {
            let _ = writeln!(s, "<div class=\"plots\">");
            for p in &c.plots {
                let _ = writeln!(s, "<img src=\"{}\" alt=\"{}\">", esc(&p.file), esc(&p.title));
            }
            let _ = writeln!(s, "</div>");
        }
        let _ = writeln!(s, "<ul>");
        for d in &c.details {
            let _ = writeln!(s, "<li>{}</li>", esc(d));
        }
        let _ = writeln!(s, "<li>time: {:.2} s</li></ul>", c.seconds);
        if !c.rows.is_empty() {
            let deciding = c.rows.iter().filter(|r| !r.informative).count();
            let _ = writeln!(
                s,
                "<details{}><summary>{} rows ({deciding} deciding, {} informative)</summary>",
                if c.rows.len() <= 12 { " open" } else { "" },
                c.rows.len(),
                c.rows.len() - deciding
            );
            let _ = writeln!(
                s,
                "<table><tr><th>row</th><th>expected</th><th>measured</th><th>σ</th><th>approx + floor</th>\
                 <th>tolerance</th><th>|Δ|/tol</th><th>result</th></tr>"
            );
            for r in &c.rows {
                let (cls, text) = row_result(r);
                let _ = writeln!(
                    s,
                    "<tr{}><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
                     <td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{:.2}</td><td class=\"{cls}\">{}</td></tr>",
                    if r.informative { " class=\"informative\"" } else { "" },
                    esc(&r.label),
                    fmt(r.expected),
                    fmt(r.measured),
                    fmt(r.sigma),
                    fmt(r.approx + r.floor),
                    fmt(r.tolerance()),
                    r.ratio(),
                    esc(&text)
                );
            }
            let _ = writeln!(s, "</table></details>");
        }
    }
    s.push_str("</body></html>\n");
    s
}

/// Writes report.md, report.html, report.json, the SVG plots and the PNG pictures into `dir`.
pub fn write_folder(dir: &Path, checks: &[Check], quick: bool, seconds: f64) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create the report folder: {e}", dir.display()))?;
    for c in checks {
        for p in &c.plots {
            plot::write_svg(dir, p)?;
        }
        for p in &c.pictures {
            p.write_png(dir)?;
        }
    }
    if checks.iter().any(|c| !c.pictures.is_empty()) {
        picture::write_z_scale(dir)?;
    }
    let w = |name: &str, text: String| {
        std::fs::write(dir.join(name), text).map_err(|e| format!("{}: {e}", dir.join(name).display()))
    };
    w("report.md", markdown(checks, quick, seconds))?;
    w("report.html", html(checks, quick, seconds))?;
    w("report.json", serde_json::to_string_pretty(&Report::new(checks, quick, seconds)).unwrap_or_default())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checks() -> Vec<Check> {
        let mut exact = Check::new("mirror", "30, 33", "");
        exact.push(Row::new("B_00", 1.0, 1.01, 0.01));
        let mut approx = Check::new("phong", "41–46", "");
        approx.push(Row::new("eq. 46 l = 4", 0.5, 0.52, 0.001).approx(0.03));
        let mut outside = Check::new("torrance-sparrow", "50–59", "");
        outside.push(Row::new("eq. 58 θ_o = 30°", 0.9, 0.9, 0.01));
        outside.push(Row::new("eq. 59 θ_o = 60°", 0.9, 0.5, 0.01).informative());
        let mut failing = Check::new("lambert", "34, 38", "");
        failing.push(Row::new("l = 2", 0.25, 0.5, 0.01));
        vec![exact, approx, outside, failing]
    }

    #[test]
    fn verdict_names_each_kind_of_check() {
        let v = verdict(&checks());
        assert!(v.starts_with("Verdict: 3 of 4 checks pass."), "{v}");
        let holds = v.split("Hold to the noise").nth(1).unwrap().split("Hold within").next().unwrap();
        assert!(holds.contains("`mirror`") && !holds.contains("`phong`"), "{v}");
        let within = v.split("Hold within a stated").nth(1).unwrap().split("Fail:").next().unwrap();
        assert!(within.contains("`phong`") && within.contains("`torrance-sparrow`"), "{v}");
        let fail = v.split("Fail:").nth(1).unwrap();
        assert!(fail.contains("`lambert`") && fail.contains("worst row l = 2"), "{v}");
    }

    #[test]
    fn reports_open_with_the_verdict_and_show_informative_rows_as_such() {
        let c = checks();
        let md = markdown(&c, true, 1.0);
        let first_para = md.split("\n\n").nth(1).unwrap();
        assert!(first_para.starts_with("Verdict:"), "{md}");
        assert!(!md.contains("FAIL (info)") && !md.contains("(info)"), "{md}");
        assert!(md.contains("| info: outside tolerance (does not decide) |"), "{md}");
        let html = html(&c, true, 1.0);
        assert!(html.contains("<p class=\"verdict\">Verdict:"), "{html}");
        assert!(html.contains("<code>mirror</code>"), "{html}");
        assert!(html.contains("<td class=\"info\">info: outside tolerance (does not decide)</td>"), "{html}");
        assert!(!html.contains("(info)"), "{html}");
        // The deciding failure is still red.
        assert!(html.contains("<td class=\"fail\">FAIL</td>"), "{html}");
        // The summary is an HTML table with a coloured verdict cell per check.
        assert!(html.contains("<table class=\"summary\">") && html.contains("<td class=\"fail\">FAIL</td>"), "{html}");
    }
}
