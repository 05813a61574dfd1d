//! The `aleph` command-line program. Argument parsing and reporting only: the work is done by
//! the `aleph` and `perception` libraries.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    cli::main()
}
