#!/usr/bin/env bash
# Installs the Debian 12 packages ctcal needs. Idempotent: does nothing (and needs no network)
# when everything is already present. Must run as root (or via sudo) on a fresh machine.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config git
  libeigen3-dev libceres-dev libsuitesparse-dev
  libopencv-dev libopencv-contrib-dev
  libapriltag-dev
  libboost-program-options-dev libboost-math-dev
  libmrcal-dev mrcal
  libgtest-dev libgmock-dev libbenchmark-dev
  libyaml-cpp-dev libcairo2-dev libpng-dev zlib1g-dev
  clang-format
  poppler-utils opencv-doc visp-images-data
  chromium python3
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "[install_deps] all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "[install_deps] installing: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "[install_deps] error: missing packages and not root (no sudo): ${missing[*]}" >&2
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "[install_deps] done"
