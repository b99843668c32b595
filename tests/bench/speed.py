#!/usr/bin/env python3
"""speed.py — issue 20 item 5's figures, in one run on one machine: what a
bake costs against the floor, the one-triangle bake, peak memory.

Measured (each bake a fresh `sylva-bake bake` process, one at a time; wall
time of the process, and its peak RSS from wait4's rusage):
  - `sylva-bake info` on the ficus (median of 3): the cost of reading a tree;
  - the floor (tests/tools/bench_floor: import + validate + one OSMesa
    rasterisation of the whole mesh at the texel density of the bake's finest
    atlas; the default bake's density when the method draws no atlas);
  - every method's default (`{"method": M}` with the tree's units), the
    spec `{}`, and the billboard cloud without evaluation: wall time,
    report.json's stage times, × floor and × info;
  - the one-triangle OBJ with `{}`: time and peak RSS;
  - peak RSS of `{}` on the largest shared tree.
Daemon jobs per minute with and without the worker pool are pool.py's
section. Writes bench/results/speed.tsv and the "Speed" section of
docs/benchmarks.md. Env: BUILD, SYLVA_DATA, SYLVA_SPEED_TREE (default
scopia_ficusTree)."""
import json, os, statistics, subprocess, sys, tempfile, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402

root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
build = os.path.join(root, os.environ.get("BUILD", "build"))
data = os.environ.get("SYLVA_DATA", os.path.join(root, "..", "shared", "data"))
res_dir = os.path.join(root, "bench", "results")
BAKE = os.path.join(build, "sylva-bake")
FLOOR = os.path.join(build, "tools", "bench_floor")
METHODS = ["crossed_quads", "leaf_clusters", "billboard_cloud", "slicing", "stochastic", "octahedral"]
TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def trees():
    rows = []
    with open(os.path.join(root, "tests", "data", "trees.tsv")) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            d, mesh, units, tris = line.split("\t")[:4]
            rows.append((d, mesh, units, int(tris)))
    return rows


def companions(d, mesh):
    return [os.path.join(d, f) for f in sorted(os.listdir(d))
            if f != mesh and f.lower().endswith((".mtl", ".png", ".jpg", ".jpeg", ".bin"))]


def run(cmd):
    """(wall seconds, peak RSS in MB) of one process; raises on failure."""
    t0 = time.time()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(p.pid, 0)
    secs = time.time() - t0
    err = p.stderr.read().decode(errors="replace")
    p.stderr.close()
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise RuntimeError("%s: exit %d: %s" % (" ".join(cmd[:3]), p.returncode, err[-300:]))
    return secs, ru.ru_maxrss / 1024.0


def bake(files, spec, tmp, tag):
    sp = os.path.join(tmp, tag + ".json")
    with open(sp, "w") as f:
        json.dump(spec, f)
    out = os.path.join(tmp, tag)
    secs, rss = run([BAKE, "bake"] + files + ["--spec", sp, "--out", out, "--progress", "none"])
    rep = json.load(open(os.path.join(out, "report.json")))
    texel = None
    for lod in rep["lods"]:  # finest first: the first with an atlas
        if lod.get("texel_size"):
            texel = lod["texel_size"]
            break
    return {"tag": tag, "seconds": secs, "rss_mb": rss, "times": rep.get("times", {}),
            "texel_size": texel, "lods": len(rep["lods"])}


def floor(files, units, texel, tmp):
    sp = os.path.join(tmp, "floor.json")
    with open(sp, "w") as f:
        json.dump({"method": "crossed_quads", "import": {"units": units}}, f)
    out = subprocess.run([FLOOR, "--spec", sp, "--repeat", "3", "--texel-size", "%.9g" % texel] + files,
                         capture_output=True, text=True, check=True).stdout
    j = json.loads(out)
    return j["floor"][0]["floor_seconds"], j["floor"][0]["pixels"]


def main():
    os.makedirs(res_dir, exist_ok=True)
    want = os.environ.get("SYLVA_SPEED_TREE", "scopia_ficusTree")
    all_trees = trees()
    pick = [t for t in all_trees if t[0] == want]
    if not pick:
        print("speed: %s not in tests/data/trees.tsv" % want)
        return 1
    d, mesh, units, tris = pick[-1]  # the .glb row when there is one (the faster import)
    src = os.path.join(data, d)
    files = [os.path.join(src, mesh)] + companions(src, mesh)
    big = max(all_trees, key=lambda t: t[3])
    big_files = [os.path.join(data, big[0], big[1])] + companions(os.path.join(data, big[0]), big[1])
    load0 = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        info = statistics.median(run([BAKE, "info"] + files)[0] for _ in range(3))
        specs = [("{}", {"import": {"units": units}})]
        specs += [(m, {"method": m, "import": {"units": units}}) for m in METHODS]
        specs += [("billboard_cloud, no evaluation",
                   {"method": "billboard_cloud", "import": {"units": units}, "evaluate": {"enabled": False}})]
        default_texel = None
        for i, (label, spec) in enumerate(specs):
            r = bake(files, spec, tmp, "b%d" % i)
            r["label"] = label
            if label == "{}":
                default_texel = r["texel_size"]
            rows.append(r)
            print("speed: %-32s %6.2f s  %5.0f MB" % (label, r["seconds"], r["rss_mb"]), flush=True)
        floors = {}
        for r in rows:
            t = r["texel_size"] or default_texel
            if t not in floors:
                floors[t] = floor(files, units, t, tmp)
            r["floor"], r["floor_px"] = floors[t]
        tri = os.path.join(tmp, "tri.obj")
        with open(tri, "w") as f:
            f.write(TRI)
        one = [bake([tri], {}, tmp, "tri%d" % k) for k in range(3)]
        one_s = statistics.median(r["seconds"] for r in one)
        one_rss = max(r["rss_mb"] for r in one)
        one_eval = statistics.median(r["times"].get("evaluate", 0) for r in one)
        bigr = bake(big_files, {"import": {"units": big[2]}}, tmp, "big")
    load1 = os.getloadavg()

    with open(os.path.join(res_dir, "speed.tsv"), "w") as f:
        f.write("spec\tseconds\trss_mb\tfloor_s\tinfo_s\t" + "\t".join(
            "t_" + k for k in ("import", "classify", "method", "bake", "evaluate", "write")) + "\n")
        for r in rows:
            f.write("%s\t%.3f\t%.0f\t%.3f\t%.3f\t%s\n" % (r["label"], r["seconds"], r["rss_mb"], r["floor"], info,
                    "\t".join("%.3f" % r["times"].get(k, 0) for k in
                              ("import", "classify", "method", "bake", "evaluate", "write"))))
        f.write("one triangle {}\t%.3f\t%.0f\t\t\t\n" % (one_s, one_rss))
        f.write("%s {}\t%.3f\t%.0f\t\t\t\n" % (big[0], bigr["seconds"], bigr["rss_mb"]))

    def t(r, k):
        return "%.2f" % r["times"].get(k, 0)
    L = ["<!-- speed:begin (tests/bench/speed.py writes this section) -->",
         "### Speed: a bake against the floor, one run (issue 20)", "",
         "%s (`%s`, %d triangles), units %s. Each bake a fresh `sylva-bake bake` process, one at a time; "
         "wall time and peak RSS of the process (wait4). Floor = import + validate + one OSMesa "
         "rasterisation of the whole mesh at the texel density of the bake's finest atlas "
         "(tests/tools/bench_floor, median of 3). `sylva-bake info`: %.2f s (median of 3). "
         "Load average before / after: %.1f / %.1f (2 cores, shared)." %
         (d, mesh, tris, units, info, load0[0], load1[0]), "",
         "| spec | levels | wall s | × floor | × info | peak RSS MB | classify | method | bake | evaluate | write |",
         "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        L.append("| %s | %d | %.2f | %.1f (%.2f s, %d²) | %.1f | %.0f | %s | %s | %s | %s | %s |" % (
            r["label"], r["lods"], r["seconds"], r["seconds"] / r["floor"], r["floor"], r["floor_px"],
            r["seconds"] / info, r["rss_mb"], t(r, "classify"), t(r, "method"), t(r, "bake"),
            t(r, "evaluate"), t(r, "write")))
    bc = [r for r in rows if r["label"] == "billboard_cloud"][0]
    worst = max(rows[:1 + len(METHODS)], key=lambda r: r["seconds"] / r["floor"])
    L += ["",
          "| goal (issue 20) | measured | met |", "| --- | --- | --- |",
          "| %s billboard-cloud default incl. evaluation ≤ 3 s | %.2f s | %s |" %
          (d, bc["seconds"], "yes" if bc["seconds"] <= 3 else "no"),
          "| every method's default ≤ 5× the floor | worst %s: %.1f× | %s |" %
          (worst["label"], worst["seconds"] / worst["floor"],
           "yes" if worst["seconds"] / worst["floor"] <= 5 else "no"),
          "| one-triangle `{}` bake ≤ 0.5 s and ≤ 150 MB | %.2f s (evaluate %.2f s), %.0f MB (median / max of 3) | %s |" %
          (one_s, one_eval, one_rss, "yes" if one_s <= 0.5 and one_rss <= 150 else "no"),
          "| peak RSS ≤ 400 MB for a 200k-triangle tree | %s (%d triangles, the largest shared tree) `{}`: %.0f MB, %.1f s | %s |" %
          (big[0], big[3], bigr["rss_mb"], bigr["seconds"], "yes" if bigr["rss_mb"] <= 400 else "no"),
          "",
          "Daemon jobs per minute with and without the worker pool: the next section (pool.py).",
          "<!-- speed:end -->"]
    write_section(os.path.join(root, "docs", "benchmarks.md"), "speed", L)
    print("\n".join(L))
    return 0


if __name__ == "__main__":
    sys.exit(main())
