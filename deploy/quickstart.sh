#!/usr/bin/env bash
# From a fresh Debian 12 checkout: install, build, run the quick-start scene into runs/quickstart.
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
deploy/build.sh
out=runs/quickstart
if [ -e "$out" ]; then out="runs/quickstart-$(date +%Y%m%d-%H%M%S)"; fi
build/bin/hemocosim run scenes/quickstart.toml --out "$out"
echo "quick-start results: $out (particles.h5, metrics.csv, fluid/, logs)"
