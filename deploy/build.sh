#!/usr/bin/env bash
# Configure and build hemocosim (programs and tests) into build/. Run deploy/install-deps.sh first.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
# HEMOCOSIM_WERROR=ON (deploy/test.sh, CI) makes a compiler warning fail the build.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DHEMOCOSIM_WERROR="${HEMOCOSIM_WERROR:-OFF}" >/dev/null
cmake --build build -j "$jobs"
