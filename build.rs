//! With `--features denoise`, the binaries and tests find Intel Open Image Denoise where the
//! build found it (`OIDN_DIR/lib`, from scripts/oidn.sh) through an rpath, so they run without
//! LD_LIBRARY_PATH. The Python extension module (python/Cargo.toml) builds with this script
//! too, so `import aleph` needs no LD_LIBRARY_PATH either.
fn main() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_DENOISE").is_some()
        && let Some(dir) = std::env::var_os("OIDN_DIR")
    {
        let lib = std::path::Path::new(&dir).join("lib");
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}
