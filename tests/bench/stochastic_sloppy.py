#!/usr/bin/env python3
"""stochastic_sloppy.py [--tag NAME] [--trees d1,d2] [--extra OBJ:UNITS ...] —
every level of one `{"method": "stochastic", "lod": {"chain": false}}` bake
(the default levels λ = 1, 0.5, 0.25, 0.1) against meshoptimizer's sloppy
simplifier at the same triangle count, both judged by ../shared/tools/sveval
(soft IoU at 64 px, 24 views) against the original file.

For each tree: one bake (units given), each level's triangle count read from
report.json, `mosimplify ORIGINAL out.obj --ratio R --sloppy` with R raised or
bisected until sloppy lands within [0.95, 1.02] x our count (sloppy_at in
stochastic_peers.py), then sveval on both. The acceptance is ours >= sloppy -
0.02 on every level. Prints one line per level and writes
bench/results/stochastic_sloppy-TAG.tsv. `--extra` adds trees that are not in
../shared/data; `--twig` adds tests/tools/twig_tree.py's tree of twig elements
(1500 twigs, seed 7, 0.08 m leaves), made in a temporary folder; `--doc`
writes the "Stochastic levels of one bake against meshopt sloppy" section of
docs/benchmarks.md (`--doc-from TSV`: from a TSV this script wrote). Run by `make bench` with --twig --doc. Env: BUILD,
SYLVA_DATA.
"""
import argparse, json, os, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402
from fidelity import trees, companions, data, bake, sv_dir, res_dir, root  # noqa: E402
from stochastic_peers import sv, sloppy_at  # noqa: E402


def one_tree(name, src, comp, units, tmp):
    scale = 0.01 if units == "cm" else 1.0
    od = os.path.join(tmp, name)
    os.makedirs(od)
    spec = {"method": "stochastic", "import": {"units": units}, "lod": {"chain": False}}
    sp = os.path.join(od, "spec.json")
    with open(sp, "w") as f:
        json.dump(spec, f)
    subprocess.run(["nice", bake, "bake", src] + comp + ["--spec", sp, "--out", os.path.join(od, "bake")],
                   check=True, capture_output=True)
    rep = json.load(open(os.path.join(od, "bake", "report.json")))
    total = rep["input"]["mesh"]["imported_triangles"]
    rows = []
    for lv in rep["lods"]:
        if lv.get("source") != "stochastic" or lv.get("lambda", 1) >= 1:
            continue
        lam, tris = lv["lambda"], lv["triangles"]
        ours, _ = sv(src, os.path.join(od, "bake", lv["file"]), scale)
        s_iou, s_tris = sloppy_at(src, os.path.join(od, "sloppy-%g" % lam), tris / total, tris)
        row = (name, lam, tris, ours, s_iou, s_tris, lv.get("leaf_fraction", 0),
               lv.get("leaves_whole", -1), lv.get("leaves_simplified", -1))
        rows.append(row)
        print("%-30s λ %-5g ours %.3f (%6d)  sloppy %.3f (%6d)  %+.3f  μ %.2f  whole %s simplified %s" %
              (name, lam, ours, tris, s_iou, s_tris, ours - s_iou, row[6], row[7], row[8]), flush=True)
    return rows


def write_doc(rows, bad):
    md = ["<!-- stochsloppy:begin (tests/bench/stochastic_sloppy.py writes this section) -->",
          "## Stochastic levels of one bake against meshopt sloppy", "",
          "Each tree baked once with `{\"method\": \"stochastic\", \"lod\": {\"chain\": false}}` "
          "(units given; the default levels, those the bake keeps); each level against "
          "`mosimplify --sloppy` on the original at the same triangle count (ratio searched to "
          "[0.95, 1.02] × ours), both judged by `../shared/tools/sveval` (soft IoU at 64 px, 24 views). "
          "Acceptance: ours ≥ sloppy − 0.02. `twig_tree` is tests/tools/twig_tree.py's tree of twig "
          "elements (not in ../shared/data). Whole / simplified: the drawn elements kept as modelled "
          "by the silhouette rule and those drawn simplified (docs/methods/stochastic.md).", "",
          "| tree | λ | ours (triangles) | sloppy (triangles) | ours − sloppy | μ | whole / simplified |",
          "| --- | ---: | --- | --- | ---: | ---: | --- |"]
    for r in rows:
        md.append("| %s | %g | %.3f (%d) | %.3f (%d) | %+.3f | %.2f | %s / %s |" % (
            r[0], r[1], r[3], r[2], r[4], r[5], r[3] - r[4], r[6], r[7], r[8]))
    md += ["", "Levels below sloppy − 0.02: %d of %d." % (len(bad), len(rows)),
           "<!-- stochsloppy:end -->"]
    write_section(os.path.join(root, "docs", "benchmarks.md"), "stochsloppy", md)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tag", default="now")
    ap.add_argument("--trees", default="")
    ap.add_argument("--extra", action="append", default=[])
    ap.add_argument("--twig", action="store_true")
    ap.add_argument("--doc", action="store_true")
    ap.add_argument("--doc-from", help="write the docs section from this TSV, bake nothing")
    a = ap.parse_args()
    if a.doc_from:
        rows = []
        with open(a.doc_from) as f:
            next(f)
            for line in f:
                c = line.rstrip("\n").split("\t")
                rows.append((c[0], float(c[1]), int(c[2]), float(c[3]), float(c[4]), int(c[5]),
                             float(c[6]), c[7], c[8]))
        write_doc(rows, [r for r in rows if r[3] < r[4] - 0.02])
        return 0
    subprocess.run(["make", "-s", "-C", sv_dir], check=True, capture_output=True)
    want = set(filter(None, a.trees.split(",")))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for d, mesh, units in trees():
            if want and d not in want:
                continue
            sd = os.path.join(data, d)
            rows += one_tree(d, os.path.join(sd, mesh), companions(sd, mesh), units, tmp)
        if a.twig:
            tw = os.path.join(tmp, "twig-src")
            os.makedirs(tw)
            subprocess.run([sys.executable, os.path.join(root, "tests", "tools", "twig_tree.py"),
                            os.path.join(tw, "twig_tree.obj"), "1500", "7", "0.08", "twigs"], check=True)
            a.extra.append(os.path.join(tw, "twig_tree.obj") + ":m")
        for e in a.extra:
            path, units = e.rsplit(":", 1)
            d = os.path.dirname(os.path.abspath(path))
            rows += one_tree(os.path.splitext(os.path.basename(path))[0], path,
                             companions(d, os.path.basename(path)), units, tmp)
    os.makedirs(res_dir, exist_ok=True)
    with open(os.path.join(res_dir, "stochastic_sloppy-%s.tsv" % a.tag), "w") as f:
        f.write("tree\tlambda\ttriangles\tours64\tsloppy64\tsloppy_tris\tleaf_fraction\tleaves_whole\tleaves_simplified\n")
        for r in rows:
            f.write("%s\t%g\t%d\t%.4f\t%.4f\t%d\t%.4f\t%s\t%s\n" % r)
    bad = [r for r in rows if r[3] < r[4] - 0.02]
    if a.doc:
        write_doc(rows, bad)
    print("stochastic_sloppy: %d levels, %d below sloppy - 0.02" % (len(rows), len(bad)))


if __name__ == "__main__":
    sys.exit(main())
