#!/usr/bin/env bash
# From a fresh Debian 12 checkout: install, build, run the whole test suite (unit + integration).
set -euo pipefail
cd "$(dirname "$0")/.."
deploy/install-deps.sh
# A warning in our code fails the run, so that a clean clone stays clean at -Wall -Wextra.
HEMOCOSIM_WERROR=ON deploy/build.sh
cd build
# As many tests at once as cores (HEMOCOSIM_TEST_JOBS to change it): a test of several processes
# says how many cores it takes (PROCESSORS), and the integration tests run alone (RUN_SERIAL).
ctest --output-on-failure --timeout 900 -j "${HEMOCOSIM_TEST_JOBS:-$(nproc)}" "$@"
