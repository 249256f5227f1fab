#!/usr/bin/env bash
# Set up Granary on a fresh Debian machine: install missing packages, configure, build.
# (python3-gsd: HOOMD's own GSD reader, which the tests use to check that frames.gsd is GSD.)
# Idempotent: packages already installed are not touched; the build is incremental.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${GRANARY_BUILD_DIR:-$here/build}"

packages=(build-essential cmake pkg-config git libsqlite3-dev sqlite3 nlohmann-json3-dev
          libboost-dev libboost-filesystem-dev libgsl-dev libgtest-dev googletest
          liggghts openmpi-bin gnuplot-nox lammps zlib1g-dev libxxhash-dev
          libcairo2-dev ffmpeg python3-numpy python3-pandas python3-pytest python3-jsonschema python3-gsd slurmctld slurmd slurm-client munge
          libpmix-dev clang-format clang-tidy clang-tools)
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

# python/granary on the path of Debian's python3 (the one with numpy and pandas; a python3 earlier
# on PATH, e.g. pyenv's, has neither): a .pth file naming this checkout's python/ folder, which
# works offline (pip install -e would want setuptools from the network for its build).
python=/usr/bin/python3
site_dir="$("$python" -c 'import site; print(site.getsitepackages()[0])')"
if [ "$(cat "$site_dir/granary.pth" 2>/dev/null)" != "$here/python" ]; then
  sudo_cmd=""
  [ "$(id -u)" = 0 ] || [ -w "$site_dir" ] || sudo_cmd="sudo"
  $sudo_cmd mkdir -p "$site_dir"
  echo "$here/python" | $sudo_cmd tee "$site_dir/granary.pth" >/dev/null
  echo "setup: $python imports granary from $here/python ($site_dir/granary.pth)"
fi

cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release -DGRANARY_PYTHON="$python" >/dev/null
cmake --build "$build" -j "$(nproc)"
