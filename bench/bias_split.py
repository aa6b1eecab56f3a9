#!/usr/bin/env python3
"""bias_split.py - splits a cached image's error into the part every seed shares and
the part that changes with the seed, over the pixels that see the volume.

usage: bench/bias_split.py REF_DIR RUN.lum|RUN.pfm [RUN ...]

REF_DIR: a reference folder of picvr-bench-error (bench/refs/<key>/: chunk_*.lum.gz,
gzip-compressed grayscale PFMs of the chunks' luminance, or chunk_*.pfm, RGB); RUN: the
final images of runs of one condition with different seeds, at least two: luminance
(bench/results/<out>/runs/*_r?_warm.lum, float32, rows top to bottom) or picvr-render's
--out-float images (RUN.pfm).  The reference is the mean of its chunks, reduced to
luminance with the weights bench/error/ uses.

Pixels: those whose reference differs from the image's most common value (the
background, which every run renders exactly where no ray meets the volume).
Printed (RMS over those pixels):
  error of the mean   the mean of the runs minus the reference
  between seeds       a pixel's standard deviation over the runs
  systematic          the error of the mean with the seeds' share (variance / runs)
                      taken out: the part every seed's cache shares
  mean offset         the runs' mean luminance over those pixels against the
                      reference's, in per cent (the bias of the image's mean)
  true RMSE per run   over all pixels, as bench/error/ measures it
Standard library only (docs/cache.md, "A full cache's error floor").
"""
import glob
import gzip
import math
import os
import struct
import sys
from collections import Counter


def read_pfm_luminance(path):
    """Luminance, rows top to bottom, of an RGB PFM or a (gzipped) grayscale one."""
    with (gzip.open if path.endswith('.gz') else open)(path, 'rb') as f:
        magic = f.readline().strip()
        if magic not in (b'PF', b'Pf'):
            sys.exit('%s: not a PFM' % path)
        c = 3 if magic == b'PF' else 1
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = f.read(w * h * 4 * c)
    fmt = ('<' if scale < 0 else '>') + '%df' % (w * h * c)
    v = struct.unpack(fmt, data)
    lum = v if c == 1 else [0.2126 * v[3 * i] + 0.7152 * v[3 * i + 1] + 0.0722 * v[3 * i + 2]
                            for i in range(w * h)]
    return [lum[(h - 1 - y) * w + x] for y in range(h) for x in range(w)], w, h


def read_lum(path, n):
    with open(path, 'rb') as f:
        data = f.read()
    if len(data) != 4 * n:
        sys.exit('%s: %d bytes, expected %d' % (path, len(data), 4 * n))
    return struct.unpack('<%df' % n, data)


def read_run(path, w, h):
    if path.endswith('.pfm'):
        lum, rw, rh = read_pfm_luminance(path)
        if (rw, rh) != (w, h):
            sys.exit('%s: %dx%d, the reference is %dx%d' % (path, rw, rh, w, h))
        return lum
    return read_lum(path, w * h)


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    chunks = sorted(glob.glob(os.path.join(sys.argv[1], 'chunk_*.lum.gz')) +
                    glob.glob(os.path.join(sys.argv[1], 'chunk_*.pfm')))
    if not chunks:
        sys.exit('%s: no chunk_*.lum.gz or chunk_*.pfm' % sys.argv[1])
    ref, w, h = None, 0, 0
    for c in chunks:
        lum, w, h = read_pfm_luminance(c)
        ref = lum if ref is None else [a + b for a, b in zip(ref, lum)]
    ref = [a / len(chunks) for a in ref]
    n = w * h
    runs = [read_run(p, w, h) for p in sys.argv[2:]]
    k = len(runs)
    background = Counter(ref).most_common(1)[0][0]
    pixels = [i for i in range(n) if ref[i] != background]
    if not pixels:
        sys.exit('no pixel sees the volume')
    se = var = mean_ref = mean_run = 0.0
    for i in pixels:
        m = sum(r[i] for r in runs) / k
        se += (m - ref[i]) ** 2
        var += sum((r[i] - m) ** 2 for r in runs) / (k - 1)
        mean_ref += ref[i]
        mean_run += m
    p = len(pixels)
    print('%d runs, %d of %d pixels see the volume (mean reference %.4f)'
          % (k, p, n, mean_ref / p))
    print('error of the mean %.4f  between seeds %.4f  systematic %.4f'
          % (math.sqrt(se / p), math.sqrt(var / p), math.sqrt(max(se - var / k, 0.0) / p)))
    # mean_ref > 0: a pixel that sees the volume differs from the background, and
    # luminance is never negative; the guard keeps an all-black reference printable.
    offset = 100.0 * (mean_run / mean_ref - 1.0) if mean_ref > 0 else 0.0
    rmse = [math.sqrt(sum((r[i] - ref[i]) ** 2 for i in range(n)) / n) for r in runs]
    print('mean offset %+.2f %%  true RMSE per run %s'
          % (offset, ' '.join('%.4f' % e for e in rmse)))


if __name__ == '__main__':
    main()
