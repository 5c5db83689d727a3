//! Reporting: the table on stdout (check, equation, expected, measured, tolerance, pass/fail —
//! the deciding row with the largest |Δ|/tolerance), the JSON document of CONVENTIONS §7, and the
//! report folder: `report.md`, `report.html` (every row of every check) and the SVG plots.

use super::check::{Check, FAMILY_ROWS, K_SIGMA, Row};
use super::plot;
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

/// The one-line-per-check table.
pub fn table(checks: &[Check]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<17} {:<20} {:>12} {:>12} {:>11} {:>11}  {:<6} worst row",
        "check", "equation", "expected", "measured", "σ", "tolerance", "result"
    );
    for c in checks {
        let verdict = if c.passed() { "PASS" } else { "FAIL" };
        match (c.worst(), &c.error) {
            (_, Some(e)) => {
                let _ = writeln!(
                    s,
                    "{:<17} {:<20} {:>12} {:>12} {:>11} {:>11}  {:<6} error: {}",
                    c.name,
                    c.equation,
                    "-",
                    "-",
                    "-",
                    "-",
                    verdict,
                    e.lines().next().unwrap_or("")
                );
            }
            (Some(r), None) => {
                let _ = writeln!(
                    s,
                    "{:<17} {:<20} {:>12} {:>12} {:>11} {:>11}  {:<6} {} ({} rows)",
                    c.name,
                    c.equation,
                    fmt(r.expected),
                    fmt(r.measured),
                    fmt(r.sigma),
                    fmt(r.tolerance()),
                    verdict,
                    r.label,
                    c.rows.iter().filter(|r| !r.informative).count()
                );
            }
            (None, None) => {
                let _ = writeln!(
                    s,
                    "{:<17} {:<20} {:>12} {:>12} {:>11} {:>11}  {:<6} nothing compared",
                    c.name, c.equation, "-", "-", "-", "-", verdict
                );
            }
        }
    }
    let failed = checks.iter().filter(|c| !c.passed()).count();
    let _ = writeln!(
        s,
        "{} checks, {} passed, {} failed (tolerance = kσ + stated approximation error + f32 floor; k = {K_SIGMA}, Šidák-corrected in checks with more than {FAMILY_ROWS} noisy rows)",
        checks.len(),
        checks.len() - failed,
        failed
    );
    s
}

pub fn json(checks: &[Check], quick: bool, seconds: f64) -> serde_json::Value {
    serde_json::json!({
        "checks": checks.iter().map(Check::to_json).collect::<Vec<_>>(),
        "passed": checks.iter().all(Check::passed),
        "quick": quick,
        "k_sigma": K_SIGMA,
        "seconds": seconds,
    })
}

/// The result cell of a row: deciding rows pass or FAIL; informative rows do not decide, so they
/// say "info" and whether they are inside the tolerance, never "FAIL".
fn result_text(r: &Row) -> &'static str {
    match (r.informative, r.passed()) {
        (false, true) => "pass",
        (false, false) => "FAIL",
        (true, true) => "info: within",
        (true, false) => "info: outside",
    }
}

fn row_md(r: &Row) -> String {
    format!(
        "| {} | {} | {} | {} | {} | {} | {} |\n",
        r.label,
        fmt(r.expected),
        fmt(r.measured),
        fmt(r.sigma),
        fmt(r.approx + r.floor),
        fmt(r.tolerance()),
        result_text(r)
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

pub fn markdown(checks: &[Check], quick: bool, seconds: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# reflect verify — report\n");
    let _ = writeln!(s, "{}\n", verdict(checks));
    let _ = writeln!(
        s,
        "Mode: {}. Wall time {seconds:.1} s. Tolerance of every row: |measured − expected| ≤ k·σ + approximation \
         error (stated per row, only where the paper's formula is an approximation or a quadrature is involved) + f32 \
         floor (noise-free renders), with k = {K_SIGMA}; a check with more than {FAMILY_ROWS} noisy deciding rows uses the \
         Šidák-corrected k that keeps its false-alarm rate at that of {FAMILY_ROWS} rows at {K_SIGMA}σ (1.9e-3; stated in its notes). \
         Rows whose result is \"info\" are informative: reported, with whether they are within the tolerance, but \
         they do not decide.\n",
        if quick { "--quick" } else { "default" }
    );
    let _ = writeln!(s, "```\n{}```\n", table(checks));
    for c in checks {
        let _ = writeln!(s, "## {} ({}) — {}\n", c.name, c.equation, if c.passed() { "PASS" } else { "FAIL" });
        if !c.description.is_empty() {
            let _ = writeln!(s, "{}\n", c.description);
        }
        if let Some(e) = &c.error {
            let _ = writeln!(s, "**Could not run:** {e}\n");
        }
        let deciding: Vec<&Row> = c.rows.iter().filter(|r| !r.informative).collect();
        if !deciding.is_empty() {
            let zmax = deciding.iter().filter(|r| r.sigma > 0.0).map(|r| r.deviation() / r.sigma).fold(0.0, f64::max);
            let _ = writeln!(
                s,
                "- {} deciding rows, {} pass; largest |Δ|/tolerance = {:.2}; largest |Δ|/σ = {:.2} (rows with σ > 0)",
                deciding.len(),
                deciding.iter().filter(|r| r.passed()).count(),
                c.worst().map(Row::ratio).unwrap_or(0.0),
                zmax
            );
        }
        for d in &c.details {
            let _ = writeln!(s, "- {d}");
        }
        let _ = writeln!(s, "- time: {:.2} s\n", c.seconds);
        for p in &c.plots {
            let _ = writeln!(s, "![{}]({})\n", p.title, p.file);
        }
        if !c.rows.is_empty() {
            let _ = writeln!(
                s,
                "| row | expected | measured | σ | approx + floor | tolerance | result |\n|---|---|---|---|---|---|---|"
            );
            for r in &c.rows {
                s.push_str(&row_md(r));
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
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

pub fn html(checks: &[Check], quick: bool, seconds: f64) -> String {
    let mut s = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>reflect verify</title><style>\
         body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}\
         td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}.pass{color:#080}.fail{color:#c00;font-weight:bold}\
         .info{color:#555;font-style:italic}.verdict{font-size:15px;border-left:4px solid #888;padding-left:8px}\
         pre{background:#f6f6f6;padding:8px;overflow:auto}</style></head><body>\n",
    );
    let _ = writeln!(s, "<h1>reflect verify</h1><p class=\"verdict\">{}</p>", md_code_to_html(&esc(&verdict(checks))));
    let _ = writeln!(
        s,
        "<p>Mode: {}; wall time {seconds:.1} s; tolerance = kσ + stated approximation error + f32 floor (k = {K_SIGMA}; Šidák-corrected above {FAMILY_ROWS} noisy rows).</p>",
        if quick { "--quick" } else { "default" }
    );
    let _ = writeln!(s, "<pre>{}</pre>", esc(&table(checks)));
    for c in checks {
        let cls = if c.passed() { "pass" } else { "fail" };
        let _ = writeln!(
            s,
            "<h2>{} ({}) — <span class=\"{cls}\">{}</span></h2><p>{}</p>",
            esc(&c.name),
            esc(&c.equation),
            if c.passed() { "PASS" } else { "FAIL" },
            esc(&c.description)
        );
        if let Some(e) = &c.error {
            let _ = writeln!(s, "<p class=\"fail\">Could not run: {}</p>", esc(e));
        }
        let _ = writeln!(s, "<ul>");
        for d in &c.details {
            let _ = writeln!(s, "<li>{}</li>", esc(d));
        }
        let _ = writeln!(s, "<li>time: {:.2} s</li></ul>", c.seconds);
        for p in &c.plots {
            let _ = writeln!(s, "<p><img src=\"{}\" alt=\"{}\"></p>", esc(&p.file), esc(&p.title));
        }
        if !c.rows.is_empty() {
            let _ = writeln!(
                s,
                "<table><tr><th>row</th><th>expected</th><th>measured</th><th>σ</th><th>approx + floor</th><th>tolerance</th><th>result</th></tr>"
            );
            for r in &c.rows {
                let cls = match (r.informative, r.passed()) {
                    (true, _) => "info",
                    (false, true) => "pass",
                    (false, false) => "fail",
                };
                let _ = writeln!(
                    s,
                    "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"{cls}\">{}</td></tr>",
                    esc(&r.label),
                    fmt(r.expected),
                    fmt(r.measured),
                    fmt(r.sigma),
                    fmt(r.approx + r.floor),
                    fmt(r.tolerance()),
                    result_text(r)
                );
            }
            let _ = writeln!(s, "</table>");
        }
    }
    s.push_str("</body></html>\n");
    s
}

/// Writes report.md, report.html and the SVG plots into `dir`.
pub fn write_folder(dir: &Path, checks: &[Check], quick: bool, seconds: f64) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create the report folder: {e}", dir.display()))?;
    for c in checks {
        for p in &c.plots {
            plot::write_svg(dir, p)?;
        }
    }
    let w = |name: &str, text: String| {
        std::fs::write(dir.join(name), text).map_err(|e| format!("{}: {e}", dir.join(name).display()))
    };
    w("report.md", markdown(checks, quick, seconds))?;
    w("report.html", html(checks, quick, seconds))?;
    w("report.json", serde_json::to_string_pretty(&json(checks, quick, seconds)).unwrap_or_default())?;
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
        assert!(md.contains("| info: outside |"), "{md}");
        let html = html(&c, true, 1.0);
        assert!(html.contains("<p class=\"verdict\">Verdict:"), "{html}");
        assert!(html.contains("<code>mirror</code>"), "{html}");
        assert!(html.contains("<td class=\"info\">info: outside</td>"), "{html}");
        assert!(!html.contains("(info)"), "{html}");
        // The deciding failure is still red.
        assert!(html.contains("<td class=\"fail\">FAIL</td>"), "{html}");
    }
}
