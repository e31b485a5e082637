#!/usr/bin/env bash
# Fluid cost per coupling step against the number of cells (issue #6: "cost linear in the number
# of cells from 10^3 to 10^5").
#
# Runs the real fluid node (hemocosim-fluid) under the real coordinator over the real bus, with
# the stand-in particle node hemocosim-prescribed-particles (tests/fluid) publishing a moving
# solid-fraction blob (so the pressure problem is not trivial, as in a coupled run), on five
# O-grids of the same vessel (d = 100 um, l = 600 um, 799 1/s), one after the other, and prints
# one table: cells, ms per step (median and mean of the fluid's compute_s over the steps after
# the first two), ns per cell-step, PISO correctors and p / U linear-solver iterations per step,
# and the fluid node's peak memory (profile.csv).
#
#   fluid-node/bench/fluid_cost.sh [-b BIN_DIR] [-o OUT_DIR] [-n STEPS] [-m MODE] [-d DT] [-s SCENE_EXTRA]
#
#   BIN_DIR  where hemocosim, hemocosim-fluid and hemocosim-prescribed-particles are (build/bin)
#   OUT_DIR  scenes and run directories (runs/fluid-cost; each run is redone)
#   STEPS    coupling steps per mesh (20)
#   MODE     blob (default) or none (particle-free Poiseuille: a trivial pressure problem)
#   DT       coupling interval in s (1e-4, the calibration scene's)
#   SCENE_EXTRA  extra TOML appended to every scene (e.g. "[fluid]\npressure_tolerance = 1e-10")
#
# SPDX-License-Identifier: GPL-3.0-or-later
set -euo pipefail

bin=build/bin
out=runs/fluid-cost
steps=20
mode=blob
dt=1e-4
extra=""
while getopts "b:o:n:m:d:s:h" opt; do
  case $opt in
    b) bin=$OPTARG ;;
    o) out=$OPTARG ;;
    n) steps=$OPTARG ;;
    m) mode=$OPTARG ;;
    d) dt=$OPTARG ;;
    s) extra=$OPTARG ;;
    *) sed -n '2,22p' "$0"; exit 2 ;;
  esac
done
bin=$(cd "$bin" && pwd)
for p in hemocosim hemocosim-fluid hemocosim-prescribed-particles; do
  [[ -x $bin/$p ]] || { echo "fluid_cost.sh: no $bin/$p (build it first)" >&2; exit 1; }
done
case $mode in
  blob) particles="hemocosim-prescribed-particles --mode blob --phi 0.1 --blob-phi 0.3 --blob-sigma-um 12 --blob-x-um 15 --blob-speed-m-s 0.05" ;;
  none) particles="hemocosim-prescribed-particles --mode none" ;;
  *) echo "fluid_cost.sh: mode must be blob or none" >&2; exit 2 ;;
esac
mkdir -p "$out"

# core ring axial: 64, 132, 256, 576, 1024 cells per section; cells ~ 10^3, 3.2e3, 1.0e4, 3.0e4, 9.8e4
meshes=("4 3 16" "6 4 24" "8 6 40" "12 9 52" "16 12 96")

printf "%-8s %-10s %9s %9s %9s %9s %9s %8s %7s %7s %9s\n" cells core/ring/ax "ms/step" "ms mean" "U ms" "p ms" "ns/cell" corr p_it U_it "peak MiB"
for m in "${meshes[@]}"; do
  read -r core ring axial <<<"$m"
  name="cells-$core-$ring-$axial"
  scene="$out/$name.toml"
  cat >"$scene" <<SCENE
# written by fluid-node/bench/fluid_cost.sh
[run]
name = "$name"
node_timeout_s = 120
particle_command = "$particles"

[vessel]
diameter_um = 100
length_um = 600

[mesh]
core_cells = $core
ring_cells = $ring
axial_cells = $axial

[driving]
wall_shear_rate_per_s = 799

[time]
coupling_interval_s = $dt
coupling_steps = $steps

[output]
every_steps = 1000000
SCENE
  printf "%b\n" "$extra" >>"$scene"
  rm -rf "${out:?}/$name"
  if ! PATH="$bin:$PATH" "$bin/hemocosim" run "$scene" --out "$out/$name" >"$out/$name.log" 2>&1; then
    echo "fluid_cost.sh: run $name failed, see $out/$name.log" >&2
    tail -3 "$out/$name.log" >&2
    exit 1
  fi
  cells=$(( (core*core + 4*core*ring) * axial ))
  # metrics.csv: step,time_s,node,name,value. Steps 3.. (the first two set up GAMG's levels).
  awk -F, -v cells="$cells" -v core="$core" -v ring="$ring" -v axial="$axial" \
      -v peak="$(awk -F, '$1=="fluid" && $2=="peak_memory_MiB"{print $3}' "$out/$name/profile.csv")" '
    $3=="fluid" && $1>=3 {
      if ($4=="compute_s") { t[n++]=$5; sum+=$5 }
      if ($4=="piso_correctors") corr+=$5
      if ($4=="p_iterations") pit+=$5
      if ($4=="U_iterations") uit+=$5
      if ($4=="phase_fluid_momentum_s") mom+=$5
      if ($4=="phase_fluid_pressure_s") pre+=$5
    }
    END {
      # median by insertion sort (a few dozen values)
      for (i=1;i<n;i++){v=t[i];j=i-1;while(j>=0&&t[j]>v){t[j+1]=t[j];j--}t[j+1]=v}
      med = n%2 ? t[(n-1)/2] : (t[n/2-1]+t[n/2])/2
      printf "%-8d %-10s %9.2f %9.2f %9.2f %9.2f %9.0f %8.1f %7.1f %7.1f %9.1f\n", cells, core "/" ring "/" axial,
             1e3*med, 1e3*sum/n, 1e3*mom/n, 1e3*pre/n, 1e9*med/cells, corr/n, pit/n, uit/n, peak
    }' "$out/$name/metrics.csv"
done
