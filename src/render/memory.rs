//! What a render holds in memory at once, and what this machine has: a render whose images
//! cannot fit is refused before it starts ([`Error::Memory`]), instead of failing an
//! allocation part-way (docs/cli.md#limits).
//!
//! A render held whole (the CPU reference, adaptive precision, `--spp`, and GPU renders not in
//! bands) holds its images: per sample an id, a distance and a
//! normal in its precision, a shade hook's colour, and adaptive precision's certainty; a
//! supersampled one holds the samples' images and then the pixels' with their coverage. That
//! is a lower bound (the encoded files, the GPU's buffers and the scene come on top), so a
//! render refused could not have run. Renders in bands hold one band and are not refused.

use crate::error::{Error, Result};
use crate::mode::Precision;

/// The environment variable that sets the memory raycast may use, instead of the machine's.
const MEMORY_VAR: &str = "RAYCAST_MEMORY";

/// Bytes of one sample's images in `precision`, with a shade hook's colour where `shaded`.
pub(crate) fn sample_bytes(precision: Precision, shaded: bool) -> u64 {
    let (real, certainty) = match precision {
        Precision::F32 => (4, 0),
        Precision::F64 => (8, 0),
        Precision::Adaptive => (4, 1),
    };
    4 + 4 * real + certainty + if shaded { 4 } else { 0 }
}

/// Bytes of a pixel's coverage in a supersampled render: its hits, alpha and colour sums.
const COVERAGE_BYTES: u64 = 4 + 4 + 12;

/// What a render of `[nx, ny]` pixels of `spp` samples each, whole, in `precision` holds at
/// once (module docs), in bytes.
pub(crate) fn whole_render_bytes(
    [nx, ny]: [u32; 2],
    spp: u32,
    precision: Precision,
    shaded: bool,
) -> u128 {
    let pixels = u128::from(nx) * u128::from(ny);
    let sample = u128::from(sample_bytes(precision, shaded));
    let reduced = match spp > 1 {
        true => pixels * (sample + u128::from(COVERAGE_BYTES)),
        false => 0,
    };
    pixels * u128::from(spp) * sample + reduced
}

/// Refuses a render of `[nx, ny]` pixels of `spp` samples held whole in `precision` whose
/// images need more memory than this process may use ([`available`]), naming
/// `samples_per_pixel` when supersampled, else `size`; `bands` says whether the render could
/// go in bands instead (GPU, f32 or f64, one sample), which the advice then offers.
pub(crate) fn check_whole_render(
    size: [u32; 2],
    spp: u32,
    precision: Precision,
    shaded: bool,
    bands: bool,
) -> Result<()> {
    let needed = whole_render_bytes(size, spp, precision, shaded);
    let Some(limit) = available()? else {
        return within_address_space(needed, size, spp);
    };
    if needed <= u128::from(limit) {
        return Ok(());
    }
    let [nx, ny] = size;
    let room = match std::env::var_os(MEMORY_VAR) {
        Some(_) => format!("more than the {} {MEMORY_VAR} allows", human(limit)),
        None => format!("more than the {} of memory available", human(limit)),
    };
    Err(match spp > 1 {
        true => Error::Memory {
            option: format!("samples_per_pixel {spp}"),
            message: format!(
                "{nx}x{ny} pixels of {spp} samples, held whole, need {} for the samples' images, {room}; lower `samples_per_pixel` or `size`",
                human_wide(needed)
            ),
        },
        false => Error::Memory {
            option: format!("size {nx}x{ny}"),
            message: format!(
                "an image of {nx}x{ny} pixels held whole ({precision}) needs {} for its images, {room}; lower `size`{}",
                human_wide(needed),
                match bands {
                    true => ", or render it in bands with `precision` f32 or f64 on the GPU",
                    false => "",
                }
            ),
        },
    })
}

/// Where the machine's memory is not known: refuses only what no address space holds.
fn within_address_space(needed: u128, [nx, ny]: [u32; 2], spp: u32) -> Result<()> {
    match needed <= isize::MAX as u128 {
        true => Ok(()),
        false => Err(Error::Memory {
            option: format!("size {nx}x{ny}"),
            message: format!(
                "at {spp} samples per pixel needs {}, more than this machine can address",
                human_wide(needed)
            ),
        }),
    }
}

/// The bytes of memory this process may use: [`MEMORY_VAR`] where set; on Linux the memory
/// available (`MemAvailable` of /proc/meminfo, else `MemTotal`), or less where the process's
/// cgroup (a container's limit) leaves less; elsewhere on unix the physical memory; `None`
/// where it cannot be told.
pub(crate) fn available() -> Result<Option<u64>> {
    if let Ok(text) = std::env::var(MEMORY_VAR) {
        return parse_bytes(&text).map(Some).ok_or_else(|| Error::Argument {
            option: MEMORY_VAR.into(),
            message: format!(
                "must be a number of bytes, with K, M, G or T for 10^3, 10^6, 10^9 or 10^12 (e.g. 16G), got `{}`",
                text.escape_debug()
            ),
        });
    }
    let machine = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| meminfo_bytes(&m))
        .or_else(physical_memory);
    Ok(match (machine, cgroup_room()) {
        (Some(m), Some(c)) => Some(m.min(c)),
        (m, c) => m.or(c),
    })
}

/// `MemAvailable` of /proc/meminfo's text, else `MemTotal` (kernels before 3.14), in bytes.
fn meminfo_bytes(meminfo: &str) -> Option<u64> {
    let field = |name: &str| {
        let line = meminfo.lines().find(|l| l.starts_with(name))?;
        let kib: u64 = line[name.len()..]
            .trim()
            .trim_end_matches("kB")
            .trim()
            .parse()
            .ok()?;
        kib.checked_mul(1024)
    };
    field("MemAvailable:").or_else(|| field("MemTotal:"))
}

/// What the process's cgroup (v2) lets it use beyond what it uses, where it sets a limit.
fn cgroup_room() -> Option<u64> {
    let cgroup = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = cgroup.lines().find_map(|l| l.strip_prefix("0::"))?;
    let dir = std::path::Path::new("/sys/fs/cgroup").join(path.trim_start_matches('/'));
    let read = |name: &str| -> Option<u64> {
        std::fs::read_to_string(dir.join(name))
            .ok()?
            .trim()
            .parse()
            .ok()
    };
    // "max" (no limit) does not parse.
    let limit = read("memory.max")?;
    Some(limit.saturating_sub(read("memory.current").unwrap_or(0)))
}

/// The physical memory (unix but Linux, where /proc/meminfo is not there).
fn physical_memory() -> Option<u64> {
    #[cfg(unix)]
    {
        // SAFETY: sysconf reads a system value; it has no preconditions.
        let (pages, page) = unsafe {
            (
                libc::sysconf(libc::_SC_PHYS_PAGES),
                libc::sysconf(libc::_SC_PAGESIZE),
            )
        };
        if pages > 0 && page > 0 {
            return (pages as u64).checked_mul(page as u64);
        }
    }
    None
}

/// A number of bytes written as [`MEMORY_VAR`] takes it: digits, then K, M, G or T (decimal).
fn parse_bytes(text: &str) -> Option<u64> {
    let text = text.trim();
    let split = text
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(text.len());
    let (digits, unit) = text.split_at(split);
    let scale: u64 = match unit.trim().trim_end_matches(['B', 'b']) {
        "" => 1,
        "K" | "k" => 1_000,
        "M" => 1_000_000,
        "G" => 1_000_000_000,
        "T" => 1_000_000_000_000,
        _ => return None,
    };
    digits.parse::<u64>().ok()?.checked_mul(scale)
}

/// `bytes` for a message: `170 GB`, `2.5 GB`, `750 MB` (decimal units).
pub(crate) fn human(bytes: u64) -> String {
    human_wide(u128::from(bytes))
}

fn human_wide(bytes: u128) -> String {
    let units = [("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)];
    let b = bytes as f64;
    match units.iter().find(|(_, size)| b >= *size) {
        Some((unit, size)) if b / size >= 10.0 => format!("{:.0} {unit}", b / size),
        Some((unit, size)) => format!("{:.1} {unit}", b / size),
        None => format!("{bytes} bytes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_gives_available_or_total_memory() {
        let text = "MemTotal:       24684084 kB\nMemFree:        20600936 kB\nMemAvailable:   24236616 kB\n";
        assert_eq!(meminfo_bytes(text), Some(24236616 * 1024));
        let old = "MemTotal:       1000 kB\nMemFree:        20 kB\n";
        assert_eq!(meminfo_bytes(old), Some(1000 * 1024));
        assert_eq!(meminfo_bytes("nothing"), None);
    }

    #[test]
    fn memory_sizes_parse_in_decimal_units() {
        assert_eq!(parse_bytes("1234"), Some(1234));
        assert_eq!(parse_bytes(" 16G "), Some(16_000_000_000));
        assert_eq!(parse_bytes("512MB"), Some(512_000_000));
        assert_eq!(parse_bytes("2T"), Some(2_000_000_000_000));
        for bad in ["", "G", "1.5G", "-1", "16X", "99999999999T"] {
            assert_eq!(parse_bytes(bad), None, "{bad}");
        }
        assert_eq!(human(33_973_862_400), "34 GB");
        assert_eq!(human(2_500_000_000), "2.5 GB");
        assert_eq!(human(999), "999 bytes");
    }

    /// The request: 1920x1080 at 4096 spp, adaptive, holds 21 bytes a sample.
    #[test]
    fn the_memory_of_a_whole_render_counts_every_sample() {
        let spp = whole_render_bytes([1920, 1080], 4096, Precision::Adaptive, false);
        assert_eq!(
            spp,
            1920 * 1080 * 4096 * 21 + 1920 * 1080 * (21 + COVERAGE_BYTES as u128)
        );
        assert_eq!(
            whole_render_bytes([100_000, 100_000], 1, Precision::F64, true),
            10_000_000_000 * 40
        );
        assert_eq!(sample_bytes(Precision::F32, false), 20);
    }
}
