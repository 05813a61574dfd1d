//! aleph's integration tests: one binary, a module per area (ripgrep's layout).

mod util;

mod adaptive;
mod animation;

mod bad_input;
mod denoise;
mod determinism;
mod diff;
mod farm;
mod furnace;
mod fuzz;
mod fuzz_options;
mod golden;
mod job;
mod lights;
mod reference;
mod reuse;
mod scenes;
mod strategies;
mod surfaces;
mod tonemap;
