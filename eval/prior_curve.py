#!/usr/bin/env python3
"""The prior's held-out curve: 2D scores of several prior checkpoints on validation splits (stdlib).

Each point is a folder of `mf eval-prior` outputs, one sub-folder per split (table2d.csv: per-view
records; on a 3D split also objects.csv). Views are grouped into objects (a 3D split: objects.csv;
a test-2d-layout split: consecutive runs of --views-per-object sample indices), so every mean, CI
and paired test is over objects, not over correlated views.

Writes OUT/objects.csv (method@label, split, object, metric, per-object mean: the input of
`mf compare`, which pairs each point with the reference) and OUT/README.md (means ± 95% CI per
point and split; paired differences from OUT/<split>/<model>/paired.csv, which `mf compare --ref
<model>@<ref>` writes between the two calls).

usage: prior_curve.py -o OUT --split NAME [--split ...] --point LABEL STEPS DIR [--point ...]
                      [--ref LABEL] [--views-per-object 4] [--readme-only] [--caption TEXT]
"""
import argparse
import collections
import csv
import os
import sys

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from frontier import mean_ci  # noqa: E402

MODELS = ["StableMaterial", "StableMaterialMV"]
FREE = {"albedo_psnr": ["Retinex", "Input image"], "orm_psnr": ["Train-mean ORM"]}
METRICS = ["albedo_psnr", "orm_psnr"]


def per_object(folder, vpo):
    """{(method, object): {metric: mean over its views}} of one eval-prior output folder."""
    objs = os.path.join(folder, "objects.csv")
    src = objs if os.path.exists(objs) else os.path.join(folder, "table2d.csv")
    acc = collections.defaultdict(lambda: collections.defaultdict(list))
    with open(src) as f:
        for r in csv.DictReader(f):
            obj = r["scene"] if src == objs else "%03d" % (int(r["scene"]) // vpo)
            acc[(r["method"], obj)][r["metric"]].append(float(r["value"]))
    return {k: {m: sum(v) / len(v) for m, v in d.items()} for k, d in acc.items()}


def fmt(m, ci):
    return "%.2f ± %.2f" % (m, ci) if ci == ci else "%.2f" % m


def paired_rows(out, split, model):
    path = os.path.join(out, split, model, "paired.csv")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return {(r["method"], r["metric"]): r for r in csv.DictReader(f)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("-o", required=True)
    ap.add_argument("--split", action="append", required=True)
    ap.add_argument("--point", nargs=3, action="append", required=True, metavar=("LABEL", "STEPS", "DIR"))
    ap.add_argument("--ref", help="reference point of the paired differences (default the first)")
    ap.add_argument("--views-per-object", type=int, default=4)
    ap.add_argument("--readme-only", action="store_true", help="only the README (after mf compare)")
    ap.add_argument("--caption", default="")
    a = ap.parse_args()
    ref = a.ref or a.point[0][0]
    data = {(lab, s): per_object(os.path.join(d, s), a.views_per_object) for lab, _, d in a.point for s in a.split}
    os.makedirs(a.o, exist_ok=True)
    if not a.readme_only:
        tmp = os.path.join(a.o, "objects.csv.tmp")
        with open(tmp, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["method", "dataset", "scene", "metric", "value"])
            for (lab, s), d in data.items():
                for (method, obj), ms in sorted(d.items()):
                    name = method if method not in MODELS else "%s@%s" % (method, lab)
                    if method not in MODELS and lab != ref:
                        continue  # the training-free rows do not depend on the prior
                    for m, v in sorted(ms.items()):
                        w.writerow([name, s, obj, m, "%.6f" % v])
        os.replace(tmp, os.path.join(a.o, "objects.csv"))
        return
    lines = ["# The prior's held-out curve (issue 12)", "", a.caption, ""] if a.caption else \
        ["# The prior's held-out curve (issue 12)", ""]
    for s in a.split:
        nobj = len({o for (_, o) in data[(ref, s)]})
        lines += ["## %s (%d objects; masked PSNR, dB; mean over objects ± 95%% CI)" % (s, nobj), "",
                  "| point | denoiser steps | SM albedo | SM ORM | MV albedo | MV ORM |", "|---|---:|---:|---:|---:|---:|"]
        for lab, steps, _ in a.point:
            d = data[(lab, s)]
            cells = []
            for model in MODELS:
                for m in METRICS:
                    cells.append(fmt(*mean_ci([v[m] for (meth, _), v in d.items() if meth == model and m in v])))
            lines.append("| %s | %s | %s |" % (lab, steps, " | ".join(cells)))
        free = []
        for m, names in FREE.items():
            for n in names:
                xs = [v[m] for (meth, _), v in data[(ref, s)].items() if meth == n and m in v]
                if xs:
                    free.append("%s (%s) %s" % (n, {"albedo_psnr": "albedo", "orm_psnr": "ORM"}[m], fmt(*mean_ci(xs))))
        lines += ["", "Training-free: " + "; ".join(free) + ".", ""]
        pr = {k: v for model in MODELS for k, v in paired_rows(a.o, s, model).items() if k[0].startswith(model + "@")}
        if pr:
            lines += ["Paired over objects, each point minus %s (mean [95%% CI], wins/n, paired t-test p; "
                      "`mf compare`, %s/<model>/paired.md):" % (ref, s), "",
                      "| point | model | albedo | ORM |", "|---|---|---|---|"]
            for lab, _, _ in a.point:
                if lab == ref:
                    continue
                for model in MODELS:
                    cells = []
                    for m in METRICS:
                        r = pr.get(("%s@%s" % (model, lab), m))
                        cells.append("%+.2f [%+.2f, %+.2f], %s/%s, p %.2g" % (float(r["mean"]), float(r["lo"]), float(r["hi"]),
                                                                               r["wins"], r["n"], float(r["p_t"])) if r else "–")
                    lines.append("| %s | %s | %s |" % (lab, model, " | ".join(cells)))
            lines.append("")
    tmp = os.path.join(a.o, "README.md.tmp")
    with open(tmp, "w") as f:
        f.write("\n".join(lines).rstrip() + "\n")
    os.replace(tmp, os.path.join(a.o, "README.md"))


if __name__ == "__main__":
    main()
