#!/bin/sh
# check_viewer.sh [BUILD_DIR] - picvr-viewer (examples/viewer.cpp) on a virtual display
# (xvfb-run), against picvr-render's image of the same scene: the cloud at 160x120 from
# picvr-render's camera (the same options for both programs).  Each viewer run has the
# Khronos validation layer on (PICVR_VALIDATION=1) and fails by itself on any message
# or a frame with an unsampled pixel (picvr_stats.pixels_unsampled after each step);
# its --screenshot is the last frame's swapchain image as shown, read back.
#
# 1. Moving: ORBIT_FRAMES frames, the camera turned by 3 degrees every frame (--orbit 3),
#    a 0 ms budget: with scheduler.frames on, each frame is then exactly one pass over
#    the image (a step lasts max(budget, the rest of the pass)), on any device.  The same
#    seed, camera path and pass count give the same image (picvr.h, random numbers; the
#    viewer's temporal reuse is deterministic too), so the last frame must equal
#    picvr-render --frames N --orbit 3 --frame-ms 0 --reuse on to the byte
#    (channel order, rows, exposure, camera, lights: everything the window shows).
# 2. Still: FRAMES frames at the default 16 ms budget (--priorities off: round robin, so
#    every pixel holds the same number of samples, give or take one), which depend on
#    the machine's speed; picvr-render then renders a reference of REF_SPP samples per
#    pixel (seed 1) and a control with as many samples per pixel as the viewer's image
#    holds (its spp_mean, rounded; seed 2): the viewer's image as it should be, with
#    other random numbers, so the same noise and the same small darkening that the tone
#    curve gives a noisy image (it is concave).  The 8-bit RGB images must satisfy
#    a. mean |viewer - ref| <= 1.1 * mean |control - ref| + 0.1 (levels): the viewer's
#       image is as close to the reference as an image of its sample count is.  Over
#       57600 values the mean |difference| fluctuates by well under 1 %, and rounding
#       spp_mean moves the control's noise by under 2 % (noise ~ 1/sqrt(spp)); measured
#       ratios 0.99-1.01;
#    b. per channel, |mean(viewer - ref) - mean(control - ref)| <= 4 standard errors of
#       that difference + 0.25: no shift of brightness or colour (a swapped channel, a
#       wrong exposure or sRGB encoding, black holes).  Pixels' noise is independent
#       (picvr hashes its random numbers per pixel), so the standard error of a mean over
#       n pixels is the differences' standard deviation / sqrt(n) (0.06-0.1 levels
#       here); 0.25 levels cover the rounding to 8 bits and of spp_mean.
#    To show that the check can fail, the viewer's image with R and B swapped, and upside
#    down, must each fail it.
# 3. The light field (--render field-mc): moving, the field's image byte for byte; still,
#    Monte Carlo from it, within the noise (as in 2).
# Prints what it measured; exit status 1 on a failure.  About 50 s on 2 cores (lavapipe).
# The volume: the repository's cloud (data/).
set -u
B=${1:-build}
FRAMES=${FRAMES:-120}
ORBIT_FRAMES=${ORBIT_FRAMES:-24}
REF_SPP=${REF_SPP:-256}
V="$B/picvr-viewer"
R="$B/picvr-render"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fail() { echo "check_viewer: FAIL: $*"; exit 1; }

VOLUME=data/wdas_cloud_sixteenth_126x86x154_float32.raw.gz
[ -f "$VOLUME" ] || fail "$VOLUME not found (run from the repository root)"
command -v xvfb-run > /dev/null || fail "xvfb-run is missing (tools/install-deps.sh viewer)"
command -v python3 > /dev/null || fail "python3 is missing"
SCENE="--volume $VOLUME --spacing 3.33,3.33,3.33 --tf cloud --lights sun-sky --camera 35,-8,0.75 --size 160x120"

# viewer NAME ARGS...: picvr-viewer under Xvfb, validation on; the check fails unless it
# exits 0 (which it does only without validation messages and holes).
viewer() {
    name=$1
    shift
    # the timeout inside: xvfb-run stops its X server only when it ends by itself
    PICVR_VALIDATION=1 xvfb-run -a -s "-screen 0 1024x768x24" \
        timeout 120 "$V" $SCENE "$@" --screenshot "$T/$name.png" > "$T/$name.out" 2> "$T/$name.err"
    rc=$?
    cat "$T/$name.out"
    if [ "$rc" != 0 ]; then
        sed 's/^/    /' "$T/$name.err" | tail -n 20
        fail "picvr-viewer $* exited with status $rc"
    fi
    grep -q "validation layer on" "$T/$name.err" || fail "the validation layer was not on (vulkan-validationlayers?)"
}

# render NAME ARGS...: picvr-render's PNG of the scene.
render() {
    name=$1
    shift
    timeout 120 "$R" $SCENE "$@" --quiet --out "$T/$name.png" > "$T/$name.out" 2>&1 ||
        { cat "$T/$name.out"; fail "picvr-render $* failed"; }
}

# The comparisons, on PNGs decoded by python3's standard library.
cat > "$T/compare.py" <<'EOF'
import math, struct, sys, zlib

def read_png(path):
    """8-bit RGB or RGBA, non-interlaced (what stb_image_write writes): (w, h, rows of RGB)."""
    data = open(path, 'rb').read()
    assert data[:8] == b'\x89PNG\r\n\x1a\n', path + ': not a PNG'
    pos, idat = 8, b''
    while pos < len(data):
        n, kind = struct.unpack('>I4s', data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b'IHDR':
            w, h, depth, ctype, _, _, interlace = struct.unpack('>IIBBBBB', body)
            assert depth == 8 and ctype in (2, 6) and interlace == 0, path + ': unsupported PNG'
            bpp = 3 if ctype == 2 else 4
        elif kind == b'IDAT':
            idat += body
        pos += 12 + n
    raw, stride, prev, px = zlib.decompress(idat), w * bpp, bytearray(w * bpp), []
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        px.append([bytes(line[x * bpp:x * bpp + 3]) for x in range(w)])
        prev = line
    return w, h, px

def channels(img):
    """Per channel, the flat list of values."""
    w, h, px = img
    return [[px[y][x][c] for y in range(h) for x in range(w)] for c in range(3)]

def mean(v): return sum(v) / len(v)

def diff_stats(a, b):
    """Per channel: the mean and standard deviation of a - b; and mean |a - b| overall."""
    means, sds, mad = [], [], 0.0
    for ca, cb in zip(a, b):
        d = [x - y for x, y in zip(ca, cb)]
        m = mean(d)
        means.append(m)
        sds.append(math.sqrt(sum((x - m) ** 2 for x in d) / (len(d) - 1)))
        mad += mean([abs(x) for x in d]) / 3
    return means, sds, mad

def same(a_path, b_path):
    a, b = read_png(a_path), read_png(b_path)
    if a[:2] != b[:2]:
        print('check_viewer: FAIL: sizes %dx%d and %dx%d' % (a[0], a[1], b[0], b[1]))
        return False
    diff = [max(abs(p - q) for p, q in zip(pa, pb)) for ra, rb in zip(a[2], b[2]) for pa, pb in zip(ra, rb)]
    bad = sum(1 for d in diff if d)
    print('check_viewer: moving: the last frame and picvr-render\'s: %d of %d pixels differ (largest %d levels)'
          % (bad, len(diff), max(diff)))
    return bad == 0

def verdict(name, view, ref, ctrl_stats, show):
    n = len(ref[0])
    vm, vs, vmad = diff_stats(view, ref)
    cm, cs, cmad = ctrl_stats
    limit = 1.1 * cmad + 0.1
    ok = vmad <= limit
    if show:
        print('check_viewer: still: mean |viewer - ref| %.3f, mean |control - ref| %.3f, limit %.3f (8-bit levels)'
              % (vmad, cmad, limit))
    for c in range(3):
        se = math.sqrt((vs[c] ** 2 + cs[c] ** 2) / n)
        tol = 4 * se + 0.25
        ok = ok and abs(vm[c] - cm[c]) <= tol
        if show:
            print('check_viewer: still: %s mean(viewer - ref) %+.3f, mean(control - ref) %+.3f, |difference| %.3f, '
                  'limit %.3f (4 s.e. %.3f + 0.25)' % ('RGB'[c], vm[c], cm[c], abs(vm[c] - cm[c]), tol, 4 * se))
    if not show:
        print('check_viewer: still: the check %s %s: mean |. - ref| %.2f (limit %.2f), channel means off by %s'
              % ('rejects' if not ok else 'ACCEPTS', name, vmad, limit,
                 ', '.join('%+.2f' % (vm[c] - cm[c]) for c in range(3))))
    return ok

def within_noise(view_path, ref_path, ctrl_path, ref_spp, ctrl_spp):
    view_img, ref_img, ctrl_img = (read_png(p) for p in (view_path, ref_path, ctrl_path))
    sizes = {img[:2] for img in (view_img, ref_img, ctrl_img)}
    if len(sizes) != 1:
        print('check_viewer: FAIL: image sizes differ: %s' % sorted(sizes))
        return False
    view, ref, ctrl = channels(view_img), channels(ref_img), channels(ctrl_img)
    print('check_viewer: still: %dx%d; mean RGB: viewer %s, reference (%s spp) %s, control (%s spp) %s'
          % (view_img[0], view_img[1], ' '.join('%.1f' % mean(c) for c in view), ref_spp,
             ' '.join('%.1f' % mean(c) for c in ref), ctrl_spp, ' '.join('%.1f' % mean(c) for c in ctrl)))
    ctrl_stats = diff_stats(ctrl, ref)
    ok = verdict('the viewer', view, ref, ctrl_stats, True)
    # The check must be able to fail: R and B swapped, and the rows upside down.
    w, h, px = view_img
    wrong = [verdict('R and B swapped', [view[2], view[1], view[0]], ref, ctrl_stats, False),
             verdict('the image upside down', channels((w, h, px[::-1])), ref, ctrl_stats, False)]
    if any(wrong):
        print('check_viewer: FAIL: the check accepts a wrong image: its tolerance is too loose')
        return False
    return ok

if sys.argv[1] == 'same':
    ok = same(sys.argv[2], sys.argv[3])
else:
    ok = within_noise(*sys.argv[2:7])
sys.exit(0 if ok else 1)
EOF

# 1. moving: every frame one pass, byte for byte picvr-render's
viewer orbit --orbit 3 --frame-ms 0 --frames "$ORBIT_FRAMES"
render orbit_ref --frames "$ORBIT_FRAMES" --orbit 3 --frame-ms 0 --reuse on   # the viewer's default
python3 "$T/compare.py" same "$T/orbit.png" "$T/orbit_ref.png" ||
    fail "the viewer's moving frame is not picvr-render's"

# 2. still: progressive refinement at 16 ms a frame, within the noise of picvr-render's
viewer still --priorities off --frames "$FRAMES"
spp=$(sed -n 's/.* spp_mean=\([0-9.]*\) .*/\1/p' "$T/still.out")
[ -n "$spp" ] || fail "no spp_mean in picvr-viewer's output"
K=$(python3 -c "print(max(1, round($spp)))")
render ref --iterations "$REF_SPP" --seed 1
render control --iterations "$K" --seed 2
python3 "$T/compare.py" noise "$T/still.png" "$T/ref.png" "$T/control.png" "$REF_SPP" "$K" ||
    fail "the viewer's image differs from picvr-render's beyond the noise"
# 3. the light field, from instant to exact (--render field-mc).  Moving: every frame is
#    the field's image, byte for byte picvr-render --render field's of the same camera
#    path.  Still: Monte Carlo goes on from the field, which counts as 8 samples per
#    pixel (field.prior_samples), so after spp_mean samples in all the image is
#    (8 field + (spp - 8) samples) / spp: the variance of a sample times (spp - 8) / spp^2,
#    that of an image of spp^2 / (spp - 8) samples, which the control therefore has (the
#    same noise, so the same darkening by the tone curve); the field's share 8 / spp of
#    its own few per cent of bias moves the means by a fraction of a level.
viewer field_orbit --render field-mc --orbit 3 --frame-ms 0 --frames "$ORBIT_FRAMES"
render field_orbit_ref --render field --frames "$ORBIT_FRAMES" --orbit 3 --frame-ms 0
python3 "$T/compare.py" same "$T/field_orbit.png" "$T/field_orbit_ref.png" ||
    fail "the viewer's moving frame is not the field's image"
viewer field_still --render field-mc --priorities off --frames "$FRAMES"
spp=$(sed -n 's/.* spp_mean=\([0-9.]*\) .*/\1/p' "$T/field_still.out")
[ -n "$spp" ] || fail "no spp_mean in picvr-viewer's output"
K=$(python3 -c "s = $spp; print(max(1, round(s * s / max(s - 8, 1))))")
render field_control --iterations "$K" --seed 3
python3 "$T/compare.py" noise "$T/field_still.png" "$T/ref.png" "$T/field_control.png" "$REF_SPP" "$K" ||
    fail "the viewer's image from the field differs from Monte Carlo's beyond the noise"
echo "check_viewer: ok: the viewer shows picvr-render's images (moving: the same bytes; still: within the noise;"
echo "check_viewer: ok: the field: moving, its image; still, Monte Carlo from it)"
