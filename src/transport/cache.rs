//! The bake cache on disk: one file per baked light, per hierarchical engine's operator and per
//! light solved on such an engine (docs/DECISIONS.md "Bake cache"), keyed by a hash of
//! everything that affects what it holds, with a header and a checksum. Stale or corrupt files
//! are detected and rebuilt, never trusted; writes are atomic (temporary file in the same
//! directory, fsync, rename).
//!
//! Layout (little-endian): `b"HAIKOBAK"`, format version (u32), reserved (u32), key (u64),
//! payload length (u64), payload checksum (FNV-1a 64, u64), payload.
//!
//! The directory is bounded ([`BakeCache`]): a hit refreshes the file's modification time, and
//! after every write the least recently used files are removed until the directory holds at most
//! the cap ([`DEFAULT_MAX_BYTES`], or `$HAIKO_CACHE_MAX_MB` megabytes). A light that moves in the
//! editor removes the entry of its previous position (docs/DECISIONS.md "Bake cache").

use std::fs;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// File magic.
const MAGIC: &[u8; 8] = b"HAIKOBAK";
/// Bumped whenever the payload layout or the bake's maths change (2: shadow rays meet a mesh's
/// triangles along their shared edges, docs/DECISIONS.md "Shadow rays through a mesh's edges").
pub const FORMAT_VERSION: u32 = 2;
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

    /// Reads the entry for `key` with `decode`, which reads its values in the order they were
    /// written and returns `None` when they do not make sense. The entry is a hit only if its
    /// checksum holds and `decode` read it to the end; a hit refreshes its use time (for the LRU
    /// order).
    pub fn read_with<T>(&self, key: u64, decode: impl FnOnce(&mut EntryReader) -> Option<T>) -> CacheLoad<T> {
        let path = file_for(&self.dir, key);
        let mut reader = match EntryReader::open(&path, key) {
            Ok(r) => r,
            Err(None) => return CacheLoad::Missing,
            Err(Some(why)) => return CacheLoad::Invalid(why),
        };
        let value = decode(&mut reader);
        let fully_read = reader.remaining == 0;
        if let Err(defect) = reader.finish() {
            return CacheLoad::Invalid(format!("{}: {defect}", path.display()));
        }
        match value.filter(|_| fully_read) {
            Some(value) => {
                if let Ok(file) = fs::File::options().append(true).open(&path) {
                    let _ = file.set_modified(SystemTime::now());
                }
                CacheLoad::Hit(value)
            }
            None => CacheLoad::Invalid(format!(
                "{}: its payload does not fit what it is for",
                path.display()
            )),
        }
    }

    /// Writes the entry for `key` atomically with `encode`, then evicts the least recently used
    /// entries (never this one) until the directory holds at most `max_bytes`. The values are
    /// streamed to the file as they come (an entry may be hundreds of MB).
    pub fn write_with(&self, key: u64, encode: impl FnOnce(&mut EntryWriter)) -> std::io::Result<()> {
        let path = file_for(&self.dir, key);
        let mut writer = EntryWriter::create(&path, key)?;
        encode(&mut writer);
        writer.finish()?;
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

/// What reading a cache entry found.
#[derive(Debug, Clone, PartialEq)]
pub enum CacheLoad<T> {
    /// A valid entry for this key: what was decoded from it.
    Hit(T),
    /// No file.
    Missing,
    /// A file that is not valid for this key; the reason is a one-line notice.
    Invalid(String),
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

/// Little-endian values written into a cache entry. A slice is its length (u64), then its
/// elements.
pub trait ValueSink {
    /// Appends raw bytes.
    fn put(&mut self, bytes: &[u8]);
    /// Appends a u64.
    fn u64(&mut self, v: u64) {
        self.put(&v.to_le_bytes());
    }
    /// Appends a length-prefixed u32 slice.
    fn u32s(&mut self, v: &[u32]) {
        put_slice(self, v, u32::to_le_bytes);
    }
    /// Appends a length-prefixed f32 slice.
    fn f32s(&mut self, v: &[f32]) {
        put_slice(self, v, f32::to_le_bytes);
    }
    /// Appends a length-prefixed f64 slice.
    fn f64s(&mut self, v: &[f64]) {
        put_slice(self, v, f64::to_le_bytes);
    }
}

/// Bytes converted per [`ValueSink::put`] / [`ValueSource::fill`] call.
const CHUNK_BYTES: usize = 1 << 16;

fn put_slice<S: ValueSink + ?Sized, T: Copy, const N: usize>(sink: &mut S, v: &[T], bytes: fn(T) -> [u8; N]) {
    sink.u64(v.len() as u64);
    let mut buf = vec![0u8; CHUNK_BYTES];
    for chunk in v.chunks(CHUNK_BYTES / N) {
        for (out, &x) in buf.chunks_exact_mut(N).zip(chunk) {
            out.copy_from_slice(&bytes(x));
        }
        sink.put(&buf[..chunk.len() * N]);
    }
}

/// Reads what a [`ValueSink`] wrote. Every read checks that the entry holds that many bytes
/// before it allocates (a checked entry can still be from a buggy writer).
pub trait ValueSource {
    /// Fills `buf` with the next bytes; `None` when fewer are left or the read fails.
    fn fill(&mut self, buf: &mut [u8]) -> Option<()>;
    /// Bytes left to read.
    fn remaining(&self) -> u64;
    /// Reads a u64.
    fn u64(&mut self) -> Option<u64> {
        let mut b = [0u8; 8];
        self.fill(&mut b)?;
        Some(u64::from_le_bytes(b))
    }
    /// Reads a length-prefixed u32 slice.
    fn u32s(&mut self) -> Option<Vec<u32>> {
        take_slice(self, u32::from_le_bytes)
    }
    /// Reads a length-prefixed f32 slice.
    fn f32s(&mut self) -> Option<Vec<f32>> {
        take_slice(self, f32::from_le_bytes)
    }
    /// Reads a length-prefixed f64 slice.
    fn f64s(&mut self) -> Option<Vec<f64>> {
        take_slice(self, f64::from_le_bytes)
    }
}

fn take_slice<S: ValueSource + ?Sized, T, const N: usize>(
    source: &mut S,
    from: fn([u8; N]) -> T,
) -> Option<Vec<T>> {
    let n = source.u64()?;
    if n.checked_mul(N as u64)? > source.remaining() {
        return None;
    }
    let n = usize::try_from(n).ok()?;
    let mut out = Vec::with_capacity(n);
    let mut buf = vec![0u8; CHUNK_BYTES];
    while out.len() < n {
        let m = (n - out.len()).min(CHUNK_BYTES / N);
        source.fill(&mut buf[..m * N])?;
        out.extend(
            buf[..m * N]
                .chunks_exact(N)
                .map(|c| from(c.try_into().expect("N bytes"))),
        );
    }
    Some(out)
}

/// An entry's values in memory, for tests of what encoders write.
#[cfg(test)]
impl ValueSink for Vec<u8> {
    fn put(&mut self, bytes: &[u8]) {
        self.extend_from_slice(bytes);
    }
}

#[cfg(test)]
impl ValueSource for &[u8] {
    fn fill(&mut self, buf: &mut [u8]) -> Option<()> {
        let (head, rest) = self.split_at_checked(buf.len())?;
        buf.copy_from_slice(head);
        *self = rest;
        Some(())
    }

    fn remaining(&self) -> u64 {
        self.len() as u64
    }
}

/// A cache entry being written: the values go to a temporary file in the same directory as
/// they come, with their checksum; [`Self::finish`] writes the header's length and checksum,
/// syncs and renames the file into place. Dropped unfinished, it removes the temporary file.
#[derive(Debug)]
pub struct EntryWriter {
    file: Option<BufWriter<fs::File>>,
    tmp: PathBuf,
    path: PathBuf,
    hash: Fnv64,
    len: u64,
    /// The first write error; later writes are skipped and [`Self::finish`] returns it.
    error: Option<std::io::Error>,
}

impl EntryWriter {
    /// Starts the entry for `key` at `path` (creating its directory).
    fn create(path: &Path, key: u64) -> std::io::Result<Self> {
        let dir = path.parent().unwrap_or(Path::new("."));
        fs::create_dir_all(dir)?;
        let tmp = dir.join(format!(
            ".{}.tmp{}",
            path.file_name().and_then(|n| n.to_str()).unwrap_or("bake"),
            std::process::id()
        ));
        // A fresh file, never an existing one (a FIFO under this name would block the open).
        let _ = fs::remove_file(&tmp);
        let file = fs::OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        let mut writer = EntryWriter {
            file: Some(BufWriter::with_capacity(CHUNK_BYTES, file)),
            tmp,
            path: path.to_path_buf(),
            hash: Fnv64::default(),
            len: 0,
            error: None,
        };
        let mut header = Vec::with_capacity(HEADER_LEN);
        header.extend_from_slice(MAGIC);
        header.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        header.extend_from_slice(&0u32.to_le_bytes());
        header.extend_from_slice(&key.to_le_bytes());
        // Length and checksum, written by `finish`.
        header.extend_from_slice(&[0u8; 16]);
        writer.raw(&header);
        match writer.error.take() {
            Some(e) => Err(e),
            None => Ok(writer),
        }
    }

    fn raw(&mut self, bytes: &[u8]) {
        if self.error.is_none()
            && let Some(file) = self.file.as_mut()
            && let Err(e) = file.write_all(bytes)
        {
            self.error = Some(e);
        }
    }

    /// Puts the entry in place: length and checksum into the header, fsync, rename.
    fn finish(mut self) -> std::io::Result<()> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        let file = self.file.take().expect("an unfinished entry has its file");
        let mut file = file.into_inner().map_err(|e| e.into_error())?;
        file.seek(SeekFrom::Start((HEADER_LEN - 16) as u64))?;
        file.write_all(&self.len.to_le_bytes())?;
        file.write_all(&self.hash.finish().to_le_bytes())?;
        file.sync_all()?;
        fs::rename(&self.tmp, &self.path)?;
        // Renamed: nothing left for `drop` to remove.
        self.tmp = PathBuf::new();
        Ok(())
    }
}

impl ValueSink for EntryWriter {
    fn put(&mut self, bytes: &[u8]) {
        self.hash.bytes(bytes);
        self.len += bytes.len() as u64;
        self.raw(bytes);
    }
}

impl Drop for EntryWriter {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            self.file = None;
            let _ = fs::remove_file(&self.tmp);
        }
    }
}

/// A cache entry being read: its header checked against the key and the file's length, its
/// values read as they are asked for, and its checksum checked at [`Self::finish`].
#[derive(Debug)]
pub struct EntryReader {
    file: BufReader<fs::File>,
    hash: Fnv64,
    checksum: u64,
    remaining: u64,
}

impl EntryReader {
    /// Opens the entry at `path` for `key`. The file is opened through
    /// [`crate::fsio::open_regular`]: a FIFO or a device with a cache file's name is never
    /// opened (docs/DECISIONS.md "Bad input"). `Err(None)`: no file; `Err(Some(why))`: a file
    /// that is not valid for this key, with a one-line notice.
    fn open(path: &Path, key: u64) -> Result<Self, Option<String>> {
        let (file, len) = match fsio::open_regular(path, FileKind::BakeCache) {
            Ok(f) => f,
            Err(ReadError::NotFound) => return Err(None),
            Err(e) => return Err(Some(e.into_error(path, FileKind::BakeCache).to_string())),
        };
        let invalid = |d: Defect| Some(format!("{}: {d}", path.display()));
        let mut file = BufReader::with_capacity(CHUNK_BYTES, file);
        let mut header = [0u8; HEADER_LEN];
        if file.read_exact(&mut header).is_err() || &header[..8] != MAGIC {
            return Err(invalid(Defect::NotABakeFile));
        }
        let u32_at = |o: usize| u32::from_le_bytes(header[o..o + 4].try_into().expect("4 bytes"));
        let u64_at = |o: usize| u64::from_le_bytes(header[o..o + 8].try_into().expect("8 bytes"));
        let version = u32_at(8);
        if version != FORMAT_VERSION {
            return Err(invalid(Defect::Version(version)));
        }
        if u64_at(16) != key {
            return Err(invalid(Defect::Key));
        }
        let (stated, actual) = (u64_at(24), len - HEADER_LEN as u64);
        if stated != actual {
            return Err(invalid(Defect::Length { actual, stated }));
        }
        Ok(EntryReader {
            file,
            hash: Fnv64::default(),
            checksum: u64_at(32),
            remaining: stated,
        })
    }

    /// Reads what is left (into the checksum) and checks the checksum.
    fn finish(mut self) -> Result<(), Defect> {
        let mut buf = vec![0u8; CHUNK_BYTES];
        while self.remaining > 0 {
            let n = (self.remaining as usize).min(buf.len());
            self.fill(&mut buf[..n]).ok_or(Defect::Checksum)?;
        }
        if self.hash.finish() == self.checksum {
            Ok(())
        } else {
            Err(Defect::Checksum)
        }
    }
}

impl ValueSource for EntryReader {
    fn fill(&mut self, buf: &mut [u8]) -> Option<()> {
        if buf.len() as u64 > self.remaining || self.file.read_exact(buf).is_err() {
            return None;
        }
        self.remaining -= buf.len() as u64;
        self.hash.bytes(buf);
        Some(())
    }

    fn remaining(&self) -> u64 {
        self.remaining
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads three slices back.
    fn decode(r: &mut EntryReader) -> Option<(Vec<f32>, Vec<f64>, Vec<u32>)> {
        Some((r.f32s()?, r.f64s()?, r.u32s()?))
    }

    #[test]
    fn round_trip_and_every_kind_of_damage_is_caught() {
        let dir = std::env::temp_dir().join(format!("haiko-cache-test-{}", std::process::id()));
        let cache = BakeCache::in_dir(&dir);
        let path = file_for(&dir, 42);
        // More than one chunk of u32s, so the chunked copies are exercised.
        let ints: Vec<u32> = (0..40_000u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
        let write = |cache: &BakeCache| {
            cache
                .write_with(42, |w| {
                    w.f32s(&[1.0, -2.5, 3.25]);
                    w.f64s(&[std::f64::consts::PI]);
                    w.u32s(&ints);
                })
                .unwrap()
        };
        write(&cache);
        let CacheLoad::Hit((f, d, u)) = cache.read_with(42, decode) else {
            panic!("expected a hit")
        };
        assert_eq!((f, d), (vec![1.0, -2.5, 3.25], vec![std::f64::consts::PI]));
        assert_eq!(u, ints);
        fn invalid<T>(load: CacheLoad<T>, what: &str) -> bool {
            matches!(load, CacheLoad::Invalid(m) if m.contains(what))
        }
        // Read with a wrong key, or not to its end, or past its end.
        let keyed = fs::read(&path).unwrap();
        fs::copy(&path, file_for(&dir, 43)).unwrap();
        assert!(invalid(cache.read_with(43, decode), "key"));
        fs::remove_file(file_for(&dir, 43)).unwrap();
        assert!(invalid(cache.read_with(42, |r| r.f32s()), "does not fit"));
        assert!(invalid(
            cache.read_with(42, |r| {
                decode(r)?;
                r.u64()
            }),
            "does not fit"
        ));
        let good = fs::read(&path).unwrap();
        assert_eq!(good, keyed, "a failed read leaves the entry as it was");
        let mut flipped = good.clone();
        *flipped.last_mut().unwrap() ^= 0x10;
        fs::write(&path, &flipped).unwrap();
        assert!(invalid(cache.read_with(42, decode), "checksum"));
        // A flipped length prefix must not allocate what the file cannot hold.
        let mut huge = good.clone();
        huge[HEADER_LEN + 7] = 0x7f;
        fs::write(&path, &huge).unwrap();
        assert!(invalid(cache.read_with(42, decode), "checksum"));
        fs::write(&path, &good[..good.len() - 3]).unwrap();
        assert!(invalid(cache.read_with(42, decode), "truncated"));
        let mut old = good.clone();
        old[8] = 0;
        fs::write(&path, &old).unwrap();
        assert!(invalid(cache.read_with(42, decode), "version"));
        fs::write(&path, b"HAIKO").unwrap();
        assert!(invalid(cache.read_with(42, decode), "not a Haiko bake file"));
        assert_eq!(cache.read_with(7, decode), CacheLoad::Missing);
        // An entry whose writing stops (an error in its encoder's caller) leaves nothing behind.
        let path_9 = file_for(&dir, 9);
        let unfinished = EntryWriter::create(&path_9, 9).unwrap();
        drop(unfinished);
        assert!(!path_9.exists());
        write(&cache);
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
        let write = |key: u64| cache.write_with(key, |w| w.put(&payload)).unwrap();
        let read = |key: u64| {
            cache.read_with(key, |r| {
                let mut back = vec![0u8; payload.len()];
                r.fill(&mut back)
            })
        };
        write(1);
        set_used(1, 1000);
        write(2);
        set_used(2, 2000);
        // Reading 1 makes 2 the least recently used.
        assert!(matches!(read(1), CacheLoad::Hit(_)));
        write(3);
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
