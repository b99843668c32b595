#!/usr/bin/env python3
"""unseen.py — issue 18's fidelity points on trees that are not in
../shared/data: ez-tree presets (a pine, a bush, an oak and an aspen of other
sizes than the shared ones), generated here with the data set's own generator
(../shared/data/generators/eztree_gen.mjs, npm's @dgreenheck/ez-tree 1.1.0 and
three, pinned in tests/bench/eztree/), so no method can be tuned to them by
looking. Each tree: crossed quads, billboard clouds of 20 and 32 planes and 32
leaf clusters, chain off, judged by ../shared/tools/sveval (soft IoU at 64 px)
beside our report, as fidelity.py does. Writes bench/results/unseen.tsv and
the "Trees not in the data set" section of docs/benchmarks.md.

Run by `make bench` (tests/bench/run.sh); needs node and npm (make deps).
"""
import json, os, shutil, subprocess, sys, tempfile, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402
from fidelity import POINTS, bound64, bound_table, cell, run_bake, spec_for, run_sveval, bake, sv_dir, root, build, res_dir, data  # noqa: E402

PRESETS = ["Pine Medium", "Bush 2", "Oak Medium", "Aspen Large"]
UNITS = 0.2  # ez-tree units, as the shared ez-trees (../shared/data/README.md)


def generate(work):
    """npm ci of the pinned packages in work, then the data set's generator;
    returns the folder with the OBJs, MTLs and their textures."""
    here = os.path.dirname(os.path.abspath(__file__))
    for f in ("package.json", "package-lock.json"):
        shutil.copy(os.path.join(here, "eztree", f), work)
    subprocess.run(["npm", "ci", "--no-audit", "--no-fund", "--loglevel=error"], cwd=work,
                   check=True, capture_output=True)
    # the generator imports ez-tree by name: it runs beside node_modules
    gen = os.path.join(work, "eztree_gen.mjs")
    shutil.copy(os.path.join(data, "generators", "eztree_gen.mjs"), gen)
    out = os.path.join(work, "trees")
    os.makedirs(out)
    subprocess.run(["node", gen, out] + PRESETS, cwd=work, check=True, capture_output=True)
    assets = os.path.join(work, "node_modules", "@dgreenheck", "ez-tree", "src", "lib", "assets")
    for mtl in [f for f in os.listdir(out) if f.endswith(".mtl")]:
        for line in open(os.path.join(out, mtl)):
            if not line.startswith(("map_Kd", "map_d")):
                continue
            name = line.split()[1]
            if os.path.exists(os.path.join(out, name)):
                continue
            kind, rest = name.split("_", 1)  # bark_oak_color_1k.jpg, leaves_oak_color.png
            shutil.copy(os.path.join(assets, "bark" if kind == "bark" else "leaves", rest),
                        os.path.join(out, name))
    return out


def main():
    subprocess.run(["make", "-s", "-C", sv_dir, "sveval"], check=True, capture_output=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        trees = generate(tmp)
        for preset in PRESETS:
            base = preset.replace(" ", "_").lower()
            obj = os.path.join(trees, base + ".obj")
            mtl = os.path.join(trees, base + ".mtl")
            tex = sorted({l.split()[1] for l in open(mtl) if l.startswith(("map_Kd", "map_d"))})
            for label, method, settings, other in POINTS:
                spec = spec_for(method, settings, other, UNITS)
                sp = os.path.join(tmp, "spec.json")
                with open(sp, "w") as f:
                    json.dump(spec, f)
                out = os.path.join(tmp, "%s-%d" % (base, len(rows)))
                t0 = time.time()
                run_bake([obj, mtl] + [os.path.join(trees, t) for t in tex] + ["--spec", sp, "--out", out])
                secs = time.time() - t0
                l0 = json.load(open(os.path.join(out, "report.json")))["lods"][0]
                ours = [a["iou_mean"] for a in l0["accuracy"] if a["pixels"] == 64][0]
                theirs = run_sveval(obj, os.path.join(out, "model.glb"), UNITS)
                rows.append({"tree": preset, "point": label, "triangles": l0["triangles"],
                             "ours": ours, "sveval": theirs, "seconds": secs,
                             "bound": bound64(l0), "name": l0["name"], "target": "target" in other})
                print("%-12s %-20s tris %5d  sveval %.3f  ours %.3f  %.1fs" %
                      (preset, label, l0["triangles"], theirs, ours, secs), flush=True)
    os.makedirs(res_dir, exist_ok=True)
    with open(os.path.join(res_dir, "unseen.tsv"), "w") as f:
        f.write("tree\tpoint\ttriangles\tours64\tsveval64\tbound64\tseconds\n")
        for r in rows:
            f.write("%s\t%s\t%d\t%.4f\t%.4f\t%s\t%.1f\n" % (
                r["tree"], r["point"], r["triangles"], r["ours"], r["sveval"],
                "%.4f" % r["bound"] if r["bound"] is not None else "", r["seconds"]))
    by = {}
    for r in rows:
        by.setdefault(r["tree"], {})[r["point"]] = r
    md = ["<!-- unseen:begin (tests/bench/unseen.py writes this section) -->",
          "## Trees not in the data set (issue 18)", "",
          "ez-tree presets generated by the bench with the data set's own generator "
          "(`tests/bench/unseen.py`; the pinned packages in `tests/bench/eztree/`): a pine, "
          "a bush, an oak and an aspen that no method was looked at on while it was made. "
          "The points of the table above, judged the same way. Cells: sveval / ours "
          "(triangles drawn).", "",
          "| tree | " + " | ".join(p[0] for p in POINTS) + " | bc20 − cq |",
          "| --- |" + " --- |" * (len(POINTS) + 1)]
    for t, pts in by.items():
        cells = [cell(pts[p[0]]) for p in POINTS]
        gain = pts["billboard cloud 20"]["sveval"] - pts["crossed quads"]["sveval"]
        md.append("| %s | %s | %+.3f |" % (t, " | ".join(cells), gain))
    md += ["", "Against the flattening bound (as in the table above): sveval / bound "
           "(sveval − bound).", ""]
    md += bound_table(by)
    md.append("<!-- unseen:end -->")
    write_section(os.path.join(root, "docs", "benchmarks.md"), "unseen", md)
    print("unseen: wrote bench/results/unseen.tsv and docs/benchmarks.md")


if __name__ == "__main__":
    sys.exit(main())
