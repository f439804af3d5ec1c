//! The bake cache on disk: one file per baked light, keyed by a hash of everything that affects
//! the bake, with a header and a checksum. Stale or corrupt files are detected and rebuilt, never
//! trusted; writes are atomic (temporary file in the same directory, fsync, rename).
//!
//! Layout (little-endian): `b"HAIKOBAK"`, format version (u32), reserved (u32), key (u64),
//! payload length (u64), payload checksum (FNV-1a 64, u64), payload.
//!
//! The directory is bounded ([`BakeCache`]): a hit refreshes the file's modification time, and
//! after every write the least recently used files are removed until the directory holds at most
//! the cap ([`DEFAULT_MAX_BYTES`], or `$HAIKO_CACHE_MAX_MB` megabytes). A light that moves in the
//! editor removes the entry of its previous position (docs/DECISIONS.md "Bake cache").

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// File magic.
const MAGIC: &[u8; 8] = b"HAIKOBAK";
/// Bumped whenever the payload layout or the bake's maths change.
pub const FORMAT_VERSION: u32 = 1;
const HEADER_LEN: usize = 8 + 4 + 4 + 8 + 8 + 8;

pub use crate::fsio::Fnv64;
use crate::fsio::{self, FileKind, ReadError};

/// Where cache files live: `$HAIKO_CACHE_DIR`, else `$XDG_CACHE_HOME/haiko`, else
/// `$HOME/.cache/haiko`, else `haiko-cache` in the system temporary directory.
pub fn default_dir() -> PathBuf {
    let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    env("HAIKO_CACHE_DIR")
        .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("haiko")))
        .or_else(|| env("HOME").map(|d| d.join(".cache").join("haiko")))
        .unwrap_or_else(|| std::env::temp_dir().join("haiko-cache"))
}

/// The file for a key inside `dir`.
pub fn file_for(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("{key:016x}.{EXTENSION}"))
}

/// File extension of cache entries.
pub const EXTENSION: &str = "bake";

/// Default cap on the cache directory's size: 1 GiB.
pub const DEFAULT_MAX_BYTES: u64 = 1 << 30;

/// Environment variable overriding the cap, in megabytes (10⁶ bytes).
pub const MAX_MB_ENV: &str = "HAIKO_CACHE_MAX_MB";

/// The cap from [`MAX_MB_ENV`] when it holds a whole number of megabytes, else
/// [`DEFAULT_MAX_BYTES`].
pub fn default_max_bytes() -> u64 {
    std::env::var(MAX_MB_ENV)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .map_or(DEFAULT_MAX_BYTES, |mb| mb.saturating_mul(1_000_000))
}

/// One file of the cache directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CacheEntry {
    /// Its path.
    pub path: PathBuf,
    /// Its size in bytes.
    pub bytes: u64,
    /// When it was last written or used.
    pub used: SystemTime,
}

/// A bounded cache directory: reads refresh an entry's use time, writes evict the least
/// recently used entries beyond `max_bytes`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BakeCache {
    /// The directory (created on the first write).
    pub dir: PathBuf,
    /// The most bytes its entries may hold together.
    pub max_bytes: u64,
}

impl BakeCache {
    /// The user's cache: [`default_dir`] bounded by [`default_max_bytes`].
    pub fn user() -> Self {
        BakeCache {
            dir: default_dir(),
            max_bytes: default_max_bytes(),
        }
    }

    /// A cache in `dir` with the default cap.
    pub fn in_dir(dir: impl Into<PathBuf>) -> Self {
        BakeCache {
            dir: dir.into(),
            max_bytes: default_max_bytes(),
        }
    }

    /// Reads the entry for `key`; a hit refreshes its use time (for the LRU order).
    pub fn read(&self, key: u64) -> CacheLoad {
        let path = file_for(&self.dir, key);
        let load = read(&path, key);
        if matches!(load, CacheLoad::Hit(_))
            && let Ok(file) = fs::File::options().append(true).open(&path)
        {
            let _ = file.set_modified(SystemTime::now());
        }
        load
    }

    /// Writes the entry for `key` atomically, then evicts the least recently used entries
    /// (never this one) until the directory holds at most `max_bytes`.
    pub fn write(&self, key: u64, payload: &[u8]) -> std::io::Result<()> {
        let path = file_for(&self.dir, key);
        write_atomic(&path, key, payload)?;
        self.evict(&path);
        Ok(())
    }

    /// Removes the entry for `key`, if any.
    pub fn remove(&self, key: u64) {
        let _ = fs::remove_file(file_for(&self.dir, key));
    }

    /// The entries, least recently used first (an unreadable directory has none).
    pub fn entries(&self) -> Vec<CacheEntry> {
        let Ok(dir) = fs::read_dir(&self.dir) else {
            return Vec::new();
        };
        let mut entries: Vec<CacheEntry> = dir
            .filter_map(|e| e.ok())
            .filter(|e| e.path().extension().is_some_and(|x| x == EXTENSION))
            .filter_map(|e| {
                let meta = e.metadata().ok().filter(fs::Metadata::is_file)?;
                Some(CacheEntry {
                    path: e.path(),
                    bytes: meta.len(),
                    used: meta.modified().unwrap_or(SystemTime::UNIX_EPOCH),
                })
            })
            .collect();
        entries.sort_by(|a, b| a.used.cmp(&b.used).then_with(|| a.path.cmp(&b.path)));
        entries
    }

    /// Removes every entry; returns how many files and bytes were removed.
    pub fn clear(&self) -> (usize, u64) {
        self.entries()
            .into_iter()
            .filter(|e| fs::remove_file(&e.path).is_ok())
            .fold((0, 0), |(n, bytes), e| (n + 1, bytes + e.bytes))
    }

    fn evict(&self, keep: &Path) {
        let entries = self.entries();
        let mut total: u64 = entries.iter().map(|e| e.bytes).sum();
        for entry in entries {
            if total <= self.max_bytes {
                break;
            }
            if entry.path != keep && fs::remove_file(&entry.path).is_ok() {
                total -= entry.bytes;
            }
        }
    }
}

/// What reading a cache file found.
#[derive(Debug, Clone, PartialEq)]
pub enum CacheLoad {
    /// A valid file for this key: the payload.
    Hit(Vec<u8>),
    /// No file.
    Missing,
    /// A file that is not valid for this key; the reason is a one-line notice.
    Invalid(String),
}

/// Reads and checks a cache file against `key`. The file is read through
/// [`crate::fsio::read_bytes`]: a FIFO or a device with a cache file's name is never opened
/// (docs/DECISIONS.md "Bad input") and is reported invalid, so the bake is redone.
pub fn read(path: &Path, key: u64) -> CacheLoad {
    let data = match fsio::read_bytes(path, FileKind::BakeCache) {
        Ok(d) => d,
        Err(ReadError::NotFound) => return CacheLoad::Missing,
        Err(e) => return CacheLoad::Invalid(e.into_error(path, FileKind::BakeCache).to_string()),
    };
    match check(&data, key) {
        Ok(()) => CacheLoad::Hit(data[HEADER_LEN..].to_vec()),
        Err(why) => CacheLoad::Invalid(format!("{}: {why}", path.display())),
    }
}

/// Why a cache file is not valid for a key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
enum Defect {
    #[error("not a Haiko bake file (truncated header or wrong magic)")]
    NotABakeFile,
    #[error("format version {0}, this Haiko writes {FORMAT_VERSION}")]
    Version(u32),
    #[error("made for different inputs (key mismatch)")]
    Key,
    #[error("payload is {actual} bytes, header says {stated} (truncated?)")]
    Length { actual: u64, stated: u64 },
    #[error("checksum mismatch (corrupted)")]
    Checksum,
}

fn check(data: &[u8], key: u64) -> Result<(), Defect> {
    if data.len() < HEADER_LEN || &data[..8] != MAGIC {
        return Err(Defect::NotABakeFile);
    }
    let u32_at = |o: usize| u32::from_le_bytes(data[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(data[o..o + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if version != FORMAT_VERSION {
        return Err(Defect::Version(version));
    }
    if u64_at(16) != key {
        return Err(Defect::Key);
    }
    let (stated, actual) = (u64_at(24), (data.len() - HEADER_LEN) as u64);
    if stated != actual {
        return Err(Defect::Length { actual, stated });
    }
    if Fnv64::default().bytes(&data[HEADER_LEN..]).finish() != u64_at(32) {
        return Err(Defect::Checksum);
    }
    Ok(())
}

/// Writes a cache file atomically: a temporary file in the same directory, fsync, rename.
pub fn write_atomic(path: &Path, key: u64, payload: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    fs::create_dir_all(dir)?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        path.file_name().and_then(|n| n.to_str()).unwrap_or("bake"),
        std::process::id()
    ));
    let result = (|| {
        // A fresh file, never an existing one (a FIFO under this name would block the open).
        let _ = fs::remove_file(&tmp);
        let mut f = fs::OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        f.write_all(MAGIC)?;
        f.write_all(&FORMAT_VERSION.to_le_bytes())?;
        f.write_all(&0u32.to_le_bytes())?;
        f.write_all(&key.to_le_bytes())?;
        f.write_all(&(payload.len() as u64).to_le_bytes())?;
        f.write_all(&Fnv64::default().bytes(payload).finish().to_le_bytes())?;
        f.write_all(payload)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Appends little-endian values to a payload.
#[derive(Debug, Default)]
pub struct PayloadWriter(pub Vec<u8>);

impl PayloadWriter {
    /// Appends a u64.
    pub fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    /// Appends a length-prefixed f32 slice.
    pub fn f32s(&mut self, v: &[f32]) {
        self.u64(v.len() as u64);
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
    /// Appends a length-prefixed f64 slice.
    pub fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
}

/// Reads what [`PayloadWriter`] wrote; every read checks bounds (a checked file can still be from
/// a buggy writer).
#[derive(Debug)]
pub struct PayloadReader<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> PayloadReader<'a> {
    /// Starts reading `data`.
    pub fn new(data: &'a [u8]) -> Self {
        PayloadReader { data, at: 0 }
    }
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.data.get(self.at..end)?;
        self.at = end;
        Some(s)
    }
    /// Reads a u64.
    pub fn u64(&mut self) -> Option<u64> {
        self.take(8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
    }
    /// Reads a length-prefixed f32 slice.
    pub fn f32s(&mut self) -> Option<Vec<f32>> {
        let n = usize::try_from(self.u64()?).ok()?;
        let bytes = self.take(n.checked_mul(4)?)?;
        Some(
            bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
                .collect(),
        )
    }
    /// Reads a length-prefixed f64 slice.
    pub fn f64s(&mut self) -> Option<Vec<f64>> {
        let n = usize::try_from(self.u64()?).ok()?;
        let bytes = self.take(n.checked_mul(8)?)?;
        Some(
            bytes
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect(),
        )
    }
    /// True when everything was read.
    pub fn is_done(&self) -> bool {
        self.at == self.data.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_every_kind_of_damage_is_caught() {
        let dir = std::env::temp_dir().join(format!("haiko-cache-test-{}", std::process::id()));
        let path = file_for(&dir, 42);
        let mut w = PayloadWriter::default();
        w.f32s(&[1.0, -2.5, 3.25]);
        w.f64s(&[std::f64::consts::PI]);
        write_atomic(&path, 42, &w.0).unwrap();
        let CacheLoad::Hit(payload) = read(&path, 42) else {
            panic!("expected a hit")
        };
        let mut r = PayloadReader::new(&payload);
        assert_eq!(r.f32s().unwrap(), vec![1.0, -2.5, 3.25]);
        assert_eq!(r.f64s().unwrap(), vec![std::f64::consts::PI]);
        assert!(r.is_done());
        assert!(matches!(read(&path, 43), CacheLoad::Invalid(m) if m.contains("key")));
        let good = fs::read(&path).unwrap();
        let mut flipped = good.clone();
        *flipped.last_mut().unwrap() ^= 0x10;
        fs::write(&path, &flipped).unwrap();
        assert!(matches!(read(&path, 42), CacheLoad::Invalid(m) if m.contains("checksum")));
        fs::write(&path, &good[..good.len() - 3]).unwrap();
        assert!(matches!(read(&path, 42), CacheLoad::Invalid(m) if m.contains("truncated")));
        let mut old = good.clone();
        old[8] = 0;
        fs::write(&path, &old).unwrap();
        assert!(matches!(read(&path, 42), CacheLoad::Invalid(m) if m.contains("version")));
        assert_eq!(read(&file_for(&dir, 7), 7), CacheLoad::Missing);
        assert_eq!(
            fs::read_dir(&dir).unwrap().count(),
            1,
            "no temporary files left behind"
        );
        fs::remove_dir_all(&dir).unwrap();
    }

    /// With a cap of two entries' size, a third write evicts the least recently used entry —
    /// the one not read since it was written — and a read refreshes an entry's place.
    #[test]
    fn writes_evict_the_least_recently_used_entries_beyond_the_cap() {
        let dir = std::env::temp_dir().join(format!("haiko-lru-test-{}", std::process::id()));
        let payload = vec![7u8; 1000];
        let entry_bytes = (HEADER_LEN + payload.len()) as u64;
        let cache = BakeCache {
            dir: dir.clone(),
            max_bytes: 2 * entry_bytes,
        };
        let set_used = |key: u64, secs: u64| {
            let file = fs::File::options()
                .append(true)
                .open(file_for(&dir, key))
                .unwrap();
            file.set_modified(SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(secs))
                .unwrap();
        };
        cache.write(1, &payload).unwrap();
        set_used(1, 1000);
        cache.write(2, &payload).unwrap();
        set_used(2, 2000);
        // Reading 1 makes 2 the least recently used.
        assert!(matches!(cache.read(1), CacheLoad::Hit(_)));
        cache.write(3, &payload).unwrap();
        let left: Vec<PathBuf> = cache.entries().into_iter().map(|e| e.path).collect();
        assert_eq!(left.len(), 2, "{left:?}");
        assert!(
            left.contains(&file_for(&dir, 1)) && left.contains(&file_for(&dir, 3)),
            "{left:?}"
        );
        cache.remove(3);
        assert_eq!(cache.entries().len(), 1);
        assert_eq!(cache.clear(), (1, entry_bytes));
        assert!(cache.entries().is_empty());
        fs::remove_dir_all(&dir).unwrap();
    }
}
