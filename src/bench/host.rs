//! What a benchmark figure depends on besides the code: the machine, its load and the build. A
//! figure without these cannot be compared with another (docs/src/reference/bench.md).

use serde::Serialize;

/// The host, the build and the load around a benchmark run.
#[derive(Clone, Debug, Serialize)]
pub struct Fingerprint {
    /// `model name` of /proc/cpuinfo (null where not Linux).
    pub cpu: Option<String>,
    /// Logical CPUs the OS reports.
    pub logical_cpus: usize,
    /// SIMD features the CPU has (run-time detection): sse4.2, avx, avx2, fma, avx512f.
    pub cpu_features: Vec<&'static str>,
    /// SIMD features this build was compiled to assume (`-C target-feature` / `target-cpu`).
    pub build_features: Vec<&'static str>,
    /// Worker threads of each render.
    pub threads: usize,
    /// "release" or "debug" (debug assertions on).
    pub profile: &'static str,
    /// The crate version and, for a binary inside a git checkout (`<checkout>/target/<profile>/reflect`),
    /// the checkout's commit (`-dirty` with local changes; not proof that the binary is up to date).
    pub version: String,
    /// Load averages (1, 5, 15 min) before and after the run (/proc/loadavg).
    pub load_before: Option<[f64; 3]>,
    pub load_after: Option<[f64; 3]>,
    /// Share of CPU time stolen by the hypervisor during the run (/proc/stat), 0–1.
    pub steal: Option<f64>,
    /// UTC time at the start, RFC 3339.
    pub started: String,
}

/// CPU counters of /proc/stat's first line: (steal, total) jiffies.
pub fn cpu_times() -> Option<(u64, u64)> {
    let text = std::fs::read_to_string("/proc/stat").ok()?;
    let v: Vec<u64> = text.lines().next()?.split_whitespace().skip(1).filter_map(|x| x.parse().ok()).collect();
    Some((*v.get(7)?, v.iter().take(8).sum()))
}

/// The three load averages of /proc/loadavg.
pub fn load_average() -> Option<[f64; 3]> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    let v: Vec<f64> = text.split_whitespace().take(3).filter_map(|x| x.parse().ok()).collect();
    Some([*v.first()?, *v.get(1)?, *v.get(2)?])
}

/// `git describe --always --dirty` of the checkout holding this executable, if any.
fn checkout_commit() -> Option<String> {
    let exe = std::env::current_exe().ok()?;
    let checkout = exe.parent()?.ancestors().nth(2)?;
    if !checkout.join("Cargo.toml").is_file() {
        return None;
    }
    let o = std::process::Command::new("git")
        .arg("-C")
        .arg(checkout)
        .args(["describe", "--always", "--dirty", "--abbrev=12"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    let c = String::from_utf8_lossy(&o.stdout).trim().to_string();
    (o.status.success() && !c.is_empty()).then_some(c)
}

fn cpu_model() -> Option<String> {
    let text = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("model name"))?;
    Some(line.split_once(':')?.1.trim().to_string())
}

fn cpu_features() -> Vec<&'static str> {
    let mut f = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        for (name, on) in [
            ("sse4.2", std::arch::is_x86_feature_detected!("sse4.2")),
            ("avx", std::arch::is_x86_feature_detected!("avx")),
            ("avx2", std::arch::is_x86_feature_detected!("avx2")),
            ("fma", std::arch::is_x86_feature_detected!("fma")),
            ("avx512f", std::arch::is_x86_feature_detected!("avx512f")),
        ] {
            if on {
                f.push(name);
            }
        }
    }
    f
}

fn build_features() -> Vec<&'static str> {
    let mut f = Vec::new();
    if cfg!(target_feature = "sse4.2") {
        f.push("sse4.2");
    }
    if cfg!(target_feature = "avx") {
        f.push("avx");
    }
    if cfg!(target_feature = "avx2") {
        f.push("avx2");
    }
    if cfg!(target_feature = "fma") {
        f.push("fma");
    }
    if cfg!(target_feature = "avx512f") {
        f.push("avx512f");
    }
    f
}

impl Fingerprint {
    /// The fingerprint at the start of a run (`load_after` and `steal` are filled by [`Fingerprint::finish`]).
    pub fn start(threads: usize, started: String) -> Fingerprint {
        Fingerprint {
            cpu: cpu_model(),
            logical_cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
            cpu_features: cpu_features(),
            build_features: build_features(),
            threads,
            profile: if cfg!(debug_assertions) { "debug" } else { "release" },
            version: match checkout_commit() {
                Some(c) => format!("{} ({c})", env!("CARGO_PKG_VERSION")),
                None => env!("CARGO_PKG_VERSION").to_string(),
            },
            load_before: load_average(),
            load_after: None,
            steal: None,
            started,
        }
    }

    /// Records the load after the run and the steal since `times_before` ([`cpu_times`]).
    pub fn finish(&mut self, times_before: Option<(u64, u64)>) {
        self.load_after = load_average();
        if let (Some((s0, t0)), Some((s1, t1))) = (times_before, cpu_times())
            && t1 > t0
        {
            self.steal = Some((s1.saturating_sub(s0)) as f64 / (t1 - t0) as f64);
        }
    }
}

impl std::fmt::Display for Fingerprint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let load = |l: Option<[f64; 3]>| l.map_or("?".into(), |l| format!("{:.2}", l[0]));
        write!(
            f,
            "host: {} ({} logical CPUs; {}), {} threads; reflect {} {} build (compiled for: {}); load {} → {}{}; {}",
            self.cpu.as_deref().unwrap_or("unknown CPU"),
            self.logical_cpus,
            self.cpu_features.join(" "),
            self.threads,
            self.version,
            self.profile,
            if self.build_features.is_empty() { "baseline".into() } else { self.build_features.join(" ") },
            load(self.load_before),
            load(self.load_after),
            self.steal.map_or(String::new(), |s| format!(", steal {:.1} %", 100.0 * s)),
            self.started
        )
    }
}
