//! A peer's process and how it is supervised: started in a process group of its own with a
//! private directory (mode 0700), spoken to one JSON line at a time with a deadline on every
//! reply and a bound on its length, and ended with its whole group. Every way a peer can fail —
//! it exits, hangs, stops reading, writes garbage or an endless line — becomes an error of the
//! one request, never a signal or an allocation failure in tetbench.
//!
//! - **Process group.** The peer leads a new group (`setpgid`), so that tetbench can end it
//!   with everything it started (`killpg`), and a Ctrl-C in the terminal reaches tetbench alone.
//!   On Linux the peer also gets `PR_SET_PDEATHSIG = SIGKILL`: if tetbench is killed outright,
//!   the kernel ends the peer. (That signal follows the *thread* that started the peer, so
//!   peers are started from the thread that prepares the renderer and lives for the run.)
//! - **Live groups.** Every running group is listed in [`LIVE`], so that a signal handler can
//!   end them all before tetbench exits ([`end_all`]).
//! - **SIGPIPE.** `tetbench` restores SIGPIPE's default action (so that `tetbench list | head`
//!   ends quietly), under which a write to a peer that has exited would kill tetbench. Writes
//!   to a peer block SIGPIPE on the writing thread and discard the one they raise: the write
//!   fails with `EPIPE` instead, and that becomes the request's error.
//! - **Deadlines.** Reads and writes are non-blocking and wait in `poll` with the request's
//!   deadline; a peer past it is killed.
//! - **Bounded replies.** A reply line longer than [`MAX_REPLY_LINE`] ends the peer.
//! - **Private directory.** `tetbench-peer-PID-N` under the temporary directory, mode 0700,
//!   removed when the peer ends. It holds a `.lock` file that its tetbench keeps locked
//!   (`flock`) while it lives; a directory whose lock can be taken belongs to a run that was
//!   killed, and the next run removes it ([`PrivateDir::create`], in `private_dir.rs`).

use std::ffi::OsString;
use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::AsRawFd;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use serde_json::Value;

use super::private_dir::PrivateDir;
use crate::error::{Error, Result};

/// The longest reply line a peer may send (images travel as files: a reply is a few hundred
/// bytes of JSON).
pub const MAX_REPLY_LINE: usize = 1 << 20;

/// How long a peer has to leave on its own after `bye` before its group is killed.
const GRACE: Duration = Duration::from_secs(2);

/// The environment variable that tells a peer its private directory.
pub const DIR_VAR: &str = "TETBENCH_PEER_DIR";

/// Process groups of the peers running now (see [`end_all`]).
static LIVE: Mutex<Vec<i32>> = Mutex::new(Vec::new());

/// Ends every running peer's process group at once (SIGKILL). For a signal handler that is
/// about to exit the process: the peers' `Drop` will not run then.
pub fn end_all() {
    let groups = match LIVE.lock() {
        Ok(g) => g.clone(),
        Err(p) => p.into_inner().clone(),
    };
    for g in groups {
        // SAFETY: kill has no memory preconditions; a negative pid names a process group.
        unsafe {
            libc::kill(-g, libc::SIGKILL);
        }
    }
}

fn live(pgid: i32, add: bool) {
    let mut l = LIVE.lock().unwrap_or_else(|p| p.into_inner());
    if add {
        l.push(pgid);
    } else {
        l.retain(|&g| g != pgid);
    }
}

/// How to start a peer.
#[derive(Clone, Debug)]
pub struct Launch {
    pub program: OsString,
    pub args: Vec<OsString>,
    /// Where it starts; `None`: in its private directory.
    pub cwd: Option<PathBuf>,
    /// Extra environment variables.
    pub env: Vec<(OsString, OsString)>,
    /// Files written into the private directory before the start (name, contents).
    pub files: Vec<(&'static str, &'static str)>,
}

impl Launch {
    /// The command line as a shell would show it (for the preflight and error messages).
    pub fn command_line(&self) -> String {
        std::iter::once(&self.program)
            .chain(&self.args)
            .map(|a| shell_word(&a.to_string_lossy()))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

fn shell_word(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

fn errno() -> i32 {
    std::io::Error::last_os_error().raw_os_error().unwrap_or(0)
}

/// Blocks SIGPIPE on this thread while alive; on drop, discards a SIGPIPE raised meanwhile and
/// restores the mask (module docs).
struct SigpipeBlocked {
    old: libc::sigset_t,
    set: libc::sigset_t,
}

impl SigpipeBlocked {
    fn new() -> SigpipeBlocked {
        // SAFETY: the sets are plain data initialised by sigemptyset before use.
        unsafe {
            let mut set: libc::sigset_t = std::mem::zeroed();
            let mut old: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            libc::sigaddset(&mut set, libc::SIGPIPE);
            libc::pthread_sigmask(libc::SIG_BLOCK, &set, &mut old);
            SigpipeBlocked { old, set }
        }
    }
}

impl Drop for SigpipeBlocked {
    fn drop(&mut self) {
        // SAFETY: as above; sigtimedwait with a zero timeout only takes a pending signal.
        unsafe {
            if libc::sigismember(&self.old, libc::SIGPIPE) == 0 {
                let mut pending: libc::sigset_t = std::mem::zeroed();
                libc::sigpending(&mut pending);
                if libc::sigismember(&pending, libc::SIGPIPE) == 1 {
                    let zero = libc::timespec {
                        tv_sec: 0,
                        tv_nsec: 0,
                    };
                    libc::sigtimedwait(&self.set, std::ptr::null_mut(), &zero);
                }
            }
            libc::pthread_sigmask(libc::SIG_SETMASK, &self.old, std::ptr::null_mut());
        }
    }
}

fn set_nonblocking(fd: i32) -> std::io::Result<()> {
    // SAFETY: fcntl on a descriptor we own.
    unsafe {
        let flags = libc::fcntl(fd, libc::F_GETFL);
        if flags < 0 || libc::fcntl(fd, libc::F_SETFL, flags | libc::O_NONBLOCK) < 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(())
}

/// Waits until `fd` is ready for `events` or `deadline` passes; false on the deadline.
fn wait_fd(fd: i32, events: i16, deadline: Instant) -> bool {
    loop {
        let now = Instant::now();
        if now >= deadline {
            return false;
        }
        let ms = (deadline - now).as_millis().clamp(1, i32::MAX as u128) as i32;
        let mut p = libc::pollfd {
            fd,
            events,
            revents: 0,
        };
        // SAFETY: one valid pollfd.
        let r = unsafe { libc::poll(&mut p, 1, ms) };
        if r > 0 {
            return true;
        }
        if r < 0 && errno() != libc::EINTR {
            // Let the read or write report the error.
            return true;
        }
    }
}

/// One running peer process.
pub struct PeerProcess {
    name: String,
    child: Child,
    pgid: i32,
    stdin: ChildStdin,
    stdout: ChildStdout,
    pending: Vec<u8>,
    log: PathBuf,
    log_start: u64,
    ended: bool,
    // Dropped after the process has ended (fields drop in order, after `Drop::drop`).
    dir: PrivateDir,
}

impl PeerProcess {
    /// Starts the peer. Its stderr goes to `log` (appended) when given, else to a file in its
    /// private directory (then only its last line survives, in error messages).
    pub fn start(name: &str, launch: &Launch, log: Option<&Path>) -> Result<PeerProcess> {
        let dir = PrivateDir::create(&std::env::temp_dir())?;
        for (file, text) in &launch.files {
            let p = dir.path().join(file);
            std::fs::write(&p, text).map_err(|e| Error::io(&p, e))?;
        }
        let log = match log {
            Some(l) => {
                if let Some(parent) = l.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
                }
                l.to_path_buf()
            }
            None => dir.path().join("stderr.log"),
        };
        let mut err = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .map_err(|e| Error::io(&log, e))?;
        let log_start = err.metadata().map(|m| m.len()).unwrap_or(0);
        let _ = writeln!(
            err,
            "--- tetbench: peer '{name}': {}",
            launch.command_line()
        );
        let log_start = log_start.max(err.metadata().map(|m| m.len()).unwrap_or(0));

        let mut cmd = Command::new(&launch.program);
        cmd.args(&launch.args)
            .current_dir(launch.cwd.as_deref().unwrap_or(dir.path()))
            .env(DIR_VAR, dir.path())
            .envs(launch.env.iter().map(|(k, v)| (k, v)))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(err)
            .process_group(0);
        #[cfg(target_os = "linux")]
        {
            let parent = std::process::id() as i32;
            // SAFETY: only async-signal-safe calls between fork and exec.
            unsafe {
                cmd.pre_exec(move || {
                    libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
                    // tetbench died before the line above: the signal will never come.
                    if libc::getppid() != parent {
                        libc::_exit(1);
                    }
                    Ok(())
                });
            }
        }
        let mut child = cmd.spawn().map_err(|e| {
            Error::Input(format!(
                "peer '{name}': cannot start `{}`: {e}",
                launch.command_line()
            ))
        })?;
        let pgid = child.id() as i32;
        live(pgid, true);
        let stdin = child.stdin.take().expect("piped");
        let stdout = child.stdout.take().expect("piped");
        let mut p = PeerProcess {
            name: name.to_string(),
            child,
            pgid,
            stdin,
            stdout,
            pending: Vec::new(),
            log,
            log_start,
            ended: false,
            dir,
        };
        if let Err(e) =
            set_nonblocking(p.stdin.as_raw_fd()).and_then(|_| set_nonblocking(p.stdout.as_raw_fd()))
        {
            p.end(false);
            return Err(Error::Internal(format!("peer '{name}': {e}")));
        }
        Ok(p)
    }

    /// The private directory.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Whether the process was ended (after a fault); a new one must be started.
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// Sends one request and waits for its reply line until `timeout`. Any fault ends the
    /// process and comes back as an error naming the request; the reply's own `ok: false` is
    /// the caller's to read.
    pub fn call(&mut self, request: &Value, timeout: Duration) -> Result<Value> {
        let what = request["type"].as_str().unwrap_or("request").to_string();
        let deadline = Instant::now() + timeout;
        let mut line = request.to_string().into_bytes();
        line.push(b'\n');
        let r = self
            .send(&line, deadline, &what, timeout)
            .and_then(|_| self.receive(deadline, &what, timeout));
        if r.is_err() {
            self.end(false);
        }
        r
    }

    fn fault(&mut self, msg: String) -> Error {
        Error::Input(format!("peer '{}': {msg}", self.name))
    }

    fn send(&mut self, bytes: &[u8], deadline: Instant, what: &str, t: Duration) -> Result<()> {
        let _sigpipe = SigpipeBlocked::new();
        let mut off = 0;
        while off < bytes.len() {
            match self.stdin.write(&bytes[off..]) {
                Ok(n) => off += n,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    if !wait_fd(self.stdin.as_raw_fd(), libc::POLLOUT, deadline) {
                        let m = format!(
                            "did not read the {what} request within {} s",
                            t.as_secs_f64()
                        );
                        return Err(self.fault(m));
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    let m = format!(
                        "stopped reading requests before {what} ({e}){}",
                        self.exit_and_last_words()
                    );
                    return Err(self.fault(m));
                }
            }
        }
        Ok(())
    }

    fn receive(&mut self, deadline: Instant, what: &str, t: Duration) -> Result<Value> {
        let mut buf = [0u8; 1 << 16];
        loop {
            if let Some(pos) = self.pending.iter().position(|&b| b == b'\n') {
                let line: Vec<u8> = self.pending.drain(..=pos).collect();
                let text = String::from_utf8_lossy(&line);
                let text = text.trim();
                if text.is_empty() {
                    continue;
                }
                return match serde_json::from_str::<Value>(text) {
                    Ok(v) if v.is_object() && v["ok"].is_boolean() => Ok(v),
                    _ => {
                        let shown: String = text.chars().take(80).collect();
                        Err(self.fault(format!(
                            "answered {what} with a line that is not a reply object: {shown:?}"
                        )))
                    }
                };
            }
            if self.pending.len() > MAX_REPLY_LINE {
                return Err(self.fault(format!(
                    "reply to {what} is longer than {} bytes",
                    MAX_REPLY_LINE
                )));
            }
            if !wait_fd(self.stdout.as_raw_fd(), libc::POLLIN, deadline) {
                return Err(self.fault(format!(
                    "no reply to {what} within {} s (timeout_s); ended",
                    t.as_secs_f64()
                )));
            }
            match self.stdout.read(&mut buf) {
                Ok(0) => {
                    let m = format!("exited during {what}{}", self.exit_and_last_words());
                    return Err(self.fault(m));
                }
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(self.fault(format!("reading the reply to {what}: {e}"))),
            }
        }
    }

    /// ` (exit status 1): <its last line on stderr>`, waiting briefly for the exit status.
    fn exit_and_last_words(&mut self) -> String {
        let mut status = None;
        for _ in 0..50 {
            if let Ok(Some(s)) = self.child.try_wait() {
                status = Some(s);
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let status = status.map(|s| format!(" ({s})")).unwrap_or_default();
        format!("{status}{}", self.last_words())
    }

    /// `: <last non-empty line this process wrote to its log>`, or nothing.
    pub fn last_words(&self) -> String {
        let Ok(mut f) = File::open(&self.log) else {
            return String::new();
        };
        use std::io::Seek;
        let len = f.metadata().map(|m| m.len()).unwrap_or(0);
        // The last 4 KiB of what this process wrote.
        let from = self.log_start.max(len.saturating_sub(4096));
        if f.seek(std::io::SeekFrom::Start(from)).is_err() {
            return String::new();
        }
        let mut tail = Vec::new();
        let _ = f.take(4096).read_to_end(&mut tail);
        let tail = String::from_utf8_lossy(&tail);
        tail.lines()
            .map(plain_text)
            .rev()
            .find(|l| !l.trim().is_empty())
            .map(|l| format!(": {}", l.trim().chars().take(300).collect::<String>()))
            .unwrap_or_default()
    }

    /// The peak resident set of the peer's process group: the sum of each member's high-water
    /// mark (`VmHWM`), read from /proc (0 where there is none).
    pub fn peak_rss(&self) -> u64 {
        if self.ended {
            return 0;
        }
        group_members(self.pgid)
            .into_iter()
            .map(|pid| vm_hwm(pid).unwrap_or(0))
            .sum()
    }

    /// Kills the peer's whole group now (after a fault in what it sent).
    pub fn kill(&mut self) {
        self.end(false);
    }

    /// Says `bye` (when `polite`), gives the peer [`GRACE`] to leave, then kills its whole
    /// group and reaps it.
    fn end(&mut self, polite: bool) {
        if self.ended {
            return;
        }
        self.ended = true;
        if polite {
            let bye = b"{\"type\":\"bye\"}\n";
            let deadline = Instant::now() + GRACE;
            {
                let _sigpipe = SigpipeBlocked::new();
                let _ = self.stdin.write(bye);
            }
            while Instant::now() < deadline && !exited(self.child.id() as i32) {
                std::thread::sleep(Duration::from_millis(5));
            }
        }
        // SAFETY: the group's leader is our unreaped child, so the group id is still ours.
        unsafe {
            libc::kill(-self.pgid, libc::SIGKILL);
        }
        let _ = self.child.wait();
        live(self.pgid, false);
    }
}

impl Drop for PeerProcess {
    fn drop(&mut self) {
        self.end(true);
    }
}

/// Whether `pid` (our child) has exited, without reaping it.
fn exited(pid: i32) -> bool {
    // SAFETY: a zeroed siginfo_t is a valid out-parameter.
    unsafe {
        let mut info: libc::siginfo_t = std::mem::zeroed();
        let r = libc::waitid(
            libc::P_PID,
            pid as libc::id_t,
            &mut info,
            libc::WEXITED | libc::WNOHANG | libc::WNOWAIT,
        );
        r != 0 || info.si_pid() != 0
    }
}

/// A log line as plain text for a one-line note: terminal colour sequences (`ESC [ … letter`)
/// and other control characters left out.
fn plain_text(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            if chars.peek() == Some(&'[') {
                chars.next();
                for d in chars.by_ref() {
                    if d.is_ascii_alphabetic() {
                        break;
                    }
                }
            }
        } else if !c.is_control() || c == '\t' {
            out.push(c);
        }
    }
    out
}

/// The processes whose process group is `pgid` (from /proc; empty elsewhere).
pub fn group_members(pgid: i32) -> Vec<i32> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<i32>().ok())
        .filter(|&pid| {
            std::fs::read_to_string(format!("/proc/{pid}/stat"))
                .ok()
                .and_then(|s| {
                    // Fields after the command name (which may hold spaces and parentheses):
                    // state, ppid, pgrp.
                    let rest = &s[s.rfind(')')? + 1..];
                    rest.split_whitespace().nth(2)?.parse::<i32>().ok()
                })
                == Some(pgid)
        })
        .collect()
}

/// A process's peak resident set in bytes (`VmHWM` in /proc/PID/status).
fn vm_hwm(pid: i32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_lose_colour_sequences_and_control_characters() {
        assert_eq!(
            plain_text("\u{1b}[0m\u{1b}[33m2026 WARN| Undefined edge case\u{1b}[0m\u{7}"),
            "2026 WARN| Undefined edge case"
        );
        assert_eq!(plain_text("a\tb"), "a\tb");
    }

    #[test]
    fn command_lines_quote_what_a_shell_would_split() {
        let l = Launch {
            program: "/bin/my peer".into(),
            args: vec!["--x=1".into(), "it's".into()],
            cwd: None,
            env: Vec::new(),
            files: Vec::new(),
        };
        assert_eq!(l.command_line(), "'/bin/my peer' --x=1 'it'\\''s'");
    }
}
