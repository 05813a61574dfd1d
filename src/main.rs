//! The `aleph` command-line program. Argument parsing and reporting only: the work is done by
//! the `aleph` and `perception` libraries.

mod cli;

use std::process::ExitCode;

/// mimalloc keeps freed pages for reuse: the perception models allocate image-sized buffers on
/// every call, and glibc's allocator would hand them back to the OS and page-fault them in
/// again each time (measured: ~50 ms of a 1920×1080 threshold map).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Exit status after SIGINT or SIGTERM (128 + SIGINT, the shell's convention).
const EXIT_INTERRUPTED: i32 = 130;

fn main() -> ExitCode {
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
