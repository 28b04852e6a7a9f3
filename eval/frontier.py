#!/usr/bin/env python3
"""make bench-frontier's staging and report (eval/bench_frontier.sh runs it; stdlib only).

stage:  one result folder per budget point under --eval, in mf eval's layout
        (<point>/<scene>/albedo.png orm.png env.exr mesh.obj run.json). A snapshot run
        (runs/<method>_r<res>_s<spp>/) gives a point per ladder iteration I from
        snapshots/iter_I; a single run (runs/<method>[+<flag>]_r<res>_s<spp>_i<iters>/) gives one.
        run.json is the run's, with wall_seconds replaced by the optimisation loop's wall time at
        that iteration (log.csv; holdout.csv when later), so every point is timed the same way.
report: frontier.csv (per point: mean over the scenes and 95% CI half-width, Student t, of wall
        time and relit / albedo / ORM PSNR), frontier.png (gnuplot), flags.csv (each budget flag
        paired against its fixed-budget run: wall time ratio and PSNR differences) and README.md.
"""
import argparse
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys

T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262, 10: 2.228}
POINT = re.compile(r"^(?P<method>[a-z0-9-]+)(?:\+(?P<flag>[a-z-]+))?_r(?P<res>\d+)_s(?P<spp>\d+)(?:_i(?P<iters>\d+))?$")
METRICS = ["relit_psnr", "albedo_psnr", "orm_psnr"]


def mean_ci(xs):
    n = len(xs)
    if n == 0:
        return float("nan"), float("nan")
    m = sum(xs) / n
    if n < 2:
        return m, float("nan")
    sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1))
    return m, T95.get(n - 1, 1.96) * sd / math.sqrt(n)


def log_wall(run_dir, it=None):
    """Loop wall seconds at iteration it (the last row when None) from log.csv / holdout.csv."""
    wall = None
    for name in ("log.csv", "holdout.csv"):
        p = os.path.join(run_dir, name)
        if not os.path.exists(p):
            continue
        with open(p) as f:
            for row in csv.DictReader(f):
                if it is None or int(row["iter"]) == it:
                    w = float(row["wall_s"])
                    wall = w if wall is None else max(wall, w)
    return wall


def load(run_dir):
    with open(os.path.join(run_dir, "run.json")) as f:
        return json.load(f)


def stage_one(src_tex, run_dir, dst, wall, note):
    out = os.path.join(dst, "run.json")
    if os.path.exists(out) and os.path.getmtime(out) >= os.path.getmtime(os.path.join(run_dir, "run.json")):
        return  # staged from this run already (kept, so mf eval's inputs stay older than its report)
    os.makedirs(dst, exist_ok=True)
    for f in ("albedo.png", "orm.png", "env.exr"):
        shutil.copyfile(os.path.join(src_tex, f), os.path.join(dst, f))
    for f in ("mesh.obj", "mesh.mtl"):
        if os.path.exists(os.path.join(run_dir, f)):
            shutil.copyfile(os.path.join(run_dir, f), os.path.join(dst, f))
    rj = load(run_dir)
    rj["wall_seconds"] = wall
    rj["frontier"] = note
    tmp = os.path.join(dst, "run.json.tmp")
    with open(tmp, "w") as f:
        json.dump(rj, f, indent=1)
    os.replace(tmp, os.path.join(dst, "run.json"))


def stage(a):
    ladder = [int(x) for x in a.iters.split()]
    n = 0
    for name in sorted(os.listdir(a.runs)):
        m = POINT.match(name)
        if not m or not os.path.isdir(os.path.join(a.runs, name)):
            continue
        for scene in sorted(os.listdir(os.path.join(a.runs, name))):
            rd = os.path.join(a.runs, name, scene)
            if not os.path.exists(os.path.join(rd, "run.json")) or "stopped" in load(rd)["options"]:
                continue  # unfinished or stopped by an error: not a point
            if m.group("iters"):
                stage_one(rd, rd, os.path.join(a.eval, name, scene), log_wall(rd), "final result; wall = loop wall time")
                n += 1
                continue
            for it in ladder:
                sd = os.path.join(rd, "snapshots", "iter_%05d" % it)
                if os.path.isdir(sd) and log_wall(rd, it) is not None:
                    stage_one(sd, rd, os.path.join(a.eval, "%s_i%d" % (name, it), scene), log_wall(rd, it),
                              "snapshot at iteration %d of a %s run; wall = loop wall time at it" % (it, name))
                    n += 1
    print("frontier: staged %d result folders under %s" % (n, a.eval))


def read_scenes(path):
    vals = {}  # (point, scene, metric) -> value
    with open(path) as f:
        for row in csv.DictReader(f):
            vals[(row["method"], row["scene"], row["metric"])] = float(row["value"])
    return vals


def report(a):
    vals = read_scenes(os.path.join(a.eval_dir, "scenes.csv"))
    ev = a.points
    points = sorted({k[0] for k in vals if POINT.match(k[0])})
    rows, per = [], {}
    for p in points:
        m = POINT.match(p)
        scenes = sorted({k[1] for k in vals if k[0] == p})
        walls = {}
        for s in scenes:
            with open(os.path.join(ev, p, s, "run.json")) as f:
                walls[s] = float(json.load(f)["wall_seconds"])
        per[p] = {"wall": walls}
        row = {"point": p, "method": m.group("method"), "flag": m.group("flag") or "", "res": int(m.group("res")),
               "spp": int(m.group("spp")), "iters": int(m.group("iters")), "scenes": len(scenes),
               "default": int(p == "nvdiffrecmc_" + a.default or p == "materialfusion_" + a.default)}
        row["wall_s"], row["wall_s_ci"] = mean_ci([walls[s] for s in scenes])
        for met in METRICS:
            xs = {s: vals[(p, s, met)] for s in scenes if (p, s, met) in vals}
            per[p][met] = xs
            row[met], row[met + "_ci"] = mean_ci(list(xs.values()))
        rows.append(row)
    rows.sort(key=lambda r: (r["flag"] != "", r["method"], r["res"], r["spp"], r["iters"], r["flag"]))
    cols = ["point", "method", "flag", "res", "spp", "iters", "scenes", "default", "wall_s", "wall_s_ci"]
    for met in METRICS:
        cols += [met, met + "_ci"]
    os.makedirs(a.out, exist_ok=True)
    write_csv(os.path.join(a.out, "frontier.csv"), cols, rows)

    # the budget flags, paired per scene with their fixed-budget run (same method, res, spp, iters)
    flags = []
    for r in rows:
        if not r["flag"]:
            continue
        ref = "%s_r%d_s%d_i%d" % (r["method"], r["res"], r["spp"], r["iters"])
        if ref not in per:
            continue
        shared = sorted(set(per[r["point"]]["wall"]) & set(per[ref]["wall"]))
        f = {"flag": r["flag"], "point": r["point"], "reference": ref, "scenes": len(shared)}
        f["wall_ratio"], f["wall_ratio_ci"] = mean_ci([per[r["point"]]["wall"][s] / per[ref]["wall"][s] for s in shared])
        for met in METRICS:
            d = [per[r["point"]][met][s] - per[ref][met][s] for s in shared
                 if s in per[r["point"]][met] and s in per[ref][met]]
            f["d_" + met], f["d_" + met + "_ci"] = mean_ci(d)
        f["detail"] = flag_detail(ev, r["point"], shared)
        flags.append(f)
    fcols = ["flag", "point", "reference", "scenes", "wall_ratio", "wall_ratio_ci"]
    for met in METRICS:
        fcols += ["d_" + met, "d_" + met + "_ci"]
    fcols.append("detail")
    write_csv(os.path.join(a.out, "flags.csv"), fcols, flags)
    plot(a.out, rows)
    readme(a, rows, flags)


def budget_decisions(run_dir):
    """What the budget flags that were on decided in one run (its run.json's options): "stop" (the
    early-stop iteration, 0: no stop), "metal" (metal_auto's decision string), "tex" (tex_auto's tex_res),
    "env" (env_auto's covered fraction), "envres" ((env width, height, 10th-percentile roughness) of
    env_res_auto), "spp" ((final spp, [iterations it grew at]) of spp_grow)."""
    with open(os.path.join(run_dir, "run.json")) as f:
        o = json.load(f)["options"]
    d = {}
    if "early_stop_result" in o:
        d["stop"] = int(o["early_stop_result"]["stop_iter"])
    if "metal_auto_result" in o:
        d["metal"] = o["metal_auto_result"]["decision"]
    if o.get("tex_auto"):
        d["tex"] = int(o["tex_res"])
    if "env_auto_covered_fraction" in o:
        d["env"] = float(o["env_auto_covered_fraction"])
    if "env_res_result" in o:
        d["envres"] = (int(o["env_res_result"]["env_w"]), int(o["env_res_result"]["env_h"]),
                       float(o["env_res_result"]["roughness_p10"]))
    if "spp_grow_result" in o:
        d["spp"] = (int(o["spp_grow_result"]["spp_final"]), list(o["spp_grow_result"]["grew_at"]))
    return d


def flag_detail(ev, point, scenes):
    """What each flag decided per scene (from the staged run.json's options)."""
    out = []
    for sc in scenes:
        d = budget_decisions(os.path.join(ev, point, sc))
        if "stop" in d:
            out.append("%s: %s" % (sc, "stopped at %d" % d["stop"] if d["stop"] else "no stop"))
        elif "metal" in d:
            out.append("%s: %s" % (sc, d["metal"]))
        elif "tex" in d:
            out.append("%s: tex_res %d" % (sc, d["tex"]))
    return "; ".join(out)


def write_csv(path, cols, rows):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow([("%.4f" % r[c]) if isinstance(r[c], float) else r[c] for c in cols])
    os.replace(tmp, path)


def plot(out, rows):
    """frontier.gp + frontier.dat (one block per line: method, res, spp), frontier.png."""
    lines = {}
    for r in rows:
        if not r["flag"]:
            lines.setdefault((r["method"], r["res"], r["spp"]), []).append(r)
    dat = []
    for (m, res, spp), pts in sorted(lines.items()):
        dat.append("# %s %d px spp %d" % (m, res, spp))
        for r in sorted(pts, key=lambda r: r["iters"]):
            dat.append("%.3f %.4f %.4f %.4f %d %d" % (r["wall_s"], r["relit_psnr"], r["albedo_psnr"], r["orm_psnr"],
                                                      r["iters"], r["default"]))
        dat += ["", ""]
    with open(os.path.join(out, "frontier.dat"), "w") as f:
        f.write("\n".join(dat))
    titles = ["%s %dpx spp%d" % k for k in sorted(lines)]
    gp = ["set terminal pngcairo size 1500,560 font ',10'", "set output 'frontier.png'", "set multiplot layout 1,3",
          "set logscale x", "set xlabel 'wall time per scene [s] (optimisation loop, mean over scenes)'", "set grid",
          "set key outside below horizontal maxrows 3"]
    for col, name in ((2, "relit PSNR [dB]"), (3, "albedo PSNR [dB]"), (4, "ORM PSNR [dB]")):
        parts = []
        for i, t in enumerate(titles):
            parts.append("'frontier.dat' index %d using 1:%d with linespoints lw 2 pt 7 title '%s'" % (i, col, t))
            parts.append("'frontier.dat' index %d using 1:($6 == 1 ? $%d : 1/0) with points pt 6 ps 3 lc rgb 'black' "
                         "notitle" % (i, col))
            parts.append("'frontier.dat' index %d using 1:%d:(sprintf('%%d', $5)) with labels offset 0,1 font ',8' "
                         "notitle" % (i, col))
        gp += ["set ylabel '%s'" % name, "set title '%s vs wall time (circled: current default)'" % name,
               "plot " + ", \\\n     ".join(parts)]
    gp.append("unset multiplot")
    with open(os.path.join(out, "frontier.gp"), "w") as f:
        f.write("\n".join(gp) + "\n")
    try:
        subprocess.run(["gnuplot", "frontier.gp"], cwd=out, check=True, stdin=subprocess.DEVNULL)
    except (OSError, subprocess.CalledProcessError) as e:
        print("frontier: gnuplot failed (%s): frontier.png not made" % e, file=sys.stderr)


def knee(pts, tol=0.2):
    """Cheapest point of a line whose mean relit PSNR is within tol dB of the line's best."""
    best = max(r["relit_psnr"] for r in pts)
    return min((r for r in pts if r["relit_psnr"] >= best - tol), key=lambda r: r["wall_s"]), best


def pareto(pts):
    """Points no other point beats on both wall time (lower) and mean relit PSNR (higher), by wall time."""
    return sorted((r for r in pts if not any(q["wall_s"] <= r["wall_s"] and q["relit_psnr"] >= r["relit_psnr"] and
                                             (q["wall_s"], q["relit_psnr"]) != (r["wall_s"], r["relit_psnr"]) for q in pts)),
                  key=lambda r: r["wall_s"])


def default_section(rows):
    """Where each method's default budget sits: its Pareto front over every line (relit PSNR against wall
    time) and the points that are both cheaper (by 10% or more) and no worse in mean relit PSNR."""
    L = ["", "## Where the defaults sit", "",
         "Per method, over every point of every line: the Pareto front (no other point both cheaper and better in "
         "mean relit PSNR) and the points that dominate the default (at least 10% cheaper and no worse in mean "
         "relit PSNR; albedo and ORM beside them). Means over the scenes; their CIs (table above) are wide, so "
         "read small differences as ties.", ""]
    for m in sorted({r["method"] for r in rows if not r["flag"]}):
        pts = [r for r in rows if r["method"] == m and not r["flag"]]
        d = next((r for r in pts if r["default"]), None)
        front = pareto(pts)
        L.append("- %s: front %s." % (m, ", ".join("%s (%.0f s, %.2f dB)" % (r["point"], r["wall_s"], r["relit_psnr"])
                                                     for r in front)))
        if d is None:
            L.append("  Its default budget is not a point of this run.")
            continue
        dom = [r for r in pts if r["wall_s"] <= 0.9 * d["wall_s"] and r["relit_psnr"] >= d["relit_psnr"]]
        where = "on the front" if d in front else "off the front"
        if dom:
            L.append("  The default (%s, %.0f s, relit %.2f / albedo %.2f / ORM %.2f dB) is %s, dominated by %s." % (
                d["point"], d["wall_s"], d["relit_psnr"], d["albedo_psnr"], d["orm_psnr"], where,
                "; ".join("%s (%.2fx its time, relit %+.2f, albedo %+.2f, ORM %+.2f dB)" % (
                    r["point"], r["wall_s"] / d["wall_s"], r["relit_psnr"] - d["relit_psnr"],
                    r["albedo_psnr"] - d["albedo_psnr"], r["orm_psnr"] - d["orm_psnr"]) for r in dom)))
        else:
            L.append("  The default (%s, %.0f s, relit %.2f / albedo %.2f / ORM %.2f dB) is %s; no point is both at least "
                     "10%% cheaper and as good in relit PSNR." % (d["point"], d["wall_s"], d["relit_psnr"], d["albedo_psnr"],
                                                                  d["orm_psnr"], where))
        better = [r for r in front if r["relit_psnr"] > d["relit_psnr"]]
        if better:
            L.append("  Better in relit PSNR on the front: %s." % "; ".join(
                "%s (%.2fx the time, relit %+.2f, albedo %+.2f, ORM %+.2f dB)" % (
                    r["point"], r["wall_s"] / d["wall_s"], r["relit_psnr"] - d["relit_psnr"],
                    r["albedo_psnr"] - d["albedo_psnr"], r["orm_psnr"] - d["orm_psnr"]) for r in better))
    return L


def fmt(m, ci):
    return ("%.2f" % m) + ("" if math.isnan(ci) else " ± %.2f" % ci)


def readme(a, rows, flags):
    L = ["# Speed/error frontier (issue 16)", "",
         "Generated by `make bench-frontier` (eval/bench_frontier.sh, eval/frontier.py); do not edit.", ""]
    if a.ladder:
        L += ["Ladder of this run: " + a.ladder, ""]
    if "nvdiffrecmc_full" not in a.ladder:
        L += ["The published budget (`make bench-frontier BENCH_FULL=1`: baselines/nvdiffrecmc_full.json — batch 8, "
              "1024² textures, 256×128 light — at 64 and 128 px, spp 2/4/8, up to 5000 iterations) is not part of "
              "this run.", ""]
    L += ["Each point: a budget (training resolution `r`, `--spp` `s`, iterations `i`) of a method on the scenes "
          "listed in frontier.csv; wall time is the optimisation loop's (log.csv; mean over the scenes on this "
          "shared 2-core machine), quality is `mf eval`'s relit / albedo / ORM PSNR (eval/scenes.csv) with the "
          "95% CI half-width over the scenes (Student t). The baseline's iteration points are snapshots of one run "
          "(its learning rate depends on the iteration only); MaterialFusion's are separate runs (its SDS weight "
          "depends on the total).", "",
          "![frontier](frontier.png)", "",
          "| point | scenes | wall s | relit PSNR | albedo PSNR | ORM PSNR |", "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        if r["flag"]:
            continue
        name = r["point"] + (" **(default)**" if r["default"] else "")
        L.append("| %s | %d | %s | %s | %s | %s |" % (name, r["scenes"], fmt(r["wall_s"], r["wall_s_ci"]),
                                                    fmt(r["relit_psnr"], r["relit_psnr_ci"]),
                                                    fmt(r["albedo_psnr"], r["albedo_psnr_ci"]),
                                                    fmt(r["orm_psnr"], r["orm_psnr_ci"])))
    L += ["", "## Where the knee is", "",
          "Knee of a line (fixed method, resolution, spp): its cheapest point whose mean relit PSNR is within "
          "0.2 dB of the line's best.", ""]
    lines = {}
    for r in rows:
        if not r["flag"]:
            lines.setdefault((r["method"], r["res"], r["spp"]), []).append(r)
    for (m, res, spp), pts in sorted(lines.items()):
        k, best = knee(pts)
        pts = sorted(pts, key=lambda r: r["iters"])
        steps = ", ".join("%d: %.2f dB (%.0f s)" % (r["iters"], r["relit_psnr"], r["wall_s"]) for r in pts)
        if k is pts[-1] and len(pts) > 1:
            where = ("no knee inside the ladder: its largest budget, %d iterations, is still %.2f dB above the one "
                     "before it (%d iterations), so the knee lies beyond %d iterations" %
                     (k["iters"], k["relit_psnr"] - pts[-2]["relit_psnr"], pts[-2]["iters"], k["iters"]))
        else:
            where = "knee at %d iterations (%.1f s, relit %.2f dB; best %.2f dB)" % (k["iters"], k["wall_s"],
                                                                                   k["relit_psnr"], best)
        L.append("- %s, %d px, spp %d: %s. Relit PSNR by iterations: %s." % (m, res, spp, where, steps))
        walls = [r["wall_s"] for r in pts]
        if any(b <= a for a, b in zip(walls, walls[1:])):
            L.append("  Its wall times do not grow with the iterations: its runs were made at different moments on "
                     "this shared machine, under different loads, so read its cost from the iteration counts (the "
                     "baseline's points, snapshots of one run, are timed under one load per scene); wall times compared "
                     "across lines carry the same caveat.")
    L += default_section(rows)
    if flags:
        L += ["", "## Budget flags (each alone, paired per scene with the same budget without it)", "",
              "Wall time ratio: mean over the scenes of the flag's loop wall time over its reference's, both measured "
              "on this shared machine at different moments (its load changes the ratio by tens of percent: "
              "metal-auto renders the same samples per iteration as its reference). Δ: flag minus reference, mean ± 95% CI "
              "half-width; paired/ has the t-test and sign-test p of every point against the default.", "",
              "| flag | vs | scenes | wall time ratio | Δ relit dB | Δ albedo dB | Δ ORM dB | decisions |",
              "|---|---|---:|---:|---:|---:|---:|---|"]
        for f in flags:
            L.append("| %s | %s | %d | %s | %s | %s | %s | %s |" % (f["flag"], f["reference"], f["scenes"],
                                                              fmt(f["wall_ratio"], f["wall_ratio_ci"]),
                                                              fmt(f["d_relit_psnr"], f["d_relit_psnr_ci"]),
                                                              fmt(f["d_albedo_psnr"], f["d_albedo_psnr_ci"]),
                                                              fmt(f["d_orm_psnr"], f["d_orm_psnr_ci"]),
                                                              f["detail"]))
    L += metal_section(a.out)
    notes = os.environ.get("FRONTIER_NOTES", "")
    if notes and os.path.exists(notes):
        with open(notes) as f:
            L += ["", f.read().rstrip()]
    L += ["", "Files: frontier.csv (every point), flags.csv, frontier.dat + frontier.gp (gnuplot) -> frontier.png, "
          "eval/ (the full mf eval report over every point: relight.md, materials.md, scenes.csv, per_view.csv, "
          "runs.md with each run's command)."]
    tmp = os.path.join(a.out, "README.md.tmp")
    with open(tmp, "w") as f:
        f.write("\n".join(L) + "\n")
    os.replace(tmp, os.path.join(a.out, "README.md"))


def has_metal(scene_dir, diffuse):
    """Ground truth: a diffuse split has none (metallic 0 everywhere), else any part of
    gt/object.json with metallic > 0 or a metallic mask."""
    if diffuse:
        return False
    with open(os.path.join(scene_dir, "gt", "object.json")) as f:
        parts = json.load(f).get("parts", [])
    return any(p.get("metallic", 0) > 0 or p.get("metallic_mask", False) for p in parts)


def metal(a):
    rows = []
    for sp in sorted(os.listdir(a.metal)):
        if not os.path.isdir(os.path.join(a.metal, sp)):
            continue
        with open(os.path.join(a.data, sp, "manifest.json")) as f:
            diffuse = bool(json.load(f).get("diffuse", False))
        for sc in sorted(os.listdir(os.path.join(a.metal, sp))):
            rd = os.path.join(a.metal, sp, sc)
            if not os.path.exists(os.path.join(rd, "run.json")):
                continue
            res = load(rd)["options"].get("metal_auto_result", {})
            rows.append({"split": sp, "scene": sc, "gt_metal": int(has_metal(os.path.join(a.data, sp, sc), diffuse)),
                         "metal_fraction": float(res.get("metal_fraction", float("nan"))),
                         "frozen": int(res.get("decision", "") == "metallic fixed at 0")})
    os.makedirs(a.out, exist_ok=True)
    write_csv(os.path.join(a.out, "metal.csv"), ["split", "scene", "gt_metal", "metal_fraction", "frozen"], rows)
    print("frontier: metal test on %d scenes -> %s" % (len(rows), os.path.join(a.out, "metal.csv")))


def metal_section(out):
    p = os.path.join(out, "metal.csv")
    if not os.path.exists(p):
        return []
    with open(p) as f:
        rows = list(csv.DictReader(f))
    metal_rows = [r for r in rows if r["gt_metal"] == "1"]
    plain = [r for r in rows if r["gt_metal"] == "0"]
    wrong_freeze = sum(r["frozen"] == "1" for r in metal_rows)
    missed = sum(r["frozen"] == "0" for r in plain)
    L = ["", "## metal_auto: the no-metal test (metal.csv)", "",
         "After 50 warm-up iterations at 64 px (baseline, default budget), metallic is fixed at 0 when under 2% of "
         "the texels seen by the training views have metallic > 0.5. Ground truth: the split's manifest "
         "(`diffuse`: no metal) or the scene's gt/object.json.", "",
         "- scenes with metal whose metallic was wrongly fixed at 0 (the harmful error): %d of %d" %
         (wrong_freeze, len(metal_rows)),
         "- scenes without metal where metal was seen (metallic kept: no harm, no saving): %d of %d" %
         (missed, len(plain)), "",
         "| split | scene | metal in GT | fraction > 0.5 | decision |", "|---|---|---|---:|---|"]
    for r in rows:
        L.append("| %s | %s | %s | %.4f | %s |" % (r["split"], r["scene"], "yes" if r["gt_metal"] == "1" else "no",
                                                 float(r["metal_fraction"]),
                                                 "fixed at 0" if r["frozen"] == "1" else "kept"))
    return L


def main():
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("stage")
    s.add_argument("--runs", required=True)
    s.add_argument("--eval", required=True)
    s.add_argument("--iters", required=True)
    r = sub.add_parser("report")
    r.add_argument("--eval-dir", required=True)
    r.add_argument("--points", required=True)
    r.add_argument("--out", required=True)
    r.add_argument("--default", required=True)
    r.add_argument("--ladder", default="", help="one line describing the ladder, for the README")
    m = sub.add_parser("metal")
    m.add_argument("--metal", required=True)
    m.add_argument("--data", required=True)
    m.add_argument("--out", required=True)
    a = ap.parse_args()
    {"stage": stage, "report": report, "metal": metal}[a.cmd](a)


if __name__ == "__main__":
    main()
