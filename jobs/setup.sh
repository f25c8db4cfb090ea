#!/usr/bin/env bash
# Installs what parode needs on a fresh Debian machine (apt packages, Python
# packages for analysis/), then configures and builds with a CMake preset.
# Idempotent: installs only what is missing, rebuilds only what changed.
# Usage: jobs/setup.sh [PRESET]   (default: ci = OpenMP + MPI, warnings as errors)
set -euo pipefail
preset="${1:-ci}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export DEBIAN_FRONTEND=noninteractive

apt_packages=(build-essential cmake ninja-build pkg-config libode-dev libmetis-dev
  libopenmpi-dev openmpi-bin libgtest-dev nlohmann-json3-dev libtoml11-dev libcli11-dev shellcheck
  python3 python3-pip)
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

if ! python3 -c "import numpy, matplotlib, pandas" 2>/dev/null; then
  echo "setup: installing numpy, matplotlib and pandas"
  python3 -m pip install --quiet numpy matplotlib pandas 2>/dev/null \
    || python3 -m pip install --quiet --break-system-packages numpy matplotlib pandas
fi

cd "$root"
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j "$(nproc)"
