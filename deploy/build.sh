#!/usr/bin/env bash
# Configure and build hemocosim (programs and tests) into build/. Run deploy/install-deps.sh first.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$jobs"
