#!/usr/bin/env python3
"""default_chains.py — issue 19's acceptance figure for docs/benchmarks.md
(between markers): the spec `{}`, literally (no units, so the Scopia trees in
centimetres are read as 100 times too tall and the ez-trees as 102 m), on
every shared tree (one file per tree): the levels the chain keeps, finest
first, with triangles, texels and the screen size each is drawn up to, the
scene range `"auto"` chose, and the wall time. Every tree must keep three
levels or more (four until issue 41: `lod.min_saving` then dropped the
bonsai's second and third billboard clouds, 220 and 208 triangles after a
245-triangle one, drawn where that one is good; docs/lod.md); the script
exits 1 when one does not. Each chain is also
checked by tests/tools/chain_check.py (the chain chosen by cost, docs/lod.md
"Which level is drawn": no level drawn where one 10 times cheaper is within
0.02, none over 5,000 triangles below 48 px, the original as LOD0), on the
shared trees and, beside them, on the held-out ez-tree presets unseen.py
generates (never tuned on; skipped when node is missing).

Run by `make bench` (tests/bench/run.sh). Env: BUILD, SYLVA_DATA,
SYLVA_BENCH_TREES (comma-separated folders; default every tree). Bakes run
one at a time.
"""
import json, os, subprocess, sys, tempfile, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402
from chain_check_import import check as chain_rules  # noqa: E402

root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
build = os.path.join(root, os.environ.get("BUILD", "build"))
data = os.environ.get("SYLVA_DATA", os.path.join(root, "..", "shared", "data"))
bake = os.path.join(build, "sylva-bake")
MIN_LEVELS = 3


def trees():
    want = os.environ.get("SYLVA_BENCH_TREES")
    want = set(want.split(",")) if want else None
    rows = []
    with open(os.path.join(root, "tests", "data", "trees.tsv")) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            d, mesh = line.split("\t")[:2]
            if (want is None or d in want) and not any(r[0] == d for r in rows):
                rows.append((d, mesh))
    return rows


def files(d, mesh):
    folder = os.path.join(data, d)
    extra = sorted(f for f in os.listdir(folder) if f != mesh and
                   f.lower().endswith((".mtl", ".png", ".jpg", ".jpeg", ".bin")))
    return [os.path.join(folder, mesh)] + [os.path.join(folder, f) for f in extra]


def heldout(tmp):
    """The held-out presets (unseen.py), as (name, [files]); [] without node."""
    try:
        import unseen
        folder = unseen.generate(tmp)
    except Exception as e:  # no node/npm here: the shared set alone
        print("default_chains: no held-out trees (%s)" % e)
        return []
    out = []
    for obj in sorted(f for f in os.listdir(folder) if f.endswith(".obj")):
        extra = sorted(f for f in os.listdir(folder) if f.endswith((".mtl", ".png", ".jpg")))
        out.append(("held-out " + obj[:-4], [os.path.join(folder, obj)] +
                    [os.path.join(folder, f) for f in extra]))
    return out


def main():
    rows, short = [], []
    with tempfile.TemporaryDirectory() as tmp:
        spec = os.path.join(tmp, "spec.json")
        with open(spec, "w") as f:
            f.write("{}")
        gen = os.path.join(tmp, "gen")
        os.makedirs(gen)
        todo = [(d, files(d, mesh)) for d, mesh in trees()] + heldout(gen)
        for d, fl in todo:
            out = os.path.join(tmp, d.replace(" ", "_"))
            t0 = time.time()
            p = subprocess.run([bake, "bake"] + fl + ["--spec", spec, "--out", out],
                               capture_output=True, text=True)
            dt = time.time() - t0
            if p.returncode != 0:
                sys.exit("default_chains: %s: bake failed (%d): %s" % (d, p.returncode, p.stderr[-400:]))
            r = json.load(open(os.path.join(out, "report.json")))
            lv = r["lods"]
            chain = ", ".join("%s (%d tris, %s, %.0f px)" % (
                l["name"], l["triangles"],
                "%dk texels" % round(l["texels"] / 1024) if l.get("texels") else "no atlas",
                l["switch_pixels"]) for l in lv)
            dist = r["scene"]["distance"]
            bad = chain_rules(os.path.join(out, "report.json"))
            rows.append("| %s | %d | %s | %.3g–%.3g m | %s | %.1f |" % (
                d, len(lv), chain, dist[0], dist[1], "ok" if not bad else "; ".join(bad), dt))
            print("default_chains: %s %d levels %.1f s" % (d, len(lv), dt))
            if len(lv) < MIN_LEVELS:
                short.append(d)
    lines = ["<!-- defaultchains:begin (tests/bench/default_chains.py writes this section) -->",
             "## The default bake `{}` on every shared tree (issue 19)",
             "",
             "The spec `{}` as it is: no units (the Scopia trees, in centimetres, are read "
             "as metres; the ez-trees as 102-unit giants), the scene's distance range "
             "`\"auto\"` (the tree filling a 1080-line screen down to 100 times smaller). "
             "Each kept level, finest first: name (triangles, atlas texels, the largest "
             "screen height in pixels it is drawn at).",
             "",
             "| tree | levels | chain | scene range | chain rules | time (s) |",
             "| --- | ---: | --- | --- | --- | ---: |"] + rows + [
             "",
             "Trees with fewer than three levels: %s (four until issue 41's "
             "`lod.min_saving`, which drops a level saving less than a quarter of the "
             "triangles of the one drawn before it)." % (", ".join(short) or "none"),
             "<!-- defaultchains:end -->"]
    write_section(os.path.join(root, "docs", "benchmarks.md"), "defaultchains", lines)
    print("default_chains: wrote docs/benchmarks.md")
    sys.exit(1 if short else 0)


if __name__ == "__main__":
    main()
