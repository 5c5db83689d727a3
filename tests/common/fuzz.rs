//! A small, dependency-free mutation fuzzer for the loaders, on stable Rust.
//!
//! - [`Mutator`]: a seeded byte mutator (bit flips, interesting bytes and numbers, deletions,
//!   duplications, dictionary tokens, splices between seeds, truncation), deterministic for a seed.
//! - [`CountingAlloc`]: a global allocator wrapping [`System`] that counts live bytes and the peak,
//!   and refuses (returns null, which aborts the process) any single request above
//!   [`set_hard_cap`]. Declare it in the test binary with
//!   `#[global_allocator] static A: fuzz::CountingAlloc = fuzz::CountingAlloc;`.
//! - [`run`]: feeds mutated inputs to a target, each in a worker thread with a wall-clock bound;
//!   a panic, a time-out, a contract violation reported by the target (`Err`) or a peak allocation
//!   above the budget fails the run, with the offending input saved under `target/fuzz-failures/`.
//!   Fuzz runs in one binary are serialised (a global lock) so that the allocation counts belong to
//!   one input.
//!
//! The iteration count can be raised for a longer run with `REFLECT_FUZZ_ITERS=<n>` and the mutator
//! seed changed with `REFLECT_FUZZ_SEED=<u64>`.
#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::Duration;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static HARD_CAP: AtomicUsize = AtomicUsize::new(usize::MAX);

/// Counting global allocator (see the module documentation).
pub struct CountingAlloc;

// SAFETY: every call is forwarded unchanged to `System`; the counters are plain atomics.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > HARD_CAP.load(Ordering::Relaxed) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            add(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > HARD_CAP.load(Ordering::Relaxed) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            add(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > HARD_CAP.load(Ordering::Relaxed) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            add(new_size);
        }
        p
    }
}

fn add(n: usize) {
    let live = LIVE.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(live, Ordering::Relaxed);
}

/// Any single allocation request above `bytes` fails (the process aborts with "memory allocation
/// of N bytes failed"), so a loader that trusts a size field cannot take the machine down.
pub fn set_hard_cap(bytes: usize) {
    HARD_CAP.store(bytes, Ordering::Relaxed);
}

/// Bytes currently allocated through the counting allocator (0 if it is not installed).
pub fn live_bytes() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// Seeded byte mutator (SplitMix64 stream).
pub struct Mutator {
    state: u64,
}

/// Numbers that tend to sit on boundaries of size fields and parsers.
const INTERESTING_NUMBERS: &[&str] = &[
    "0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "7",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "-2147483648",
    "9223372036854775807",
    "18446744073709551615",
    "1e39",
    "-1e39",
    "1e-45",
    "nan",
    "inf",
    "-inf",
    "0.0",
    "-0.0",
    "1.5",
    "5120",
    "5121",
    "5122",
    "5123",
    "5125",
    "5126",
    "1000000000",
];

const INTERESTING_BYTES: &[u8] = &[0, 1, 0x7f, 0x80, 0xff, b'\n', b'\r', b'\t', b' ', b'-', b'/', b'0', b'9', b'#'];

impl Mutator {
    pub fn new(seed: u64) -> Self {
        Mutator { state: seed ^ 0x9e37_79b9_7f4a_7c15 }
    }

    /// SplitMix64.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// One mutated copy of `seed`: 1 to 4 stacked mutations. `others` are the other seeds (for
    /// splicing); `dict` holds format tokens to insert (keywords, field names).
    pub fn mutate(&mut self, seed: &[u8], others: &[Vec<u8>], dict: &[&[u8]]) -> Vec<u8> {
        let mut v = seed.to_vec();
        let n = 1 + self.below(4);
        for _ in 0..n {
            self.mutate_once(&mut v, others, dict);
        }
        v
    }

    fn mutate_once(&mut self, v: &mut Vec<u8>, others: &[Vec<u8>], dict: &[&[u8]]) {
        let len = v.len();
        match self.below(11) {
            0 if len > 0 => {
                let i = self.below(len);
                v[i] ^= 1 << self.below(8);
            }
            1 if len > 0 => {
                let i = self.below(len);
                v[i] = self.next_u64() as u8;
            }
            2 if len > 0 => {
                let i = self.below(len);
                v[i] = INTERESTING_BYTES[self.below(INTERESTING_BYTES.len())];
            }
            3 if len > 0 => {
                // Delete a span.
                let i = self.below(len);
                let n = 1 + self.below((len - i).min(64));
                v.drain(i..i + n);
            }
            4 if len > 0 => {
                // Duplicate a span in place (repeated structures: nodes, faces, chunks).
                let i = self.below(len);
                let n = 1 + self.below((len - i).min(256));
                let span: Vec<u8> = v[i..i + n].to_vec();
                let at = self.below(len + 1);
                v.splice(at..at, span);
            }
            5 | 6 => {
                // Replace a run of digits (or insert at a random place) by an interesting number.
                let num = INTERESTING_NUMBERS[self.below(INTERESTING_NUMBERS.len())].as_bytes();
                let digits: Vec<usize> = (0..len).filter(|&i| v[i].is_ascii_digit()).collect();
                if digits.is_empty() {
                    let at = self.below(len + 1);
                    v.splice(at..at, num.iter().copied());
                } else {
                    let start = digits[self.below(digits.len())];
                    let mut end = start;
                    while end < len && (v[end].is_ascii_digit() || v[end] == b'.' || v[end] == b'-') {
                        end += 1;
                    }
                    v.splice(start..end, num.iter().copied());
                }
            }
            7 if !dict.is_empty() => {
                let tok = dict[self.below(dict.len())];
                let at = self.below(len + 1);
                v.splice(at..at, tok.iter().copied());
            }
            8 if !others.is_empty() => {
                // Splice: our head with the tail of another seed.
                let o = &others[self.below(others.len())];
                let at = self.below(len + 1);
                let from = self.below(o.len() + 1);
                v.truncate(at);
                v.extend_from_slice(&o[from..]);
            }
            9 if len > 0 => {
                v.truncate(self.below(len));
            }
            10 if len >= 4 => {
                // Overwrite a little-endian u32 with a boundary value (binary size fields).
                let i = self.below(len - 3);
                let vals = [0u32, 1, 3, 4, 0x7fff_ffff, 0x8000_0000, 0xffff_ffff, 0xffff, 0x1_0000, 12, 20];
                let x = vals[self.below(vals.len())];
                v[i..i + 4].copy_from_slice(&x.to_le_bytes());
            }
            _ => {
                let at = self.below(len + 1);
                v.insert(at, self.next_u64() as u8);
            }
        }
    }
}

/// Settings of one fuzz run.
#[derive(Clone, Debug)]
pub struct FuzzConfig {
    /// Name of the loader (used for the failure file name).
    pub name: &'static str,
    /// Mutated inputs to try (overridden by `REFLECT_FUZZ_ITERS`).
    pub iterations: usize,
    /// Wall-clock bound per input.
    pub time_limit: Duration,
    /// Peak allocation (bytes above the level before the input) an input may cause (a function of
    /// the input, so an image's budget can follow what its headers claim).
    pub alloc_budget: fn(&[u8]) -> usize,
    /// Mutator seed (overridden by `REFLECT_FUZZ_SEED`).
    pub seed: u64,
}

impl FuzzConfig {
    /// Defaults: 2000 inputs, 10 s per input, 4 MiB + 64 bytes per input byte.
    pub fn new(name: &'static str) -> Self {
        FuzzConfig {
            name,
            iterations: 2000,
            time_limit: Duration::from_secs(10),
            alloc_budget: |input| (4 << 20) + 64 * input.len(),
            seed: 1,
        }
    }
}

/// Outcome of a successful run.
#[derive(Clone, Debug, Default)]
pub struct FuzzReport {
    pub inputs: usize,
    /// Inputs the target accepted (`Ok(true)`), the rest were refused cleanly.
    pub accepted: usize,
    pub peak_bytes: usize,
    pub slowest: Duration,
}

/// Serialises fuzz runs within one test binary.
static RUN_LOCK: Mutex<()> = Mutex::new(());

/// Where the last panic's message and location are kept (the hook below writes it).
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

fn install_quiet_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if std::thread::current().name().is_some_and(|n| n.starts_with("fuzz-worker")) {
                if let Ok(mut g) = LAST_PANIC.lock() {
                    *g = Some(info.to_string().replace('\n', " "));
                }
            } else {
                default(info);
            }
        }));
    });
}

fn save_failure(name: &str, k: usize, input: &[u8]) -> String {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures");
    let _ = std::fs::create_dir_all(&dir);
    let p = dir.join(format!("{name}-{k}.bin"));
    let _ = std::fs::write(&p, input);
    p.display().to_string()
}

/// Runs `target` on the seeds and then on `cfg.iterations` mutated inputs. The target returns
/// `Ok(true)` when it accepted the input, `Ok(false)` when it refused it cleanly (a one-line error)
/// and `Err(description)` when it broke a contract (e.g. a multi-line error). Panics (fails the
/// test) at the first fault with the input saved to a file.
pub fn run<F>(cfg: &FuzzConfig, seeds: &[Vec<u8>], dict: &[&[u8]], target: F) -> FuzzReport
where
    F: Fn(&[u8]) -> Result<bool, String> + Send + Sync + 'static,
{
    assert!(!seeds.is_empty(), "{}: no seeds", cfg.name);
    let _guard = RUN_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    install_quiet_hook();
    let iterations = std::env::var("REFLECT_FUZZ_ITERS").ok().and_then(|s| s.parse().ok()).unwrap_or(cfg.iterations);
    let seed = std::env::var("REFLECT_FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(cfg.seed);
    let target = Arc::new(target);
    let mut mutator = Mutator::new(seed);
    let mut report = FuzzReport::default();
    for k in 0..seeds.len() + iterations {
        let input =
            if k < seeds.len() { seeds[k].clone() } else { mutator.mutate(&seeds[k % seeds.len()], seeds, dict) };
        let budget = (cfg.alloc_budget)(&input);
        let (tx, rx) = mpsc::channel();
        let t = Arc::clone(&target);
        let data = input.clone();
        let base = LIVE.load(Ordering::Relaxed);
        PEAK.store(base, Ordering::Relaxed);
        let start = std::time::Instant::now();
        std::thread::Builder::new()
            .name(format!("fuzz-worker-{}", cfg.name))
            .spawn(move || {
                let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| t(&data)));
                let _ = tx.send(r);
            })
            .expect("spawn fuzz worker");
        let result = match rx.recv_timeout(cfg.time_limit) {
            Ok(r) => r,
            Err(_) => {
                let p = save_failure(cfg.name, k, &input);
                panic!("{}: input {k} ran longer than {:?} (saved to {p})", cfg.name, cfg.time_limit);
            }
        };
        let elapsed = start.elapsed();
        let peak = PEAK.load(Ordering::Relaxed).saturating_sub(base);
        match result {
            Err(_) => {
                let msg = LAST_PANIC.lock().ok().and_then(|mut g| g.take()).unwrap_or_default();
                let p = save_failure(cfg.name, k, &input);
                panic!("{}: input {k} panicked: {msg} (saved to {p})", cfg.name);
            }
            Ok(Err(fault)) => {
                let p = save_failure(cfg.name, k, &input);
                panic!("{}: input {k}: {fault} (saved to {p})", cfg.name);
            }
            Ok(Ok(accepted)) => report.accepted += accepted as usize,
        }
        if peak > budget {
            let p = save_failure(cfg.name, k, &input);
            panic!(
                "{}: input {k} ({} bytes) allocated {peak} bytes at peak, budget {budget} (saved to {p})",
                cfg.name,
                input.len()
            );
        }
        report.inputs += 1;
        report.peak_bytes = report.peak_bytes.max(peak);
        report.slowest = report.slowest.max(elapsed);
    }
    eprintln!(
        "fuzz {}: {} inputs ({} accepted), peak allocation {} KiB, slowest {:?}",
        cfg.name,
        report.inputs,
        report.accepted,
        report.peak_bytes >> 10,
        report.slowest
    );
    report
}

/// Every regular file under `dir` (recursively) whose name ends with one of `exts`, sorted, at most
/// `max_len` bytes each (larger files are skipped: seeds should be small).
pub fn seed_files(dir: &std::path::Path, exts: &[&str], max_len: u64) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if let Some(name) = p.file_name().and_then(|n| n.to_str())
                && exts.iter().any(|x| name.to_ascii_lowercase().ends_with(x))
                && e.metadata().is_ok_and(|m| m.len() <= max_len)
            {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// A single-line check for the error contract: one line, naming `name`.
pub fn check_error_line(err: &str, name: &str) -> Result<bool, String> {
    if err.contains('\n') {
        return Err(format!("error message spans several lines: {err:?}"));
    }
    if !err.contains(name) {
        return Err(format!("error message does not name the file {name}: {err:?}"));
    }
    Ok(false)
}
