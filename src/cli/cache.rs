//! `haiko cache [list|clear]`: where the bake cache lives, what it holds, and emptying it.

use crate::error::Result;
use crate::transport::cache::{BakeCache, MAX_MB_ENV};

/// Prints the cache directory, its cap, and each entry (size, last use), least recently used
/// first.
pub(crate) fn run_list() -> Result<()> {
    let cache = BakeCache::user();
    let entries = cache.entries();
    let total: u64 = entries.iter().map(|e| e.bytes).sum();
    println!(
        "bake cache {}: {} entries, {:.2} MB of at most {:.0} MB (${MAX_MB_ENV} to change)",
        cache.dir.display(),
        entries.len(),
        total as f64 / 1e6,
        cache.max_bytes as f64 / 1e6
    );
    let now = std::time::SystemTime::now();
    for entry in &entries {
        let age = now.duration_since(entry.used).map_or(0, |d| d.as_secs());
        println!(
            "{:>10.2} MB  used {:>6} s ago  {}",
            entry.bytes as f64 / 1e6,
            age,
            entry.path.display()
        );
    }
    Ok(())
}

/// Removes every entry and says how many and how much.
pub(crate) fn run_clear() -> Result<()> {
    let cache = BakeCache::user();
    let (files, bytes) = cache.clear();
    println!(
        "bake cache {}: removed {files} entries, {:.2} MB",
        cache.dir.display(),
        bytes as f64 / 1e6
    );
    Ok(())
}
