//! Huge pages for the tables the render reads at random.
//!
//! The environment map's sampling table (one 32-byte entry per pixel, 16 MiB for a 1024 × 512
//! map) and a large mesh's BVH (63 MB of nodes for 1.31 M triangles, plus the triangle records)
//! are read at scattered addresses, several per sample. With 4 KiB pages those reads need more
//! page translations than the TLB holds (about 2,000 entries cover 8 MiB), so many of them add a
//! page walk to the cache miss. In 2 MiB pages the same tables take a handful of entries.
//!
//! Linux's transparent huge pages are often set to `madvise` (so on this project's machine):
//! only memory that asks gets them. [`advise_huge_pages`] asks for a table once it is built
//! (`MADV_HUGEPAGE`, and `MADV_COLLAPSE`, Linux 6.1, to move the pages already written into huge
//! pages at once rather than whenever `khugepaged` gets to them). It is a hint: it changes no
//! value, and where the kernel declines (THP `never`, an old kernel, no free huge page, another
//! OS) the table simply stays in small pages. Measured effect: guide "Performance notes and their history".

/// Asks the kernel to back the 2 MiB-aligned part of `data` with transparent huge pages.
///
/// A slice shorter than 2 MiB, or without a whole aligned 2 MiB inside it, is left alone. Never
/// fails and never changes `data`: the kernel's answer is ignored (a declined hint costs
/// nothing but the system call). Call it after the table is written, once: `MADV_COLLAPSE`
/// copies the written pages into huge pages (a few milliseconds for tens of MiB).
pub fn advise_huge_pages<T>(data: &[T]) {
    #[cfg(target_os = "linux")]
    {
        const HUGE_PAGE: usize = 2 << 20;
        let start = data.as_ptr() as usize;
        let end = start + std::mem::size_of_val(data);
        let (lo, hi) = (start.next_multiple_of(HUGE_PAGE), end / HUGE_PAGE * HUGE_PAGE);
        if hi <= lo {
            return;
        }
        let (addr, len) = (lo as *mut libc::c_void, hi - lo);
        // SAFETY: [lo, hi) lies inside `data`'s allocation, which is mapped; both advices only
        // change how the kernel backs those pages, never their contents or the mapping's access.
        unsafe {
            libc::madvise(addr, len, libc::MADV_HUGEPAGE);
            #[cfg(target_env = "gnu")]
            libc::madvise(addr, len, libc::MADV_COLLAPSE);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = data;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The advice changes no value, on a table long enough to hold aligned huge pages and on
    /// short and empty ones.
    #[test]
    fn advice_keeps_the_data() {
        for n in [0usize, 1, 1000, 3 << 20] {
            let v: Vec<u32> = (0..n as u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
            let copy = v.clone();
            advise_huge_pages(&v);
            assert_eq!(v, copy, "{n} values");
        }
    }
}
