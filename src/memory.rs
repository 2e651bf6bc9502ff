//! Memory a job needs, estimated before anything is allocated, against the memory the
//! machine has available.
//!
//! A scene of 10⁹ tiny particles is valid geometry, but its run would abort in an allocation
//! (or be killed by the kernel's out-of-memory killer) minutes into the seeding. The
//! estimates here are per particle (or voxel) times the measured peak of a whole process, so
//! such a job is refused before it starts, with the estimate and the limit.

/// Peak resident memory of a sphere run per particle: seeding, kernel, verification and
/// the packing record. Measured 242 B at 10⁶ spheres above the empty process (247.2 B for
/// the whole process; calendar queue, `densepack bench-child-memory 1000000 calendar`,
/// BENCHMARKS.md "Memory"), 283 B with the heap queue, 254 B at 2·10⁵; smaller runs carry
/// fixed buffers as well, well inside [`BASE_BYTES`]. Rounded up, with room for a host
/// process that keeps glibc's dynamic mmap threshold ([`map_large_blocks`]).
pub const SPHERE_BYTES: u64 = 300;

/// Peak resident memory of a sphere + cylinder mixture per body: 238 B (RSA) and 571 B
/// (relaxer) measured at 2·10⁴ spheres + 2·10⁴ cylinders, rounded up to the larger.
pub const MIXTURE_BODY_BYTES: u64 = 600;

/// Resident memory of the process before the first particle (measured 5.7 MiB for a run of
/// ten spheres), rounded up.
pub const BASE_BYTES: u64 = 8 << 20;

/// The environment variable that skips the check ([`check`]) when set to `1`.
pub const OVERRIDE_ENV: &str = "DENSEPACK_IGNORE_MEMORY_CHECK";

/// Estimated peak memory of a job of `count` items of `bytes_each`, with the process's
/// own base. Saturates instead of overflowing (a count of 10³⁰ is simply too much).
pub fn estimate(count: f64, bytes_each: u64) -> u64 {
    let items = if count.is_finite() && count > 0.0 {
        // `as` saturates at u64::MAX for counts beyond it.
        count.ceil() as u64
    } else if count > 0.0 {
        u64::MAX
    } else {
        0
    };
    items.saturating_mul(bytes_each).saturating_add(BASE_BYTES)
}

/// Hands the pages of freed heap memory back to the system (glibc's `malloc_trim`; nothing
/// elsewhere). glibc keeps freed blocks resident below a trim threshold that grows with the
/// largest block freed, so the scratch of a grid rebuild at 10⁶ particles, freed below the
/// lists, stayed resident through the run: 19 B per particle of the whole process's peak.
/// A walk over the heap's free blocks; for large systems only (the caller decides).
pub(crate) fn release_freed() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only returns unused pages of the allocator's own heap to the
    // system; it is safe to call at any time from any thread.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Smallest block the allocator maps on its own after [`map_large_blocks`] (glibc's initial
/// mmap threshold, 128 KiB).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MAP_FROM: i32 = 128 << 10;

/// Makes the allocator serve every block of 128 KiB or more by a mapping of its
/// own, handed back to the system when the block is freed (glibc: fixes `M_MMAP_THRESHOLD`;
/// nothing elsewhere).
///
/// glibc otherwise raises its threshold to the size of every mapped block freed, up to
/// 32 MiB, and serves later blocks below it from the heap, where they are placed among
/// longer-lived ones. At 10⁶ spheres the 32 MB local event lists, freed and allocated again
/// at each grid rebuild, then raised the peak of a run by 27 B per particle (BENCHMARKS.md,
/// "Memory"). Fixing the threshold turns the adjustment off.
///
/// For a process that owns its allocator: the command line calls it first. A library host
/// (Python) keeps its own policy; the kernel still trims freed pages after grid rebuilds
/// there (`malloc_trim`).
pub fn map_large_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only changes the allocator's policy for later allocations; it is
    // called before the command starts any thread.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MAP_FROM);
    }
}

/// Memory the machine can give a new job without swapping: `MemAvailable` of
/// `/proc/meminfo` (Linux). `None` where it is not known; then nothing is checked.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    available_in_meminfo(&text)
}

/// The `MemAvailable` line of a `/proc/meminfo` text, in bytes.
fn available_in_meminfo(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => value.checked_mul(1024),
        None => Some(value),
        Some(_) => None,
    }
}

/// A job whose estimate exceeds the available memory.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "needs about {} of memory (estimate: {what}), but only {} is available \
     (MemAvailable); use fewer or larger particles, or run anyway with {override_hint}",
    human(*needed),
    human(*available)
)]
pub struct TooLarge {
    /// The estimate, bytes.
    pub needed: u64,
    /// The available memory, bytes.
    pub available: u64,
    /// How the estimate was formed (`10⁹ spheres × 300 B + 8 MiB`).
    pub what: String,
    /// The option or variable that skips the check.
    pub override_hint: String,
}

/// Refuses a job of `needed` bytes when the machine has less available (unknown: accepted).
/// `what` says how the estimate was formed; `override_hint` how to skip the check.
pub fn check(needed: u64, what: String, override_hint: &str) -> Result<(), TooLarge> {
    match available_bytes() {
        Some(available) if needed > available => Err(TooLarge {
            needed,
            available,
            what,
            override_hint: override_hint.into(),
        }),
        _ => Ok(()),
    }
}

/// Whether [`OVERRIDE_ENV`] asks to skip the check.
pub fn overridden() -> bool {
    std::env::var(OVERRIDE_ENV).is_ok_and(|v| v == "1")
}

/// Bytes as a short decimal figure (`1.2 GB`).
pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    for (unit, scale) in [("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)] {
        if b >= scale {
            return format!("{:.1} {unit}", b / scale);
        }
    }
    format!("{bytes} B")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_is_read_in_kibibytes() {
        let text = "MemTotal:       32768000 kB\nMemFree:  100 kB\nMemAvailable:   24264752 kB\n";
        assert_eq!(available_in_meminfo(text), Some(24_264_752 * 1024));
        assert_eq!(available_in_meminfo("MemTotal: 5 kB\n"), None);
        assert_eq!(available_in_meminfo("MemAvailable: 12 MB\n"), None);
    }

    #[test]
    fn estimates_saturate_instead_of_overflowing() {
        assert_eq!(estimate(0.0, 320), BASE_BYTES);
        assert_eq!(estimate(1e6, 320), 320_000_000 + BASE_BYTES);
        assert_eq!(estimate(2.5, 100), 300 + BASE_BYTES);
        assert_eq!(estimate(1e30, 320), u64::MAX);
        assert_eq!(estimate(f64::INFINITY, 1), u64::MAX);
        assert_eq!(estimate(f64::NAN, 1), BASE_BYTES);
    }

    #[test]
    fn human_figures() {
        assert_eq!(human(999), "999 B");
        assert_eq!(human(320_000_000_000), "320.0 GB");
        assert_eq!(human(1_500_000), "1.5 MB");
    }
}
