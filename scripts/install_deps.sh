#!/usr/bin/env bash
# Installs the Debian 12 packages ctcal needs. Idempotent: does nothing (and needs no network)
# when everything is already present. Must run as root (or via sudo) on a fresh machine.
set -euo pipefail

PACKAGES=(
  build-essential make cmake pkg-config git
  libeigen3-dev libceres-dev libsuitesparse-dev
  libopencv-dev libopencv-contrib-dev
  libapriltag-dev
  libboost-program-options-dev libboost-math-dev
  libmrcal-dev mrcal
  libgtest-dev libgmock-dev libbenchmark-dev
  libyaml-cpp-dev libcairo2-dev libdeflate-dev zlib1g-dev
  libpng-dev libjpeg62-turbo-dev
  fonts-dejavu-core
  clang-format
  poppler-utils opencv-doc visp-images-data
  chromium python3 python3-numpy python3-opencv
  librosbag-storage-dev libsqlite3-dev python3-rosbag
)
# Why the less obvious ones: make runs the README's two commands (a fresh Debian 12 has none);
# libdeflate-dev compresses the report data and the figures' PNGs (report/CMakeLists.txt) and
# inflates the common PNGs the detector reads (targets/src/png_direct.cpp);
# libpng-dev and libjpeg62-turbo-dev read the datasets' PNG / JPEG images and write the
# simulator's PNGs (targets/src/image_file.cpp: OpenCV's imgcodecs is not linked into ctcal);
# fonts-dejavu-core holds the report's "DejaVu Sans" / "DejaVu Sans Mono" (report/src/plot_draw.h);
# poppler-utils (pdftoppm, pdftotext), chromium and python3 (scripts/spec_sim.py, standard
# library only) are called by tests; python3-numpy and python3-opencv are what the independent
# image renderer (scripts/spec_render.py, run by /usr/bin/python3) needs; opencv-doc and visp-images-data hold real board photos the
# detector tests read.
# librosbag-storage-dev reads and writes ROS1 bags (`--data X.bag`, `simulate --bag`; it brings
# roscpp_serialization, cpp_common, console_bridge, bz2 / lz4 and the pluginlib headers its bag.h
# includes); libsqlite3-dev reads ROS2 bags' sqlite3 storage; python3-rosbag is the independent
# ROS1 bag writer and reader the bag tests compare against (scripts/ros_bags.py). scripts/fuzz.sh
# alone needs clang-14, libclang-rt-14-dev and libfuzzer-14-dev (not installed by default).

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
