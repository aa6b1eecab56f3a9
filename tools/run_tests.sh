#!/bin/sh
# run_tests.sh - `make test`: runs every check and the test suite, goes on past a
# failure, and ends with one line "N passed, N failed, N skipped" that sums
# them all: each check counts once, except those that report their own counts
# (check_build.sh's builds, cmocka's tests in picvr-tests).  Exit status 1 if anything
# failed.  Environment: MAKE, B (build folder), DATA (the data folder, absolute).
set -u
# A leftover filter would shrink the suite without a word: `make test` runs all of it.
unset PICVR_TEST_FILTER PICVR_TEST_SKIP PICVR_LONG_RUN
MAKE=${MAKE:-make}
B=${B:-build}
pass=0
fail=0
skip=0
failed=""
count() {   # name, status
    if [ "$2" = 0 ]; then pass=$((pass + 1)); else fail=$((fail + 1)); failed="$failed $1"; fi
}
for t in check-shaders check-layout check-examples; do
    $MAKE --no-print-directory -s "$t"
    count "$t" $?
done
# the library built as applications build it (its own summary line)
out=$(sh tools/check_build.sh "$B"); rc=$?
echo "$out"
line=$(echo "$out" | sed -n 's/^check_build: \([0-9]*\) passed, \([0-9]*\) failed$/\1 \2/p')
if [ -n "$line" ]; then
    set -- $line; pass=$((pass + $1)); fail=$((fail + $2))
    [ "$2" = 0 ] || failed="$failed check-build"
else
    count check-build 1
fi
# the command-line renderer's options and file checks (its own summary line)
out=$(sh tools/check_cli.sh "$B"); rc=$?
echo "$out"
line=$(echo "$out" | sed -n 's/^check_cli: \([0-9]*\) passed, \([0-9]*\) failed, \([0-9]*\) skipped$/\1 \2 \3/p')
if [ -n "$line" ]; then
    set -- $line; pass=$((pass + $1)); fail=$((fail + $2)); skip=$((skip + $3))
    [ "$2" = 0 ] || failed="$failed check-cli"
else
    count check-cli 1
fi
"$B/picvr-bench-error" --self-test
count bench-self-test $?
# the viewer under Xvfb, its screenshots against picvr-render's images
DATA=${DATA:-} sh tools/check_viewer.sh "$B"
count check-viewer $?
# the test suite: cmocka's own summary, "[  PASSED  ] N test(s)." / "[  FAILED  ] N test(s)"
log=$B/picvr-tests.log
(cd "$B" && PICVR_VALIDATION=1 PICVR_DATA="$DATA" ./picvr-tests; echo $? > picvr-tests.rc) 2>&1 | tee "$log"
rc=$(cat "$B/picvr-tests.rc" 2>/dev/null || echo 1)
p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test(s)\.$/\1/p' "$log" | tail -n 1)
f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test(s).*/\1/p' "$log" | tail -n 1)
s=$(sed -n 's/^\[  SKIPPED \] \([0-9]*\) test(s).*/\1/p' "$log" | tail -n 1)
if [ -z "$p" ] && [ -z "$f" ]; then
    count picvr-tests 1      # it did not get to its summary (a crash or the watchdog)
else
    # parts of tests left out (tu_partial_skip) count as skipped too
    ps=$(sed -n 's/^picvr-tests: \([0-9]*\) partial skips$/\1/p' "$log" | tail -n 1)
    pass=$((pass + ${p:-0})); fail=$((fail + ${f:-0})); skip=$((skip + ${s:-0} + ${ps:-0}))
    [ "${f:-0}" = 0 ] || failed="$failed picvr-tests"
    # a clean summary but a failing exit (a crash at exit, a leak report): one failure more
    if [ "${f:-0}" = 0 ] && [ "$rc" != 0 ]; then count picvr-tests-exit 1; fi
fi
[ -z "$failed" ] || echo "failed:$failed"
echo "$pass passed, $fail failed, $skip skipped"
[ "$fail" = 0 ]
