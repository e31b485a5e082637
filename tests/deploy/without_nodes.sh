#!/usr/bin/env bash
# The offline tools (analysis, plots, studies, bench) build and pass their tests on a host without the engines (issue #22): a fresh
# build tree with HEMOCOSIM_NODES empty and no OpenFOAM headers, the analysis and study tests
# built and run there, and none of their programs linked to LIGGGHTS or OpenFOAM.
# usage: without_nodes.sh SOURCE_DIR BUILD_DIR
# SPDX-License-Identifier: GPL-3.0-or-later
set -euo pipefail
src=$1 build=$2
rm -rf "$build"
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache); fi
cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release -DHEMOCOSIM_WERROR=ON -DHEMOCOSIM_NODES= \
  -DHEMOCOSIM_OPENFOAM_HEADERS=/nonexistent "${launcher[@]}" >"$build.configure.log" 2>&1 ||
  { cat "$build.configure.log"; exit 1; }
# What a node build would have defined must be absent.
for target in hemocosim-particles hemocosim-fluid hemo_particle_engine; do
  if cmake --build "$build" --target help | grep -qx "\.\.\. $target"; then
    echo "without nodes, the build still defines $target"; exit 1
  fi
done
cmake --build "$build" -j "$(nproc)" --target hemobench test_analysis test_studies
for program in "$build"/bin/test_analysis "$build"/bin/test_studies; do
  if ldd "$program" | grep -Ei 'liggghts|openfoam|finiteVolume'; then
    echo "$program links an engine"; exit 1
  fi
done
"$build"/bin/test_analysis --gtest_brief=1
"$build"/bin/test_studies --gtest_brief=1
echo "the offline tools build and pass their tests without the engines"
