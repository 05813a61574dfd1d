//! With `--features denoise`, the extension module finds Intel Open Image Denoise where the
//! build found it (`OIDN_DIR/lib`, from scripts/oidn.sh) through an rpath, as the CLI does
//! (the root package's build.rs), so `import aleph` needs no LD_LIBRARY_PATH.
fn main() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_DENOISE").is_some()
        && let Some(dir) = std::env::var_os("OIDN_DIR")
    {
        let lib = std::path::Path::new(&dir).join("lib");
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}
