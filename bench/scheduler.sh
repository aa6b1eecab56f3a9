#!/bin/sh
# bench/scheduler.sh - the scheduler benchmark (issue 4): bonsai under each of the three
# light set-ups of the paper's §8, rendered with the cache (object-space locking) with and
# without the Eq. 12 priorities, and plain Monte Carlo with and without them.  Prints the
# estimated error (image mean of the left side of Eq. 5, absolute and relative) against
# time, the measured device-time shares against the §6 targets, and how closely
# picvr_step(ROUND ms) kept its budget.  Writes bench/results/scheduler*.csv.
#
# usage: bench/scheduler.sh [SECONDS per run, default 20] [SIZE, default 128x128]
set -eu
SECS=${1:-20}
SIZE=${2:-128x128}
ROUND=100
B=build
DATA=${DATA:-../shared/data}
OUT=bench/results
mkdir -p "$OUT"
VOL="$DATA/bonsai_256x256x256_uint8.raw.gz"
SUMMARY="$OUT/scheduler.csv"
echo "lights,cache,priorities,t_s,est_error,est_rel_error,hit_rate,entries,fraction_render,fraction_create,fraction_update,target_create,target_update" > "$SUMMARY"

# est_error etc. at the first logged round at or after t seconds (the last round for the
# run's full length; columns of picvr-render --log)
at_time() {
    awk -F, -v t="$2" 'NR > 1 && $2 >= t * 1000 { print; found = 1; exit } NR > 1 { last = $0 }
                      END { if (!found && t * 1000 >= '"$((SECS * 1000))"') print last }' "$1"
}

for lights in paper1 paper3 paper4; do
    for cache in object off; do
        for prio in on off; do
            log="$OUT/scheduler_${lights}_${cache}_${prio}.csv"
            echo "bonsai $lights, cache $cache, priorities $prio: ${SECS} s at $SIZE" >&2
            "$B/picvr-render" --volume "$VOL" --tf ct-bonsai --lights "$lights" --size "$SIZE" \
                --time "$((SECS * 1000))" --round "$ROUND" --cache "$cache" --priorities "$prio" \
                --quiet --log "$log" > /dev/null
            for t in 1 2 5 10 20 40 80; do
                [ "$t" -le "$SECS" ] || continue
                row=$(at_time "$log" "$t")
                [ -n "$row" ] || continue
                echo "$row" | awk -F, -v l="$lights" -v c="$cache" -v p="$prio" -v t="$t" \
                    '{ printf "%s,%s,%s,%d,%s,%s,%s,%s,%s,%s,%s,%s,%s\n", l, c, p, t, $4, $5, $7, $8, $10, $11, $12, $13, $14 }' >> "$SUMMARY"
            done
            # step budget: elapsed_ms per picvr_step(ROUND) call (one call per logged round)
            awk -F, -v r="$ROUND" 'NR > 2 && $2 < '"$((SECS * 1000 - ROUND))"' { d = $2 - prev; s += d; n++; e = (d - r) / r; if (e < 0) e = -e;
                if (e > m) m = e; if (e > 0.1) over++ } { prev = $2 }
                END { printf "  picvr_step(%d ms): mean %.1f ms, worst deviation %.0f%%, %d of %d calls off by more than 10%%\n",
                      r, s / n, 100 * m, over, n }' "$log" >&2
        done
    done
done

echo
echo "estimated error (Eq. 5, image mean) against time; bonsai $SIZE, lavapipe unless a GPU was chosen"
printf "%-7s %-6s %-4s %5s %10s %10s %6s %7s %s\n" lights cache prio t_s est_error rel_error hit entries "shares render/create/update (targets)"
awk -F, 'NR > 1 { printf "%-7s %-6s %-4s %5d %10.5f %10.4f %6.3f %7d %.3f/%.3f/%.3f (%.3f/%.3f)\n",
                   $1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13 }' "$SUMMARY"
