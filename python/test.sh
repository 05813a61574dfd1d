#!/usr/bin/env bash
# The Python package's checks, as CI runs them (.ci/run, after the README's test command):
# a virtual environment ($ALEPH_VENV, default python/.venv), `pip install ./python[test,examples]`
# (maturin, fetched by pip from the package registry, builds the extension from these sources
# with cargo), the pytest suite, then the example, which must produce its figure.
# MATURIN_PEP517_ARGS="--features denoise" (after scripts/oidn.sh) builds it with the denoiser.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${ALEPH_VENV:-python/.venv}
python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet "./python[test,examples]"
# The CLI the bit-for-bit tests compare with: the one `cargo test --release` built.
export ALEPH_CLI=${ALEPH_CLI:-$PWD/target/release/aleph}
"$venv/bin/python" -m pytest -q python/tests
rm -f examples/out/cornell_budgets.png
"$venv/bin/python" examples/cornell_budgets.py
test -s examples/out/cornell_budgets.png
