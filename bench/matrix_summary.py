#!/usr/bin/env python3
"""matrix_summary.py - the Table 2 matrix of picvr-bench-error summed up for docs/table2.md.

usage: bench/matrix_summary.py OUT   (OUT: a results folder, e.g. bench/results/full)

Reads OUT/table2.csv and the run files OUT/runs/*_r<N>.csv, and prints Markdown:
  1. per condition, over all rows: the median, smallest and largest mean true-error
     ratio (plain / condition), the smallest ratio_true_worst and how many rows have
     ratio_true_worst >= 0.95;
  2. per scene: each condition's mean ratio and worst; the object-space cache's mean
     ratio over that of the same renderer without the cache (plain-prio, else auto: the
     cache's own effect, priorities taken out); and what explains a loss: its final hit rate and its image passes per second against a
     condition with the same priorities and no cache (plain-prio, else auto, whose
     rounds are plain until its cache pays), final iterations / final time of each run,
     averaged over the repeats.  Not against plain: with priorities off every block
     gets its turn, and blocks that see only background cost nearly nothing, so plain
     draws more passes per second for reasons that have nothing to do with the cache.
     And the hit rate at which the cache would break even, at best: a cached sample's
     variance is (1 - h g) times a plain one's (h the hit rate, g <= 1 the share of a
     sample's variance a hit removes: host/schedule.c, picvr_auto_efficiency), so with r
     the passes-per-second ratio the cache pays only where h g > 1 - r, which needs a hit
     rate of at least 1 - r even if a hit removed all of a sample's noise.
Standard library only.
"""
import csv
import glob
import os
import statistics
import sys
from collections import defaultdict


def final_rate(path):
    """Iterations per second at the end of one run file (comment lines skipped)."""
    rows = [r for r in csv.reader(l for l in open(path) if not l.startswith('#'))]
    if len(rows) < 2:
        return None
    head, last = rows[0], rows[-1]
    t, it = float(last[head.index('t_ms')]), float(last[head.index('iterations')])
    return it / (t / 1e3) if t > 0 else None


def rates(out):
    """{(scene id, condition): mean samples/s over repeats} from OUT/runs."""
    acc = defaultdict(list)
    for p in glob.glob(os.path.join(out, 'runs', '*_r[0-9].csv')):
        name = os.path.basename(p)[:-len('.csv')]
        stem, _ = name.rsplit('_r', 1)              # <scene>_<hash>_<cond>
        scene_hash, cond = stem.rsplit('_', 1)
        scene, _ = scene_hash.rsplit('_', 1)        # <dataset>_<lights>_<size>
        r = final_rate(p)
        if r:
            acc[(scene, cond)].append(r)
    return {k: sum(v) / len(v) for k, v in acc.items()}


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    rows = list(csv.DictReader(open(os.path.join(out, 'table2.csv'))))
    rate = rates(out)
    conds = []
    for r in rows:
        if r['condition'] not in conds:
            conds.append(r['condition'])
    print('| condition | rows | median ratio | smallest | largest | smallest worst | '
          'rows with worst >= 0.95 |')
    print('|---|---|---|---|---|---|---|')
    for c in conds:
        rs = [r for r in rows if r['condition'] == c]
        ratio = [float(r['ratio_true']) for r in rs]
        worst = [float(r['ratio_true_worst']) for r in rs]
        print('| `%s` | %d | %.2f | %.2f | %.2f | %.2f | %d of %d |' % (
            c, len(rs), statistics.median(ratio), min(ratio), max(ratio), min(worst),
            sum(w >= 0.95 for w in worst), len(rs)))
    print()
    base = 'plain-prio' if 'plain-prio' in conds else 'auto'
    cols = ' | '.join('`%s` ratio (worst)' % c for c in conds)
    print('| dataset | lights | background | %s | object vs %s | hit rate (object) | '
          'passes/s, object vs %s | break-even hit rate, at least |' % (cols, base, base))
    print('|---|---|---|' + '---|' * len(conds) + '---|---|---|---|')
    scenes = []
    for r in rows:
        key = (r['dataset'], r['lights'], r['background'], r['size'])
        if key not in scenes:
            scenes.append(key)
    for d, l, b, size in scenes:
        cells, hit, speed, even, vs = [], '-', '-', '-', '-'
        ratio = {}
        light_id = l + ('-bg' if b == 'on' else '')
        scene = '%s_%s_%s' % (d, light_id, size)
        for c in conds:
            m = [r for r in rows if (r['dataset'], r['lights'], r['background'], r['size'],
                                     r['condition']) == (d, l, b, size, c)]
            cells.append('%.2f (%.2f)' % (float(m[0]['ratio_true']), float(m[0]['ratio_true_worst']))
                         if m else '-')
            if m:
                ratio[c] = float(m[0]['ratio_true'])
            if m and c == 'object':
                hit = '%.2f' % float(m[0]['final_hit_rate'])
        p, o = rate.get((scene, base)), rate.get((scene, 'object'))
        if p and o:
            speed = '%.2f' % (o / p)
            even = '%.2f' % max(0.0, 1.0 - o / p)
        if 'object' in ratio and base in ratio:
            vs = '%.2f' % (ratio['object'] / ratio[base])
        print('| %s | %s | %s | %s | %s | %s | %s | %s |' % (d, l, b, ' | '.join(cells), vs, hit,
                                                            speed, even))


if __name__ == '__main__':
    main()
