#!/usr/bin/env bash
# Simulated hosts for the tests across hosts (docs/hosts.md): N Linux network namespaces on a
# bridge, each with its own IP, a route for multicast (224.0.0.0/4) and an sshd of its own
# (keys generated here, root login by key only) that runs in a UTS namespace with its own
# host name, so that Open MPI sees N different hosts. Needs root.
#
#   netns.sh up   NAME N DIR   # namespaces NAME-1..NAME-N at 10.77.0.1..N; keys and configs in DIR
#   netns.sh down NAME DIR     # removes them, stops their sshds (idempotent)
#   netns.sh block NAME I J    # drops multicast from NAME-I to NAME-J (the bus check's test)
#
# `up` prints nothing on success and leaves in DIR: ssh (a client wrapper: DIR/ssh HOST CMD),
# ssh_config, id (the user key), and sshd-I.pid. NAME must be at most 8 characters (interface
# names are limited to 15). A failed `up` cleans up after itself.
set -euo pipefail

cmd=${1:?usage: netns.sh up|down|block NAME ...}
name=${2:?NAME}
[ ${#name} -le 8 ] || { echo "netns.sh: NAME must be at most 8 characters" >&2; exit 2; }

down() {
  local dir=$1
  for pidfile in "$dir"/sshd-*.pid; do
    [ -f "$pidfile" ] || continue
    pid=$(cat "$pidfile")
    # Only an sshd started with this directory's configuration.
    if [ -n "$pid" ] && grep -qa "$dir/sshd_config" "/proc/$pid/cmdline" 2>/dev/null; then kill "$pid" 2>/dev/null || true; fi
    rm -f "$pidfile"
  done
  for ns in $(ip netns list | awk '{print $1}' | grep -E "^${name}-[0-9]+$" || true); do
    # Whatever still runs in it (nodes of a crashed test) goes with it.
    for pid in $(ip netns pids "$ns" 2>/dev/null || true); do kill -9 "$pid" 2>/dev/null || true; done
    ip netns del "$ns" 2>/dev/null || true
  done
  ip link del "${name}-br" 2>/dev/null || true
}

case "$cmd" in
up)
  n=${3:?N}
  dir=${4:?DIR}
  mkdir -p "$dir"
  dir=$(cd "$dir" && pwd)
  down "$dir"
  trap 'down "$dir"' ERR
  command -v sshd >/dev/null || [ -x /usr/sbin/sshd ] || { echo "netns.sh: no sshd (apt-get install openssh-server)" >&2; exit 3; }
  mkdir -p /run/sshd
  [ -f "$dir/host_key" ] || ssh-keygen -q -t ed25519 -N '' -f "$dir/host_key"
  [ -f "$dir/id" ] || ssh-keygen -q -t ed25519 -N '' -f "$dir/id"
  cp "$dir/id.pub" "$dir/authorized_keys"
  chmod 600 "$dir/authorized_keys"
  cat > "$dir/ssh_config" <<CFG
Host *
  User root
  IdentityFile $dir/id
  IdentitiesOnly yes
  StrictHostKeyChecking no
  UserKnownHostsFile /dev/null
  BatchMode yes
  LogLevel ERROR
  ConnectTimeout 10
CFG
  printf '#!/bin/sh\nexec ssh -F %s "$@"\n' "$dir/ssh_config" > "$dir/ssh"
  chmod 755 "$dir/ssh"
  # Open MPI's own ssh (to the other hosts of a job) is this wrapper too: sshd sets it in the
  # sessions it starts (SetEnv), as a site would in its ssh configuration.
  cat > "$dir/sshd_config" <<CFG
HostKey $dir/host_key
PermitRootLogin prohibit-password
PasswordAuthentication no
KbdInteractiveAuthentication no
PubkeyAuthentication yes
AuthorizedKeysFile $dir/authorized_keys
StrictModes no
UsePAM no
PrintMotd no
SetEnv OMPI_MCA_plm_rsh_agent=$dir/ssh
CFG
  ip link add "${name}-br" type bridge
  # Forward multicast to every port, whatever IGMP the bridge has seen.
  echo 0 > "/sys/class/net/${name}-br/bridge/multicast_snooping"
  ip link set "${name}-br" up
  for i in $(seq 1 "$n"); do
    ns="${name}-$i"
    ip netns add "$ns"
    ip link add "${name}-v$i" type veth peer name "${name}-p$i"
    ip link set "${name}-p$i" master "${name}-br" up
    ip link set "${name}-v$i" netns "$ns"
    ip -n "$ns" link set lo up
    ip -n "$ns" addr add "10.77.0.$i/24" dev "${name}-v$i"
    ip -n "$ns" link set "${name}-v$i" up
    ip -n "$ns" route add 224.0.0.0/4 dev "${name}-v$i"
    ip netns exec "$ns" unshare --uts sh -c "hostname ${name}-$i && exec /usr/sbin/sshd -f '$dir/sshd_config' \
      -o ListenAddress=10.77.0.$i -o PidFile='$dir/sshd-$i.pid'"
  done
  for i in $(seq 1 "$n"); do
    for t in $(seq 1 50); do
      ip netns exec "${name}-1" "$dir/ssh" "10.77.0.$i" true 2>/dev/null && break
      [ "$t" -lt 50 ] || { echo "netns.sh: sshd in ${name}-$i does not answer" >&2; false; }
      sleep 0.1
    done
  done
  trap - ERR
  ;;
down)
  down "$(cd "${3:?DIR}" 2>/dev/null && pwd || echo "${3}")"
  ;;
block)
  from=${3:?I}
  to=${4:?J}
  ip netns exec "${name}-$to" iptables -A INPUT -s "10.77.0.$from" -d 224.0.0.0/4 -j DROP
  ;;
*)
  echo "netns.sh: unknown command $cmd" >&2
  exit 2
  ;;
esac
