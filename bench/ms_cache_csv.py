#!/usr/bin/env python3
"""ms_cache_csv.py OUT - the multiply scattered cache's summary (`make bench-ms`).

Reads OUT/table2.csv (plain/cached true-error ratios, picvr-bench-error) and OUT/bias.csv
(the final images' relative bias in mean luminance against the reference) and writes to
stdout one row per scene x device x condition:
    dataset,size,device,condition,run_s,ratio_true,ratio_true_worst,bias_rel,
    bias_rel_stderr,hit_rate
ratio_true: plain's true error over the condition's, averaged over the run at equal
time; ratio_true_worst: its smallest value at any time; plain's own row has ratio 1.
"""
import csv
import sys


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: ms_cache_csv.py OUT")
    out = sys.argv[1]
    with open(f"{out}/table2.csv", newline="") as f:
        ratios = list(csv.DictReader(f))
    with open(f"{out}/bias.csv", newline="") as f:
        bias = list(csv.DictReader(f))
    by_scene = {(r["dataset"], r["size"], r["condition"]): r for r in ratios}
    device = {(r["dataset"], r["size"]): r["device"] for r in ratios}
    w = csv.writer(sys.stdout, lineterminator="\n")
    w.writerow(["dataset", "size", "device", "condition", "run_s", "ratio_true", "ratio_true_worst",
                "bias_rel", "bias_rel_stderr", "hit_rate"])
    for b in bias:
        key = (b["dataset"], b["size"], b["condition"])
        r = by_scene.get(key)
        if b["condition"] == "plain":
            ratio, worst = "1", "1"
        elif r is not None:
            ratio, worst = r["ratio_true"], r["ratio_true_worst"]
        else:
            continue
        w.writerow([b["dataset"], b["size"], device.get((b["dataset"], b["size"]), ""), b["condition"],
                    b["run_s"], ratio, worst, b["rel_mean_bias"], b["rel_mean_bias_stderr"], b["hit_rate"]])


if __name__ == "__main__":
    main()
