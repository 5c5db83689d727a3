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

fn row_md(r: &Row) -> String {
    format!(
        "| {} | {} | {} | {} | {} | {} | {}{} |\n",
        r.label,
        fmt(r.expected),
        fmt(r.measured),
        fmt(r.sigma),
        fmt(r.approx + r.floor),
        fmt(r.tolerance()),
        if r.passed() { "pass" } else { "FAIL" },
        if r.informative { " (info)" } else { "" }
    )
}

pub fn markdown(checks: &[Check], quick: bool, seconds: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# reflect verify — report\n");
    let _ = writeln!(
        s,
        "Mode: {}. Wall time {seconds:.1} s. Tolerance of every row: |measured − expected| ≤ k·σ + approximation \
         error (stated per row, only where the paper's formula is an approximation or a quadrature is involved) + f32 \
         floor (noise-free renders), with k = {K_SIGMA}; a check with more than {FAMILY_ROWS} noisy deciding rows uses the \
         Šidák-corrected k that keeps its false-alarm rate at that of {FAMILY_ROWS} rows at {K_SIGMA}σ (1.9e-3; stated in its notes). \
         Rows marked (info) are reported but do not decide.\n",
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

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

pub fn html(checks: &[Check], quick: bool, seconds: f64) -> String {
    let mut s = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>reflect verify</title><style>\
         body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}\
         td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}.pass{color:#080}.fail{color:#c00;font-weight:bold}\
         pre{background:#f6f6f6;padding:8px;overflow:auto}</style></head><body>\n",
    );
    let _ = writeln!(
        s,
        "<h1>reflect verify</h1><p>Mode: {}; wall time {seconds:.1} s; tolerance = kσ + stated approximation error + f32 floor (k = {K_SIGMA}; Šidák-corrected above {FAMILY_ROWS} noisy rows).</p>",
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
                let cls = if r.passed() {
                    "pass"
                } else if r.informative {
                    ""
                } else {
                    "fail"
                };
                let _ = writeln!(
                    s,
                    "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"{cls}\">{}{}</td></tr>",
                    esc(&r.label),
                    fmt(r.expected),
                    fmt(r.measured),
                    fmt(r.sigma),
                    fmt(r.approx + r.floor),
                    fmt(r.tolerance()),
                    if r.passed() { "pass" } else { "FAIL" },
                    if r.informative { " (info)" } else { "" }
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
