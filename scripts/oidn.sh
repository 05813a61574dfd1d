#!/usr/bin/env bash
# Intel Open Image Denoise 2.5.1 for `--features denoise`: Debian bookworm has no package, so the
# library comes from the `pyoidn` wheel on the Python package registry (it ships
# libOpenImageDenoise with its CPU device), installed into a virtual environment of its own
# ($ALEPH_OIDN_VENV, default .oidn beside this repository's Cargo.toml). Prints the line that
# points the build at it; use it as
#   eval "$(bash scripts/oidn.sh)" && cargo build --release --features denoise
# The binary finds the library through an rpath the build writes (build.rs), so nothing else is
# needed at run time.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${ALEPH_OIDN_VENV:-$PWD/.oidn}
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv" >&2
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check "pyoidn==2.5.1.0" >&2
dir=$("$venv/bin/python" - <<'PY'
import pathlib, importlib.util
spec = importlib.util.find_spec("pyoidn")
print(pathlib.Path(spec.origin).parent / "oidn")
PY
)
test -f "$dir/lib/libOpenImageDenoise.so" || { echo "no libOpenImageDenoise.so in $dir/lib" >&2; exit 1; }
echo "export OIDN_DIR='$dir'"
