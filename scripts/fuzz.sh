#!/usr/bin/env bash
# Fuzzing vbme's parsers with libFuzzer (clang, AddressSanitizer + UndefinedBehaviorSanitizer).
#
#   scripts/fuzz.sh build                  build every fuzz target in build-fuzz/
#   scripts/fuzz.sh list                   the targets
#   scripts/fuzz.sh run TARGET [SECONDS] [libFuzzer options…]
#                                          fuzz one target (default 600 s) at nice 19; the
#                                          growing corpus is build-fuzz/corpus/TARGET (seeded
#                                          from fuzz/corpus/TARGET), crashes go to
#                                          build-fuzz/artifacts/TARGET/, the log to
#                                          build-fuzz/logs/TARGET.log
#   scripts/fuzz.sh minimize TARGET CRASH  minimise a crash (then copy it to fuzz/corpus/TARGET)
#   scripts/fuzz.sh minimize TARGET        minimise the corpus: the committed seeds stay, and
#                                          of the campaign's corpus (build-fuzz/corpus/TARGET)
#                                          only the inputs that add coverage to them are copied
#                                          into fuzz/corpus/TARGET (libFuzzer -merge=1)
#
# The replay of the committed corpus (no libFuzzer, any compiler) is a CTest test per target:
#   ctest --test-dir build -L fuzz
# Needs clang and the libFuzzer runtime (Debian: clang, libclang-rt-14-dev; install-deps.sh).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${VBME_FUZZ_BUILD:-$ROOT/build-fuzz}"
CXX_FUZZ="${CXX_FUZZ:-$(command -v clang++-14 || command -v clang++ || true)}"
CC_FUZZ="${CC_FUZZ:-$(command -v clang-14 || command -v clang || true)}"
TARGETS=(scene_yaml scene_json annotation camera_path material tracker_params colmap_cameras
         colmap_images colmap_points mesh mask cli)
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=0:abort_on_error=1:allocator_may_return_null=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# an image of more than 4096 x 4096 pixels is refused by OpenCV's decoders while fuzzing
export OPENCV_IO_MAX_IMAGE_PIXELS="${OPENCV_IO_MAX_IMAGE_PIXELS:-16777216}"

usage() { sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }

case "${1:-}" in
  build)
    [ -n "$CXX_FUZZ" ] || { echo "fuzz.sh: clang++ not found (apt-get install clang)" >&2; exit 1; }
    launcher=()
    command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
    cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DCMAKE_C_COMPILER="$CC_FUZZ" -DCMAKE_CXX_COMPILER="$CXX_FUZZ" "${launcher[@]}" \
      -DVBME_SANITIZE=ON -DVBME_FUZZ=ON -DVBME_BUILD_TESTS=OFF -DVBME_BUILD_PERF=OFF \
      -DVBME_BUILD_SAMPLES=OFF
    shift
    if [ $# -gt 0 ]; then
      cmake --build "$BUILD" -j"${JOBS:-2}" --target "${@/#/vbme_fuzz_}"
    else
      cmake --build "$BUILD" -j"${JOBS:-2}" --target vbme_fuzz_all
    fi
    ;;
  list)
    printf '%s\n' "${TARGETS[@]}"
    ;;
  run)
    t="${2:?target}"; secs="${3:-600}"; shift 3 || shift $#
    exe="$BUILD/fuzz/vbme_fuzz_$t"
    [ -x "$exe" ] || { echo "fuzz.sh: $exe missing: run 'scripts/fuzz.sh build $t' first" >&2; exit 1; }
    mkdir -p "$BUILD/corpus/$t" "$BUILD/artifacts/$t" "$BUILD/logs"
    cp -n "$ROOT/fuzz/corpus/$t/"* "$BUILD/corpus/$t/" 2>/dev/null || true
    maxlen=8192
    [ "$t" = cli ] && maxlen=512
    cd "$BUILD/artifacts/$t"
    nice -n 19 "$exe" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 \
      -max_len="$maxlen" -print_final_stats=1 -close_fd_mask=1 \
      -artifact_prefix="$BUILD/artifacts/$t/" "$@" "$BUILD/corpus/$t" 2>&1 |
      tee "$BUILD/logs/$t.log" | grep -E "^#[0-9]+.*(INITED|DONE|pulse)|ERROR|FINDING|^stat::|Done " || true
    ;;
  minimize)
    t="${2:?target}"; crash="${3:-}"
    exe="$BUILD/fuzz/vbme_fuzz_$t"
    [ -x "$exe" ] || { echo "fuzz.sh: $exe missing: run 'scripts/fuzz.sh build $t' first" >&2; exit 1; }
    if [ -n "$crash" ]; then
      "$exe" -minimize_crash=1 -runs=20000 -max_total_time=120 \
        -exact_artifact_path="$crash.min" "$crash"
    else
      [ -d "$BUILD/corpus/$t" ] || { echo "fuzz.sh: no campaign corpus $BUILD/corpus/$t" >&2; exit 1; }
      before=$(ls "$ROOT/fuzz/corpus/$t" | wc -l)
      nice -n 19 "$exe" -merge=1 -timeout=10 -rss_limit_mb=2048 -close_fd_mask=1 \
        "$ROOT/fuzz/corpus/$t" "$BUILD/corpus/$t" 2>&1 | grep -E "MERGE-OUTER: [0-9]+ new files" || true
      echo "fuzz/corpus/$t: $before -> $(ls "$ROOT/fuzz/corpus/$t" | wc -l) files" \
        "(campaign corpus: $(ls "$BUILD/corpus/$t" | wc -l))"
    fi
    ;;
  *) usage ;;
esac
