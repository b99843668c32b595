#!/usr/bin/env python3
"""target_cost.py — issue 19's speed figures for docs/benchmarks.md (between
markers): (1) a target search against one bake of the setting it chose
(item 6: at most 3x), both timed in this run; (2) the default bake `{}` (with
the tree's units): levels kept, triangles, switch distances and time
(items 1 and 7). Bakes run one at a time.

Run by `make bench` (tests/bench/run.sh). Env: BUILD, SYLVA_DATA,
SYLVA_BENCH_TREES (comma-separated folders; default three trees).
"""
import json, os, re, subprocess, sys, tempfile, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402

root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
build = os.path.join(root, os.environ.get("BUILD", "build"))
data = os.environ.get("SYLVA_DATA", os.path.join(root, "..", "shared", "data"))
bake = os.path.join(build, "sylva-bake")
DEFAULT = ["eztree_oak_large", "scopia_ficusTree", "sapling_small_maple"]
# ez-tree units are not metres: a leaf card about 4.5 units across is a twig,
# about 0.2 m per unit (examples/README.md)
UNITS = {"eztree_oak_large": 0.2, "eztree_ash_medium": 0.2, "eztree_aspen_small": 0.2}


def trees():
    want = os.environ.get("SYLVA_BENCH_TREES")
    want = want.split(",") if want else DEFAULT
    rows = {}
    with open(os.path.join(root, "tests", "data", "trees.tsv")) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            d, mesh, units = line.split("\t")[:3]
            if d in want and mesh.endswith(".obj") and d not in rows:
                rows[d] = (mesh, UNITS.get(d, units))
    return [(d,) + rows[d] for d in want if d in rows]


def files(d, mesh):
    folder = os.path.join(data, d)
    extra = sorted(f for f in os.listdir(folder)
                   if f.lower().endswith((".mtl", ".png", ".jpg", ".jpeg", ".tga")))
    return [os.path.join(folder, mesh)] + [os.path.join(folder, f) for f in extra]


def run(fs, spec, out):
    path = out + ".json"
    with open(path, "w") as f:
        json.dump(spec, f)
    t0 = time.time()
    p = subprocess.run([bake, "bake"] + fs + ["--spec", path, "--out", out],
                       capture_output=True, text=True)
    dt = time.time() - t0
    if p.returncode not in (0, 3):
        sys.exit("target_cost: bake failed (%d): %s" % (p.returncode, p.stderr[-400:]))
    return dt, json.load(open(os.path.join(out, "report.json")))


def main():
    tmp = tempfile.mkdtemp(prefix="sylva-target-cost.")
    search, chain = [], []
    for d, mesh, units in trees():
        fs = files(d, mesh)
        base = {"import": {"units": units}}
        spec = dict(base, method="leaf_clusters", lod={"chain": False}, target={"iou": 0.85})
        ts, rep = run(fs, spec, os.path.join(tmp, d + "-search"))
        t = rep["target"]
        direct = dict(base, method="leaf_clusters", lod={"chain": False},
                      leaf_clusters=rep["method"]["settings"])
        td, _ = run(fs, direct, os.path.join(tmp, d + "-direct"))
        search.append((d, len(t["tries"]), json.dumps(rep["method"]["settings"]), t["met"], ts, td))
        tc, rc = run(fs, base, os.path.join(tmp, d + "-default"))
        chain.append((d, units, tc, rc))
        print("target_cost: %s search %.1f s / direct %.1f s; default %.1f s, %d levels"
              % (d, ts, td, tc, len(rc["lods"])))
    md = ["<!-- target:begin (tests/bench/target_cost.py writes this section) -->",
          "## Target search and the default chain (issue 19)", "",
          "A target search (`leaf_clusters`, chain off, `{\"iou\": 0.85}`) against one bake of "
          "the setting it chose, both timed in this run (issue 19 item 6 asks for at most 3×):", "",
          "| tree | tries | chosen | met | search (s) | one bake (s) | ratio |",
          "| --- | ---: | --- | --- | ---: | ---: | ---: |"]
    for d, n, ch, met, ts, td in search:
        md.append("| %s | %d | `%s` | %s | %.1f | %.1f | %.2f× |" % (d, n, ch, met, ts, td, ts / td))
    md += ["", "The default bake (`{}` with the tree's units): the levels the chain keeps, "
           "finest first, as name (triangles, switch distance in m):", "",
           "| tree | units | levels | chain | time (s) |", "| --- | --- | ---: | --- | ---: |"]
    for d, units, tc, rc in chain:
        lv = ", ".join("%s (%d, %.0f m)" % (l["name"], l["triangles"], l.get("switch_distance", 0))
                       for l in rc["lods"])
        md.append("| %s | %s | %d | %s | %.1f |" % (d, units, len(rc["lods"]), lv, tc))
    md.append("<!-- target:end -->")
    write_section(os.path.join(root, "docs", "benchmarks.md"), "target", md)
    subprocess.run(["rm", "-rf", tmp])
    print("target_cost: wrote docs/benchmarks.md")


if __name__ == "__main__":
    main()
