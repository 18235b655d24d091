//! A lock per output folder, so two softbench processes never write into one folder at once.
//!
//! The lock is a file, `<folder>/.softbench.lock`, created with `O_EXCL` and removed when the
//! [`FolderLock`] is dropped. It records the holder's pid, hostname and start time, so a
//! refusal can name the holder. A lock whose holder is gone (a `kill -9`, a crash) is stale
//! and taken over — but staleness is judged only for a holder on this host (by asking the
//! kernel whether its pid is alive); a lock taken on another host (a shared cluster file
//! system) is never taken over, because its pid means nothing here.
//!
//! Meant for reuse: anything that owns a folder for a while (`simulate --out`, a study's
//! folder, a shard of a study on a cluster node) takes one.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The lock file's name inside the locked folder.
pub const LOCK_FILE: &str = ".softbench.lock";

/// Who holds a lock, as recorded in its file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Holder {
    pub pid: u32,
    pub host: String,
    /// When the lock was taken (seconds since the Unix epoch).
    pub since: u64,
    /// What the holder is doing (e.g. `simulate`), for the message.
    pub purpose: String,
}

impl Holder {
    /// This process, about to take a lock for `purpose`.
    fn this_process(purpose: &str) -> Self {
        Holder {
            pid: std::process::id(),
            host: hostname(),
            since: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            purpose: purpose.replace('\n', " "),
        }
    }

    fn to_text(&self) -> String {
        format!(
            "pid={}\nhost={}\nsince={}\npurpose={}\n",
            self.pid, self.host, self.since, self.purpose
        )
    }

    /// Parses a lock file's text; `None` if it is not one (e.g. a half-written file).
    fn parse(text: &str) -> Option<Self> {
        let field = |key: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(key)?.strip_prefix('='))
        };
        Some(Holder {
            pid: field("pid")?.trim().parse().ok()?,
            host: field("host")?.trim().to_owned(),
            since: field("since")
                .and_then(|s| s.trim().parse().ok())
                .unwrap_or(0),
            purpose: field("purpose").unwrap_or("").trim().to_owned(),
        })
    }

    /// Whether this holder is certainly gone: same host and no such process.
    fn is_stale(&self) -> bool {
        self.host == hostname() && !process_alive(self.pid)
    }
}

impl std::fmt::Display for Holder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "softbench pid {} on host {}", self.pid, self.host)?;
        if !self.purpose.is_empty() {
            write!(f, " ({})", self.purpose)?;
        }
        Ok(())
    }
}

/// What a waiting [`FolderLock::acquire`] waits for, for its message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Waiting {
    /// A live softbench process holds the lock.
    Holder(Holder),
    /// The lock file cannot be parsed (empty, garbage or written by something else): the wait
    /// ends when it is removed.
    Unreadable { lock: PathBuf, excerpt: String },
}

impl std::fmt::Display for Waiting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Holder(h) => h.fmt(f),
            Self::Unreadable { lock, excerpt } => write!(
                f,
                "whoever wrote {} (not a lock softbench can read: it holds `{excerpt}`; \
                 remove it if no softbench process uses the folder)",
                lock.display()
            ),
        }
    }
}

/// How long a lock file may stay unparseable before it is reported: its creator writes it
/// right after creating it (on a file system without hard links), so a longer one is garbage.
pub const UNREADABLE_GRACE: Duration = Duration::from_secs(1);

/// Why a folder could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{folder} is in use by {holder}: wait for it to finish (or pass --wait); if that \
         process is gone, remove {lock}"
    )]
    Held {
        folder: PathBuf,
        lock: PathBuf,
        holder: Holder,
    },
    /// The lock file is not one softbench wrote (empty, garbage, binary).
    #[error(
        "{lock} is not a lock softbench can read (it holds `{excerpt}`): if no softbench \
         process is writing into {folder}, remove {lock} and run the command again"
    )]
    Unreadable {
        folder: PathBuf,
        lock: PathBuf,
        excerpt: String,
    },
    #[error("{path}: cannot lock: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
}

impl softbench_core::error_class::Classify for LockError {
    /// A lock file that is not softbench's is in the user's folder; a folder held by another
    /// process, or one that cannot be locked, is not the input's fault.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        softbench_core::error_class::ErrorClass::bad_input_if(matches!(
            self,
            Self::Unreadable { .. }
        ))
    }
}

/// What to do when another process holds the lock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wait {
    /// Fail at once with [`LockError::Held`].
    No,
    /// Poll until the holder releases it (calling `on_wait` once, with the holder).
    Yes,
}

/// A held lock on a folder; released (its file removed) on drop.
#[derive(Debug)]
pub struct FolderLock {
    path: PathBuf,
    holder: Holder,
}

impl FolderLock {
    /// Lock `folder` (which must exist). A stale lock of a dead process on this host is taken
    /// over. With [`Wait::Yes`], polls while another live process holds it, calling
    /// `on_wait(holder)` once before the first wait.
    pub fn acquire(
        folder: &Path,
        purpose: &str,
        wait: Wait,
        mut on_wait: impl FnMut(&Waiting),
    ) -> Result<Self, LockError> {
        let path = folder.join(LOCK_FILE);
        let io = |error| LockError::Io {
            path: path.clone(),
            error,
        };
        let me = Holder::this_process(purpose);
        let mut announced = false;
        let mut unreadable_since: Option<std::time::Instant> = None;
        loop {
            match create_exclusive(&path, &me.to_text()) {
                Ok(()) => return Ok(FolderLock { path, holder: me }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(io(e)),
            }
            let text = match std::fs::read(&path) {
                Ok(t) => String::from_utf8_lossy(&t).into_owned(),
                // Released between our attempt and the read: try again.
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                Err(e) => return Err(io(e)),
            };
            match Holder::parse(&text) {
                Some(holder) if holder.is_stale() => {
                    take_over_stale(&path, &text).map_err(io)?;
                    continue;
                }
                Some(holder) => {
                    unreadable_since = None;
                    if wait == Wait::No {
                        return Err(LockError::Held {
                            folder: folder.to_owned(),
                            lock: path.clone(),
                            holder,
                        });
                    }
                    if !announced {
                        on_wait(&Waiting::Holder(holder));
                        announced = true;
                    }
                }
                // Being written right now by its creator, or garbage once that took longer
                // than the grace period.
                None => {
                    let since = *unreadable_since.get_or_insert_with(std::time::Instant::now);
                    if since.elapsed() >= UNREADABLE_GRACE {
                        let excerpt = excerpt(&text);
                        if wait == Wait::No {
                            return Err(LockError::Unreadable {
                                folder: folder.to_owned(),
                                lock: path.clone(),
                                excerpt,
                            });
                        }
                        if !announced {
                            on_wait(&Waiting::Unreadable {
                                lock: path.clone(),
                                excerpt,
                            });
                            announced = true;
                        }
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(200));
            if softbench_core::interrupt::requested().is_some() {
                return Err(io(std::io::Error::new(
                    std::io::ErrorKind::Interrupted,
                    "interrupted while waiting for the lock",
                )));
            }
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Who holds it (this process).
    pub fn holder(&self) -> &Holder {
        &self.holder
    }

    /// Reads the holder of `folder`'s lock, if any.
    pub fn holder_of(folder: &Path) -> Option<Holder> {
        let text = std::fs::read_to_string(folder.join(LOCK_FILE)).ok()?;
        Holder::parse(&text)
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        // Remove the file only if it is still ours.
        if let Ok(text) = std::fs::read_to_string(&self.path)
            && Holder::parse(&text).is_some_and(|h| h == self.holder)
        {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Creates `path` with `O_EXCL` and writes `text` completely. The text is written to a
/// unique temporary file first and hard-linked into place, so a reader never sees a lock
/// file without its holder.
fn create_exclusive(path: &Path, text: &str) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut temp = tempfile::Builder::new()
        .prefix(".softbench.lock.")
        .suffix(".new")
        .tempfile_in(dir)?;
    temp.write_all(text.as_bytes())?;
    temp.as_file().sync_all()?;
    // `hard_link` fails with AlreadyExists when the lock is held: the atomic test-and-set.
    match std::fs::hard_link(temp.path(), path) {
        Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => {
            // A file system without hard links: create it directly (a reader may briefly see
            // it empty, which `acquire` treats as "being written").
            let mut file = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(path)?;
            file.write_all(text.as_bytes())?;
            file.sync_all()
        }
        other => other,
    }
}

/// Removes a stale lock whose text was `stale`. The file is first renamed to a name only this
/// process uses; if what was renamed is not the stale lock (another process took over and
/// locked in between), it is put back.
fn take_over_stale(path: &Path, stale: &str) -> std::io::Result<()> {
    let aside = path.with_file_name(format!("{LOCK_FILE}.stale.{}", std::process::id()));
    match std::fs::rename(path, &aside) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e),
    }
    let moved = std::fs::read_to_string(&aside).unwrap_or_default();
    if moved != stale {
        // A live lock: restore it unless someone has locked again meanwhile.
        let _ = std::fs::hard_link(&aside, path);
    }
    std::fs::remove_file(&aside)
}

/// The start of an unreadable lock's text, escaped, for a message.
fn excerpt(text: &str) -> String {
    if text.is_empty() {
        return "nothing: it is empty".into();
    }
    let shown: String = text.chars().take(40).flat_map(char::escape_debug).collect();
    if text.chars().count() > 40 {
        format!("{shown}...")
    } else {
        shown
    }
}

/// This machine's host name (from the kernel), or `unknown`.
pub fn hostname() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: the buffer is valid for its length; gethostname writes at most that many bytes.
    let rc = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
    if rc != 0 {
        return "unknown".into();
    }
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    String::from_utf8_lossy(&buf[..end]).into_owned()
}

/// Whether a process with this pid exists on this host.
fn process_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    if pid <= 0 {
        return false;
    }
    // SAFETY: signal 0 only checks that the process exists and may be signalled.
    let rc = unsafe { libc::kill(pid, 0) };
    // EPERM: it exists but belongs to someone else.
    rc == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holder_text_round_trips() {
        let h = Holder::this_process("simulate");
        assert_eq!(Holder::parse(&h.to_text()), Some(h));
    }

    #[test]
    fn a_lock_is_released_on_drop_and_refused_while_held() {
        let dir = tempfile::tempdir().unwrap();
        let lock = FolderLock::acquire(dir.path(), "test", Wait::No, |_| {}).unwrap();
        let again = FolderLock::acquire(dir.path(), "test", Wait::No, |_| {});
        match again {
            Err(LockError::Held { holder, .. }) => assert_eq!(holder.pid, std::process::id()),
            other => panic!("expected Held, got {other:?}"),
        }
        drop(lock);
        assert!(!dir.path().join(LOCK_FILE).exists());
        FolderLock::acquire(dir.path(), "test", Wait::No, |_| {}).unwrap();
    }

    #[test]
    fn a_stale_lock_on_this_host_is_taken_over_but_not_one_of_another_host() {
        let dir = tempfile::tempdir().unwrap();
        let dead = Holder {
            pid: i32::MAX as u32 - 7,
            host: hostname(),
            since: 0,
            purpose: "gone".into(),
        };
        std::fs::write(dir.path().join(LOCK_FILE), dead.to_text()).unwrap();
        let lock = FolderLock::acquire(dir.path(), "test", Wait::No, |_| {}).unwrap();
        assert_eq!(lock.holder().pid, std::process::id());
        drop(lock);
        let elsewhere = Holder {
            host: format!("{}-elsewhere", hostname()),
            ..dead
        };
        std::fs::write(dir.path().join(LOCK_FILE), elsewhere.to_text()).unwrap();
        assert!(matches!(
            FolderLock::acquire(dir.path(), "test", Wait::No, |_| {}),
            Err(LockError::Held { .. })
        ));
    }
}
