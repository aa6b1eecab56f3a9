#!/bin/sh
# check_cli.sh BUILD_DIR - picvr-render's command line, on a tiny volume in a temporary
# folder: bad option values are refused with a message and exit status 2; --env files
# it cannot read (missing, empty, not .hdr, OpenEXR, truncated, corrupt, all black) with
# a message and status 1, never a crash or a hang; the scattering and environment
# options render (lavapipe: seconds) and reach the JSON.  Ends with one line
# "check_cli: N passed, N failed, N skipped" (skipped: the checks that read a volume of
# the optional data folder, $DATA or ../shared/data, when it lacks that file); exit
# status 1 if anything failed.
set -u
B=${1:-build}
R=$B/picvr-render
DATA_DIR=${DATA:-../shared/data}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
pass=0
fail=0
skip=0
# skipped N WHAT: N checks need a file of the data folder that is not there
skipped() { skip=$((skip + $1)); echo "check_cli: $1 skipped ($2 not in $DATA_DIR)"; }

# expect STATUS PATTERN ARGS...: picvr-render ARGS exits with STATUS and its stderr (its
# stdout for status 0) has a line matching PATTERN.
expect() {
    want=$1 pattern=$2
    shift 2
    timeout 120 "$R" "$@" > "$T/out" 2> "$T/err"
    rc=$?
    [ "$want" = 0 ] && cp "$T/out" "$T/err"
    if [ "$rc" = "$want" ] && grep -q -e "$pattern" "$T/err"; then
        pass=$((pass + 1))
    else
        fail=$((fail + 1))
        echo "check_cli: FAIL (status $rc, expected $want and /$pattern/): picvr-render $*"
        sed 's/^/    /' "$T/err" | head -n 5
    fi
}

# The volume: 4x4x4 voxels of 255.  Maps: 4x2 flat RGBE texels of 1.0 (width < 8), and
# 8x2 in new-style RLE (a run of 8 per component per row).
V="$T/cube_4x4x4_uint8.raw"
printf '\377%.0s' $(seq 64) > "$V"
HEAD='#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n'
printf "$HEAD-Y 2 +X 4\n" > "$T/flat.hdr"
printf '\200\200\200\201%.0s' $(seq 8) >> "$T/flat.hdr"
printf "$HEAD-Y 2 +X 8\n" > "$T/rle.hdr"
printf '\002\002\000\010\210\200\210\200\210\200\210\201%.0s' 1 2 >> "$T/rle.hdr"
head -c 21 "$T/rle.hdr" > "$T/header-only.hdr"
size=$(wc -c < "$T/rle.hdr")
head -c $((size - 3)) "$T/rle.hdr" > "$T/truncated-rle.hdr"   # hangs stb_image itself
head -c $((size - 12)) "$T/rle.hdr" > "$T/truncated-row.hdr"
size=$(wc -c < "$T/flat.hdr")
head -c $((size - 1)) "$T/flat.hdr" > "$T/truncated-flat.hdr"
{ printf "$HEAD-Y 2 +X 8\n"; printf '\002\002\000\010\000\200%.0s' 1 2; } > "$T/zero-count.hdr"
{ printf "$HEAD-Y 1 +X 4\n"; printf '\000\000\000\000%.0s' 1 2 3 4; } > "$T/black.hdr"
: > "$T/empty.hdr"
printf 'not an image\n' > "$T/text.hdr"
printf '\211PNG\r\n\032\n0000' > "$T/png.hdr"
printf 'v/1\001\002\000\000\000' > "$T/map.exr"
RUN="--volume $V --size 8x8 --iterations 1 --quiet"

# usage errors: status 2
expect 2 "bad value for --bounces" $RUN --bounces -1
expect 2 "bad value for --bounces" $RUN --bounces 2.5
expect 2 "bad value for --bounces" $RUN --bounces infinite
expect 2 "bad value for --bounces" $RUN --bounces 4294967295
expect 2 "needs a value" $RUN --bounces
expect 2 "bad value for --g" $RUN --g 1
expect 2 "bad value for --g" $RUN --g -1
expect 2 "bad value for --g" $RUN --g nan
expect 2 "bad value for --g" $RUN --g 0.5x
expect 2 "bad value for --phase-back" $RUN --phase-back 0.5
expect 2 "bad value for --phase-back" $RUN --phase-back 1,0.5
expect 2 "bad value for --phase-back" $RUN --phase-back -0.3,1
expect 2 "bad value for --phase-back" $RUN --phase-back -0.3,-0.1
expect 2 "bad value for --env-intensity" $RUN --env "$T/flat.hdr" --env-intensity -1
expect 2 "bad value for --env-rotate" $RUN --env "$T/flat.hdr" --env-rotate inf
expect 2 "give --env FILE" $RUN --env-rotate 90
expect 2 "give --env FILE" $RUN --env-intensity 2
expect 2 "unknown --lights" $RUN --lights sun-skies

# --env files that cannot be used: status 1
expect 1 "cannot read .*No such file" $RUN --env "$T/missing.hdr"
expect 1 "cannot read .*directory" $RUN --env "$T"
expect 1 "the file is empty" $RUN --env "$T/empty.hdr"
expect 1 "not a Radiance .hdr" $RUN --env "$T/text.hdr"
expect 1 "not a Radiance .hdr" $RUN --env "$T/png.hdr"
expect 1 "OpenEXR is not supported" $RUN --env "$T/map.exr"
expect 1 "no size line" $RUN --env "$T/header-only.hdr"
expect 1 "truncated or corrupt" $RUN --env "$T/truncated-rle.hdr"
expect 1 "truncated or corrupt" $RUN --env "$T/truncated-row.hdr"
expect 1 "truncated or corrupt" $RUN --env "$T/truncated-flat.hdr"
expect 1 "truncated or corrupt" $RUN --env "$T/zero-count.hdr"
expect 1 "every texel is black" $RUN --env "$T/black.hdr"

# accepted: status 0, the summary line; the JSON holds the settings
expect 0 "mean_luminance" $RUN --env "$T/flat.hdr"
expect 0 "mean_luminance" $RUN --bounces unlimited --g 0.5 --phase-back -0.3,0.2 --tf cloud \
    --lights sun-sky --env "$T/rle.hdr" --env-rotate 90 --env-intensity 2 --json "$T/run.json"
for key in '"mean_path_length": ' '"max_bounces": "unlimited"' '"back_g": -0.3' \
           '"back_weight": 0.2' '"g": 0.5' '"rotation_degrees": 90' '"intensity": 2' \
           '"file": ".*rle.hdr"'; do
    if grep -q -e "$key" "$T/run.json"; then pass=$((pass + 1)); else
        fail=$((fail + 1)); echo "check_cli: FAIL: --json lacks $key"; fi
done
expect 0 "mean_luminance" $RUN --tf cloud --bounces 0 --lights sun-sky --json "$T/single.json"
for key in '"max_bounces": 0' '"g": null' '"file": null'; do
    if grep -q -e "$key" "$T/single.json"; then pass=$((pass + 1)); else
        fail=$((fail + 1)); echo "check_cli: FAIL: --json lacks $key"; fi
done
# NRRD volumes: the header gives the layout (never --dims), a bad one is refused (status
# 1), an orientation other than the identity is applied (no warning)
{ printf 'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nspacings: 1 1 2\nencoding: raw\n\n'
  printf '\377%.0s' $(seq 64); } > "$T/cube.nrrd"
{ printf 'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n'
  printf 'space directions: (0,1,0) (1,0,0) (0,0,1)\n\n'; printf '\377%.0s' $(seq 64); } > "$T/turned.nrrd"
{ printf 'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n\n'; printf 'x%.0s' $(seq 10); } > "$T/short.nrrd"
expect 0 "mean_luminance" --volume "$T/cube.nrrd" --size 8x8 --iterations 1 --quiet
expect 0 "mean_luminance" --volume "$T/turned.nrrd" --size 8x8 --iterations 1 --quiet
expect 2 "come from the file's header" --volume "$T/cube.nrrd" --dims 4,4,4 --size 8x8 --iterations 1
expect 1 "truncated" --volume "$T/short.nrrd" --size 8x8 --iterations 1 --quiet
expect 0 "mean_luminance" --volume "$T/cube.nrrd" --range auto --size 8x8 --iterations 1 --quiet
expect 2 "bad value for --range" --volume "$T/cube.nrrd" --range automatic --size 8x8 --iterations 1

# outputs in the format their extension names (magic bytes; TGA is written RLE: type 10),
# or refused; --dims that disagree with the
# name refused (a permutation would render sheared slabs without a word)
expect 2 "names no format written" $RUN --out "$T/x.exr"
expect 2 "names no format written" $RUN --out "$T/x"
expect 2 "names no format written" $RUN --out-float "$T/x.tiff"
expect 2 "needs an image format with alpha" $RUN --alpha --out "$T/x.jpg"
expect 2 "disagree with the file name" --volume "$V" --dims 4,2,8 --size 8x8 --iterations 1
expect 0 "mean_luminance" $RUN --out "$T/x.jpg" --out-float "$T/x.hdr"
expect 0 "mean_luminance" $RUN --out "$T/x.TGA" --alpha --out-float "$T/x.pfm"
expect 0 "mean_luminance" $RUN --out "$T/x.bmp" --out-float "$T/x.exr"
for f in "x.jpg ffd8ff" "x.TGA 00000a" "x.bmp 424d" "x.hdr 233f524144" "x.pfm 50460a" "x.exr 762f3101"; do
    set -- $f
    magic=$(od -An -tx1 -N $(( ${#2} / 2 )) "$T/$1" | tr -d ' \n')
    if [ "$magic" = "$2" ]; then pass=$((pass + 1)); else
        fail=$((fail + 1)); echo "check_cli: FAIL: $1 starts with $magic, not $2"; fi
done

# Scans: what picvr-render says on stderr about the file (the transfer function it chose,
# the value window, the reader's warnings), with status 0.
says() {
    pattern=$1
    shift
    if timeout 300 "$R" "$@" > "$T/out" 2> "$T/err" && grep -q -e "$pattern" "$T/err"; then
        pass=$((pass + 1))
    else
        fail=$((fail + 1))
        echo "check_cli: FAIL (expected status 0 and /$pattern/ on stderr): picvr-render $*"
        sed 's/^/    /' "$T/err" | head -n 5
    fi
}
S="--size 16x16 --iterations 2"
# a CT series in Hounsfield units (tools/make_dicom_series.py, fuel as int16 + rescale):
# ct-bone chosen from the modality; files in shuffled order
FUEL=$DATA_DIR/fuel_64x64x64_uint8.raw.gz
if [ ! -f "$FUEL" ]; then
    skipped 4 fuel_64x64x64_uint8.raw.gz
elif /usr/bin/python3 tools/make_dicom_series.py "$FUEL" "$T/dicom" > /dev/null 2>&1; then
    says "tf ct-bone (a CT)" --volume "$T/dicom" $S
    says "tf ct-bone (a CT)" --volume "$T/dicom/IM0007.dcm" $S
    says "" --volume "$T/dicom" --tf ct-lung $S
else
    fail=$((fail + 1)); echo "check_cli: FAIL: tools/make_dicom_series.py (python3-pydicom)"
fi
# a CT as NIfTI in HU (int16, written by nibabel from the fuel data: value * 8 - 1000):
# ct-bone chosen from the histogram (no modality in NIfTI)
if [ ! -f "$FUEL" ]; then
    :
elif /usr/bin/python3 -c "
import gzip, numpy as np, nibabel as nib
v = np.frombuffer(gzip.open('$DATA_DIR/fuel_64x64x64_uint8.raw.gz').read(), np.uint8).reshape(64, 64, 64)
hu = (v.astype(np.int16) * 8 - 1000).transpose(2, 1, 0)
nib.save(nib.Nifti1Image(hu, np.diag([0.8, 0.8, 1.5, 1.0])), '$T/ct.nii.gz')" 2> /dev/null; then
    says "tf ct-bone (values like Hounsfield units" "$T/ct.nii.gz" $S
else
    fail=$((fail + 1)); echo "check_cli: FAIL: a NIfTI CT could not be written (python3-nibabel)"
fi
# a T1 MRI (Debian's mricron-data): mr on its percentiles; a view; clipping
MRI=/usr/share/mricron/templates/ch2.nii.gz
if [ -f "$MRI" ]; then
    says "tf mr (a scan)" "$MRI" $S
    says "quantiles" --volume "$MRI" --view left --clip-plane 1,0,0,0 $S
    expect 1 "made for CT in Hounsfield units" --volume "$MRI" --tf ct-bone $S
    says "" --volume "$MRI" --tf ct-bone --wl 120,90 $S
fi
# the Disney cloud as OpenVDB: cloud chosen
if [ -f "$DATA_DIR/wdas_cloud_sixteenth.vdb" ]; then
    says "tf cloud (a cloud)" --volume "$DATA_DIR/wdas_cloud_sixteenth.vdb" $S --bounces 0
    expect 1 "no grid 'nothing'" --volume "$DATA_DIR/wdas_cloud_sixteenth.vdb" --grid nothing $S
else
    skipped 2 wdas_cloud_sixteenth.vdb
fi
# outputs checked before the work: an unwritable path fails before the volume is read
# (the volume here does not exist either, and is not what is reported)
for opt in --out --out-float --json --log; do
    ext=png; [ "$opt" = --out-float ] && ext=pfm
    expect 1 "cannot write $T/no-such-folder/x.$ext" --volume "$T/none_4x4x4_uint8.raw" $opt "$T/no-such-folder/x.$ext"
done
expect 1 "cannot write $T: Is a directory" $RUN --json "$T"
# a budget too short for every pixel to get a sample: it renders on until they all have one
says "rendered .* more, until every pixel had one" --volume "$V" --size 512x512 --time 1 --json "$T/short.json"
if grep -q '"pixels_unsampled": 0' "$T/short.json"; then pass=$((pass + 1)); else
    fail=$((fail + 1)); echo "check_cli: FAIL: a short budget left pixels without a sample"; fi
# transfer-function files: a good one (physical units), and refusals naming the line
printf '# HU table\nunits value\ndensity 0.5\n-1000 1 1 1 0\n300 1 0.9 0.8 0.5 0.2\n2000 1 1 1 1\n' > "$T/bone.tf"
printf '0 1 1 1 0\n0.5 2 1 1 1\n' > "$T/bad.tf"
printf '0.5 1 1 1 0\n0.2 1 1 1 1\n' > "$T/down.tf"
expect 0 "mean_luminance" $RUN --tf "$T/bone.tf" --wl 200,100
expect 1 "bad.tf:2: albedo" $RUN --tf "$T/bad.tf"
expect 1 "down.tf:2: values must not decrease" $RUN --tf "$T/down.tf"
expect 2 "unknown --tf" $RUN --tf no-such-preset
# windows, views, clipping, sizes
expect 1 "made for CT in Hounsfield units" $RUN --tf ct-bone
expect 0 "mean_luminance" $RUN --tf ct-bone --wl 200,100
expect 2 "bad value for --wl" $RUN --wl 0,100
expect 2 "not both" $RUN --wl 200,100 --range 0,1
expect 0 "mean_luminance" $RUN --view anterior
expect 0 "mean_luminance" $RUN --up +z
expect 2 "unknown --view" $RUN --view sideways
expect 2 "bad value for --up" $RUN --up z
expect 2 "give --view or --up" $RUN --view left --up +z
expect 0 "mean_luminance" $RUN --clip-plane 1,0,0,0 --clip-box -1,-1,-1,1,1,1
expect 2 "bad value for --clip-plane" $RUN --clip-plane 0,0,0,1
expect 2 "bad value for --clip-box" $RUN --clip-box 1,1,1,0,0,0
expect 2 "at most 8 --clip-plane" $RUN --clip-plane 1,0,0,0 --clip-plane 1,0,0,0 --clip-plane 1,0,0,0 \
    --clip-plane 1,0,0,0 --clip-plane 1,0,0,0 --clip-plane 1,0,0,0 --clip-plane 1,0,0,0 --clip-plane 1,0,0,0 \
    --clip-plane 1,0,0,0
expect 2 "picvr's largest image" --volume "$V" --size 100000x8 --iterations 1

# real-time frames: one sample per pixel at least in every frame, even at a 0 ms budget
F="--volume $V --size 40x24 --quiet"
expect 2 "give --frames, --time or --iterations" $F --frames 3 --time 100
expect 2 "give --frames, --time or --iterations" $F --frames 3 --iterations 2
expect 2 "apply to --frames" $F --orbit 5
expect 2 "apply to --frames" $F --frame-ms 16
expect 2 "bad value for --frames" $F --frames 0
expect 2 "bad value for --frames" $F --frames -2
expect 2 "bad value for --frame-ms" $F --frames 2 --frame-ms -1
expect 2 "bad value for --frame-ms" $F --frames 2 --frame-ms nan
expect 2 "bad value for --orbit" $F --frames 2 --orbit inf
expect 2 "bad value for --reuse" $F --frames 2 --reuse maybe
expect 0 "mean_luminance" $F --frames 4 --frame-ms 0 --orbit 30 --reuse on --json "$T/frames.json"
for key in '"pixels_unsampled": 0' '"count": 4' '"orbit_degrees": 30' '"pixels_unsampled_max": 0' \
           '"temporal_reuse": "on"' '"reuse_history": 16' \
           '"per_frame": \[{"ms": '; do
    if grep -q -e "$key" "$T/frames.json"; then pass=$((pass + 1)); else
        fail=$((fail + 1)); echo "check_cli: FAIL: --json lacks $key"; fi
done
# The light field: its options refused out of range; --render field deterministic (two
# seeds, the same PNG, byte for byte); field-mc renders for a time.
expect 2 "bad value for --render" $F --render fields
expect 2 "bad value for --field-ratio" $F --render field --field-ratio 9
expect 2 "bad value for --field-directions" $F --render field --field-directions 33
expect 2 "bad value for --field-step" $F --render field --field-step 0.1
expect 2 "leave --time and --iterations out" $F --render field --time 100
expect 2 "renders without the cache" $F --render field --cache object
expect 0 "mean_luminance" $F --render field --bounces unlimited --seed 1 --out "$T/field1.png"
expect 0 "mean_luminance" $F --render field --bounces unlimited --seed 9 --out "$T/field9.png" --json "$T/field.json"
if cmp -s "$T/field1.png" "$T/field9.png"; then pass=$((pass + 1)); else
    fail=$((fail + 1)); echo "check_cli: FAIL: --render field differs between seeds"; fi
if grep -q '"field_builds": 1' "$T/field.json"; then pass=$((pass + 1)); else
    fail=$((fail + 1)); echo "check_cli: FAIL: --json lacks field_builds 1"; fi
expect 0 "mean_luminance" $F --render field-mc --bounces unlimited --time 200
for key in '--bounces N|unlimited' '--g G' '--phase-back G,W' '--env FILE' '--env-rotate DEG' \
           '--env-intensity X' 'sun-sky' 'cloud-iso' '--frames N' '--frame-ms MS' '--orbit DEG' '--reuse on|off' \
           '--render mc|field|field-mc' '--field-ratio N' '--field-directions D' '--field-step S'; do
    expect 0 "$key" --help
done

echo "check_cli: $pass passed, $fail failed, $skip skipped"
[ "$fail" = 0 ]
