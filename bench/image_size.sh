#!/bin/sh
# bench/image_size.sh - how the cache's cost is shared by more pixels (issue 3/5):
# bonsai, one area light (paper1), plain Monte Carlo against the cache with object- and
# screen-space locking, at three image sizes, the same run time each.  The cache's cost
# (its entries) depends on the volume and the lights, not on the image, while its benefit
# (cheaper samples where it hits) grows with the number of pixels; so the ratio of the
# estimated errors (Eq. 5, image mean, plain / cached, at the end of the run; above 1:
# the cache wins) should grow with the image.  No reference is needed: this compares the
# paper's own estimate, which bench/bench_error.c showed to rank the conditions like the
# true error.  Writes bench/results/image_size.csv.
#
# usage: bench/image_size.sh [SECONDS per run, default 40] [SIZES, default "128x128 256x256 512x512"]
set -eu
SECS=${1:-40}
SIZES=${2:-128x128 256x256 512x512}
B=build
DATA=${DATA:-../shared/data}
OUT=bench/results
mkdir -p "$OUT"
VOL="$DATA/bonsai_256x256x256_uint8.raw.gz"
CSV="$OUT/image_size.csv"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
echo "size,cache,seconds,iterations,est_error,est_rel_error,hit_rate,entries,ratio_est" > "$CSV"
for size in $SIZES; do
    plain=
    for cache in off object screen; do
        echo "bonsai paper1 $size, cache $cache: ${SECS} s" >&2
        log="$TMP/${size}_$cache.csv"
        "$B/picvr-render" --volume "$VOL" --tf ct-bonsai --lights paper1 --size "$size" \
            --time "$((SECS * 1000))" --cache "$cache" --quiet --log "$log" > /dev/null
        # last logged round: iterations, est_error, est_rel_error, hit_rate, entries
        row=$(tail -n 1 "$log")
        est=$(echo "$row" | cut -d, -f4)
        [ -n "$plain" ] || plain=$est
        echo "$row" | awk -F, -v s="$size" -v c="$cache" -v t="$SECS" -v p="$plain" \
            '{ printf "%s,%s,%d,%d,%s,%s,%s,%s,%.3f\n", s, c, t, $3, $4, $5, $7, $8, p / $4 }' >> "$CSV"
    done
done
echo
echo "bonsai, paper1, ${SECS} s per run; ratio_est = plain est_error / cached est_error (> 1: the cache wins)"
awk -F, '{ printf "%-8s %-7s %8s %10s %10s %14s %9s %8s %9s\n", $1, $2, $3, $4, $5, $6, $7, $8, $9 }' "$CSV"
