//! Peer renderers in the same run: Mitsuba 3 through its Python package, driven by
//! `benches/peers/mitsuba_worker.py` (compiled into this binary, written into the work folder),
//! which holds the scene translation. A peer that is not installed is a note, not an error
//! (unless asked for by name); a peer that hangs is killed after [`PEER_TIMEOUT`] and named.

use super::convergence::Reference;
use super::{BenchError, BenchParams, Point, Series};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The worker script (one place for the scene translation; `peers.py` imports it too).
const WORKER: &str = include_str!("../../benches/peers/mitsuba_worker.py");

/// Longest a peer process may take before it is killed and the series skipped.
pub const PEER_TIMEOUT: Duration = Duration::from_secs(600);

/// Which peers a run takes.
#[derive(Clone, Debug, PartialEq)]
pub enum PeerChoice {
    /// Mitsuba 3 if `python` imports it, else a note.
    Auto { python: PathBuf },
    /// No peer.
    None,
    /// Mitsuba 3, which must import (an error otherwise).
    Mitsuba { python: PathBuf },
}

/// Mitsuba 3, ready to run.
pub struct Mitsuba {
    python: PathBuf,
    worker: PathBuf,
    version: String,
}

/// Runs `cmd` with a timeout; (status success, stdout, stderr) or None when it was killed.
fn run_with_timeout(mut cmd: Command, limit: Duration) -> std::io::Result<Option<(bool, String, String)>> {
    let mut child = cmd.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn()?;
    let (mut out, mut err) = (child.stdout.take(), child.stderr.take());
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(o) = out.as_mut() {
            let _ = o.read_to_string(&mut s);
        }
        s
    });
    let ereader = std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(e) = err.as_mut() {
            let _ = e.read_to_string(&mut s);
        }
        s
    });
    let t = Instant::now();
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(Some((status.success(), reader.join().unwrap_or_default(), ereader.join().unwrap_or_default())));
        }
        if t.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Checks the peer, writes its worker; None (with a note) when an `Auto` peer is not installed.
pub fn prepare(choice: &PeerChoice, work: &Path, notes: &mut Vec<String>) -> Option<Mitsuba> {
    let (python, required) = match choice {
        PeerChoice::None => return None,
        PeerChoice::Auto { python } => (python, false),
        PeerChoice::Mitsuba { python } => (python, true),
    };
    let mut cmd = Command::new(python);
    cmd.args(["-c", "import mitsuba, numpy; print(mitsuba.__version__)"]);
    let version = match run_with_timeout(cmd, Duration::from_secs(120)) {
        Ok(Some((true, out, _))) => out.trim().to_string(),
        Ok(Some((false, _, err))) => {
            let why = err.lines().last().unwrap_or("").to_string();
            notes.push(format!(
                "Mitsuba 3 not run: {} cannot import mitsuba and numpy ({why}){}",
                python.display(),
                if required { "" } else { "; install it (guide: Benchmarking fairly) or give --python" }
            ));
            return None;
        }
        Ok(None) => {
            notes.push(format!("Mitsuba 3 not run: importing it in {} took over 120 s", python.display()));
            return None;
        }
        Err(e) => {
            notes.push(format!("Mitsuba 3 not run: cannot start {} ({e})", python.display()));
            return None;
        }
    };
    let worker = work.join("mitsuba_worker.py");
    if let Err(e) = std::fs::write(&worker, WORKER) {
        notes.push(format!("Mitsuba 3 not run: cannot write {} ({e})", worker.display()));
        return None;
    }
    Some(Mitsuba { python: python.clone(), worker, version })
}

/// Reads a worker's raw image (H × W × 3 little-endian f32) as an image with R, G, B channels.
fn read_raw(path: &Path, size: usize) -> Result<vocab::image::Image, BenchError> {
    let bytes = std::fs::read(path).map_err(|e| BenchError::File(path.to_path_buf(), e.to_string()))?;
    if bytes.len() != size * size * 12 {
        return Err(BenchError::File(path.to_path_buf(), format!("{} bytes, expected {size}² × 3 f32", bytes.len())));
    }
    let v: Vec<f32> = bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let mut img = vocab::image::Image { width: size, height: size, ..Default::default() };
    for (k, name) in ["R", "G", "B"].iter().enumerate() {
        img.channels.insert(name.to_string(), v.iter().skip(k).step_by(3).copied().collect());
    }
    Ok(img)
}

impl Mitsuba {
    /// "Mitsuba 3 VERSION (llvm_ad_rgb)".
    pub fn describe(&self) -> String {
        format!("Mitsuba {} (llvm_ad_rgb)", self.version)
    }

    /// Both samplers' ladders for one seed of scene `name` (the worker's name), each in a fresh
    /// process with one warm-up render; a sampler whose process fails or times out is a note.
    pub fn run_series(
        &self,
        name: &str,
        p: &BenchParams,
        seed: u64,
        reference: &Reference,
        notes: &mut Vec<String>,
    ) -> Result<Vec<Series>, BenchError> {
        let mut out = Vec::new();
        for sampler in ["independent", "ldsampler"] {
            let job = serde_json::json!({
                "scene": name, "size": p.size, "ladder": p.ladder, "seed": seed, "sampler": sampler,
                "threads": p.threads, "data": p.data, "out": p.work,
            });
            let mut cmd = Command::new(&self.python);
            cmd.arg(&self.worker).arg(job.to_string());
            let what = format!("{name} ({sampler}, seed {seed})");
            let doc: serde_json::Value = match run_with_timeout(cmd, PEER_TIMEOUT) {
                Ok(Some((true, stdout, _))) => match stdout.lines().last().map(serde_json::from_str) {
                    Some(Ok(v)) => v,
                    _ => {
                        notes.push(format!("Mitsuba 3 skipped on {what}: no result line in its output"));
                        continue;
                    }
                },
                Ok(Some((false, _, err))) => {
                    notes.push(format!("Mitsuba 3 failed on {what}: {}", err.lines().last().unwrap_or("")));
                    continue;
                }
                Ok(None) => {
                    notes.push(format!(
                        "Mitsuba 3 killed on {what} after {} s (3.9.1 is known to hang in mi.Bitmap after \
                         dr.set_thread_count(1))",
                        PEER_TIMEOUT.as_secs()
                    ));
                    continue;
                }
                Err(e) => return Err(BenchError::Peer(format!("cannot start {}: {e}", self.python.display()))),
            };
            let mut points = Vec::new();
            for q in doc["points"].as_array().into_iter().flatten() {
                let file = PathBuf::from(q["file"].as_str().unwrap_or_default());
                let img = read_raw(&file, p.size as usize)?;
                let _ = std::fs::remove_file(&file);
                let e = reference.rms_rel_error(&img).map_err(|e| BenchError::Convergence(file.clone(), e))?;
                let secs = q["seconds"].as_f64().unwrap_or(f64::NAN);
                points.push(Point {
                    seed,
                    spp: q["spp"].as_u64().unwrap_or(0) as u32,
                    render_seconds: secs,
                    total_seconds: secs,
                    rms_rel_error: e,
                });
            }
            out.push(Series {
                renderer: "mitsuba3".into(),
                sampler: sampler.into(),
                points,
                time_to_target: None,
                target_spp: None,
                extrapolated: false,
                exponent: None,
                samples_per_sec: None,
                rays_per_sec: None,
                phases: None,
                peak_rss_mb: doc["peak_mb"].as_f64(),
                cold_render_seconds: doc["cold_seconds"].as_f64(),
            });
        }
        Ok(out)
    }
}
