#!/usr/bin/env bash
# Builds vbme and runs every check, on a fresh Debian machine as on CI:
#   1. installs the Debian packages it needs (scripts/install-deps.sh),
#   2. Release build of everything (library, program, samples, tests, benchmarks),
#   3. the GoogleTest suites through CTest,
#   4. installs the package and builds + runs an outside project against it (find_package(vbme)),
#   5. the test suites again in an AddressSanitizer + UndefinedBehaviorSanitizer build
#      (VBME_SKIP_SANITIZE=1 skips this step; the slow end-to-end tests listed in
#      test/sanitizer_skip.txt run only in the Release step).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
jobs=${JOBS:-$(nproc)}
start=$(date +%s)
stamp() { echo "== $* ($(( $(date +%s) - start )) s)"; }

stamp "installing dependencies"
bash scripts/install-deps.sh

stamp "Release build"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$jobs"

stamp "installed package, used by an outside project"
rm -rf build/install build/consumer
cmake --install build --prefix build/install >/dev/null
cmake -S test/consumer -B build/consumer -G Ninja -DCMAKE_PREFIX_PATH="$root/build/install" >/dev/null
cmake --build build/consumer
build/consumer/vbme_consumer

if [ "${VBME_SKIP_SANITIZE:-0}" != 1 ]; then
  stamp "AddressSanitizer + UndefinedBehaviorSanitizer build and tests"
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVBME_SANITIZE=ON \
        -DVBME_BUILD_PERF=OFF -DVBME_BUILD_SAMPLES=OFF
  cmake --build build-asan -j "$jobs"
  # test/sanitizer_skip.txt lists the slow end-to-end tests that run only in the Release run,
  # with why their code is still covered here.
  skip=$(grep -v '^[[:space:]]*\(#\|$\)' test/sanitizer_skip.txt | sed 's/[.]/[.]/g; s/.*/^&$/' | paste -sd'|')
  ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir build-asan -j "$jobs" --output-on-failure --timeout 900 -E "$skip"
fi

stamp "tests (Release)"
ctest --test-dir build -j "$jobs" --output-on-failure --timeout 600
stamp "done"
