#!/usr/bin/env bash
# Installs what benches/peer/*.py need (not the tests, not CI): a venv with Mitsuba 3, numpy
# and NVIDIA's FLIP, and Debian's libllvm19 for Mitsuba's llvm_ad_rgb variant (as root).
set -euo pipefail
cd "$(dirname "$0")"
if ! ldconfig -p | grep -q 'libLLVM.so.19\|libLLVM-19'; then
    if [ "$(id -u)" = 0 ]; then apt-get install -y -q libllvm19; else sudo apt-get install -y -q libllvm19; fi
fi
python3 -m venv .venv
.venv/bin/pip install -q 'mitsuba==3.9.1' numpy flip-evaluator
.venv/bin/python -c "import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); print('mitsuba', mi.__version__, 'llvm_ad_rgb ready')"
