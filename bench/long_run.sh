#!/bin/sh
# bench/long_run.sh - when does the irradiance cache start to pay on this machine?
# (issues 3 and 5).  Bonsai under one area light (paper1), plain Monte Carlo against the
# cache with object-space locking, one long run each from an empty cache (default 600 s,
# 128x128, priorities on).  The §6 scheduler gives entry creation a fixed share of the
# time (5-15 % by the hit rate), so the cache grows at a rate set by the device, not by
# the image; this run shows how the hit rate, the entry count and the ratio of the
# estimated errors (Eq. 5, image mean, plain / cached at equal time; above 1: the cache
# wins) develop over minutes.  No reference is needed (picvr-bench-error, bench/error/,
# showed that Eq. 5 ranks the conditions like the true error).  Writes bench/results/long_run.csv.
#
# usage: bench/long_run.sh [SECONDS, default 600] [SIZE, default 128x128]
set -eu
SECS=${1:-600}
SIZE=${2:-128x128}
B=build
DATA=${DATA:-../shared/data}
OUT=bench/results
mkdir -p "$OUT"
VOL="$DATA/bonsai_256x256x256_uint8.raw.gz"
for cache in off object; do
    echo "bonsai paper1 $SIZE, cache $cache: $SECS s" >&2
    "$B/picvr-render" --volume "$VOL" --tf ct-bonsai --lights paper1 --size "$SIZE" \
        --time "$((SECS * 1000))" --round 1000 --cache "$cache" --quiet \
        --log "$OUT/long_run_$cache.csv" > /dev/null
done
# Join at equal times: for each logged second of the cached run, the plain run's error
# interpolated linearly in time (columns of picvr-render --log: 2 elapsed_ms, 3
# iterations, 4 est_error, 7 hit_rate, 8 cache_entries, 9 cache_refs).
awk -F, 'FNR == 1 { next }
     FILENAME ~ /_off/ { n++; pt[n] = $2; pe[n] = $4; pi[n] = $3; next }
     { t = $2; j = 1; while (j < n && pt[j + 1] < t) j++;
       if (j >= n || t < pt[1] || $4 <= 0) next;     # no sample yet: no ratio
       f = (t - pt[j]) / (pt[j + 1] - pt[j]); e = pe[j] + f * (pe[j + 1] - pe[j]);
       it = pi[j] + f * (pi[j + 1] - pi[j]);
       printf "%.1f,%.6g,%.6g,%.4f,%.4f,%d,%d,%.0f,%d\n", t / 1000, e, $4, e / $4, $7, $8, $9, it, $3 }
     BEGIN { print "t_s,est_error_plain,est_error_cached,ratio_est,hit_rate,entries,refs,iterations_plain,iterations_cached" }' \
    "$OUT/long_run_off.csv" "$OUT/long_run_object.csv" > "$OUT/long_run.csv"
echo
echo "bonsai, paper1, $SIZE: plain vs cache (object space), ratio_est = plain / cached est_error (> 1: the cache wins)"
awk -F, 'function show() { printf "%8s %14s %16s %9s %8s %8s %8s %16s %17s\n", $1, $2, $3, $4, $5, $6, $7, $8, $9 }
         NR == 1 || $1 + 0 == 10 || $1 + 0 == 30 || ($1 + 0) % 60 < 1 && $1 + 0 >= 60 { show(); shown = NR }
         { last = $0 } END { if (shown != NR) { $0 = last; show() } }' "$OUT/long_run.csv"
