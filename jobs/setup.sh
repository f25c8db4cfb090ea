#!/usr/bin/env bash
# Installs what parode needs on a fresh Debian machine (apt packages, Python
# packages for analysis/ and the snapshot tests), then configures and builds
# with a CMake preset. HDF5 comes in both Debian flavours (serial for the
# serial/omp presets, Open MPI for the MPI ones); ParaView (pvbatch, run under
# Xvfb) draws analysis/snapshot_view.py's picture. No test needs ParaView (about
# 440 MB of packages): with CI=true it is left out.
# Idempotent: installs only what is missing, rebuilds only what changed.
# Usage: jobs/setup.sh [PRESET]   (default: ci = OpenMP + MPI, warnings as errors)
set -euo pipefail
preset="${1:-ci}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export DEBIAN_FRONTEND=noninteractive

apt_packages=(build-essential cmake ninja-build pkg-config libode-dev libmetis-dev libxxhash-dev
  libopenmpi-dev openmpi-bin libgtest-dev nlohmann-json3-dev libtoml11-dev libcli11-dev shellcheck
  libhdf5-dev libhdf5-openmpi-dev hdf5-tools python3 python3-pip)
[ "${CI:-}" = "true" ] || apt_packages+=(paraview python3-paraview xvfb xauth)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# h5py, pyh5md and MDAnalysis: the independent readers the snapshot tests use.
python_packages=(numpy matplotlib pandas h5py pyh5md MDAnalysis)
if ! python3 -c "import numpy, matplotlib, pandas, h5py, pyh5md, MDAnalysis" 2>/dev/null; then
  echo "setup: installing ${python_packages[*]}"
  python3 -m pip install --quiet "${python_packages[@]}" 2>/dev/null \
    || python3 -m pip install --quiet --break-system-packages "${python_packages[@]}"
fi

cd "$root"
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j "$(nproc)"
