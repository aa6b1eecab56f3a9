#!/bin/sh
# image_hashes.sh RENDER [DATA] - SHA-256 of four deterministic renders (a fixed seed and
# iteration count, float output): the bonsai plain and with the object-space cache, the
# cloud with unlimited bounces, the MRI with a clip plane.  A refactoring must leave all
# four unchanged; compare the output of the build before and after it.  The cached scene
# renders 4 iterations, which picvr-render submits in one step: its image is then
# independent of the timing that decides how many entries each round creates (the
# lookups all miss and request), so it is reproducible; longer cached runs are not.
# RENDER: a picvr-render binary; DATA: the data folder (default ../shared/data), whose
# bonsai is used when present, else the repository's cloud only.
set -eu
R=$1
DATA=${2:-../shared/data}
OUT=${TMPDIR:-/tmp}/picvr-hashes.$$
mkdir -p "$OUT"
trap 'rm -rf "$OUT"' EXIT
run() {   # name, iterations, options...
    name=$1; n=$2; shift 2
    "$R" "$@" --seed 7 --iterations "$n" --out-float "$OUT/$name.pfm" --out "$OUT/$name.png" >/dev/null 2>&1 \
        || { echo "$name: render failed"; return 0; }
    echo "$(sha256sum < "$OUT/$name.pfm" | cut -c1-16)  $name"
}
B=$DATA/bonsai_256x256x256_uint8.raw.gz
CLOUD=$DATA/wdas_cloud_sixteenth_126x86x154_float32.raw.gz
[ -f data/wdas_cloud_sixteenth_126x86x154_float32.raw.gz ] && CLOUD=data/wdas_cloud_sixteenth_126x86x154_float32.raw.gz
MRI=/usr/share/mricron/templates/ch2.nii.gz
if [ -f "$B" ]; then
    run bonsai-plain 12 --volume "$B" --tf ct-bonsai --lights studio --size 96x96
    run bonsai-cached 4 --volume "$B" --tf ct-bonsai --lights studio --size 96x96 --cache object
fi
run cloud-unlimited 12 --volume "$CLOUD" --tf cloud --lights sun-sky --bounces unlimited --size 96x64
[ -f "$MRI" ] && run mri-clip 12 --volume "$MRI" --clip-plane -1,0,0,0 --size 80x80
