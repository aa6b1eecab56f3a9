#!/bin/sh
# bench/gpu_tests.sh - the test suite (build/picvr-tests) on the device machine's GPU,
# with the Khronos validation layer, for a session lent a device machine (docs/gpu.md).
# lavapipe forgives what a GPU may not (memory ordering between workgroups, barriers,
# uninitialised reads), so the suite's first run on a GPU is a check of its own.  The libraries that bare machine lacks: bench/gpu_env.sh.
# Writes OUT/gpu_tests.txt (the whole output); prints the device, the summary and any
# failed test; exits with the suite's status.  Tests that assume a CPU device check
# stats.device_type, so on a GPU they test the GPU's limits instead.
#
# usage: bench/gpu_tests.sh [OUT, default bench/results]
# env:   B (build directory, default build), DATA (default ../shared/data),
#        EXTRA (default .gpu/extra, see gpu_env.sh), TESTS_S (stop the suite after
#        this many seconds, exit 124; default 0: no limit)
set -u
OUT=${1:-bench/results}
B=${B:-build}
DATA=${DATA:-../shared/data}
mkdir -p "$OUT"
[ -x "$B/picvr-tests" ] || { echo "gpu_tests: no $B/picvr-tests (make, or carry build/)" >&2; exit 1; }
. "$(dirname "$0")/gpu_env.sh"
data=$(cd "$DATA" && pwd)
log=$(cd "$OUT" && pwd)/gpu_tests.txt
# Line-buffered, so that a suite stopped at TESTS_S leaves every line it printed.
(cd "$B" && PICVR_VALIDATION=1 PICVR_DATA="$data" timeout "${TESTS_S:-0}" stdbuf -oL -eL \
    ./picvr-tests) > "$log" 2>&1
rc=$?
grep -m 1 "^picvr-tests: device" "$log" || true
grep -E "^\[  (PASSED|FAILED) |^\[  FAILED  \] |^\[==========\] [0-9]+ test\(s\) run" "$log"
# A layer that could not be loaded shows as a warning in every test, not as a failure.
if grep -q "validation requested but" "$log"; then
    echo "gpu_tests: WARNING: the validation layer was not found; the run was without it" >&2
fi
exit $rc
