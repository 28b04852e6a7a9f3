#!/usr/bin/env python3
"""make bench-adaptive's report (eval/bench_adaptive.sh runs it; stdlib only).

Per split and flag set: the optimisation loop's wall time (log.csv / holdout.csv, as
make bench-frontier times its points) over the default budget's, and relit / albedo / ORM PSNR
differences (mf eval's scenes.csv), paired over the scenes both finished: mean and 95% CI half-width
(Student t). Target (issue 16): within 0.2 dB of the default on all three at <= 0.5x its wall time
(mean ratio), or all three mean differences >= 0 with at least one CI above 0 at <= 1.0x.
Writes OUT/adaptive.csv and OUT/README.md (atomically).
"""
import argparse
import os
import sys

sys.dont_write_bytecode = True  # importing frontier.py leaves no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from frontier import METRICS, budget_decisions, log_wall, mean_ci, read_scenes, write_csv  # noqa: E402


def decisions(run_dir):
    """What the budget flags decided in one run, in a few words."""
    d = budget_decisions(run_dir)
    out = []
    if "stop" in d:
        out.append("stop %d" % d["stop"] if d["stop"] else "no stop")
    if "metal" in d:
        out.append({"metallic fixed at 0": "metal 0", "metallic kept": "metal kept"}.get(d["metal"], "metal " + d["metal"]))
    if "tex" in d:
        out.append("tex %d" % d["tex"])
    if "env" in d:
        out.append("env seen %.1f%%" % (100 * d["env"]))
    if "envres" in d:
        out.append("env %dx%d (roughness %.2f)" % d["envres"])
    if "spp" in d:
        out.append("spp %d%s" % (d["spp"][0], " (grew at %s)" % ", ".join(map(str, d["spp"][1])) if d["spp"][1] else ""))
    return ", ".join(out)


def split_scenes(d):
    """mf eval's scenes.csv of a split's report folder, merged with those of its subfolders (reports
    of later sittings, each an mf eval run of its own): a value scored twice must agree."""
    vals = read_scenes(os.path.join(d, "scenes.csv"))
    for sub in sorted(os.listdir(d)):
        path = os.path.join(d, sub, "scenes.csv")
        if not os.path.isfile(path):
            continue
        for k, v in read_scenes(path).items():
            if k in vals and abs(vals[k] - v) > 1e-6 * max(1.0, abs(v)):
                sys.exit("adaptive.py: %s: %s scored %g here, %g in another report" % (path, "/".join(k), v, vals[k]))
            vals[k] = v
    return vals


def same_outputs(a, b):
    """True when two runs wrote the same albedo.png, orm.png and env.exr bytes."""
    for f in ("albedo.png", "orm.png", "env.exr"):
        with open(os.path.join(a, f), "rb") as x, open(os.path.join(b, f), "rb") as y:
            if x.read() != y.read():
                return False
    return True


def verdict(ratio, d):
    if any(x != x for x in [ratio] + [m for m, _ in d]):
        return "not measured"
    if ratio <= 0.5 and all(m >= -0.2 for m, _ in d):
        return "**met** (within 0.2 dB at <= 0.5x)"
    if ratio <= 1.0 and all(m >= 0 for m, _ in d) and any(m - ci > 0 for m, ci in d):
        return "**met** (better at <= 1x)"
    return "not met"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--results", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--splits", required=True)
    ap.add_argument("--configs", required=True, help="name=flags;name=flags")
    ap.add_argument("--config", required=True)
    ap.add_argument("--time-reference", action="append", default=[],
                    help="REF:name,name (repeatable): these flag sets' wall time is over REF's, the default re-run "
                         "beside them when they were added in a later sitting (its outputs equal the default's)")
    a = ap.parse_args()
    time_ref = {}
    for t in a.time_reference:
        ref, names = t.split(":", 1)
        time_ref.update({n: ref for n in names.split(",")})
    configs = [c.split("=", 1) for c in a.configs.split(";") if "=" in c]
    rows, detail = [], []
    for sp in a.splits.split():
        vals = split_scenes(os.path.join(a.out, sp))
        for name, flags in configs:
            scenes = sorted({k[1] for k in vals if k[0] == name} & {k[1] for k in vals if k[0] == "default"})
            if not scenes:
                continue  # this flag set was not run (or not scored) on this split
            ratio, d = [], {m: [] for m in METRICS}
            for s in scenes:
                ref = time_ref.get(name, "default")
                if ref != "default" and not same_outputs(os.path.join(a.results, sp, ref, s),
                                                         os.path.join(a.results, sp, "default", s)):
                    sys.exit("adaptive.py: %s/%s/%s: the time reference's outputs differ from the default's "
                             "(another build or options?)" % (sp, ref, s))
                w0 = log_wall(os.path.join(a.results, sp, ref, s))
                w1 = log_wall(os.path.join(a.results, sp, name, s))
                ratio.append(w1 / w0)
                for m in METRICS:
                    d[m].append(vals[(name, s, m)] - vals[("default", s, m)])
                detail.append({"split": sp, "config": name, "scene": s, "wall_default_s": w0, "wall_s": w1,
                               "wall_ratio": w1 / w0, "decisions": decisions(os.path.join(a.results, sp, name, s)),
                               **{"d_" + m: d[m][-1] for m in METRICS}})
            r = {"split": sp, "config": name, "flags": flags.strip(), "scenes": len(scenes),
                 "time_reference": time_ref.get(name, "default")}
            r["wall_ratio"], r["wall_ratio_ci"] = mean_ci(ratio)
            for m in METRICS:
                r["d_" + m], r["d_" + m + "_ci"] = mean_ci(d[m])
            r["target"] = verdict(r["wall_ratio"], [(r["d_" + m], r["d_" + m + "_ci"]) for m in METRICS])
            rows.append(r)
    cols = ["split", "config", "flags", "scenes", "time_reference", "wall_ratio", "wall_ratio_ci"]
    for m in METRICS:
        cols += ["d_" + m, "d_" + m + "_ci"]
    write_csv(os.path.join(a.out, "adaptive.csv"), cols + ["target"], rows)
    write_csv(os.path.join(a.out, "scenes_adaptive.csv"),
              ["split", "config", "scene", "wall_default_s", "wall_s", "wall_ratio"] + ["d_" + m for m in METRICS] +
              ["decisions"], detail)
    md = ["# Adaptive budget vs the fixed default (issue 16)", "",
          "Generated by `make bench-adaptive` (eval/bench_adaptive.sh, eval/adaptive.py); do not edit.", "",
          "The baseline (nvdiffrecmc-style) at its default budget (%s) and with each flag set, on every scene of "
          "the validation split (val-3d: where a default may be chosen) and the test split (test-3d: where the "
          "choice is checked). Wall time: the optimisation loop's (log.csv, holdout.csv); ratio = flag set / "
          "default per scene (README \"Budgets from the data\" says under which load the runs were made). PSNR: `mf eval` (every test view, its full protocol; "
          "%s/<split>/ has its tables; flag sets scored in a later sitting are in its subfolders, one `mf eval` "
          "batch of scenes each, merged here), flag set minus default. Mean and 95%% CI half-width over the scenes "
          "(Student t). Target: within 0.2 dB of the default on relit, albedo and ORM at <= 0.5x its wall time, "
          "or all three >= 0 with at least one CI above 0 at <= 1x." % (a.config, a.out), "",
          "| split | flag set | scenes | wall time ratio | d relit dB | d albedo dB | d ORM dB | target |",
          "|---|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        ref = "" if r["time_reference"] == "default" else "; time over %s" % r["time_reference"]
        md.append("| %s | %s (`%s`%s) | %d | %.2f ± %.2f | %+.2f ± %.2f | %+.2f ± %.2f | %+.2f ± %.2f | %s |" % (
            r["split"], r["config"], r["flags"], ref, r["scenes"], r["wall_ratio"], r["wall_ratio_ci"],
            r["d_relit_psnr"], r["d_relit_psnr_ci"], r["d_albedo_psnr"], r["d_albedo_psnr_ci"],
            r["d_orm_psnr"], r["d_orm_psnr_ci"], r["target"]))
    md += ["", "Per scene (scenes_adaptive.csv):", "",
           "| split | flag set | scene | wall s default / flags | ratio | d relit | d albedo | d ORM | decisions |",
           "|---|---|---|---:|---:|---:|---:|---:|---|"]
    for r in detail:
        md.append("| %s | %s | %s | %.0f / %.0f | %.2f | %+.2f | %+.2f | %+.2f | %s |" % (
            r["split"], r["config"], r["scene"], r["wall_default_s"], r["wall_s"], r["wall_ratio"],
            r["d_relit_psnr"], r["d_albedo_psnr"], r["d_orm_psnr"], r["decisions"]))
    tmp = os.path.join(a.out, "README.md.tmp")
    with open(tmp, "w") as f:
        f.write("\n".join(md) + "\n")
    os.replace(tmp, os.path.join(a.out, "README.md"))


if __name__ == "__main__":
    main()
