//! One lock per cache entry, `runs/cache/.lock-<kind>-<hash>`, so that a stage being
//! computed by one process is waited for, not computed again, by another, also when the
//! cache lies on a file system shared by several machines (a cluster).
//!
//! The lock is a small JSON file (host, PID, Slurm job, start and heartbeat times) created
//! with `create_new`, which is atomic on local file systems and NFS v3+. While the stage
//! computes, a thread rewrites its heartbeat every few seconds. A lock is stale, and is
//! broken, when its host is this host and its PID is not alive, when its holder was an
//! earlier run of the waiter's own Slurm job (requeued, perhaps onto another node), or
//! when a waiter has seen its contents unchanged for the stale limit (60 s; `PILLAR_PIPE_LOCK_STALE_S`). The age
//! is measured on the waiter's own monotonic clock from the moment it first read that
//! heartbeat, not by comparing the holder's time stamp with the waiter's clock: the clocks
//! of two machines may differ by more than the limit, and a lock must not be broken
//! because its holder's clock runs late. The cost: a waiter that meets the lock of a
//! crashed process on another machine waits out the limit once.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Environment variable: seconds without a heartbeat after which a lock is stale.
pub const STALE_ENV: &str = "PILLAR_PIPE_LOCK_STALE_S";
const STALE_DEFAULT_S: f64 = 60.0;
/// How often a waiter reads the lock file.
const POLL: Duration = Duration::from_millis(200);

/// What a lock file holds.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LockInfo {
    pub host: String,
    pub pid: u32,
    pub slurm_job_id: Option<String>,
    /// `SLURM_RESTART_COUNT` of the holder: how often Slurm had requeued its job.
    #[serde(default)]
    pub slurm_restart: Option<u32>,
    /// ISO 8601 UTC.
    pub started: String,
    /// ISO 8601 UTC, rewritten every few seconds while the holder computes.
    pub heartbeat: String,
    /// Unique per acquisition: tells the holder its own lock from a successor's.
    pub token: String,
}

impl LockInfo {
    pub fn holder(&self) -> String {
        let job = self
            .slurm_job_id
            .as_ref()
            .map(|j| format!(", Slurm job {j}"))
            .unwrap_or_default();
        format!("{}:{}{job} since {}", self.host, self.pid, self.started)
    }
}

/// The stale limit, from `PILLAR_PIPE_LOCK_STALE_S` (seconds) or 60 s.
pub fn stale_limit() -> Duration {
    std::env::var(STALE_ENV)
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(
            Duration::from_secs_f64(STALE_DEFAULT_S),
            Duration::from_secs_f64,
        )
}

/// A quarter of the stale limit, at most 5 s: several beats fit in the limit even when
/// a busy file server delays some.
fn heartbeat_interval() -> Duration {
    (stale_limit() / 4).min(Duration::from_secs(5))
}

/// This machine's host name, with characters unfit for file names replaced.
pub fn hostname() -> &'static str {
    static HOST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HOST.get_or_init(|| {
        let mut buf = [0u8; 256];
        // SAFETY: the buffer outlives the call and its length is passed.
        let rc = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
        let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
        let raw = if rc == 0 {
            String::from_utf8_lossy(&buf[..end]).into_owned()
        } else {
            String::new()
        };
        let clean: String = raw
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '.' || c == '_' || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if clean.is_empty() {
            "unknown-host".into()
        } else {
            clean
        }
    })
    .as_str()
}

/// Whether a process with this PID exists on this machine (a zombie counts).
pub fn pid_alive(pid: u32) -> bool {
    let Ok(p) = libc::pid_t::try_from(pid) else {
        return false;
    };
    if p <= 0 {
        return false;
    }
    // SAFETY: signal 0 only checks that the process exists and may be signalled.
    let rc = unsafe { libc::kill(p, 0) };
    rc == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

fn unique_suffix() -> String {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    format!("{}-{}-{nanos}", hostname(), std::process::id())
}

/// What waiting for a lock reports to the caller.
pub enum LockEvent<'a> {
    /// Once per lock holder: another process computes the stage.
    Waiting(&'a LockInfo),
    /// A stale lock was broken (its holder, or None when the file was unreadable).
    BrokeStale(Option<&'a LockInfo>, &'a str),
}

/// Outcome of one attempt to take a lock.
pub enum Attempt {
    Taken(StageLock),
    /// Held by someone else; `None` when the file was unreadable (being written).
    Held(Option<LockInfo>, String),
}

/// A held lock: heartbeats until dropped, then removed (if it is still ours).
pub struct StageLock {
    path: PathBuf,
    token: String,
    stop: Option<mpsc::Sender<()>>,
    beat: Option<std::thread::JoinHandle<()>>,
}

impl StageLock {
    /// One attempt: create the lock file, or report who holds it.
    pub fn try_take(path: &Path) -> Result<Attempt> {
        use std::io::Write;
        let now = super::runs::now_iso();
        let info = LockInfo {
            host: hostname().to_string(),
            pid: std::process::id(),
            slurm_job_id: std::env::var("SLURM_JOB_ID").ok().filter(|s| !s.is_empty()),
            slurm_restart: restart_count(),
            started: now.clone(),
            heartbeat: now,
            token: unique_suffix(),
        };
        let text = serde_json::to_string_pretty(&info).unwrap_or_default();
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
        {
            Ok(mut f) => {
                // A reader that catches the file still empty sees it as held and unreadable.
                if let Err(e) = f.write_all(text.as_bytes()).and_then(|()| f.sync_all()) {
                    // An empty lock would hold every waiter for the stale limit.
                    let _ = std::fs::remove_file(path);
                    return Err(Error::io(path, e));
                }
                Ok(Attempt::Taken(Self::start(path, info)))
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                match std::fs::read_to_string(path) {
                    Ok(raw) => Ok(Attempt::Held(serde_json::from_str(&raw).ok(), raw)),
                    // Released between our create and our read: try again.
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => Self::try_take(path),
                    Err(e) => Err(Error::io(path, e)),
                }
            }
            Err(e) => Err(Error::io(path, e)),
        }
    }

    fn start(path: &Path, info: LockInfo) -> StageLock {
        let (tx, rx) = mpsc::channel::<()>();
        let (p, mut beat_info) = (path.to_path_buf(), info.clone());
        let every = heartbeat_interval();
        let beat = std::thread::spawn(move || {
            // Any message, or the sender dropped, ends the heartbeat.
            while let Err(mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(every) {
                if !still_ours(&p, &beat_info.token) {
                    // Broken as stale by a waiter (this process stalled): do not take it
                    // back; the stage's output is renamed into place atomically anyway.
                    return;
                }
                beat_info.heartbeat = super::runs::now_iso();
                let text = serde_json::to_string_pretty(&beat_info).unwrap_or_default();
                let tmp = p.with_file_name(format!(
                    "{}.hb-{}",
                    p.file_name()
                        .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                    beat_info.token
                ));
                // Written aside and renamed over the lock, so readers never see half of it.
                if std::fs::write(&tmp, text).is_ok() && std::fs::rename(&tmp, &p).is_err() {
                    let _ = std::fs::remove_file(&tmp);
                }
            }
        });
        StageLock {
            path: path.to_path_buf(),
            token: info.token,
            stop: Some(tx),
            beat: Some(beat),
        }
    }

    /// Take the lock, waiting while a live process holds it and breaking it when stale.
    /// `events` hears once per holder that we wait, and about every lock broken. The
    /// caller looks the stage up again once it holds the lock: the holder it waited for
    /// has usually finished it.
    pub fn take(path: &Path, events: &mut dyn FnMut(LockEvent)) -> Result<StageLock> {
        let limit = stale_limit();
        // The contents last read and when they were first seen (our clock).
        let mut seen: Option<(String, Instant)> = None;
        let mut announced: Option<String> = None;
        loop {
            let (info, raw) = match Self::try_take(path)? {
                Attempt::Taken(l) => return Ok(l),
                Attempt::Held(info, raw) => (info, raw),
            };
            let first_seen = match &seen {
                Some((r, t)) if *r == raw => *t,
                _ => {
                    let t = Instant::now();
                    seen = Some((raw.clone(), t));
                    t
                }
            };
            let dead_here = info
                .as_ref()
                .is_some_and(|i| i.host == hostname() && !pid_alive(i.pid));
            let requeued = info.as_ref().is_some_and(superseded);
            let silent = first_seen.elapsed() >= limit;
            if dead_here || requeued || silent {
                let why = if dead_here {
                    "its process is no longer running on this host".to_string()
                } else if requeued {
                    "its Slurm job was requeued: this process is that job's next run".to_string()
                } else {
                    format!(
                        "no heartbeat for {:.0} s",
                        first_seen.elapsed().as_secs_f64()
                    )
                };
                if break_stale(path, &raw)? {
                    events(LockEvent::BrokeStale(info.as_ref(), &why));
                }
                seen = None;
                continue;
            }
            if let Some(i) = &info
                && announced.as_deref() != Some(i.token.as_str())
            {
                events(LockEvent::Waiting(i));
                announced = Some(i.token.clone());
            }
            // Ctrl-C while waiting stops the run like any other stage would.
            if let Some(e) = Error::interrupted("stopped while waiting for another process") {
                return Err(e);
            }
            std::thread::sleep(POLL);
        }
    }
}

fn restart_count() -> Option<u32> {
    std::env::var("SLURM_JOB_ID")
        .ok()
        .filter(|s| !s.is_empty())?;
    Some(
        std::env::var("SLURM_RESTART_COUNT")
            .ok()
            .and_then(|r| r.trim().parse().ok())
            .unwrap_or(0),
    )
}

/// Whether the lock's holder is an earlier run of this very Slurm job (requeued after a
/// node failure or preemption, perhaps onto another node): Slurm runs one incarnation
/// of a job at a time, so that holder is gone, and waiting out its heartbeat would only
/// cost time. Several processes of one job (srun) share its id but not an older
/// restart count, so none of them breaks a live sibling's lock.
fn superseded(holder: &LockInfo) -> bool {
    let mine = std::env::var("SLURM_JOB_ID").ok().filter(|s| !s.is_empty());
    superseded_by(holder, mine.as_deref(), restart_count())
}

fn superseded_by(holder: &LockInfo, job: Option<&str>, restart: Option<u32>) -> bool {
    match (&holder.slurm_job_id, job, holder.slurm_restart, restart) {
        (Some(h), Some(j), Some(hr), Some(r)) => h == j && hr < r,
        _ => false,
    }
}

/// Whether the lock file still carries our token.
fn still_ours(path: &Path, token: &str) -> bool {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str::<LockInfo>(&t).ok())
        .is_some_and(|i| i.token == token)
}

/// Remove a stale lock whose contents were `raw`. Renamed to a unique name first, so
/// that of several waiters breaking it at once exactly one succeeds; if what was renamed
/// turns out to be a newer lock (taken between our read and our rename), it is put back.
/// `true` when we removed it.
fn break_stale(path: &Path, raw: &str) -> Result<bool> {
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let aside = path.with_file_name(format!("{name}.stale-{}", unique_suffix()));
    match std::fs::rename(path, &aside) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(Error::io(path, e)),
    }
    let got = std::fs::read_to_string(&aside).unwrap_or_default();
    if got != raw {
        // A hard link fails if yet another lock was taken meanwhile: never overwrite one.
        let _ = std::fs::hard_link(&aside, path);
        let _ = std::fs::remove_file(&aside);
        return Ok(false);
    }
    std::fs::remove_file(&aside).map_err(|e| Error::io(&aside, e))?;
    Ok(true)
}

impl Drop for StageLock {
    fn drop(&mut self) {
        drop(self.stop.take());
        if let Some(b) = self.beat.take() {
            let _ = b.join();
        }
        if still_ours(&self.path, &self.token) {
            // Renamed away before removal, as a breaker does: never remove a successor's.
            let name = self
                .path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            let aside = self
                .path
                .with_file_name(format!("{name}.released-{}", unique_suffix()));
            if std::fs::rename(&self.path, &aside).is_ok() {
                if std::fs::read_to_string(&aside)
                    .ok()
                    .and_then(|t| serde_json::from_str::<LockInfo>(&t).ok())
                    .is_some_and(|i| i.token != self.token)
                {
                    let _ = std::fs::hard_link(&aside, &self.path);
                }
                let _ = std::fs::remove_file(&aside);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pid_alive_tells_live_from_reaped() {
        assert!(pid_alive(std::process::id()));
        let mut c = std::process::Command::new("true").spawn().unwrap();
        let pid = c.id();
        c.wait().unwrap();
        assert!(!pid_alive(pid));
    }

    #[test]
    fn a_requeued_job_supersedes_its_earlier_run_only() {
        let holder = LockInfo {
            host: "node1".into(),
            pid: 4711,
            slurm_job_id: Some("12".into()),
            slurm_restart: Some(0),
            started: String::new(),
            heartbeat: String::new(),
            token: String::new(),
        };
        assert!(superseded_by(&holder, Some("12"), Some(1)));
        // The same run of the job (another srun task), another job, no Slurm.
        assert!(!superseded_by(&holder, Some("12"), Some(0)));
        assert!(!superseded_by(&holder, Some("13"), Some(1)));
        assert!(!superseded_by(&holder, None, None));
    }

    #[test]
    fn lock_is_exclusive_and_released_on_drop() {
        let d = std::env::temp_dir().join(format!("pp-lock-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join(".lock-x");
        let Attempt::Taken(l) = StageLock::try_take(&p).unwrap() else {
            panic!("free lock not taken")
        };
        let Attempt::Held(Some(info), _) = StageLock::try_take(&p).unwrap() else {
            panic!("held lock taken twice")
        };
        assert_eq!(
            (info.host.as_str(), info.pid),
            (hostname(), std::process::id())
        );
        drop(l);
        assert!(!p.exists());
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0, "nothing left");
        let _ = std::fs::remove_dir_all(&d);
    }
}
