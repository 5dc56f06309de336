#!/usr/bin/env bash
# Installs every Debian package vbme needs, for the whole planned stack.
# Idempotent: packages already present are skipped. Works as root, uses sudo otherwise.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  # vbme_core / vbme_track / vbme_inpaint / vbme_calib
  libopencv-dev libopencv-contrib-dev
  libeigen3-dev libceres-dev
  # vbme_calib: the focal length from a photograph's EXIF
  libexif-dev
  # vbme_render
  libembree-dev embree-tools libtbb-dev libopenexr-dev libassimp-dev
  # camera tracking (the colmap program) and video
  colmap ffmpeg
  # video IO in vbme_core (FFmpeg's libraries)
  libavformat-dev libavcodec-dev libswscale-dev libavutil-dev libswresample-dev
  # command line, tests, benchmarks
  libcli11-dev libgtest-dev libgmock-dev googletest libbenchmark-dev
  # fuzzing (scripts/fuzz.sh: clang with libFuzzer and the sanitizers' runtimes)
  clang libclang-rt-14-dev
  # the cluster test and `vbme farm slurm` on one machine (scripts/slurm-local.sh)
  slurm-wlm munge
  # vbme annotate: local web server, JSON; its browser test (headless chromium, node)
  libcpp-httplib-dev nlohmann-json3-dev chromium nodejs
)
# Debian's nodejs comes without npm; a nodejs that bundles npm conflicts with the npm package.
if ! command -v npm >/dev/null 2>&1; then
  PACKAGES+=(npm)
fi

# The browser test's driver (puppeteer-core, no browser download) from its lockfile.
install_browser_test() {
  local dir
  dir="$(cd "$(dirname "$0")/.." && pwd)/test/browser"
  if [ -f "$dir/package-lock.json" ] && [ ! -d "$dir/node_modules/puppeteer-core" ]; then
    echo "install-deps: npm ci in test/browser"
    (cd "$dir" && PUPPETEER_SKIP_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error)
  fi
}

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  install_browser_test
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO="sudo"
  else
    echo "install-deps: not root and sudo is not available; install: ${missing[*]}" >&2
    exit 1
  fi
fi

echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_browser_test
