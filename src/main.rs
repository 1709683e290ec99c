//! `pillar-pipe` command line: the process's setup (allocator, signals) and its exit
//! status; the commands are in `cli/`.

mod alloc;
mod cli;

use clap::Parser;

// Large tables allocate and free hundreds of MB; glibc returns each to the kernel and
// faults it in again page by page, mimalloc keeps and reuses it.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    pillar_pipe::interrupt::install();
    pillar_pipe::io::table::quiet_guarded_panics();
    // A file-size limit (`ulimit -f`) exceeded while writing should be a write error,
    // which removes the partial output and says why, not a SIGXFSZ kill that leaves it.
    // SAFETY: no thread runs yet, and SIG_IGN installs no handler code.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    // Output piped into `head` and the like: stop quietly when the reader goes away, as
    // Unix tools do, instead of panicking in `println!` on EPIPE (Rust ignores SIGPIPE by
    // default). Nothing here writes into a pipe it opened, so no other write can raise it.
    // SAFETY: as above; SIG_DFL installs no handler code.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = cli::Cli::parse();
    if let Err(e) = cli::dispatch(cli.cmd) {
        if let Some(signal) = interrupted(&e) {
            eprintln!("stopped: {e:#}");
            eprintln!("continue with: {}", resume_command(std::env::args()));
            std::process::exit(pillar_pipe::interrupt::exit_code(signal));
        }
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// The signal, where the error is a run stopped by SIGINT or SIGTERM.
fn interrupted(e: &anyhow::Error) -> Option<i32> {
    e.chain().find_map(|c| match c.downcast_ref() {
        Some(pillar_pipe::error::Error::Interrupted { signal, .. }) => Some(*signal),
        _ => None,
    })
}

/// The command that continues a stopped one: `simulate … -o DIR` becomes
/// `simulate … --resume DIR` (the options must stay those of the run); `run` and
/// `sweep` continue when typed again.
fn resume_command(args: impl Iterator<Item = String>) -> String {
    let args: Vec<String> = args.collect();
    let simulate = args.get(1).is_some_and(|a| a == "simulate");
    let mut out = vec!["pillar-pipe".to_string()];
    let mut it = args.iter().skip(1);
    while let Some(a) = it.next() {
        let dir = if !simulate {
            None
        } else if a == "-o" || a == "--output" {
            it.next().cloned()
        } else if let Some(d) = a.strip_prefix("--output=") {
            Some(d.to_string())
        } else {
            a.strip_prefix("-o")
                .filter(|d| !d.is_empty() && !a.starts_with("--"))
                .map(str::to_string)
        };
        match dir {
            Some(d) => out.extend(["--resume".to_string(), d]),
            None => out.push(a.clone()),
        }
    }
    out.iter()
        .map(|a| shell_quote(a))
        .collect::<Vec<_>>()
        .join(" ")
}

fn shell_quote(a: &str) -> String {
    let plain = !a.is_empty()
        && a.chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-./=,:+@%".contains(c));
    if plain {
        a.to_string()
    } else {
        format!("'{}'", a.replace('\'', "'\\''"))
    }
}
