#!/usr/bin/env bash
# Install everything hemocosim needs on Debian 12 (bookworm). Idempotent; run as root
# (or through sudo). Safe to re-run: every step checks whether it is already done.
#
#   deploy/install-deps.sh            # packages + OpenFOAM headers + LCM buffer settings
#
# Environment:
#   HEMOCOSIM_OPENFOAM_HEADERS  where to put the OpenFOAM headers
#                               (default /usr/local/share/hemocosim/openfoam-headers)
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: run as root or install sudo" >&2; exit 1; }
  SUDO="sudo"
fi

HEADERS_DIR="${HEMOCOSIM_OPENFOAM_HEADERS:-/usr/local/share/hemocosim/openfoam-headers}"

PACKAGES=(
  build-essential cmake pkg-config git ca-certificates dpkg-dev xz-utils
  openfoam libopenfoam
  liggghts libliggghts-dev
  liblcm-dev liblcm-bin libglib2.0-dev
  libeigen3-dev libhdf5-dev hdf5-tools
  libopenmpi-dev openmpi-bin
  libtomlplusplus-dev libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev
  libssl-dev libgtest-dev libgmock-dev libbenchmark-dev
  chromium fonts-dejavu-core
  python3 python3-numpy python3-h5py python3-matplotlib
  procps iproute2
  slurm-wlm munge  # deploy/slurm and its test (tests/deploy)
  openssh-server openssh-client iptables  # the tests across simulated hosts (tests/hosts)
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# OpenFOAM headers of exactly the installed library version, from Debian's source package.
of_version=$(dpkg-query -W -f='${Version}' libopenfoam)
stamp="$HEADERS_DIR/.version"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$of_version" ]; then
  echo "install-deps: fetching OpenFOAM $of_version headers from Debian's source package"
  if ! grep -rqs '^Types:.*deb-src' /etc/apt/sources.list.d/ && ! grep -qs '^deb-src' /etc/apt/sources.list; then
    $SUDO tee /etc/apt/sources.list.d/hemocosim-src.sources >/dev/null <<'SRC'
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: bookworm
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
    $SUDO apt-get update -q
  fi
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  src_version=${of_version%+b*}   # binNMU suffix is not part of the source version
  (cd "$work" && apt-get source --download-only -q "openfoam=$src_version")
  orig=$(ls "$work"/openfoam_*.orig.tar.* | head -n1)
  mkdir -p "$work/x"
  tar -xf "$orig" -C "$work/x" --wildcards '*/src/*' '*/etc/*' 2>/dev/null || tar -xf "$orig" -C "$work/x"
  root=$(find "$work/x" -mindepth 1 -maxdepth 1 -type d | head -n1)
  # Flatten what wmake's lnInclude would: every header/template of the libraries we use.
  $SUDO rm -rf "$HEADERS_DIR"
  for lib in OpenFOAM finiteVolume meshTools OSspecific/POSIX; do
    dest="$HEADERS_DIR/$(basename "$lib")"
    $SUDO mkdir -p "$dest"
    find "$root/src/$lib" \( -name '*.H' -o -name '*.C' -o -name '*.h' \) -print0 |
      $SUDO xargs -0 -I{} cp -n {} "$dest/" 2>/dev/null || true
  done
  echo "$of_version" | $SUDO tee "$stamp" >/dev/null
  rm -rf "$work"; trap - EXIT
fi

# LCM over UDP multicast drops large datagrams unless the receive buffers are raised.
want=$((8 * 1024 * 1024))
for key in net.core.rmem_max net.core.rmem_default; do
  cur=$(sysctl -n "$key" 2>/dev/null || echo 0)
  if [ "$cur" -lt "$want" ]; then
    $SUDO sysctl -q -w "$key=$want" 2>/dev/null ||
      echo "install-deps: warning: cannot raise $key (container?); LCM multicast may drop large messages" >&2
  fi
done
echo "install-deps: done"
