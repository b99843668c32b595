#!/usr/bin/env python3
"""brightness.py [--before SYLVA_BAKE] [--heldout] — issue 41's colour
figures on every shared tree (and with --heldout on the held-out set instead,
tests/bench/heldout.py, in the section "brightnessheldout"): `{}` with the tree's units, every level file judged by
../shared/tools/sveval in its default colour (glTF's: linear factor × texel
decoded from sRGB; 24 views): lum_ratio (the level's light ÷ the
original's where both cover; the issue asks [0.93, 1.07] for every level),
the soft 64 px RGB error and the mean RGB error, beside our report's
lum_ratio at 64 px and the level's colour_scale (docs/accuracy.md
"Brightness match"). With --before, the same bakes with another sylva-bake
(e.g. one built at an earlier commit) in the columns before.

Writes the section "brightness" of docs/benchmarks.md and
bench/results/brightness.tsv. Env: BUILD, SYLVA_DATA, SYLVA_BENCH_TREES.
About 10 minutes (20 with --before).
"""
import json, os, re, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402
from fidelity import trees as shared_trees, companions, root, data, bake, sv_dir, sveval  # noqa: E402
import heldout  # noqa: E402
from far_origin_sets import bake_to  # noqa: E402

SCALE = {"m": 1.0, "cm": 0.01}


def sv(ref, cand, scale):
    cmd = [sveval, ref, cand, "--views", "24"]
    if scale != 1.0:
        cmd += ["--ref-scale", repr(scale)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout.splitlines()[-1]
    g = lambda k: float(re.search(r"\b" + k + r"=([0-9.]+)", out).group(1))  # noqa: E731
    return g("lum_ratio"), g("soft64_rgb_err"), g("mean_rgb_err")


def levels(binary, d, files, units, tmp, tag):
    out = os.path.join(tmp, d + "-" + tag)
    rep = bake_to(files, units, out, binary)
    scale = SCALE[units] if isinstance(units, str) else float(units)
    rows = {}
    for l in rep["lods"]:
        lum, e64, emean = sv(files[0], os.path.join(out, l["file"]), scale)
        ours = [a["lum_ratio"] for a in l.get("accuracy", []) if a["pixels"] == 64]
        rows[l["name"]] = (l["quads"], lum, e64, emean, ours[0] if ours else None,
                           l.get("colour_scale"))
    subprocess.run(["rm", "-rf", out])
    return rows


def main():
    args = sys.argv[1:]
    before = args[args.index("--before") + 1] if "--before" in args else None
    subprocess.run(["make", "-s", "-C", sv_dir], check=True, capture_output=True)
    rows = []
    todo = []
    if "--heldout" in args:
        todo = [(re.sub(r"[^A-Za-z0-9]+", "_", n), fl, u) for n, fl, u in heldout.generate()
                if fl[0].endswith(".obj")]
    else:
        for d, mesh, units in shared_trees():
            if not mesh.endswith(".obj"):
                continue
            if d.startswith("eztree_"):
                units = heldout.EZTREE_UNITS  # ../shared/data/README.md: ~0.2 m a unit
            folder = os.path.join(data, d)
            todo.append((d, [os.path.join(folder, mesh)] + companions(folder, mesh), units))
    with tempfile.TemporaryDirectory() as tmp:
        for d, files, units in todo:
            after = levels(bake, d, files, units, tmp, "after")
            prev = levels(before, d, files, units, tmp, "before") if before else {}
            for name, a in after.items():
                b = prev.get(name)
                rows.append((d, name) + a + ((b[1], b[2], b[3]) if b else (None, None, None)))
                print("brightness: %-30s %-14s lum %.3f (ours %s) rgb64 %.2f mean %.2f scale %s%s"
                      % (d, name, a[1], "%.3f" % a[4] if a[4] is not None else "-", a[2], a[3],
                         a[5], "; before lum %.3f rgb64 %.2f mean %.2f" % b[1:4] if b else ""),
                      flush=True)
    res = os.path.join(root, "bench", "results")
    os.makedirs(res, exist_ok=True)
    tag = "brightnessheldout" if "--heldout" in args else "brightness"
    with open(os.path.join(res, tag + ".tsv"), "w") as f:
        f.write("tree\tlevel\tquads\tlum\trgb64\trgb_mean\tours_lum64\tcolour_scale\t"
                "before_lum\tbefore_rgb64\tbefore_rgb_mean\n")
        for r in rows:
            f.write("\t".join("" if v is None else str(v) for v in r) + "\n")
    fmt = lambda v, p: "–" if v is None else ("%." + str(p) + "f") % v  # noqa: E731
    md = ["<!-- %s:begin (tests/bench/brightness.py writes this section) -->" % tag,
          "## Brightness of every level (issue 41)%s" % (", held-out set" if tag != "brightness"
                                                          else ""), "",
          "`{}` with each tree's units; every level file judged by `../shared/tools/sveval` in its "
          "default colour (24 views): `lum_ratio` (the issue asks [0.93, 1.07]), the soft 64 px RGB "
          "error and the mean RGB error" + (", before → after" if before else "") +
          "; *ours*: the report's lum_ratio at 64 px; *scale*: the level's `colour_scale` "
          "(docs/accuracy.md \"Brightness match\").", "",
          "| tree | level | lum_ratio | soft64 RGB error | mean RGB error | ours | scale |",
          "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
    worst = 0.0
    for r in rows:
        d, name, quads, lum, e64, emean, ours, scale, blum, be64, bemean = r
        worst = max(worst, abs(lum - 1))
        if blum is not None:
            cells = ("%.3f → %.3f" % (blum, lum), "%.2f → %.2f" % (be64, e64),
                     "%.2f → %.2f" % (bemean, emean))
        else:
            cells = ("%.3f" % lum, "%.2f" % e64, "%.2f" % emean)
        md.append("| %s | %s | %s | %s | %s | %s | %s |" % ((d, name) + cells +
                                                           (fmt(ours, 3), fmt(scale, 3))))
    md += ["", "Largest |lum_ratio − 1|: %.3f." % worst, "<!-- %s:end -->" % tag]
    write_section(os.path.join(root, "docs", "benchmarks.md"), tag, md)
    print("brightness: largest |lum_ratio - 1| %.3f; wrote bench/results/brightness.tsv and "
          "docs/benchmarks.md" % worst)


if __name__ == "__main__":
    main()
