//! The resource budget (docs/DECISIONS.md "Resource budget"): the memory a session will need,
//! estimated from the plan before anything large is allocated, checked against a limit — by
//! default half of the memory this process can get, else `--max-memory`. A refusal is bad input
//! (exit code 2) naming the estimate, its parts and the setting to change.
//!
//! What the machine gives is the least of: `MemAvailable` in `/proc/meminfo` (or `MemTotal`),
//! the cgroup's `memory.max`, and the process's address-space limit (`ulimit -v`, from
//! `/proc/self/limits`); [`FALLBACK_BYTES`] when none can be read.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::transport::indirect::DIRECT_CACHE_BUDGET_BYTES;
use crate::transport::plan::{Plan, PlanOptions, plan};

/// The share of the memory available to the process that a session may plan to use.
pub const DEFAULT_SHARE: f64 = 0.5;

/// The memory assumed available when the system says nothing (no `/proc`): 8 GiB, so the
/// default limit is 4 GiB.
pub const FALLBACK_BYTES: u64 = 8 << 30;

/// Relight state per fine vertex and light, bytes: the direct cache (unit direction 24 B and
/// factor 8 B), the light's direct lux (8 B) and its RGB contribution (24 B).
const RELIGHT_BYTES_PER_VERTEX_AND_LIGHT: u64 = 64;

/// Relight state per fine vertex for all lights together, bytes: the RGB total (24 B) and at
/// most four coarse → fine interpolation terms (16 B each).
const RELIGHT_BYTES_PER_VERTEX: u64 = 88;

/// Per leaf of the hierarchical engine: its node geometry and neighbours (about 450 B measured on
/// the open-plan floor and in small rooms; docs/DECISIONS.md "Resource budget").
const ENGINE_BYTES_PER_LEAF: u64 = 512;

/// Per leaf and light of the hierarchical engine: the light's direct-light sample cache (up to
/// 4.3 kB per leaf measured in a small room with a lamp near the ceiling), all lights' caches
/// together held within [`DIRECT_CACHE_BUDGET_BYTES`].
const DIRECT_CACHE_BYTES_PER_LEAF_AND_LIGHT: u64 = 4608;

/// Per leaf and light of the hierarchical engine: its radiosity and indirect light (f32, up to
/// three channels each).
const SOLVE_BYTES_PER_LEAF_AND_LIGHT: u64 = 24;

/// The most memory a link takes while the links are built: 28 B in its task's list and 16 B for
/// its two directed entries in the operator, both held while the operator is made, and slack.
/// Measured: 43.6 B per link at the peak for 28.7 M links, 45 B for 19.2 M and for 5.3 M
/// (docs/BENCHMARKS.md "Links within the memory limit").
pub const LINK_PEAK_BYTES: u64 = 48;

/// Which engine an [`Estimate`] is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EngineKind {
    /// Direct light only: nothing is baked.
    None,
    /// The SH basis bake on the dense form factors.
    Basis,
    /// The hierarchical engine: its links are counted against the limit while they are made.
    Hierarchical,
}

/// What a session on a planned scene needs: memory in bytes, and visibility rays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Estimate {
    /// The engine the parts are for.
    pub engine: EngineKind,
    /// The dense form-factor matrix (f32); 0 unless the SH basis is baked.
    pub form_factor_bytes: u64,
    /// The stored basis (f32 direct and indirect per coarse patch and column); 0 unless the SH
    /// basis is baked.
    pub basis_bytes: u64,
    /// The hierarchical engine without its links: per leaf its geometry, per leaf and light its
    /// direct-light cache (within [`DIRECT_CACHE_BUDGET_BYTES`]) and solved values; 0 for the
    /// other engines.
    pub engine_bytes: u64,
    /// Relight state per fine vertex.
    pub relight_bytes: u64,
    /// Visibility rays cast for the dense form factors (an upper bound; the hierarchical
    /// engine's are counted as its links are made).
    pub rays: u64,
}

impl Estimate {
    /// The estimate for `plan`; `indirect` false for direct light only (no bake).
    pub fn of(plan: &Plan, indirect: bool) -> Self {
        let lights = plan.lights.len() as u64;
        let per_vertex = RELIGHT_BYTES_PER_VERTEX_AND_LIGHT * lights + RELIGHT_BYTES_PER_VERTEX;
        let engine = if !indirect || !plan.interreflection.on {
            EngineKind::None
        } else if plan.hierarchical.on {
            EngineKind::Hierarchical
        } else {
            EngineKind::Basis
        };
        let basis = engine == EngineKind::Basis;
        let leaves = plan.leaves as u64;
        let engine_bytes = if engine == EngineKind::Hierarchical {
            let caches = (leaves * lights * DIRECT_CACHE_BYTES_PER_LEAF_AND_LIGHT)
                .min(DIRECT_CACHE_BUDGET_BYTES as u64);
            leaves * ENGINE_BYTES_PER_LEAF + caches + leaves * lights * SOLVE_BYTES_PER_LEAF_AND_LIGHT
        } else {
            0
        };
        Estimate {
            engine,
            form_factor_bytes: if basis { plan.form_factor_bytes as u64 } else { 0 },
            basis_bytes: if basis { plan.basis_bytes as u64 } else { 0 },
            engine_bytes,
            relight_bytes: per_vertex.saturating_mul(plan.fine_vertices as u64),
            rays: if basis { plan.form_factor_rays as u64 } else { 0 },
        }
    }

    /// All the memory, bytes, without the hierarchical engine's links.
    pub fn bytes(&self) -> u64 {
        self.form_factor_bytes
            .saturating_add(self.basis_bytes)
            .saturating_add(self.engine_bytes)
            .saturating_add(self.relight_bytes)
    }

    /// The most links the hierarchical engine may make within `limit`: what the other parts
    /// leave, at [`LINK_PEAK_BYTES`] each.
    pub fn max_links(&self, limit: &MemoryLimit) -> usize {
        let left = limit.bytes.saturating_sub(self.bytes()) / LINK_PEAK_BYTES;
        usize::try_from(left).unwrap_or(usize::MAX)
    }
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.engine {
            EngineKind::Hierarchical => write!(
                f,
                "about {} of memory before the links (engine {}, relight {}) and {LINK_PEAK_BYTES} B \
                 per link while they are made",
                Bytes(self.bytes()),
                Bytes(self.engine_bytes),
                Bytes(self.relight_bytes),
            ),
            EngineKind::Basis | EngineKind::None => {
                write!(
                    f,
                    "about {} of memory (form factors {}, basis {}, relight {}; ",
                    Bytes(self.bytes()),
                    Bytes(self.form_factor_bytes),
                    Bytes(self.basis_bytes),
                    Bytes(self.relight_bytes),
                )?;
                match self.rays {
                    0 => write!(f, "no visibility rays)"),
                    rays => write!(f, "{:.1e} visibility rays)", rays as f64),
                }
            }
        }
    }
}

/// Plans `scene` and checks the estimate against `limit` (before any bake allocates);
/// `indirect` false for direct light only. Returns the estimate.
///
/// Errors: the estimate above the limit (bad input naming the room file).
pub fn check_scene(
    scene: &Scene,
    options: PlanOptions,
    indirect: bool,
    limit: &MemoryLimit,
) -> Result<Estimate> {
    let estimate = Estimate::of(&plan(scene, options), indirect);
    limit.check(&scene.path, &estimate)?;
    Ok(estimate)
}

/// Where a [`MemoryLimit`] came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitSource {
    /// `--max-memory`.
    Option,
    /// [`DEFAULT_SHARE`] of what the machine gives the process.
    Machine,
}

/// The most memory a session may plan to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryLimit {
    /// Bytes.
    pub bytes: u64,
    /// Where the number came from.
    pub source: LimitSource,
}

impl MemoryLimit {
    /// `--max-memory` when given, else [`MemoryLimit::machine_default`].
    pub fn from_option(max_memory: Option<MemorySize>) -> Self {
        match max_memory {
            Some(MemorySize(bytes)) => MemoryLimit {
                bytes,
                source: LimitSource::Option,
            },
            None => MemoryLimit::machine_default(),
        }
    }

    /// [`DEFAULT_SHARE`] of [`available_memory`] (or of [`FALLBACK_BYTES`]).
    pub fn machine_default() -> Self {
        let available = available_memory().unwrap_or(FALLBACK_BYTES);
        MemoryLimit {
            bytes: (available as f64 * DEFAULT_SHARE) as u64,
            source: LimitSource::Machine,
        }
    }

    /// Refuses `estimate` above the limit: bad input naming `room`, the estimate, the limit and
    /// what to change (exit code 2).
    pub fn check(&self, room: &Path, estimate: &Estimate) -> Result<()> {
        if estimate.bytes() <= self.bytes {
            return Ok(());
        }
        Err(Error::input(
            room,
            "",
            format!(
                "needs {estimate}, more than the limit of {self}: raise `settings.solver_patch_size` \
                 (and `patch_size`), or give a larger `--max-memory`"
            ),
        ))
    }
}

impl fmt::Display for MemoryLimit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.source {
            LimitSource::Option => write!(f, "{} (--max-memory)", Bytes(self.bytes)),
            LimitSource::Machine => write!(
                f,
                "{} (half the memory available to Haiko; --max-memory sets another)",
                Bytes(self.bytes)
            ),
        }
    }
}

/// Bytes shown in decimal units with three significant figures: `12.7 GB`, `512 kB`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bytes(pub u64);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.0 as f64;
        let (value, unit) = [(1e12, "TB"), (1e9, "GB"), (1e6, "MB"), (1e3, "kB")]
            .into_iter()
            .find(|&(scale, _)| b >= scale)
            .map_or((b, "B"), |(scale, unit)| (b / scale, unit));
        if unit == "B" {
            write!(f, "{} B", self.0)
        } else if value >= 100.0 {
            write!(f, "{value:.0} {unit}")
        } else if value >= 10.0 {
            write!(f, "{value:.1} {unit}")
        } else {
            write!(f, "{value:.2} {unit}")
        }
    }
}

/// A `--max-memory` value in bytes: a whole or decimal number with an optional binary unit
/// `K`, `M`, `G`, `T` (also written `KiB`, `MB`, … — all powers of 1024): `512M`, `8G`, `1.5GiB`,
/// `1000000` (bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemorySize(pub u64);

/// A `--max-memory` value that is not a size.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a memory size (a positive number with an optional unit K, M, G or T: `8G`, `512M`)")]
pub struct MemorySizeSyntax(String);

impl FromStr for MemorySize {
    type Err = MemorySizeSyntax;

    fn from_str(text: &str) -> std::result::Result<Self, Self::Err> {
        let bad = || MemorySizeSyntax(crate::error::quoted(text).trim_matches('`').to_string());
        let trimmed = text.trim();
        let split = trimmed
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(trimmed.len());
        let (number, unit) = trimmed.split_at(split);
        let number: f64 = number.parse().map_err(|_| bad())?;
        let unit = unit.trim().to_ascii_uppercase();
        let unit = unit
            .strip_suffix("IB")
            .or_else(|| unit.strip_suffix('B'))
            .unwrap_or(&unit);
        let scale: u64 = match unit {
            "" => 1,
            "K" => 1 << 10,
            "M" => 1 << 20,
            "G" => 1 << 30,
            "T" => 1 << 40,
            _ => return Err(bad()),
        };
        let bytes = number * scale as f64;
        // Below 2^63 bytes (8 EiB), so the cast is exact enough and never saturates.
        if !(1.0..9.2e18).contains(&bytes) {
            return Err(bad());
        }
        Ok(MemorySize(bytes as u64))
    }
}

/// The memory this process can get, bytes: the least of what `/proc/meminfo`, the cgroup and
/// the address-space limit say (module docs); `None` when none can be read.
pub fn available_memory() -> Option<u64> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    [
        read("/proc/meminfo").as_deref().and_then(meminfo_available),
        read("/sys/fs/cgroup/memory.max").as_deref().and_then(cgroup_max),
        read("/proc/self/limits").as_deref().and_then(address_space_limit),
    ]
    .into_iter()
    .flatten()
    .min()
}

/// `MemAvailable` (else `MemTotal`) of a `/proc/meminfo` text, bytes.
fn meminfo_available(text: &str) -> Option<u64> {
    let field = |name: &str| {
        text.lines().find_map(|line| {
            let rest = line.strip_prefix(name)?.strip_prefix(':')?;
            let kib: u64 = rest.trim().strip_suffix("kB")?.trim().parse().ok()?;
            kib.checked_mul(1024)
        })
    };
    field("MemAvailable").or_else(|| field("MemTotal"))
}

/// A cgroup v2 `memory.max` (`max` means none), bytes.
fn cgroup_max(text: &str) -> Option<u64> {
    text.trim().parse().ok()
}

/// The soft `Max address space` of a `/proc/self/limits` text (`unlimited` means none), bytes.
fn address_space_limit(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_units() {
        let size = |t: &str| t.parse::<MemorySize>().map(|s| s.0);
        assert_eq!(size("512M"), Ok(512 << 20));
        assert_eq!(size("8G"), Ok(8 << 30));
        assert_eq!(size("8gib"), Ok(8 << 30));
        assert_eq!(size("1.5GB"), Ok(3 << 29));
        assert_eq!(size("1000000"), Ok(1_000_000));
        assert_eq!(size("2T"), Ok(2 << 40));
        for bad in ["", "G", "-1G", "0", "1X", "1e3", "nan", "99999999999T"] {
            assert!(size(bad).is_err(), "{bad}");
        }
        assert_eq!(
            size("12Q").unwrap_err().to_string(),
            "`12Q` is not a memory size (a positive number with an optional unit K, M, G or T: `8G`, `512M`)"
        );
    }

    #[test]
    fn the_machine_says_what_is_available() {
        let meminfo =
            "MemTotal:       24683584 kB\nMemFree:         9324000 kB\nMemAvailable:   22618376 kB\n";
        assert_eq!(meminfo_available(meminfo), Some(22_618_376 * 1024));
        assert_eq!(meminfo_available("MemTotal:  1000 kB\n"), Some(1_024_000));
        assert_eq!(meminfo_available("nothing"), None);
        assert_eq!(cgroup_max("max\n"), None);
        assert_eq!(cgroup_max("4294967296\n"), Some(4 << 30));
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max address space         4294967296           unlimited            bytes\n";
        assert_eq!(address_space_limit(limits), Some(4 << 30));
        assert_eq!(
            address_space_limit(&limits.replace("4294967296", "unlimited")),
            None
        );
        // On this machine something is readable, and the default is half of it.
        if let Some(bytes) = available_memory() {
            assert_eq!(MemoryLimit::machine_default().bytes, (bytes as f64 * 0.5) as u64);
        }
    }

    #[test]
    fn estimates_above_the_limit_are_refused_naming_both() {
        let estimate = Estimate {
            engine: EngineKind::Basis,
            form_factor_bytes: 11_300_000_000,
            basis_bytes: 200_000_000,
            engine_bytes: 0,
            relight_bytes: 1_200_000_000,
            rays: 45_000_000_000,
        };
        assert_eq!(estimate.bytes(), 12_700_000_000);
        let limit = MemoryLimit {
            bytes: 4 << 30,
            source: LimitSource::Option,
        };
        let e = limit.check(Path::new("hall.toml"), &estimate).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert_eq!(
            e.to_string(),
            "hall.toml: needs about 12.7 GB of memory (form factors 11.3 GB, basis 200 MB, relight \
             1.20 GB; 4.5e10 visibility rays), more than the limit of 4.29 GB (--max-memory): raise \
             `settings.solver_patch_size` (and `patch_size`), or give a larger `--max-memory`"
        );
        let enough = MemoryLimit {
            bytes: 12_700_000_000,
            source: LimitSource::Machine,
        };
        assert!(enough.check(Path::new("hall.toml"), &estimate).is_ok());
        assert_eq!(Bytes(999).to_string(), "999 B");
        assert_eq!(Bytes(1_500).to_string(), "1.50 kB");
    }
}
