//! `reflect merge PART.exr… --out FINAL.exr [--partial]`: merges partial renders (shards written by
//! `reflect render --shard I/N`, or earlier merges written with `--partial`) into the image a single
//! `reflect render` writes, bit for bit in every layer, whatever the order of the parts. Parts of
//! different scenes, seeds or spp, and overlapping or missing sample ranges, are refused (exit 2, one
//! line naming the file).

use super::Error;
use super::outputs::{Files, Format};
use renderer::film::Partial;
use renderer::shard::{PartialFile, PartialHeader, read_partial, write_partial};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug, Clone)]
pub struct MergeArgs {
    /// Partial renders, in any order.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The merged image (OpenEXR).
    #[arg(long)]
    pub out: PathBuf,
    /// Write a partial render of the parts' union (a contiguous sample range) instead of the image.
    #[arg(long)]
    pub partial: bool,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Parts read, checked against each other and merged.
pub struct Merged {
    /// The union of the parts' samples.
    pub partial: Partial,
    /// The first part's header, its range and blocks those of the union.
    pub header: PartialHeader,
    /// The first part's `reflect:*` attributes.
    pub attributes: Vec<(String, String)>,
    /// The parts holding the first and the last samples.
    pub first: PathBuf,
    pub last: PathBuf,
}

/// Reads the partial renders `parts` and merges them, refusing (one line naming the file) parts of
/// different scenes, seeds, spp or sizes, overlapping ranges and gaps between them.
pub fn merge_parts(parts: &[PathBuf]) -> Result<Merged, Error> {
    let mut files: Vec<(PathBuf, PartialFile)> = Vec::with_capacity(parts.len());
    for p in parts {
        let f = read_partial(p)?;
        if let Some((first, f0)) = files.first() {
            let (h, h0): (&PartialHeader, &PartialHeader) = (&f.header, &f0.header);
            let what = if h.scene != h0.scene {
                Some("a different scene (or scene files)".to_string())
            } else if h.seed != h0.seed {
                Some(format!("seed {}, not {}", h.seed, h0.seed))
            } else if h.spp != h0.spp {
                Some(format!("{} spp, not {}", h.spp, h0.spp))
            } else if (h.width, h.height, h.batch_log2) != (h0.width, h0.height, h0.batch_log2) {
                Some(format!("{}×{} pixels, not {}×{}", h.width, h.height, h0.width, h0.height))
            } else {
                None
            };
            if let Some(what) = what {
                return Err(Error::file(p, format!("is a part of {what} than {}", first.display())));
            }
        }
        files.push((p.clone(), f));
    }
    let mut order: Vec<usize> = (0..files.len()).collect();
    order.sort_by_key(|&i| (files[i].1.partial.start, files[i].1.partial.end));
    for w in order.windows(2) {
        let ((pa, a_), (pb, b_)) = (&files[w[0]], &files[w[1]]);
        let (ra, rb) = ((a_.partial.start, a_.partial.end), (b_.partial.start, b_.partial.end));
        if rb.0 < ra.1 {
            return Err(Error::file(
                pb,
                format!("its samples [{}, {}) overlap samples [{}, {}) of {}", rb.0, rb.1, ra.0, ra.1, pa.display()),
            ));
        }
        if rb.0 > ra.1 {
            return Err(Error::file(
                pb,
                format!("samples [{}, {}) are missing between {} and this part", ra.1, rb.0, pa.display()),
            ));
        }
    }
    let (first, last) = (files[order[0]].0.clone(), files[order[order.len() - 1]].0.clone());
    let attributes = files[order[0]].1.attributes.clone();
    let header0 = files[order[0]].1.header.clone();
    let partial =
        Partial::merge(files.into_iter().map(|(_, f)| f.partial).collect()).map_err(|e| Error::new(e.to_string()))?;
    let header = PartialHeader {
        start: partial.start,
        end: partial.end,
        blocks: partial.blocks.iter().map(|b| (b.start, b.log2)).collect(),
        ..header0
    };
    Ok(Merged { partial, header, attributes, first, last })
}

pub fn run(a: MergeArgs) -> Result<ExitCode, Error> {
    Files::new().inputs("part", &a.parts).output("--out", &a.out, Format::Exr).check()?;
    let Merged { partial: merged, header, attributes: attrs, first, last } = merge_parts(&a.parts)?;
    let spp = header.spp as u64;
    if !a.partial {
        if merged.start > 0 {
            return Err(Error::file(
                &first,
                format!(
                    "samples [0, {}) are missing before this part (use --partial to merge a sub-range)",
                    merged.start
                ),
            ));
        }
        if merged.end < spp {
            return Err(Error::file(
                &last,
                format!(
                    "samples [{}, {spp}) are missing after this part (use --partial to merge a sub-range)",
                    merged.end
                ),
            ));
        }
    }
    let n = a.parts.len();
    if a.partial {
        write_partial(&a.out, &merged, &header, &attrs)?;
    } else {
        let film = merged.finish();
        renderer::output::stage_exr(&a.out, &film, &attrs)?.commit()?;
    }
    if !a.quiet {
        eprintln!(
            "wrote {}: {n} parts, samples [{}, {}) of {spp}{}",
            a.out.display(),
            merged.start,
            merged.end,
            if a.partial { " (partial render)" } else { "" }
        );
    }
    Ok(ExitCode::SUCCESS)
}
