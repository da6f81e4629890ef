#!/usr/bin/env bash
# Installs what the peers benchmark needs and builds the C++ runner; idempotent (skips what is
# there). Needs a Debian machine with gcc, g++, python3 and pip.
#   apt: libopengv-dev (OpenGV), libeigen3-dev (its headers use Eigen), nlohmann-json3-dev
#        (the JSON reader of run_opengv.cpp)
#   pip: poselib, numpy
#   build/run_opengv: g++ -O2 run_opengv.cpp -lopengv
# Environment: PYTHON (default python3), CXX (default g++).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PYTHON="${PYTHON:-python3}"
CXX="${CXX:-g++}"

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  sudo_cmd=(sudo)
fi

apt_pkgs=(libopengv-dev libeigen3-dev nlohmann-json3-dev)
missing=()
for p in "${apt_pkgs[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "install.sh: apt-get install ${missing[*]}" >&2
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q "${missing[@]}"
else
  echo "install.sh: apt packages present (${apt_pkgs[*]})" >&2
fi

if "$PYTHON" -c "import poselib, numpy" 2>/dev/null; then
  echo "install.sh: python packages present (poselib $("$PYTHON" -c 'import poselib; print(getattr(poselib, "__version__", "?"))'), numpy $("$PYTHON" -c 'import numpy; print(numpy.__version__)'))" >&2
else
  echo "install.sh: pip install poselib numpy" >&2
  # A Debian system Python refuses plain pip installs (PEP 668); retry with the override then.
  "$PYTHON" -m pip install poselib numpy || "$PYTHON" -m pip install --break-system-packages poselib numpy
fi

mkdir -p "$here/build"
bin="$here/build/run_opengv"
if [ ! -x "$bin" ] || [ "$here/run_opengv.cpp" -nt "$bin" ]; then
  echo "install.sh: building $bin" >&2
  "$CXX" -O2 -std=c++17 -I/usr/include/eigen3 "$here/run_opengv.cpp" -o "$bin" -lopengv
else
  echo "install.sh: $bin up to date" >&2
fi
