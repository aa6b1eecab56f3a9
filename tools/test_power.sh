#!/bin/sh
# test_power.sh - `make test-power`: shows that the statistical tests can fail.  For each
# deliberate error of POWER_MUTATIONS (NAME:ID:FACTOR, shaders/mutation.glsl; the
# Makefile built BP/NAME/picvr-tests with it) the statistical tests run one at a time,
# in the order below, until one fails: that test caught the mutation.  A mutation that
# every test passes is a hole in the suite, and the script fails.  The unmutated build
# passing the same tests is `make test`'s job.
#
# The order puts the tests that catch the most mutations for their time first, so a
# caught mutation costs little; every test of the list still runs against a mutation
# that the earlier ones miss.  Environment: POWER_MUTATIONS, BP (the power builds'
# folder), DATA (absolute), POWER_TESTS (the tests, space-separated; default below).
set -u
BP=${BP:-build-power}
POWER_TESTS=${POWER_TESTS:-"
  test_high_resolution_white_furnace
  test_cache_extrapolation_exact_in_log_linear_light
  test_high_resolution_cache
  test_high_resolution_single_scatter
  test_high_resolution_beer_lambert
  test_single_scatter_delta_sun_coloured
  test_beer_lambert_optical_depth_5
  test_point_light_single_scatter_closed_form
  test_cache_homogeneous_sun_matches_closed_form
  test_cache_coloured_suns_match_closed_form
  test_cache_curvature_limit_matches_closed_form
  test_path_white_furnace_homogeneous
  test_path_bounces_albedo_08_match_reference
  test_path_env_smooth_map_single_scatter_closed_form
  test_rect_light_facing_closed_form_and_back_side_dark
  test_gpu_matches_cpu_reference_area_light_background
  test_gpu_matches_cpu_reference_bounces_chromatic
  test_path_cache_ms_albedo_09_match_reference
"}
missed=""
n=0
for m in $POWER_MUTATIONS; do
    name=${m%%:*}
    factor=${m##*:}
    dir=$BP/$name
    caught=""
    t0=$(date +%s)
    for t in $POWER_TESTS; do
        if ! (cd "$dir" && PICVR_TEST_FILTER="$t" PICVR_VALIDATION=1 PICVR_DATA="${DATA:-}" \
                ./picvr-tests > "$t.log" 2>&1); then
            # A name the suite lacks is the list's error, never a catch.
            if grep -q "no test matches" "$dir/$t.log"; then
                echo "test_power: no test $t in the suite"
                exit 2
            fi
            caught=$t
            break
        fi
    done
    t1=$(date +%s)
    n=$((n + 1))
    if [ -n "$caught" ]; then
        echo "test_power: $name x $factor caught by $caught ($((t1 - t0)) s; $dir/$caught.log)"
    else
        echo "test_power: $name x $factor NOT caught: every statistical test passed ($((t1 - t0)) s)"
        missed="$missed $name"
    fi
done
if [ -n "$missed" ]; then
    echo "test_power: $n mutations, not caught:$missed"
    exit 1
fi
echo "test_power: all $n mutations caught"
