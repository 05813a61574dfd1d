//! The `aleph` command-line program. Argument parsing and reporting only: the work is done by
//! the `aleph` and `perception` libraries.

mod cli;

use std::process::ExitCode;

/// mimalloc keeps freed pages for reuse: the perception models allocate image-sized buffers on
/// every call, and glibc's allocator would hand them back to the OS and page-fault them in
/// again each time (measured: ~50 ms of a 1920×1080 threshold map).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// mimalloc's `mi_option_purge_delay` (the position in `mi_option_e` of the mimalloc 3 that
/// libmimalloc-sys 0.1.49 builds; `libmimalloc_sys` names no constant for it). The test
/// `purge_delay_is_the_option_set` pins the version it was read from.
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Keeps freed pages mapped instead of purging them after mimalloc's delay (1 s): a sequence
/// frees and allocates its per-frame buffers (reprojected frames, history, films) every frame,
/// and each purged page came back through a page fault that the kernel zeroes. Measured on the
/// Lost Empire walkthrough (240×150, frames 12-19, 2 fresh spp): system time 0.74 s → 0.29 s of
/// a 4.7 s run, 4 % off a reusing frame's time. Resident memory stays at its peak, which a
/// render reaches again in its next frame.
fn keep_freed_pages() {
    // SAFETY: sets one integer option; mimalloc reads options at any time from any thread.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) };
}

/// Exit status after SIGINT or SIGTERM (128 + SIGINT, the shell's convention).
const EXIT_INTERRUPTED: i32 = 130;

fn main() -> ExitCode {
    keep_freed_pages();
    // An interrupted write leaves no temporary file behind (a signal skips destructors).
    let _ = ctrlc::set_handler(|| {
        aleph::output::remove_staged_temporaries();
        eprintln!("aleph: interrupted");
        std::process::exit(EXIT_INTERRUPTED);
    });
    // A bug that slips past validation is reported in one line, not as a backtrace.
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        eprintln!("aleph: internal error{at}: {msg} (a bug: please report it with the input)");
        aleph::output::remove_staged_temporaries();
    }));
    cli::main()
}

#[cfg(test)]
mod tests {
    /// `MI_OPTION_PURGE_DELAY` was read from mimalloc 3.x's header; another version may number
    /// its options otherwise.
    #[test]
    fn purge_delay_is_the_option_set() {
        // SAFETY: reads the linked mimalloc's version and one option.
        let (version, delay) = unsafe {
            (
                libmimalloc_sys::mi_version(),
                libmimalloc_sys::mi_option_get(super::MI_OPTION_PURGE_DELAY),
            )
        };
        assert_eq!(version / 10000, 3, "mimalloc {version}");
        assert_eq!(delay, 1000, "the purge delay's default, mimalloc {version}");
    }
}
