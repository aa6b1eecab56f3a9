#!/bin/sh
# check_build.sh BUILD_DIR - the library builds as an application would build it:
#   1. picvr_vk.c on its own with gcc and clang, as C99, C11 and C++17, with
#      $STRICT (no feature macro, no -Wno-*), -Werror;
#   2. the one-file form: a C++17 program that defines PICVR_IMPLEMENTATION before
#      including picvr.h, compiled with the same flags, renders a small volume and checks
#      the result (tools/one_file_test.cpp); and a C99 one (tools/one_file_test.c) whose
#      own headers come first, so the library's clock falls back to what strict ISO C
#      declares, renders for a time budget.
# Prints one line per build and "check_build: N passed, N failed"; exits 1 on a failure.
set -u
B=$1
D=$B/build-check
mkdir -p "$D"
STRICT="-Wall -Wextra -Wpedantic -Wshadow -Werror"
pass=0
fail=0
run() {   # name, command...
    name=$1; shift
    if "$@" > "$D/$name.log" 2>&1; then
        pass=$((pass + 1)); echo "check_build: ok   $name"
    else
        fail=$((fail + 1)); echo "check_build: FAIL $name"; sed 's/^/    /' "$D/$name.log" | head -40
    fi
}
for cc in gcc clang; do
    for std in c99 c11; do
        run "$cc-$std" $cc -std=$std $STRICT -O1 -I. -c picvr_vk.c -o "$D/$cc-$std.o"
    done
done
run "g++-c++17" g++ -x c++ -std=c++17 $STRICT -O1 -I. -c picvr_vk.c -o "$D/g++-c++17.o"
run "clang++-c++17" clang++ -x c++ -std=c++17 $STRICT -O1 -I. -c picvr_vk.c -o "$D/clang++-c++17.o"
run "one-file-c++17-build" g++ -std=c++17 $STRICT -O1 -I. -o "$D/one_file_test" tools/one_file_test.cpp -lvulkan -lm
run "one-file-c++17-render" env PICVR_VALIDATION=1 "$D/one_file_test"
for cc in gcc clang; do
    run "one-file-$cc-c99" $cc -std=c99 $STRICT -O1 -I. -o "$D/one_file_test_$cc" tools/one_file_test.c -lvulkan -lm
    run "one-file-$cc-c99-step" env PICVR_VALIDATION=1 "$D/one_file_test_$cc"
done
echo "check_build: $pass passed, $fail failed"
[ "$fail" = 0 ]
