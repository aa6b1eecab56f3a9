#!/bin/sh
# tools/check_layout.sh - the host (host/internal.h, picvr.h) mirrors the shaders' buffer
# layouts and a few constants; this checks that they agree, so that a change on one
# side cannot silently corrupt the other (`make check-layout`, part of `make test`).
#   buffer blocks: the size glslang's reflection gives for each block of
#                  shaders/cache_create.comp (one array element for the pools) against
#                  the host's sizeof / byte constants, and the offset of every member
#                  of the cache's counter block and of the Scene uniform block against
#                  picvr_cache_counters and picvr_gpu_scene;
#   constants:     the VIEW_* numbers of shaders/views.glsl against picvr.h's
#                  picvr_debug_view, CACHE_NODE_RADII of shaders/cache.glsl against
#                  host/internal.h's, EVENT_WORDS and EVENT_GROUP of shaders/render.glsl
#                  (the rendering procedure's event queues), PATH_STEPS of
#                  shaders/limits.glsl and MS_LANE_SAMPLES of shaders/cache_create.comp
#                  against host/internal.h's;
#   specialization constants: every `layout(constant_id = N)` is in
#                  shaders/specialization.glsl, the ids are 0 .. n-1, and each name's id
#                  equals host/internal.h's PICVR_SPEC_<name>, with no name on one side
#                  only (the host fills the constants by those ids: host/pipelines.c).
# usage: tools/check_layout.sh HOST_PRINTER (the built tools/layout_host.c)
set -eu
HOST=$1
GLSLANG=${GLSLANG:-glslangValidator}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$HOST" > "$tmp/host"
"$GLSLANG" -V --target-env vulkan1.1 -Ishaders -q -o "$tmp/x.spv" shaders/cache_create.comp > "$tmp/refl"
# "Block: offset -1, type ffffffff, size N, ..." -> "Block N"
sed -n 's/^\([A-Za-z]*\): offset -1, type ffffffff, size \([0-9]*\),.*/\1 \2/p' "$tmp/refl" > "$tmp/shader"
# the members of the counter block and of the scene's uniform block: each kernel
# reflects those it uses, so all kernels
for f in shaders/*.comp; do
    "$GLSLANG" -V --target-env vulkan1.1 -Ishaders -q -o "$tmp/y.spv" "$f"
done | sed -n 's/^\(CacheCounters\.[a-z_]*\|Scene\.[a-z_0-9.]*\): offset \([0-9]*\),.*/\1 \2/p' | sort -u >> "$tmp/shader"
for v in VIEW_IMAGE VIEW_CACHE VIEW_CACHE_ERROR; do
    sed -n "s/^#define $v \([0-9]*\)u.*/$v \1/p" shaders/views.glsl
done >> "$tmp/shader"
sed -n 's/^#define CACHE_NODE_RADII \([0-9.]*\).*/CACHE_NODE_RADII \1/p' shaders/cache.glsl |
    awk '{ printf "%s %g\n", $1, $2 }' >> "$tmp/shader"
for v in EVENT_WORDS EVENT_GROUP; do
    sed -n "s/^#define $v \([0-9]*\)u.*/$v \1/p" shaders/render.glsl
done >> "$tmp/shader"
sed -n "s/^#define PATH_STEPS \([0-9]*\)u.*/PATH_STEPS \1/p" shaders/limits.glsl >> "$tmp/shader"
sed -n "s/^const uint MS_LANE_SAMPLES = \([0-9]*\)u;.*/MS_LANE_SAMPLES \1/p" shaders/cache_create.comp >> "$tmp/shader"
fail=0
# the specialization constants: "SPEC.NAME ID" per declaration, and their number
SPEC=shaders/specialization.glsl
sed -n 's/^layout(constant_id = \([0-9]*\)) const [a-z]* \([A-Z_0-9]*\) = .*/SPEC.\2 \1/p' "$SPEC" > "$tmp/spec"
if grep -nE '^[^/]*constant_id' shaders/*.glsl shaders/*.comp | grep -v "^$SPEC:" >&2; then
    echo "check-layout: specialization constants declared outside $SPEC (above)" >&2; fail=1
fi
if [ "$(grep -cE '^[^/]*constant_id' "$SPEC")" != "$(wc -l < "$tmp/spec")" ]; then
    echo "check-layout: a declaration in $SPEC is not of the form" \
         "'layout(constant_id = N) const TYPE NAME = ...;'" >&2; fail=1
fi
if [ "$(cut -d' ' -f2 "$tmp/spec" | sort -n | tr '\n' ' ')" != "$(seq 0 $(($(wc -l < "$tmp/spec") - 1)) | tr '\n' ' ')" ]; then
    echo "check-layout: the ids in $SPEC are not 0 .. n-1, each once" >&2; fail=1
fi
while read -r name value; do
    grep -q "^$name " "$tmp/host" ||
        { echo "check-layout: $name (constant_id $value) has no PICVR_SPEC_ id on the host" >&2; fail=1; }
done < "$tmp/spec"
cat "$tmp/spec" >> "$tmp/shader"
echo "SPEC_CONSTANTS $(wc -l < "$tmp/spec")" >> "$tmp/shader"
while read -r name value; do
    got=$(awk -v n="$name" '$1 == n { print $2 }' "$tmp/shader")
    if [ -z "$got" ]; then
        echo "check-layout: $name not found in the shaders" >&2; fail=1
    elif [ "$got" != "$value" ]; then
        echo "check-layout: $name: shaders $got, host $value" >&2; fail=1
    fi
done < "$tmp/host"
[ "$fail" = 0 ] || exit 1
echo "host layouts match the shaders ($(wc -l < "$tmp/host") items)"
