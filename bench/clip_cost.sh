#!/bin/sh
# bench/clip_cost.sh - what clipping costs, off and on, side by side (docs/medical.md).
# Renders the bonsai (ct-bonsai, studio lights, 256x256, a fixed number of iterations)
# with no clip, one plane that cuts nothing and eight that cut nothing, in turns, R rounds;
# with OLD=DIR/picvr-render (a build from before clipping existed) also that build, so
# that "off" is compared with no clipping code at all.  Prints samples/s per run and the
# median of each condition.  usage: bench/clip_cost.sh [BUILD] (default build)
set -eu
B=${1:-build}
DATA=${DATA:-../shared/data}
R=${R:-3}
V="$DATA/bonsai_256x256x256_uint8.raw.gz"
ARGS="--tf ct-bonsai --lights studio --size 256x256 --iterations 48 --quiet"
P="--clip-plane 1,0,0,1e6"
P8="$P $P $P $P $P $P $P $P"
out=$(mktemp)
trap 'rm -f "$out"' EXIT
run() {   # name, binary, extra args
    name=$1 bin=$2
    shift 2
    sps=$("$bin" --volume "$V" $ARGS "$@" | sed -n 's/.*(\([0-9.e+]*\) samples\/s).*/\1/p')
    echo "$name $sps" | tee -a "$out"
}
for i in $(seq "$R"); do
    [ -n "${OLD:-}" ] && run before "$OLD"
    run off "$B/picvr-render"
    run one_plane "$B/picvr-render" $P
    run eight_planes "$B/picvr-render" $P8
done
for c in before off one_plane eight_planes; do
    awk -v c="$c" '$1 == c { print $2 }' "$out" | sort -g |
        awk -v c="$c" '{ v[NR] = $1 } END { if (NR) printf "%-13s median %.4g samples/s over %d runs\n", c, v[int((NR + 1) / 2)], NR }'
done
