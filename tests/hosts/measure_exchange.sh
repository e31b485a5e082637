#!/usr/bin/env bash
# The cost of a coupling exchange between simulated hosts against loopback (docs/hosts.md):
# the same scene and ranks run from the first namespace on one host (the bus on loopback,
# ttl=0), with the fluid on host 1 and the particles' two ranks on hosts 2 and 3 (ttl=1, over
# the bridge; MPI over TCP), and with both particle ranks on host 2 (the bus across hosts, MPI
# within one), REPEAT times each; prints the lockstep's coupling overhead
# (step wall time not spent computing in a node) and step wall time per step. Needs root.
# With TRANSPORTS "multicast tcp", each placement also runs over the TCP transport (the
# coordinator's relay; rows ending in _tcp).
#
#   tests/hosts/measure_exchange.sh BUILD_DIR SCENE [REPEAT] [TRANSPORTS]
set -euo pipefail
build=$(cd "${1:?BUILD_DIR}" && pwd)
scene=$(cd "$(dirname "${2:?SCENE}")" && pwd)/$(basename "$2")
repeat=${3:-3}
transports=${4:-multicast}
here=$(cd "$(dirname "$0")" && pwd)
name=hm$$
work=$(mktemp -d)
trap '"$here/netns.sh" down $name "$work/net"; rm -rf "$work"' EXIT
"$here/netns.sh" up $name 3 "$work/net"
per_step() {  # run dir -> "overhead_ms wall_ms"
  awk -F, '$1=="lockstep" && $2=="coupling_overhead_s" {print $4}' "$1/profile.csv" | tr '\n' ' '
  awk -F, '$3=="lockstep" && $4=="step_wall_s" && $1>0 {s+=$5; n++} END {printf "%.3f\n", 1e3*s/n}' "$1/metrics.csv"
}
echo "placement overhead_ms_per_step step_wall_ms"
for i in $(seq 1 "$repeat"); do
  for t in $transports; do
    sfx=$([ "$t" = multicast ] && echo "" || echo "_$t")
    ip netns exec $name-1 "$build/bin/hemocosim" run "$scene" --out "$work/loop$t$i" --np-particles 2 \
      --transport "$t" >/dev/null 2>&1
    echo "loopback$sfx $(per_step "$work/loop$t$i")"
    ip netns exec $name-1 "$build/bin/hemocosim" run "$scene" --out "$work/hosts$t$i" --fluid-hosts 10.77.0.1 \
      --particle-hosts 10.77.0.2:1,10.77.0.3:1 --launch-command "$work/net/ssh {host} {command}" \
      --transport "$t" >/dev/null 2>&1
    echo "hosts_1_2+3$sfx $(per_step "$work/hosts$t$i")"
    ip netns exec $name-1 "$build/bin/hemocosim" run "$scene" --out "$work/two$t$i" --fluid-hosts 10.77.0.1 \
      --particle-hosts 10.77.0.2:2 --launch-command "$work/net/ssh {host} {command}" \
      --transport "$t" >/dev/null 2>&1
    echo "hosts_1_2$sfx $(per_step "$work/two$t$i")"
  done
done
