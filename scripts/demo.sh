#!/usr/bin/env bash
# The main job on a fresh Debian machine: installs what it needs, builds the vbme program, and
# runs `vbme demo`, which makes its own input (nothing is downloaded) and writes the results to
# ./vbme-demo (or the folder given as the first argument). Watch vbme-demo/insert/compare.mp4
# (input | vbme insert | truth), vbme-demo/material/chrome.mp4 and vbme-demo/material/glass.mp4.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-vbme-demo}
bash "$here/scripts/install-deps.sh"
cmake -S "$here" -B "$here/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$here/build" --target vbme -j "${JOBS:-$(nproc)}"
"$here/build/apps/vbme/vbme" demo --out "$out" --force
