#!/bin/sh
# bench/gpu_session.sh - everything a session lent the device machine measures, in one
# call (docs/gpu.md): device time is short and each start costs minutes,
# so the stages run back to back, each bounded by a timeout and packed into its own
# archive as soon as it ends (the device tool returns at most 8 files from OUT, and
# what a stage finished survives a later one that runs out of time).
#
#   0. the device picvr picks; without a GPU it retries with the NVIDIA driver's ICD file
#      named (VK_DRIVER_FILES), and without one then it prints what it found and stops
#   1. check.tgz   bench/gpu_check.sh SECS: hit rate, entries, references per entry and
#                  the Eq. 5 error over plain's at 1, 2, 3, 5 and 10 s (issue 3)
#   2. d1r4.tgz    the same for object space with delta_voxels=1, radius_max_voxels=4
#                  (docs/cache.md, "A full cache's error floor"), 128x128 and 512x512
#   3. err.tgz     the final images (PFM) of plain, object and object d1r4 runs of SECS
#                  from an empty cache, seeds 101-103, 128x128: their true error and
#                  bias against the lavapipe reference, measured back here with
#                  bench/bias_split.py (the estimator is the same on every device)
#   4. tests.txt   bench/gpu_tests.sh: the test suite with the validation layer, cut
#                  after TESTS_S seconds
#   5. paths.tgz   with PATHS=1: the path tracer's error against run time with 0, 1, 4 and
#                  unlimited bounces, cloud under sun and sky and bonsai, 256x256 (make
#                  bench-paths, shortened: about 3 min; docs/paths.md)
#   6. frames.tgz  with FRAMES=1: 120 orbiting 16 ms frames of the cloud at 1280x720,
#                  temporal reuse off and on, true error at 4 frames (docs/engines.md)
#
# usage (device machine, repo root, build/ and .gpu/ carried): sh bench/gpu_session.sh OUT [SECS]
# env:   B (default build), DATA (default .gpu: the volumes and libvulkan1's .deb),
#        TESTS_S (default 240), CACHES (gpu_check.sh's), ERR_CONDS (default "off object
#        object-d1r4"), TESTS_FIRST (a PICVR_TEST_FILTER glob run before the whole suite,
#        into tests-first.txt), ANY_DEVICE=1 (a dry run on lavapipe: any device will
#        do and the loader is not unpacked into /)
set -u
OUT=${1:?usage: gpu_session.sh OUT [SECS]}
SECS=${2:-10}
B=${B:-build}
DATA=${DATA:-.gpu}
TESTS_S=${TESTS_S:-240}
W=/tmp/picvr-gpu
VOL="$DATA/bonsai_256x256x256_uint8.raw.gz"
ICD=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
rm -rf "$W" && mkdir -p "$W" "$OUT" || exit 1

stage() { echo "== $(date -u +%T) $*"; }
pack() { tar -C "$W" -czf "$OUT/$1.tgz" "$1"; }
D1R4="--cache-param delta_voxels=1 --cache-param radius_max_voxels=4"
render() { timeout 120 "$B/picvr-render" --volume "$VOL" --tf ct-bonsai --lights paper1 --quiet "$@"; }

# The loader goes into / (the device tool's notes), the rest into /tmp (gpu_env.sh).
if [ "${ANY_DEVICE:-0}" != 1 ]; then
    for f in "$DATA"/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
export DATA
. "$(dirname "$0")/gpu_env.sh"

stage "0 device"
mkdir -p "$W/check"
nvidia-smi > "$W/check/nvidia-smi.txt" 2>&1
GPU='"device_type": "discrete-gpu"'
[ "${ANY_DEVICE:-0}" = 1 ] && GPU='"device_type"'
probe() {
    render --size 16x16 --iterations 1 --json "$W/check/device.json" > "$W/check/probe.txt" 2>&1 &&
        grep -q "$GPU" "$W/check/device.json"
}
if ! probe && [ -f "$ICD" ]; then
    export VK_DRIVER_FILES="$ICD"
    echo "no GPU through the loader's search path; VK_DRIVER_FILES=$ICD"
    probe
fi
if ! grep -q "$GPU" "$W/check/device.json" 2>/dev/null; then
    echo "gpu_session: no GPU device; what was found:"
    cat "$W/check/probe.txt" "$W/check/device.json" 2>/dev/null
    ls /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/nvidia/share/vulkan/icd.d 2>&1
    ldconfig -p | grep -i -E 'vulkan|nvidia' | head
    VK_LOADER_DEBUG=error,warn render --size 16x16 --iterations 1 2>&1 | tail -20
    pack check
    exit 3
fi
sed -n 's/.*"device_name": "\([^"]*\)".*/device: \1/p' "$W/check/device.json"

stage "1 gpu_check.sh $SECS"
timeout 400 sh "$(dirname "$0")/gpu_check.sh" "$SECS" "$W/check"
pack check

stage "2 object space, delta 1 voxel, radius_max 4 voxels"
mkdir -p "$W/d1r4"
for size in 128x128 512x512; do
    # shellcheck disable=SC2086 # $D1R4 is several options
    render --size "$size" --time "$((SECS * 1000))" --round 1000 --cache object $D1R4 \
        --log "$W/d1r4/gpu_${size}_object-d1r4.csv" --json "$W/d1r4/gpu_${size}_object-d1r4.json" |
        tail -3
done
pack d1r4

stage "3 final images against the reference"
mkdir -p "$W/err"
for seed in 101 102 103; do
    for cond in ${ERR_CONDS:-off object object-d1r4}; do
        case "$cond" in
            object-d1r4) mode="--cache object $D1R4" ;;
            *) mode="--cache $cond" ;;
        esac
        # shellcheck disable=SC2086 # $mode is several options
        render --size 128x128 --time "$((SECS * 1000))" --seed "$seed" $mode \
            --out-float "$W/err/${cond}_s$seed.pfm" --json "$W/err/${cond}_s$seed.json" > /dev/null ||
            echo "gpu_session: $cond seed $seed failed"
    done
done
pack err

if [ -n "${TESTS_FIRST:-}" ]; then
    stage "4a the tests $TESTS_FIRST first"
    PICVR_TEST_FILTER=$TESTS_FIRST sh "$(dirname "$0")/gpu_tests.sh" "$W/tests-first"
    cp "$W/tests-first/gpu_tests.txt" "$OUT/tests-first.txt" 2>/dev/null
fi
stage "4 the test suite, validation layer on, at most $TESTS_S s"
TESTS_S=$TESTS_S sh "$(dirname "$0")/gpu_tests.sh" "$W/tests"
echo "gpu_tests: exit $? (124: cut at $TESTS_S s)"
cp "$W/tests/gpu_tests.txt" "$OUT/" 2>/dev/null
if [ "${PATHS:-0}" = 1 ]; then
    stage "5 the path tracer: bounces 0, 1, 4, unlimited"
    mkdir -p "$W/paths"
    timeout 300 "$B/picvr-bench-sampling" --data "$DATA" --scenes cloud-sky,bonsai --size 256x256 \
        --time 4000 --slice 250 --ref-time 16000 --ref-chunks 4 --bounces 0,1,4,unlimited \
        --out "$W/paths" | tail -14
    pack paths
fi
if [ "${FRAMES:-0}" = 1 ]; then
    stage "6 engines: orbiting 16 ms frames of the cloud at 1280x720, temporal reuse off and on"
    mkdir -p "$W/frames"
    timeout 300 "$B/picvr-bench-sampling" --data "$DATA" --scenes cloud-sky --size 1280x720 --frames 120 \
        --frame-ms 16 --orbit 0.5 --checkpoints 4 --ref-time 30000 --ref-chunks 3 --out "$W/frames" | tail -8
    pack frames
fi
stage "done"
