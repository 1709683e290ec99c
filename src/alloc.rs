//! The allocator's settings for one command, made before the Rust runtime's first
//! allocation (which reserves mimalloc's first arena, before `main`; setting them from
//! `main` was tried and is too late).
//!
//! mimalloc commits a whole arena when it reserves one on systems that overcommit
//! (`arena_eager_commit` = 2). `track` and `locate` work one camera frame at a time
//! (about 10 MB) yet then held 90–100 MB, and faulting those pages in cost them about a
//! tenth of their time against trackpy (docs/camera.md). Commands on large tables
//! (`kinematics` on a million grains) lost system time with lazy commit instead, so only
//! the frame commands get it. A user's own MIMALLOC_ARENA_EAGER_COMMIT still wins.

/// The commands that commit arenas lazily.
const LAZY_COMMIT: [&[u8]; 2] = [b"track", b"locate"];

/// `mi_option_arena_eager_commit` in mimalloc 2's `mi_option_e` (mimalloc.h).
const MI_OPTION_ARENA_EAGER_COMMIT: i32 = 4;

#[cfg(target_os = "linux")]
#[used]
#[unsafe(link_section = ".init_array.00101")]
static SET_BEFORE_THE_RUNTIME: extern "C" fn() = set_for_this_command;

/// The command of a NUL-separated command line: the first argument after the program
/// name that is not an option.
fn command_of(cmdline: &[u8]) -> Option<&[u8]> {
    cmdline
        .split(|&b| b == 0)
        .skip(1)
        .find(|a| !a.is_empty() && a[0] != b'-')
}

#[cfg(target_os = "linux")]
extern "C" fn set_for_this_command() {
    unsafe extern "C" {
        fn mi_option_set(option: i32, value: std::ffi::c_long);
    }
    // Nothing may allocate here: a stack buffer, libc calls only.
    let mut buf = [0u8; 4096];
    // SAFETY: open/read/close on a path of this process into a buffer of its stated
    // length; one thread runs, before the runtime.
    let n = unsafe {
        let fd = libc::open(
            c"/proc/self/cmdline".as_ptr(),
            libc::O_RDONLY | libc::O_CLOEXEC,
        );
        if fd < 0 {
            return;
        }
        let n = libc::read(fd, buf.as_mut_ptr().cast(), buf.len());
        libc::close(fd);
        n
    };
    if n <= 0 {
        return;
    }
    let lazy = command_of(&buf[..n as usize]).is_some_and(|c| LAZY_COMMIT.contains(&c));
    // SAFETY: getenv reads the environment, which nothing writes this early;
    // mi_option_set stores one value in mimalloc's option table.
    unsafe {
        if lazy && libc::getenv(c"MIMALLOC_ARENA_EAGER_COMMIT".as_ptr()).is_null() {
            mi_option_set(MI_OPTION_ARENA_EAGER_COMMIT, 0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_is_the_first_argument_that_is_not_an_option() {
        let c = |s: &[u8]| command_of(s).map(|c| String::from_utf8_lossy(c).into_owned());
        assert_eq!(
            c(b"pillar-pipe\0track\0frames\0-o\0t.csv\0"),
            Some("track".into())
        );
        assert_eq!(c(b"/x/pillar-pipe\0locate\0f\0"), Some("locate".into()));
        assert_eq!(c(b"pillar-pipe\0--version\0"), None);
        assert_eq!(c(b"pillar-pipe\0"), None);
        assert_eq!(
            c(b"pillar-pipe\0kinematics\0track\0"),
            Some("kinematics".into())
        );
        // `bench track` times `track` as a child process, which gets the setting itself.
        assert!(!LAZY_COMMIT.contains(&command_of(b"p\0bench\0track\0").unwrap()));
    }
}
