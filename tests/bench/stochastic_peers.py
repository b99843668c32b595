#!/usr/bin/env python3
"""stochastic_peers.py — issue 24's table: every default stochastic level
(λ = 0.5, 0.25, 0.1, each baked alone with `"lod": {"chain": false}`) against
meshoptimizer at the same triangle count on every shared tree, judged by
../shared/tools/sveval (soft coverage IoU at 64 px, 24 views) beside our own
figure (report.json, 64 px mean IoU, same views).

The peers are the evaluator's own baseline tool, ../shared/tools/sveval/
mosimplify (each mesh of the file welded on position + UV and simplified on its
own): `--sloppy` (meshopt_simplifySloppy) and plain meshopt_simplify.
meshopt_simplifySloppy in meshoptimizer 0.18 often lands well below the count
it is asked for; so that the comparison is at equal triangles its ratio is
raised (up to 6 tries) until it reaches at least 95 % of ours. meshopt_simplify
often stops above the target: the table says what it reached.

Writes bench/results/stochastic_peers.tsv and the "Stochastic levels against
meshoptimizer" section of docs/benchmarks.md (between markers). Run by
`make bench` (tests/bench/run.sh). Env: BUILD, SYLVA_DATA, SYLVA_BENCH_TREES.
"""
import json, os, re, subprocess, sys, tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402
from fidelity import trees, companions, root, data, bake, sv_dir, sveval, res_dir  # noqa: E402

mosimplify = os.path.join(sv_dir, "mosimplify")
LEVELS = (0.5, 0.25, 0.1)


def sv(ref, cand, scale):
    cmd = [sveval, ref, cand, "--views", "24"]
    if scale != 1.0:
        cmd += ["--ref-scale", str(scale)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return (float(re.search(r"soft64_iou=([0-9.]+)", out).group(1)),
            int(re.search(r"cand_tris=(\d+)", out).group(1)))


def peer(src, out_dir, ratio, sloppy):
    os.makedirs(out_dir, exist_ok=True)
    obj = os.path.join(out_dir, "m.obj")
    cmd = [mosimplify, src, obj, "--ratio", "%.6f" % min(ratio, 1.0)] + (["--sloppy"] if sloppy else [])
    subprocess.run(cmd, check=True, capture_output=True)
    return obj


def sloppy_at(src, out_dir, ratio, tris):
    """meshopt_simplifySloppy as near our count as it gets: the ratio is
    bisected (up to 8 tries) for a result in [0.95, 1.02] × tris; the result
    nearest to tris without going above 1.02 × tris is judged."""
    lo, hi, r, best = 0.0, None, ratio, None
    for _ in range(8):
        iou, n = sv(src, peer(src, out_dir, r, True), 1.0)
        if n <= 1.02 * tris and (best is None or abs(n - tris) < abs(best[1] - tris)):
            best = (iou, n)
        if 0.95 * tris <= n <= 1.02 * tris or (n < tris and r >= 1.0):
            break
        if n < tris:
            lo = r
            r = min(1.0, 2 * r) if hi is None else (lo + hi) / 2
        else:
            hi = r
            r = (lo + hi) / 2
    return best if best else sv(src, peer(src, out_dir, ratio, True), 1.0)


def main():
    subprocess.run(["make", "-s", "-C", sv_dir], check=True, capture_output=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for d, mesh, units in trees():
            src_dir = os.path.join(data, d)
            src = os.path.join(src_dir, mesh)
            scale = 0.01 if units == "cm" else 1.0
            for lam in LEVELS:
                od = os.path.join(tmp, "%s-%g" % (d, lam))
                os.makedirs(od)
                spec = {"method": "stochastic", "stochastic": {"levels": [lam]},
                        "import": {"units": units}, "lod": {"chain": False},
                        "evaluate": {"sizes": [64], "supersample": 4}}
                sp = os.path.join(od, "spec.json")
                with open(sp, "w") as f:
                    json.dump(spec, f)
                subprocess.run([bake, "bake", src] + companions(src_dir, mesh) +
                               ["--spec", sp, "--out", os.path.join(od, "bake")],
                               check=True, capture_output=True)
                rep = json.load(open(os.path.join(od, "bake", "report.json")))
                lv = [l for l in rep["lods"] if l.get("source") == "stochastic" and l.get("lambda") == lam]
                if not lv:
                    continue
                lv = lv[0]
                ours, _ = sv(src, os.path.join(od, "bake", lv["file"]), scale)
                self64 = [a["iou_mean"] for a in lv["accuracy"] if a["pixels"] == 64][0]
                tris = lv["triangles"]
                total = rep["input"]["mesh"]["imported_triangles"]  # what mosimplify's ratio is of
                ratio = tris / total
                s_iou, s_tris = sloppy_at(src, os.path.join(od, "sloppy"), ratio, tris)
                p_iou, p_tris = sv(src, peer(src, os.path.join(od, "simplify"), tris / total, False), 1.0)
                row = {"tree": d, "lambda": lam, "triangles": tris, "leaf_fraction": lv.get("leaf_fraction"),
                       "ours": ours, "self": self64, "sloppy": s_iou, "sloppy_tris": s_tris,
                       "simplify": p_iou, "simplify_tris": p_tris}
                rows.append(row)
                print("%-30s λ %-4g ours %.3f (%6d, self %.3f)  sloppy %.3f (%6d)  simplify %.3f (%6d)  %+.3f"
                      % (d, lam, ours, tris, self64, s_iou, s_tris, p_iou, p_tris, ours - s_iou), flush=True)
    os.makedirs(res_dir, exist_ok=True)
    with open(os.path.join(res_dir, "stochastic_peers.tsv"), "w") as f:
        f.write("tree\tlambda\ttriangles\tleaf_fraction\tsveval64\tours64\tsloppy64\tsloppy_tris\t"
                "simplify64\tsimplify_tris\n")
        for r in rows:
            f.write("%s\t%g\t%d\t%.4f\t%.4f\t%.4f\t%.4f\t%d\t%.4f\t%d\n" % (
                r["tree"], r["lambda"], r["triangles"], r["leaf_fraction"] or 0, r["ours"], r["self"],
                r["sloppy"], r["sloppy_tris"], r["simplify"], r["simplify_tris"]))
    worst = min((r["ours"] - r["sloppy"] for r in rows), default=0)
    wins = sum(r["ours"] >= r["sloppy"] for r in rows)
    md = ["<!-- stochpeers:begin (tests/bench/stochastic_peers.py writes this section) -->",
          "## Stochastic levels against meshoptimizer (issue 24)", "",
          "Each default level baked alone (`{\"stochastic\": {\"levels\": [λ]}, \"lod\": {\"chain\": false}}`), "
          "judged by `../shared/tools/sveval` (soft coverage IoU at 64 px, 24 views); the peers are "
          "sveval's `mosimplify` on the original file, `--sloppy` raised until it draws at least 95 % "
          "of our triangles, plain meshopt_simplify at our ratio (it often stops above it). Cells: "
          "sveval IoU (triangles); ours also with our report's figure and μ, the fraction of the leaves drawn.", "",
          "| tree | λ | ours (triangles) | our report | μ | meshopt_simplifySloppy | meshopt_simplify | ours − sloppy |",
          "| --- | ---: | --- | ---: | ---: | --- | --- | ---: |"]
    for r in rows:
        md.append("| %s | %g | %.3f (%d) | %.3f | %.2f | %.3f (%d) | %.3f (%d) | %+.3f |" % (
            r["tree"], r["lambda"], r["ours"], r["triangles"], r["self"], r["leaf_fraction"] or 0,
            r["sloppy"], r["sloppy_tris"], r["simplify"], r["simplify_tris"], r["ours"] - r["sloppy"]))
    md += ["", "Levels at or above meshopt_simplifySloppy: %d of %d; the smallest margin: %+.3f." %
           (wins, len(rows), worst), "<!-- stochpeers:end -->"]
    write_section(os.path.join(root, "docs", "benchmarks.md"), "stochpeers", md)
    print("stochastic_peers: wrote bench/results/stochastic_peers.tsv and docs/benchmarks.md")


if __name__ == "__main__":
    sys.exit(main())
