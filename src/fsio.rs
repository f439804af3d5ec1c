//! File access policy (docs/DECISIONS.md, "Files"): how Haiko reads the files a user names and
//! writes its outputs. Every read of a user file goes through [`read`] / [`read_text`]; every
//! output goes through [`write_atomic`].
//!
//! * **Only regular files are read**, each kind up to a documented size ([`FileKind::max_bytes`]).
//!   The type is checked twice: `stat` before opening (so a device is never opened), then
//!   `fstat` on the opened handle (so a file swapped for a FIFO in between is caught). The open
//!   uses `O_NONBLOCK`, so even that race cannot block on a FIFO; for regular files the flag
//!   changes nothing. The read itself stops one byte past the limit, for files that grow or
//!   report no size (`/proc`).
//! * **Outputs are replaced atomically**: a temporary file in the target's directory, written,
//!   flushed to disk (fsync), given the old file's permissions, then renamed over the target; a
//!   failed write removes the temporary file and keeps the old one. A symlink is written through
//!   to its target. Only regular files (or new names) are written.
//! * [`check_not_an_input`] refuses an output that is the same file (device and inode, through
//!   symlinks and hard links) as one of the command's inputs: every file this process read
//!   through [`read_bytes`] (the room, its photometric, OBJ and MTL files, a points file) is
//!   noted for it.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, SystemTime};

use crate::error::{Error, Result};

/// What a file is for; decides its size limit and how it is named in messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// A room file (TOML).
    Room,
    /// An IES LM-63 photometric file.
    Ies,
    /// A EULUMDAT photometric file.
    Ldt,
    /// A Wavefront OBJ mesh.
    Obj,
    /// An OBJ material library.
    Mtl,
    /// A `probe` points file (CSV).
    Points,
    /// A bake cache file (written by Haiko itself).
    BakeCache,
}

const MIB: u64 = 1 << 20;

impl FileKind {
    /// The largest file of this kind Haiko reads, in bytes: a room file 16 MiB, IES and LDT
    /// files 16 MiB each (real ones are below 1 MiB), an OBJ 256 MiB, an MTL 16 MiB, a points
    /// file 64 MiB (a million rows), a bake cache file 4 GiB.
    pub const fn max_bytes(self) -> u64 {
        match self {
            FileKind::Room | FileKind::Ies | FileKind::Ldt | FileKind::Mtl => 16 * MIB,
            FileKind::Obj => 256 * MIB,
            FileKind::Points => 64 * MIB,
            FileKind::BakeCache => 4096 * MIB,
        }
    }

    /// The kind in words, for messages.
    pub(crate) const fn describe(self) -> &'static str {
        match self {
            FileKind::Room => "a room file",
            FileKind::Ies => "an IES file",
            FileKind::Ldt => "a EULUMDAT file",
            FileKind::Obj => "an OBJ file",
            FileKind::Mtl => "an MTL file",
            FileKind::Points => "a points file",
            FileKind::BakeCache => "a bake cache file",
        }
    }
}

/// Why a file could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// There is no such file.
    NotFound,
    /// It exists but is not a regular file: what it is (`a directory`, `a FIFO (named pipe)`, …).
    NotRegular(&'static str),
    /// It is larger than its kind's limit.
    TooLarge {
        /// The size found (at least this many bytes).
        bytes: u64,
        /// The limit.
        limit: u64,
    },
    /// Any other I/O failure (permissions, …).
    Io(io::Error),
}

impl ReadError {
    /// The error as a user-facing input error naming `path` (exit code 2).
    pub(crate) fn into_error(self, path: &Path, kind: FileKind) -> Error {
        let message = match self {
            ReadError::NotFound => "cannot read file: no such file".to_string(),
            ReadError::NotRegular(what) => format!(
                "is {what}, not a regular file (Haiko reads {} only from a regular file)",
                kind.describe()
            ),
            ReadError::TooLarge { bytes, limit } => format!(
                "is {bytes} bytes; {} may be at most {} MiB",
                kind.describe(),
                limit / MIB
            ),
            ReadError::Io(e) => format!("cannot read file: {e}"),
        };
        Error::input(path, "", message)
    }
}

impl From<io::Error> for ReadError {
    fn from(e: io::Error) -> Self {
        if e.kind() == io::ErrorKind::NotFound {
            ReadError::NotFound
        } else {
            ReadError::Io(e)
        }
    }
}

/// What a non-regular file is, in words; `None` for a regular file.
fn not_regular(file_type: fs::FileType) -> Option<&'static str> {
    if file_type.is_file() {
        return None;
    }
    if file_type.is_dir() {
        return Some("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if file_type.is_char_device() {
            return Some("a character device");
        }
        if file_type.is_block_device() {
            return Some("a block device");
        }
        if file_type.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a file")
}

/// Opens a regular file of `kind` (following symlinks) for reading, refusing anything else and
/// anything above the kind's size limit; with its size in bytes. The typed error lets callers
/// (the bake cache) tell a missing file from a bad one.
pub fn open_regular(path: &Path, kind: FileKind) -> Result<(File, u64), ReadError> {
    if let Some(what) = not_regular(fs::metadata(path)?.file_type()) {
        return Err(ReadError::NotRegular(what));
    }
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path)?;
    let metadata = file.metadata()?;
    if let Some(what) = not_regular(metadata.file_type()) {
        return Err(ReadError::NotRegular(what));
    }
    note_read(path, &metadata);
    let limit = kind.max_bytes();
    if metadata.len() > limit {
        return Err(ReadError::TooLarge {
            bytes: metadata.len(),
            limit,
        });
    }
    Ok((file, metadata.len()))
}

/// Reads a regular file of `kind` ([`open_regular`]); a file that grows past the kind's limit
/// while it is read is refused too.
pub fn read_bytes(path: &Path, kind: FileKind) -> Result<Vec<u8>, ReadError> {
    let (file, len) = open_regular(path, kind)?;
    let limit = kind.max_bytes();
    let mut data = Vec::with_capacity(len as usize);
    file.take(limit + 1).read_to_end(&mut data)?;
    if data.len() as u64 > limit {
        return Err(ReadError::TooLarge {
            bytes: data.len() as u64,
            limit,
        });
    }
    Ok(data)
}

/// [`read_bytes`] with failures as input errors naming `path` (exit code 2).
pub fn read(path: &Path, kind: FileKind) -> Result<Vec<u8>> {
    read_bytes(path, kind).map_err(|e| e.into_error(path, kind))
}

/// [`read`] as UTF-8 text (a leading byte-order mark is kept); invalid UTF-8 is an input error
/// naming the line, without quoting the file.
pub(crate) fn read_text(path: &Path, kind: FileKind) -> Result<String> {
    let bytes = read(path, kind)?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..valid].iter().filter(|&&b| b == b'\n').count();
        Error::input(
            path,
            format!("line {line}"),
            format!("is not UTF-8 text ({} must be UTF-8)", kind.describe()),
        )
    })
}

/// FNV-1a 64-bit: a stable hash (unlike `std`'s `DefaultHasher`) for cache keys, checksums and
/// the content hash of a file read for saving.
#[derive(Debug, Clone, Copy)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Hashes raw bytes.
    pub fn bytes(&mut self, data: &[u8]) -> &mut Self {
        for &b in data {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }
    /// Hashes an f64 by its bit pattern (so −0.0 ≠ 0.0; inputs come from files, not arithmetic).
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// Hashes a u64.
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// Hashes a string with its length (so concatenations differ).
    pub fn str(&mut self, s: &str) -> &mut Self {
        self.u64(s.len() as u64).bytes(s.as_bytes())
    }
    /// The hash value.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// The content hash of a file's bytes (FNV-1a 64).
pub(crate) fn content_hash(bytes: &[u8]) -> u64 {
    Fnv64::default().bytes(bytes).finish()
}

/// The most symlinks followed from an output path to the file written.
const MAX_SYMLINK_HOPS: usize = 40;

/// The file `path` finally names: symlinks followed (each relative target against its link's
/// directory) until a non-link or a missing name; `path` itself when it is no link.
pub(crate) fn resolve_symlinks(path: &Path) -> io::Result<PathBuf> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_SYMLINK_HOPS {
        match fs::symlink_metadata(&current) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = fs::read_link(&current)?;
                current = directory_of(&current).join(target);
            }
            _ => return Ok(current),
        }
    }
    Err(io::Error::other("too many levels of symbolic links"))
}

/// The directory holding `path` (`.` for a bare file name).
fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    }
}

/// The prefixes of Haiko's temporary files beside a target named `name` (the second is the one
/// older versions used when saving a room).
fn temp_prefixes(name: &str) -> [String; 2] {
    [format!(".{name}.haiko-tmp-"), format!(".{name}.haiko-save-")]
}

/// A fresh temporary path beside `target`: `.NAME.haiko-tmp-PID-N`.
fn temp_path(target: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let [prefix, _] = temp_prefixes(&name);
    directory_of(target).join(format!("{prefix}{}-{n}", std::process::id()))
}

/// Replaces the file at `path` by `bytes` atomically (module docs): through symlinks to the
/// file they name, keeping the old file's permissions. A target that exists but is not a regular
/// file is bad input (exit code 2); an I/O failure is an internal error (exit code 1) after
/// which the old file is unchanged and no temporary file is left.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let failed = |e: io::Error| {
        Error::internal(format!(
            "cannot write {}: {e} (the previous file, if any, is unchanged)",
            path.display()
        ))
    };
    let target = resolve_symlinks(path).map_err(failed)?;
    if target.file_name().is_none() {
        return Err(Error::input(path, "", "is not a file name"));
    }
    let permissions = match fs::metadata(&target) {
        Ok(m) => {
            if let Some(what) = not_regular(m.file_type()) {
                return Err(Error::input(
                    path,
                    "",
                    format!("is {what}: Haiko writes its outputs only to regular files"),
                ));
            }
            Some(m.permissions())
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => None,
        Err(e) => return Err(failed(e)),
    };
    let temp = temp_path(&target);
    let write = || -> io::Result<()> {
        let mut file = OpenOptions::new().write(true).create_new(true).open(&temp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        if let Some(permissions) = permissions {
            fs::set_permissions(&temp, permissions)?;
        }
        fs::rename(&temp, &target)?;
        // Persist the rename itself; not every platform can open a directory, so best effort.
        if let Ok(directory) = File::open(directory_of(&target)) {
            directory.sync_all().ok();
        }
        Ok(())
    };
    write().map_err(|e| {
        fs::remove_file(&temp).ok();
        failed(e)
    })
}

/// Temporary files older than this whose process cannot be checked are stale.
const STALE_AGE: Duration = Duration::from_secs(3600);

/// Removes Haiko's temporary files beside `target` left by a process that was killed while
/// writing it (a crash during a save): those whose process is gone, or, where processes cannot
/// be looked up (no `/proc`), that are older than an hour. Returns the files removed.
pub fn remove_stale_temporaries(target: &Path) -> io::Result<Vec<PathBuf>> {
    let target = resolve_symlinks(target)?;
    let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return Ok(Vec::new());
    };
    let prefixes = temp_prefixes(&name);
    let processes_visible = Path::new("/proc/self").exists();
    let mut removed = Vec::new();
    for entry in fs::read_dir(directory_of(&target))? {
        let entry = entry?;
        let file_name = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = prefixes.iter().find_map(|p| file_name.strip_prefix(p.as_str())) else {
            continue;
        };
        let Ok(metadata) = entry.metadata() else { continue };
        if !metadata.is_file() {
            continue;
        }
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        let stale = match pid {
            Some(pid) if pid == std::process::id() => false,
            Some(pid) if processes_visible => !Path::new("/proc").join(pid.to_string()).exists(),
            _ => metadata
                .modified()
                .ok()
                .and_then(|t| SystemTime::now().duration_since(t).ok())
                .is_some_and(|age| age > STALE_AGE),
        };
        if stale && fs::remove_file(entry.path()).is_ok() {
            removed.push(entry.path());
        }
    }
    Ok(removed)
}

/// A file's identity: device and inode on Unix (shared by its hard links and the symlinks to
/// it), the canonical path elsewhere.
#[derive(Debug, Clone, PartialEq, Eq)]
struct FileId {
    #[cfg(unix)]
    dev_ino: (u64, u64),
    #[cfg(not(unix))]
    canonical: PathBuf,
}

impl FileId {
    #[cfg_attr(unix, allow(unused_variables))]
    fn of(path: &Path, metadata: &fs::Metadata) -> Option<FileId> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            Some(FileId {
                dev_ino: (metadata.dev(), metadata.ino()),
            })
        }
        #[cfg(not(unix))]
        {
            fs::canonicalize(path).ok().map(|canonical| FileId { canonical })
        }
    }

    fn of_path(path: &Path) -> Option<FileId> {
        FileId::of(path, &fs::metadata(path).ok()?)
    }
}

/// Every file this process read through [`read_bytes`], with the path it was read as: the inputs
/// [`check_not_an_input`] protects. At most [`MAX_NOTED_FILES`] are kept.
static FILES_READ: Mutex<Vec<(FileId, PathBuf)>> = Mutex::new(Vec::new());

/// The most files [`FILES_READ`] keeps (a command reads a handful; a long editor session a few
/// per reload).
const MAX_NOTED_FILES: usize = 4096;

fn note_read(path: &Path, metadata: &fs::Metadata) {
    let Some(id) = FileId::of(path, metadata) else {
        return;
    };
    let mut files = FILES_READ.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if files.len() < MAX_NOTED_FILES && !files.iter().any(|(known, _)| *known == id) {
        files.push((id, path.to_path_buf()));
    }
}

/// Refuses to write `output` when it is one of the command's inputs (the same file, by device
/// and inode): one of `inputs`, or any file this process has read through [`read_bytes`] whose
/// path still names it. Bad
/// input naming the output and the input (exit code 2).
pub(crate) fn check_not_an_input(output: &Path, inputs: &[&Path]) -> Result<()> {
    let Some(output_id) = FileId::of_path(output) else {
        return Ok(()); // a new file is no input
    };
    let read = FILES_READ.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let input = inputs
        .iter()
        .map(|p| p.to_path_buf())
        .find(|input| FileId::of_path(input).as_ref() == Some(&output_id))
        .or_else(|| {
            // A file read earlier counts while its path still names that file: once it is
            // deleted, its inode may be reused by an unrelated file.
            read.iter()
                .find(|(id, path)| *id == output_id && FileId::of_path(path).as_ref() == Some(id))
                .map(|(_, p)| p.clone())
        });
    match input {
        None => Ok(()),
        Some(input) => Err(Error::input(
            output,
            "",
            format!(
                "is the input file `{}` of this command; Haiko never overwrites an input: \
                 choose another output file",
                input.display()
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv_matches_the_reference_vectors() {
        assert_eq!(Fnv64::default().finish(), 0xcbf29ce484222325);
        assert_eq!(Fnv64::default().bytes(b"a").finish(), 0xaf63dc4c8601ec8c);
        assert_eq!(content_hash(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn reads_regular_files_up_to_the_limit_of_their_kind() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("room.toml");
        fs::write(&path, "version = 1\n").unwrap();
        assert_eq!(read_text(&path, FileKind::Room).unwrap(), "version = 1\n");
        let big = dir.path().join("big.ies");
        File::create(&big)
            .unwrap()
            .set_len(FileKind::Ies.max_bytes() + 1)
            .unwrap();
        let e = read(&big, FileKind::Ies).unwrap_err().to_string();
        assert!(
            e.contains("big.ies: is 16777217 bytes; an IES file may be at most 16 MiB"),
            "{e}"
        );
        let e = read(dir.path(), FileKind::Room).unwrap_err().to_string();
        assert!(e.contains("is a directory, not a regular file"), "{e}");
        let e = read(&dir.path().join("none.toml"), FileKind::Room).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("no such file"), "{e}");
    }

    #[test]
    fn devices_are_refused_without_reading() {
        for device in ["/dev/zero", "/dev/urandom", "/dev/null"] {
            if Path::new(device).exists() {
                let e = read(Path::new(device), FileKind::Points).unwrap_err().to_string();
                assert!(e.contains("is a character device, not a regular file"), "{e}");
            }
        }
    }

    #[test]
    fn invalid_utf8_names_the_line_and_quotes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.toml");
        fs::write(&path, b"a = 1\nb = \"\xff secret\"\n").unwrap();
        let e = read_text(&path, FileKind::Room).unwrap_err().to_string();
        assert!(e.contains("line 2") && !e.contains("secret"), "{e}");
    }

    #[test]
    fn atomic_write_replaces_keeps_permissions_and_follows_symlinks() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.png");
        fs::write(&real, "old").unwrap();
        fs::set_permissions(&real, fs::Permissions::from_mode(0o640)).unwrap();
        let link = dir.path().join("link.png");
        std::os::unix::fs::symlink("real.png", &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_to_string(&real).unwrap(), "new");
        assert_eq!(fs::metadata(&real).unwrap().permissions().mode() & 0o777, 0o640);
        let names: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "no temporary file left: {names:?}");
        // A directory as the output is bad input; the missing directory an I/O failure.
        assert_eq!(write_atomic(dir.path(), b"x").unwrap_err().exit_code(), 2);
        let e = write_atomic(&dir.path().join("no/such/dir.png"), b"x").unwrap_err();
        assert_eq!(e.exit_code(), 1);
    }

    #[test]
    fn outputs_that_are_inputs_are_found_through_links() {
        let dir = tempfile::tempdir().unwrap();
        let room = dir.path().join("room.toml");
        fs::write(&room, "x").unwrap();
        let hard = dir.path().join("hard.toml");
        fs::hard_link(&room, &hard).unwrap();
        let soft = dir.path().join("soft.png");
        std::os::unix::fs::symlink(&room, &soft).unwrap();
        for output in [&room, &hard, &soft] {
            let e = check_not_an_input(output, &[room.as_path()]).unwrap_err();
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().contains("never overwrites an input"), "{e}");
        }
        let other = dir.path().join("out.png");
        assert!(check_not_an_input(&other, &[room.as_path()]).is_ok());
        fs::write(&other, "y").unwrap();
        assert!(check_not_an_input(&other, &[room.as_path()]).is_ok());
    }

    #[test]
    fn files_read_are_inputs_of_the_command() {
        let dir = tempfile::tempdir().unwrap();
        let lamp = dir.path().join("lamp.ies");
        fs::write(&lamp, "IESNA:LM-63-2002").unwrap();
        let link = dir.path().join("out.png");
        fs::hard_link(&lamp, &link).unwrap();
        assert!(check_not_an_input(&link, &[]).is_ok(), "not read yet");
        read(&lamp, FileKind::Ies).unwrap();
        let e = check_not_an_input(&link, &[]).unwrap_err().to_string();
        assert!(e.contains("is the input file") && e.contains("lamp.ies"), "{e}");
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let room = dir.path().join("room.toml");
        fs::write(&room, "x").unwrap();
        // Process ids above the kernel's maximum (2^22) are never alive.
        let dead = dir.path().join(".room.toml.haiko-tmp-99999999-0");
        let old_scheme = dir.path().join(".room.toml.haiko-save-99999998");
        let ours = temp_path(&room);
        let other_file = dir.path().join(".other.toml.haiko-tmp-99999999-0");
        for p in [&dead, &old_scheme, &ours, &other_file] {
            fs::write(p, "partial").unwrap();
        }
        let mut removed = remove_stale_temporaries(&room).unwrap();
        removed.sort();
        assert_eq!(removed, vec![old_scheme.clone(), dead.clone()]);
        assert!(ours.exists() && other_file.exists() && room.exists());
    }
}
