#!/usr/bin/env bash
# Set up Granary on a fresh Debian machine: install missing packages, configure, build.
# Idempotent: packages already installed are not touched; the build is incremental.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${GRANARY_BUILD_DIR:-$here/build}"

packages=(build-essential cmake pkg-config git libsqlite3-dev sqlite3 nlohmann-json3-dev
          libboost-dev libboost-filesystem-dev libgsl-dev libgtest-dev googletest
          liggghts openmpi-bin gnuplot-nox lammps zlib1g-dev libxxhash-dev
          libcairo2-dev ffmpeg python3-pandas python3-jsonschema slurmctld slurmd slurm-client munge
          libpmix-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" = 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)"
