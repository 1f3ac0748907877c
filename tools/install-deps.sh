#!/usr/bin/env bash
# Installs orbcal's build and test dependencies from Debian 12's packages. Idempotent: installs
# only what is missing, and does nothing (no apt-get update) when everything is present.
# Usage: tools/install-deps.sh [--tests]   (--tests adds what only the test suite needs)
set -euo pipefail
pkgs=(build-essential cmake pkg-config libeigen3-dev libboost-dev libopencv-dev libosmesa6-dev libassimp-dev
      catch2 libceres-dev libcli11-dev libyaml-cpp-dev liburdfdom-dev python3-matplotlib
      libopencv-contrib-dev   # cv::aruco: ChArUco boards
      libopenblas-dev         # BLAS and LAPACK for a long log's large dense products (orbcal/calib/dense_kernels.hpp)
      pybind11-dev python3-dev python3-numpy)   # the Python module (python/)
if [[ "${1:-}" == "--tests" ]]; then
  pkgs+=(opencv-doc)   # OpenCV's sample chessboard photographs (left01..14.jpg) for the real-image tests
  pkgs+=(python3-pytest)   # the Python module's tests
  pkgs+=(chromium)         # opens report.html headless (tests/browser/check_report.py)
  pkgs+=(slurmctld slurmd slurm-client munge iproute2)   # the one-node Slurm cluster of tools/slurm-cluster.sh (ss: free ports)
fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#pkgs[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
