#!/usr/bin/env python3
"""bench.py — issue 10, "Show what accuracy costs in time" (run by tests/bench/run.sh,
which `make bench` calls).

Sweeps the knobs that buy accuracy, per method, on real trees; bakes each point
with `sylva-bake bake` (one bake at a time: the machine is shared); measures the
peers (meshoptimizer's simplify / simplifySloppy, tests/tools/bench_peers.c) at
our triangle counts with the same evaluation, and the floor (import + one
rasterisation at the atlas texel density, tests/tools/bench_floor.c); benchmarks
the daemon with wrk when it is built; writes bench/results/*.csv + results.json
and docs/benchmarks.md with gnuplot PNGs in docs/benchmarks/.

Environment: BUILD (build dir, default build), SYLVA_DATA (trees, default
../shared/data), SYLVA_BENCH=quick|full|all (default quick: 3 trees, 8 views, a
few minutes; full: 5 trees, 24 views, the wider sweep, about 30 minutes on the
shared 2-core machine; all: the full sweep on every tree, about an hour), SYLVA_BENCH_TREES
(comma-separated folder names, overrides the mode's list),
SYLVA_BENCH_RESULTS / SYLVA_BENCH_DOC (output paths, for trial runs).
Standard library only.
"""
import csv
import datetime
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.environ.get("BUILD", "build")
if not os.path.isabs(BUILD):
    BUILD = os.path.join(ROOT, BUILD)
DATA = os.environ.get("SYLVA_DATA", os.path.join(ROOT, "..", "shared", "data"))
MODE = os.environ.get("SYLVA_BENCH", "quick")
RESULTS = os.environ.get("SYLVA_BENCH_RESULTS", os.path.join(ROOT, "bench", "results"))
DOC = os.environ.get("SYLVA_BENCH_DOC", os.path.join(ROOT, "docs", "benchmarks.md"))
PLOTS = os.path.join(os.path.dirname(DOC), "benchmarks")
BAKE = os.path.join(BUILD, "sylva-bake")
PEERS = os.path.join(BUILD, "tools", "bench_peers")
FLOOR = os.path.join(BUILD, "tools", "bench_floor")
SYLVAD = os.path.join(BUILD, "sylvad")
SIZES = [256, 128, 64, 32]
METRICS = ["iou_mean", "iou_worst", "color_error_mean", "color_error_worst",
           "depth_error_mean", "depth_error_worst"]
STAGES = ["import", "validate", "classify", "method", "bake", "pack", "evaluate", "write", "total"]
QUICK_TREES = ["eztree_aspen_small", "eztree_oak_large", "scopia_ficusTree"]
FULL_TREES = ["eztree_aspen_small", "eztree_oak_large", "scopia_bonsai-tree", "scopia_bush",
              "scopia_ficusTree"]
FICUS = "scopia_ficusTree"
BUDGETS = [64, 256]


def log(msg):
    print("bench: " + msg, flush=True)


def run(cmd, timeout=900):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                       timeout=timeout)
    return p.returncode, p.stdout, p.stderr


# ------------------------------------------------------------------ trees

def companions(d, mesh):
    """The files a mesh may reference (tests/integration/lib.inc's rule)."""
    out = []
    for f in sorted(os.listdir(d)):
        if f == mesh:
            continue
        if f.lower().endswith((".mtl", ".png", ".jpg", ".jpeg", ".bin")):
            out.append(os.path.join(d, f))
    return out


def tree_list():
    """(name, mesh path, companions, units, listed triangles): the OBJ of each
    data folder in tests/data/trees.tsv, or the bundled example without data."""
    trees = []
    if os.path.isdir(DATA):
        seen = set()
        with open(os.path.join(ROOT, "tests", "data", "trees.tsv")) as f:
            for line in f:
                if line.startswith("#") or not line.strip():
                    continue
                d, mesh, units, tris = line.rstrip("\n").split("\t")[:4]
                if d in seen or not mesh.endswith(".obj"):
                    continue
                seen.add(d)
                path = os.path.join(DATA, d, mesh)
                if os.path.isfile(path):
                    trees.append((d, path, companions(os.path.join(DATA, d), mesh), units,
                                  int(tris)))
        want = os.environ.get("SYLVA_BENCH_TREES")
        if want:
            names = want.split(",")
            trees = [t for t in trees if t[0] in names]
        elif MODE == "full":
            trees = [t for t in trees if t[0] in FULL_TREES]
        elif MODE != "all":
            trees = [t for t in trees if t[0] in QUICK_TREES]
    if not trees:
        d = os.path.join(ROOT, "examples", "oak_large")
        mesh = [f for f in sorted(os.listdir(d)) if f.endswith(".obj")][0]
        log("no tree data at %s: using the bundled example %s" % (DATA, d))
        trees.append(("example_oak_large", os.path.join(d, mesh), companions(d, mesh), "m", 0))
    return trees


# ----------------------------------------------------------------- sweeps

def available_methods():
    """Methods this sylva-bake knows (check-spec accepts them)."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for m in ["crossed_quads", "leaf_clusters", "billboard_cloud", "slicing", "stochastic"]:
            p = os.path.join(tmp, "s.json")
            with open(p, "w") as f:
                json.dump({"method": m}, f)
            rc, _, _ = run([BAKE, "check-spec", p])
            if rc == 0:
                out.append(m)
    return out


def sweep(method, trunk_tris, full, tree_name):
    """Knob points for a method: (config label, knobs for the table, spec fragment).
    trunk_tris: trunk triangles of the tree (budget points need the ratio)."""
    pts = []
    if method == "crossed_quads":
        pts.append(("default", {}, {}))
        pts.append(("planes3", {"planes": 3}, {"crossed_quads": {"planes": 3}}))
    elif method == "leaf_clusters":
        pts.append(("default", {"K": "32/16/8", "alpha_rel": 0.003}, {}))
        for b in BUDGETS:
            k = b // 4  # half the budget in quads, half in trunk triangles
            ratio = min(1.0, max(1e-4, (b - 2 * k) / trunk_tris)) if trunk_tris else 1.0
            pts.append(("budget%d" % b, {"K": k, "trunk_ratio": round(ratio, 5)},
                        {"leaf_clusters": {"clusters": [k], "trunk_ratio": [ratio]}}))
        if full:
            pts.append(("alpha0.03", {"K": "32/16/8", "alpha_rel": 0.03},
                        {"leaf_clusters": {"alpha_rel": 0.03}}))
            pts.append(("K128/64", {"K": "128/64"},
                        {"leaf_clusters": {"clusters": [128, 64], "trunk_ratio": [0.5, 0.25]}}))
        # texel density and supersampling (every method shares them; swept here)
        pts.append(("atlas1024", {"K": "32/16/8", "max_atlas": 1024},
                    {"bake": {"max_atlas": 1024}}))
        if full:
            pts.append(("ss1", {"K": "32/16/8", "max_supersample": 1},
                        {"bake": {"max_supersample": 1}}))
    elif method == "billboard_cloud":
        pts.append(("default", {"max_planes": "24/12/6"}, {}))
        # a small ε with a plane limit: the ε search raises ε until the planes fit,
        # so the plane count is close to the limit (the default ε often gives fewer)
        pts.append(("planes20", {"max_planes": 20, "epsilon": "search from 0.01"},
                    {"billboard_cloud": {"lods": [{"epsilon": 0.01, "max_planes": 20}]}}))
        pts.append(("planes32/16/8", {"max_planes": "32/16/8", "epsilon": "search from 0.01"},
                    {"billboard_cloud": {"lods": [{"epsilon": 0.01, "max_planes": n}
                                                  for n in (32, 16, 8)]}}))
        if tree_name == FICUS:  # issue 5's speed figures: one LOD at the default limit
            pts.append(("planes24", {"max_planes": 24}, {"billboard_cloud": {"lods": [24]}}))
        pts.append(("planes128/64", {"max_planes": "128/64", "epsilon": "search from 0.005"},
                    {"billboard_cloud": {"lods": [{"epsilon": 0.005, "max_planes": n}
                                                  for n in (128, 64)]}}))
        if full:
            pts.append(("eps.05/.1/.2", {"epsilon": "0.05/0.1/0.2"},
                        {"billboard_cloud": {"lods": [{"epsilon": 0.05}, {"epsilon": 0.1},
                                                      {"epsilon": 0.2}]}}))
    elif method == "slicing":
        pts.append(("default", {"slicings": 6, "slices": 5}, {}))
        pts.append(("3x3", {"slicings": 3, "slices": 3}, {"slicing": {"slicings": 3, "slices": 3}}))
        if full:
            pts.append(("12x8", {"slicings": 12, "slices": 8},
                        {"slicing": {"slicings": 12, "slices": 8}}))
    else:
        pts.append(("default", {}, {}))
    return pts


def bake(tree, method, label, fragment, views, tmp):
    name, mesh, comps, units, _ = tree
    # lod.chain false: the method's own LODs only (not the full-mesh/stochastic/crossed chain)
    spec = {"method": method, "import": {"units": units}, "evaluate": {"views": views},
            "lod": {"chain": False}}
    for k, v in fragment.items():
        if isinstance(v, dict) and isinstance(spec.get(k), dict):
            spec[k].update(v)
        else:
            spec[k] = v
    sp = os.path.join(tmp, "spec.json")
    with open(sp, "w") as f:
        json.dump(spec, f)
    out = os.path.join(tmp, "out")
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    t0 = time.monotonic()
    rc, _, err = run([BAKE, "bake", mesh] + comps + ["--spec", sp, "--out", out])
    wall = time.monotonic() - t0
    if rc != 0:
        log("%s %s %s failed: %s" % (name, method, label, err.strip().splitlines()[-1:]))
        return None, spec
    with open(os.path.join(out, "report.json")) as f:
        rep = json.load(f)
    rep["_wall"] = wall
    return rep, spec


def points_of(tree, method, label, knobs, rep, views):
    """One row per LOD of a bake."""
    rows = []
    times = rep.get("times", {})
    bake_s = times.get("total", 0) - times.get("evaluate", 0)
    for lod in rep["lods"]:
        i = lod_order(rep, lod["name"])
        r = {"tree": tree[0], "method": method, "config": label,
             "knobs": json.dumps(knobs, sort_keys=True), "lod": lod["name"], "lod_index": i,
             "quads": lod.get("quads", 0), "triangles": lod.get("triangles", 0),
             "texels": lod.get("texels", 0), "texel_size": lod.get("texel_size", 0),
             "supersample": lod.get("supersample", 0), "views": views,
             "bake_seconds": round(bake_s, 4), "wall_seconds": round(rep["_wall"], 3)}
        for s in STAGES:
            r["t_" + s] = times.get(s, "")
        acc = {a["pixels"]: a for a in lod.get("accuracy", [])}
        for px in SIZES:
            for m in METRICS:
                r["%s_%d" % (m, px)] = acc[px][m] if px in acc else ""
        r["drawn"] = True
        rows.append(r)
    # LODs the pipeline measured but dropped from the output (never drawn in the
    # scene's distance range): still points of the trade-off, marked drawn=False
    for note in skipped_lods(rep):
        r = {"tree": tree[0], "method": method, "config": label,
             "knobs": json.dumps(knobs, sort_keys=True), "lod": note["name"],
             "lod_index": lod_order(rep, note["name"]), "quads": "",
             "triangles": note.get("triangles", 0), "texels": "", "texel_size": "",
             "supersample": "", "views": views, "bake_seconds": round(bake_s, 4),
             "wall_seconds": round(rep["_wall"], 3)}
        for s in STAGES:
            r["t_" + s] = times.get(s, "")
        acc = {a["pixels"]: a for a in note.get("accuracy", [])}
        for px in SIZES:
            for m in METRICS:
                r["%s_%d" % (m, px)] = acc[px][m] if px in acc else ""
        r["drawn"] = False
        rows.append(r)
    rows.sort(key=lambda r: r["lod_index"])
    return rows


def skipped_lods(rep):
    """Every {"name", "accuracy", ...} note in a "skipped" list of the report."""
    out = []

    def walk(o):
        if isinstance(o, dict):
            for k, v in o.items():
                if k == "skipped" and isinstance(v, list):
                    out.extend(x for x in v if isinstance(x, dict) and "accuracy" in x)
                else:
                    walk(v)
        elif isinstance(o, list):
            for v in o:
                walk(v)
    walk(rep)
    return out


def lod_order(rep, name):
    """Position of a LOD among all the method's LODs, kept and dropped, finest
    first: "lodN" by N, names with a plane count (clusters16) by count, larger first."""
    names = [l["name"] for l in rep["lods"]] + [n["name"] for n in skipped_lods(rep)]

    def key(nm):
        digits = "".join(c for c in nm if c.isdigit())
        if not digits:
            return (1, 0)
        return (0, int(digits)) if nm.startswith("lod") else (0, -int(digits))
    order = sorted(range(len(names)), key=lambda i: (key(names[i]), i))
    return order.index(names.index(name))


# ------------------------------------------------------------ peers, floor

def tool_json(cmd):
    rc, out, err = run(cmd, timeout=1800)
    if rc != 0:
        log("%s failed: %s" % (os.path.basename(cmd[0]), err.strip()))
        return None
    return json.loads(out)


def peers(tree, targets, views, tmp):
    name, mesh, comps, units, _ = tree
    sp = os.path.join(tmp, "peer_spec.json")
    with open(sp, "w") as f:
        json.dump({"method": "crossed_quads", "import": {"units": units},
                   "evaluate": {"views": views}}, f)
    j = tool_json([PEERS, "--spec", sp, "--targets", ",".join(str(t) for t in targets), mesh]
                  + comps)
    rows = []
    for r in (j or {}).get("results", []):
        row = {"tree": name, "simplifier": r["simplifier"], "target": r["target"],
               "triangles": r["triangles"], "seconds": r["seconds"], "views": views}
        acc = {a["pixels"]: a for a in (r["accuracy"] or [])}
        for px in SIZES:
            for m in METRICS:
                row["%s_%d" % (m, px)] = acc[px][m] if px in acc else ""
        rows.append(row)
    return rows


def floor(tree, texels, tmp):
    name, mesh, comps, units, _ = tree
    sp = os.path.join(tmp, "floor_spec.json")
    with open(sp, "w") as f:
        json.dump({"method": "crossed_quads", "import": {"units": units}}, f)
    return tool_json([FLOOR, "--spec", sp, "--repeat", "3", "--texel-size",
                      ",".join("%.9g" % t for t in texels), mesh] + comps)


# ------------------------------------------------------------------ daemon

def daemon_bench(tmp):
    """requests/s for GET /v1/health and a cached artifact (wrk, 64 connections),
    bakes/minute of a small tree with 2 workers. None when not possible."""
    if not os.access(SYLVAD, os.X_OK):
        return {"skipped": "%s not built" % SYLVAD}
    if not shutil.which("wrk") or not shutil.which("curl"):
        return {"skipped": "wrk or curl missing (make deps installs them)"}
    store = os.path.join(tmp, "store")
    portf = os.path.join(tmp, "port")
    logf = open(os.path.join(tmp, "sylvad.log"), "w")
    d = subprocess.Popen([SYLVAD, "--listen", "127.0.0.1:0", "--store", store, "--port-file",
                          portf, "--worker", BAKE, "--workers", "2", "--log-level", "error"],
                         stdout=logf, stderr=logf)
    res = {}
    try:
        for _ in range(100):
            if os.path.exists(portf) and open(portf).read().strip():
                break
            time.sleep(0.1)
        else:
            return {"skipped": "sylvad did not start"}
        url = "http://127.0.0.1:%s" % open(portf).read().strip()
        # bakes/minute: small tree (aspen, or the example), distinct seeds so each is new work
        small = None
        for t in tree_list_all():
            if t[0] in ("eztree_aspen_small", "example_oak_large"):
                small = t
        if small is None:
            return {"skipped": "no small tree"}
        n = 6
        keys = []
        t0 = time.monotonic()
        for i in range(n):
            spec = json.dumps({"method": "leaf_clusters", "import": {"units": small[3]},
                               "evaluate": {"views": 8}, "seed": 1000 + i})
            cmd = ["curl", "-sS", "-X", "POST", url + "/v1/bakes", "-F", "spec=%s" % spec,
                   "-F", "mesh=@%s" % small[1]]
            for c in small[2]:
                cmd += ["-F", "file=@%s" % c]
            rc, out, err = run(cmd)
            try:
                keys.append(json.loads(out)["key"])
            except (ValueError, KeyError):
                return {"skipped": "upload failed: %s %s" % (out.strip()[:200], err.strip()[:200])}
        done = 0
        deadline = time.monotonic() + 600
        while done < n and time.monotonic() < deadline:
            done = 0
            for k in keys:
                rc, out, _ = run(["curl", "-sS", url + "/v1/bakes/" + k])
                try:
                    st = json.loads(out).get("state")
                except ValueError:
                    st = None
                if st in ("done", "failed"):
                    done += 1
            time.sleep(0.5)
        el = time.monotonic() - t0
        res["bakes"] = n
        res["bake_tree"] = small[0]
        res["bakes_seconds"] = round(el, 2)
        res["bakes_per_minute"] = round(60.0 * done / el, 2) if done == n else None

        def wrk(path):
            rc, out, err = run(["wrk", "-t2", "-c64", "-d5s", url + path], timeout=60)
            for line in out.splitlines():
                if line.startswith("Requests/sec:"):
                    return float(line.split()[1])
            return None
        res["health_rps"] = wrk("/v1/health")
        res["artifact_rps"] = wrk("/v1/bakes/%s/artifacts/planes.json" % keys[0])
        res["artifact"] = "planes.json"
        return res
    finally:
        d.terminate()
        try:
            d.wait(timeout=30)
        except subprocess.TimeoutExpired:
            d.kill()
        logf.close()


_ALL = None


def tree_list_all():
    global _ALL
    if _ALL is None:
        _ALL = tree_list()
    return _ALL


# ------------------------------------------------------------- analysis

def fnum(x, nd=3):
    if x == "" or x is None:
        return "–"
    if isinstance(x, float):
        if math.isnan(x):
            return "–"
        return ("%." + str(nd) + "f") % x
    return str(x)


def pareto(points, better_x_smaller=True):
    """points: (x, y) with smaller x and larger y better; the non-dominated set,
    sorted by x."""
    pts = sorted(points, key=lambda p: (p[0], -p[1]))
    front, best = [], -1e300
    for x, y in pts:
        if y > best:
            front.append((x, y))
            best = y
    return front


def write_csv(path, rows):
    if not rows:
        return
    keys = []
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow(r)


def gnuplot(tree, rows, peer_rows, outdir, tmp):
    """Two PNGs per tree: IoU@64 vs bake time and vs triangles; Pareto front marked."""
    if not shutil.which("gnuplot"):
        return []
    methods = sorted(set(r["method"] for r in rows))
    files = []
    for kind in ("time", "triangles"):
        series = []
        allpts = []
        for m in methods:
            pts = [(r["bake_seconds"] if kind == "time" else max(1, r["triangles"]),
                    r["iou_mean_64"]) for r in rows if r["method"] == m and r["iou_mean_64"] != ""]
            series.append((m, pts))
            allpts += pts
        if kind == "triangles":
            for s in ("meshopt_simplify", "meshopt_simplifySloppy"):
                pts = [(max(1, p["triangles"]), p["iou_mean_64"]) for p in peer_rows
                       if p["simplifier"] == s and p["iou_mean_64"] != ""]
                series.append((s, pts))
                allpts += pts
        else:
            for s in ("meshopt_simplify", "meshopt_simplifySloppy"):
                pts = [(max(1e-4, p["seconds"]), p["iou_mean_64"]) for p in peer_rows
                       if p["simplifier"] == s and p["iou_mean_64"] != ""]
                series.append((s, pts))
                allpts += pts
        front = pareto(allpts)
        plot = []
        for i, (m, pts) in enumerate(series):
            if not pts:
                continue
            dat = os.path.join(tmp, "%s_%s_%d.dat" % (tree, kind, i))
            with open(dat, "w") as f:
                for x, y in pts:
                    f.write("%g %g\n" % (x, y))
            plot.append("'%s' using 1:2 with points pt %d ps 1.4 title '%s'" % (dat, 5 + 2 * i
                                                                                 if i < 4 else i, m))
        fd = os.path.join(tmp, "%s_%s_front.dat" % (tree, kind))
        with open(fd, "w") as f:
            for x, y in front:
                f.write("%g %g\n" % (x, y))
        plot.append("'%s' using 1:2 with steps lw 2 lc rgb 'black' dt 2 title 'Pareto front'" % fd)
        png = os.path.join(outdir, "%s_%s.png" % (tree, kind))
        xlabel = ("bake time without evaluation (s; peers: simplification time)" if kind == "time"
                  else "triangles drawn")
        script = "\n".join([
            "set terminal png size 900,520 noenhanced",
            "set output '%s'" % png,
            "set title '%s: coverage IoU at 64 px vs %s'" % (tree, "bake time" if kind == "time"
                                                               else "primitives"),
            "set logscale x", "set xlabel '%s'" % xlabel,
            "set ylabel 'mean coverage IoU at 64 px'", "set key outside right", "set grid",
            "plot " + ", ".join(plot)])
        sp = os.path.join(tmp, "plot.gp")
        with open(sp, "w") as f:
            f.write(script + "\n")
        rc, _, err = run(["gnuplot", sp])
        if rc == 0:
            files.append(png)
        else:
            log("gnuplot failed: %s" % err.strip()[:300])
    return files


def machine():
    cpu = ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
            mem = "%.1f GiB" % (kb / 1048576.0)
    except (OSError, ValueError, IndexError):
        pass
    rc, commit, _ = run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"])
    return {"cpu": cpu, "cores": os.cpu_count(), "memory": mem, "os": platform.platform(),
            "python": platform.python_version(), "commit": commit.strip() if rc == 0 else ""}


def main():
    for exe in (BAKE, PEERS, FLOOR):
        if not os.access(exe, os.X_OK):
            sys.exit("bench: %s is not built (make BUILD=... all)" % exe)
    full = MODE in ("full", "all")
    views = 24 if full else 8
    trees = tree_list_all()
    methods = available_methods()
    started = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    load0 = os.getloadavg()
    log("mode %s: %d trees, methods %s, %d views" % (MODE, len(trees), ", ".join(methods), views))
    rows, peer_rows, floor_rows, stage_rows, missing = [], [], [], [], []
    with tempfile.TemporaryDirectory(prefix="sylva-bench-") as tmp:
        for tree in trees:
            name = tree[0]
            rc, out, err = run([BAKE, "info", tree[1]] + tree[2] + ["--json"] +
                               (["--spec", _units_spec(tmp, tree[3])]))
            info = json.loads(out) if rc == 0 else {}
            trunk = info.get("classification", {}).get("trunk_triangles", 0)
            default_texel = {}
            default_tris = set()
            for m in methods:
                for label, knobs, frag in sweep(m, trunk, full, name):
                    rep, spec = bake(tree, m, label, frag, views, tmp)
                    if rep is None:
                        missing.append((name, m, label))
                        continue
                    pts = points_of(tree, m, label, knobs, rep, views)
                    rows += pts
                    if label == "default":
                        # the finest drawn LOD with an atlas
                        withq = [p for p in pts if p["drawn"] and p["texel_size"] not in ("", 0)]
                        if withq:
                            default_texel[m] = withq[0]["texel_size"]
                        default_tris.add(pts[0]["triangles"])
                    log("%s %-15s %-14s %5.1fs  %s" % (
                        name, m, label, rep["_wall"],
                        " ".join("%s:%d/%s" % (p["lod"], p["triangles"], fnum(p["iou_mean_64"]))
                                 for p in pts)))
            # views sweep: what evaluation costs (the ficus, or the only tree)
            if full and (name == FICUS or len(trees) == 1) and "leaf_clusters" in methods:
                for v in (8, 48):
                    rep, _ = bake(tree, "leaf_clusters", "views%d" % v, {}, v, tmp)
                    if rep:
                        rows += points_of(tree, "leaf_clusters", "views%d" % v,
                                          {"K": "32/16/8", "views": v}, rep, v)
            targets = sorted(set(BUDGETS) | default_tris)
            log("%s peers at %s triangles" % (name, targets))
            peer_rows += peers(tree, targets, views, tmp)
            texels = sorted(set(t for t in default_texel.values() if t > 0))
            if texels:
                fl = floor(tree, texels, tmp)
                if fl:
                    st = {k: v for k, v in fl.items() if k != "floor"}
                    st["tree"] = name
                    stage_rows.append(st)
                    for f in fl["floor"]:
                        for m, t in default_texel.items():
                            if abs(t - f["texel_size"]) <= 1e-9 * max(1.0, t):
                                r = dict(f)
                                r["tree"] = name
                                r["method"] = m
                                floor_rows.append(r)
        daemon = daemon_bench(tmp) if (full or os.environ.get("SYLVA_BENCH_DAEMON")) else \
            {"skipped": "quick mode (SYLVA_BENCH=full or SYLVA_BENCH_DAEMON=1 runs it)"}
        load1 = os.getloadavg()
        finished = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
        os.makedirs(RESULTS, exist_ok=True)
        write_csv(os.path.join(RESULTS, "points.csv"), rows)
        write_csv(os.path.join(RESULTS, "peers.csv"), peer_rows)
        write_csv(os.path.join(RESULTS, "floor.csv"), floor_rows)
        write_csv(os.path.join(RESULTS, "stages.csv"), stage_rows)
        meta = {"mode": MODE, "views": views, "started": started.isoformat(),
                "finished": finished.isoformat(), "machine": machine(),
                "load_before": [round(x, 2) for x in load0],
                "load_after": [round(x, 2) for x in load1], "methods": methods,
                "trees": [t[0] for t in trees], "failed": missing}
        with open(os.path.join(RESULTS, "results.json"), "w") as f:
            json.dump({"meta": meta, "points": rows, "peers": peer_rows, "floor": floor_rows,
                       "stages": stage_rows, "daemon": daemon}, f, indent=1, sort_keys=True)
            f.write("\n")
        os.makedirs(PLOTS, exist_ok=True)
        plots = {}
        for tree in trees:
            tr = [r for r in rows if r["tree"] == tree[0]]
            pr = [p for p in peer_rows if p["tree"] == tree[0]]
            plots[tree[0]] = gnuplot(tree[0], tr, pr, PLOTS, tmp)
        import bench_report
        text = bench_report.render(meta, rows, peer_rows, floor_rows, stage_rows, daemon, plots,
                                   os.path.dirname(DOC))
        with open(DOC, "w") as f:
            f.write(text)
    log("wrote %s and %s (%s)" % (RESULTS, DOC, finished - started))


def _units_spec(tmp, units):
    p = os.path.join(tmp, "units.json")
    with open(p, "w") as f:
        json.dump({"method": "crossed_quads", "import": {"units": units}}, f)
    return p


def report_only():
    """Re-renders the plots and docs/benchmarks.md from bench/results/results.json
    (no baking): `python3 tests/bench/bench.py --report`."""
    import bench_report
    with open(os.path.join(RESULTS, "results.json")) as f:
        j = json.load(f)
    os.makedirs(PLOTS, exist_ok=True)
    plots = {}
    with tempfile.TemporaryDirectory(prefix="sylva-bench-") as tmp:
        for t in j["meta"]["trees"]:
            plots[t] = gnuplot(t, [r for r in j["points"] if r["tree"] == t],
                               [p for p in j["peers"] if p["tree"] == t], PLOTS, tmp)
    text = bench_report.render(j["meta"], j["points"], j["peers"], j["floor"], j["stages"],
                               j["daemon"], plots, os.path.dirname(DOC))
    with open(DOC, "w") as f:
        f.write(text)
    log("wrote %s" % DOC)


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    if sys.argv[1:] == ["--report"]:
        report_only()
    else:
        main()
