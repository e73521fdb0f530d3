//! Files in and out, the one way every part of tetbench opens them.
//!
//! In: [`open_input`] opens a file to read and refuses anything that is not a regular file
//! once symbolic links are followed (a named pipe would block the open until a writer comes; a
//! character device such as `/dev/zero`, a directory or a socket would never give a file's
//! contents), with one line naming it. [`read_input`] reads a whole file bounded by what such a
//! file can hold, and [`BoundedLines`] bounds the records of a file read as a stream.
//!
//! Out: [`atomic_write`] writes through a temporary sibling named by [`temp_name`] (process and
//! host), so a failure never leaves a half-written file; [`is_stale_temp`] says which such
//! siblings a killed writer left, also in a directory several machines share.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use crate::error::{Error, Result};

/// What a path is, in words, when it is not a regular file.
fn kind_of(t: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a named pipe"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

fn not_regular(path: &Path, t: std::fs::FileType) -> Error {
    Error::Input(format!(
        "{}: {} (tetbench reads only regular files)",
        path.display(),
        kind_of(t)
    ))
}

/// Opens `path` to read. Anything but a regular file (after following symbolic links) is
/// refused with one line naming it, without blocking: the type is checked before the open, and
/// the open itself does not wait for a pipe's writer (`O_NONBLOCK`), so a file swapped for a
/// pipe in between is refused by the check on the opened file.
pub fn open_input(path: &Path) -> Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, meta.file_type()));
    }
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    let meta = f.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, meta.file_type()));
    }
    // Back to ordinary blocking reads (O_NONBLOCK means nothing to a regular file; cleared so
    // that the descriptor is the plain one every reader expects).
    {
        use std::os::fd::AsRawFd;
        let fd = f.as_raw_fd();
        // SAFETY: fcntl on a descriptor this function owns, with integer arguments only.
        unsafe {
            let flags = libc::fcntl(fd, libc::F_GETFL);
            if flags >= 0 {
                libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK);
            }
        }
    }
    Ok(f)
}

/// No bound but memory: what [`read_input`] takes for files whose size nothing else limits
/// (meshes).
pub const ANY_SIZE: u64 = u64::MAX;

/// Bytes a text file of settings (an experiment, a transfer function) can sensibly hold.
pub const MAX_SETTINGS_BYTES: u64 = 64 << 20;

/// Reads the whole regular file `path` (see [`open_input`]). A file over `max` bytes is
/// refused, and so is one whose size memory cannot hold (one line each, never an abort).
pub fn read_input(path: &Path, max: u64) -> Result<Vec<u8>> {
    let mut f = open_input(path)?;
    let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
    if len > max {
        return Err(Error::Input(format!(
            "{}: {len} bytes, more than such a file can hold ({max} bytes)",
            path.display()
        )));
    }
    let mut buf = crate::util::alloc::try_vec_with_capacity::<u8>(len as usize + 1)
        .map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
    // The file may grow while it is read: never past `max`.
    (&mut f)
        .take(max.saturating_add(1))
        .read_to_end(&mut buf)
        .map_err(|e| Error::io(path, e))?;
    if buf.len() as u64 > max {
        return Err(Error::Input(format!(
            "{}: grew past {max} bytes while it was read",
            path.display()
        )));
    }
    Ok(buf)
}

/// [`read_input`] for a UTF-8 text file: one line naming the file when it is not text.
pub fn read_input_string(path: &Path, max: u64) -> Result<String> {
    String::from_utf8(read_input(path, max)?).map_err(|e| {
        Error::Input(format!(
            "{}: not a UTF-8 text file ({})",
            path.display(),
            e.utf8_error()
        ))
    })
}

/// A reader that fails once a line (the bytes between two `\n`) grows past a bound, so that a
/// file that never ends a record (a CSV of zeros) is refused instead of being buffered until
/// memory runs out. The caller names the file.
pub struct BoundedLines<R> {
    inner: R,
    max_line: usize,
    run: usize,
}

impl<R: Read> BoundedLines<R> {
    pub fn new(inner: R, max_line: usize) -> Self {
        BoundedLines {
            inner,
            max_line,
            run: 0,
        }
    }
}

impl<R: Read> Read for BoundedLines<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                self.run = 0;
            } else {
                self.run += 1;
                if self.run > self.max_line {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!(
                            "a line longer than {} bytes (a record that never ends)",
                            self.max_line
                        ),
                    ));
                }
            }
        }
        Ok(n)
    }
}

/// This machine's name as temporary file names carry it: letters, digits and `-` only.
pub fn host_name() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: gethostname writes at most `buf.len()` bytes into the buffer it is given.
    let r = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
    let raw = if r == 0 {
        let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
        String::from_utf8_lossy(&buf[..end]).into_owned()
    } else {
        String::new()
    };
    let clean: String = raw
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    if clean.is_empty() {
        "unknown-host".into()
    } else {
        clean
    }
}

/// The part of a temporary file's name that says who writes it: `tmp<pid>@<host>`.
fn temp_tag() -> String {
    format!("tmp{}@{}", std::process::id(), host_name())
}

/// The temporary sibling a writer of `path` uses: `.NAME.tmp<pid>@<host>`, or with `ext`,
/// `.STEM.tmp<pid>@<host>.EXT` (for writers that pick their format by extension).
pub fn temp_name(path: &Path, ext: Option<&str>) -> PathBuf {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.unwrap_or(Path::new("."));
    match ext {
        None => {
            let name = path.file_name().unwrap_or_default().to_string_lossy();
            dir.join(format!(".{name}.{}", temp_tag()))
        }
        Some(ext) => {
            let stem = path.file_stem().unwrap_or_default().to_string_lossy();
            dir.join(format!(".{stem}.{}.{ext}", temp_tag()))
        }
    }
}

/// A temporary file whose writer's machine is not this one is left this long before it is
/// taken for stale: no writer takes an hour over one file.
pub const FOREIGN_TEMP_AGE: Duration = Duration::from_secs(3600);

/// Whether `name`, a file's name in a directory, is a temporary sibling (see [`temp_name`])
/// that its writer left behind: written on this machine by a process that no longer runs, or
/// on another machine (or by a version that did not name the machine) and untouched for
/// [`FOREIGN_TEMP_AGE`]. `modified` is the file's modification time.
pub fn is_stale_temp(name: &str, modified: Option<SystemTime>) -> bool {
    if !name.starts_with('.') {
        return false;
    }
    let Some(pos) = name.rfind(".tmp") else {
        return false;
    };
    let rest = &name[pos + 4..];
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    let Ok(pid) = digits.parse::<i32>() else {
        return false;
    };
    let rest = &rest[digits.len()..];
    let (host, rest) = match rest.strip_prefix('@') {
        Some(h) => {
            let end = h.find('.').unwrap_or(h.len());
            (Some(&h[..end]), &h[end..])
        }
        None => (None, rest),
    };
    // Nothing after the tag but an extension.
    if !rest.is_empty() && !rest.starts_with('.') {
        return false;
    }
    let old = || {
        modified
            .and_then(|m| SystemTime::now().duration_since(m).ok())
            .is_some_and(|age| age > FOREIGN_TEMP_AGE)
    };
    match host {
        Some(h) if h == host_name() => !process_alive(pid) || pid as u32 == std::process::id(),
        _ => old(),
    }
}

/// Whether process `pid` runs on this machine.
pub fn process_alive(pid: i32) -> bool {
    if pid <= 0 {
        return false;
    }
    // SAFETY: signal 0 only checks that the process exists; it sends nothing.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// Writes a file through a temporary sibling ([`temp_name`]) and renames it into place, so
/// that a failure never leaves a half-written output.
pub fn atomic_write(
    path: &Path,
    body: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    if path.file_name().is_none() {
        return Err(Error::Input(format!("{}: not a file name", path.display())));
    }
    let tmp = temp_name(path, None);
    let result = (|| {
        let f = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(f);
        body(&mut w)?;
        use std::io::Write;
        w.flush()?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        std::fs::remove_file(&tmp).ok();
        Error::io(path, e)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("tetbench-files-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A named pipe, a character device, a directory and a socket are refused at once, with one
    /// line naming the path and what it is; a link to a regular file is read.
    #[test]
    fn only_regular_files_are_opened() {
        let d = dir("kinds");
        let fifo = d.join("pipe.off");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo with a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let sock = d.join("sock.off");
        let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
        let link = d.join("zero.off");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        for (p, what) in [
            (fifo.as_path(), "a named pipe"),
            (Path::new("/dev/zero"), "a character device"),
            (link.as_path(), "a character device"),
            (d.as_path(), "a directory"),
            (sock.as_path(), "a socket"),
        ] {
            let e = open_input(p).unwrap_err().to_string();
            assert!(
                e.contains(&p.display().to_string()) && e.contains(what) && !e.contains('\n'),
                "{e}"
            );
            let e = read_input(p, ANY_SIZE).unwrap_err().to_string();
            assert!(e.contains(what), "{e}");
        }
        let f = d.join("a.txt");
        std::fs::write(&f, b"hello").unwrap();
        let l = d.join("link.txt");
        std::os::unix::fs::symlink(&f, &l).unwrap();
        assert_eq!(read_input(&l, 5).unwrap(), b"hello");
        assert_eq!(read_input_string(&f, ANY_SIZE).unwrap(), "hello");
        let e = read_input(&f, 4).unwrap_err().to_string();
        assert!(e.contains("a.txt") && e.contains("5 bytes"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_line_that_never_ends_is_refused() {
        let mut r = BoundedLines::new(std::io::repeat(b'0'), 1000);
        let mut buf = Vec::new();
        let e = (&mut r).take(10_000).read_to_end(&mut buf).unwrap_err();
        assert!(e.to_string().contains("never ends"), "{e}");
        let text = "a,b\n".repeat(10_000);
        let mut ok = BoundedLines::new(text.as_bytes(), 10);
        let mut s = String::new();
        ok.read_to_string(&mut s).unwrap();
        assert_eq!(s, text);
    }

    /// Temporary files: this machine's dead writers' are stale at once; another machine's only
    /// when old (its writer may be alive there); other names never.
    #[test]
    fn stale_temporary_files_across_machines() {
        let host = host_name();
        let now = Some(SystemTime::now());
        let long_ago = Some(SystemTime::now() - 2 * FOREIGN_TEMP_AGE);
        let dead = format!(".ref-x.exr.tmp999999999@{host}");
        assert!(is_stale_temp(&dead, now));
        let live = format!(".ref-x.exr.tmp1@{host}");
        assert!(!is_stale_temp(&live, now), "pid 1 is alive");
        let plot = format!(".speed.tmp999999999@{host}.png");
        assert!(is_stale_temp(&plot, now));
        let foreign = ".ref-x.exr.tmp999999999@some-other-node";
        assert!(!is_stale_temp(foreign, now));
        assert!(is_stale_temp(foreign, long_ago));
        assert!(!is_stale_temp(".ref-x.exr.tmp12", now));
        assert!(is_stale_temp(".ref-x.exr.tmp12", long_ago));
        for not_temp in ["ref-x.exr", ".tmpfoo", ".a.tmp12x", "a.exr.tmp1"] {
            assert!(!is_stale_temp(not_temp, long_ago), "{not_temp}");
        }
        let t = temp_name(Path::new("/d/plot.png"), Some("png"));
        let name = t.file_name().unwrap().to_str().unwrap();
        assert!(
            name.starts_with(".plot.tmp") && name.ends_with(".png"),
            "{name}"
        );
        assert!(
            is_stale_temp(name, now),
            "this process's own: stale at start"
        );
    }
}
