#!/usr/bin/env python3
"""heldout_figures.py [--shared] [--heldout-only] — issue 40's figures on the
held-out set (tests/bench/heldout.py: 13 trees from ez-tree, Sapling and
sweethome3d-furniture, never tuned on) and, with --shared, on every shared tree
(tests/data/trees.tsv, one file per tree; its units, except the ez-trees,
read as 0.2 m a unit as ../shared/data/README.md says and as the held-out
ez-trees are), side by side.

Per tree:
- the default bake `{"import": {"units": U}}`: the kept chain (name, triangles,
  the largest screen height in px it is drawn at), the up axis the import chose
  (input.up_check), the wall time;
- `python3 tests/tools/chain_check.py REPORT` (cost and density rules, the
  original as LOD0);
- every written level file (report.json's lods[].file) drawn by
  ../shared/tools/sveval (soft IoU at 64 and 32 px, 24 views, `--byte-color`:
  coverage figures are the same; `--ref-scale` for cm and ez-tree units) against
  the report's figure at that size: the largest |ours − sveval| and the largest
  ours − sveval over the levels, at 64 and at 32 px (issue 40: within 0.02;
  own − sveval ≤ 0.01);
- every alphaCutoff of a MASK material of those files (issue 40: in [0.1, 0.9];
  tests/tools/level_agrees.py checks one level the same way);
- the stochastic levels λ 0.5, 0.25, 0.1 (one bake,
  `{"method": "stochastic", "stochastic": {"levels": [...]}, "lod": {"chain": false}}`),
  each drawn by sveval at 64 px, against `mosimplify --sloppy` (meshoptimizer's
  simplifySloppy, sveval's own baseline tool) on the original file at the same
  triangle count (its ratio bisected, as tests/bench/stochastic_peers.py does,
  for a result in [0.95, 1.02] × ours; issue 40: ours ≥ sloppy − 0.02).

Writes bench/results/heldout.tsv (a row per tree), bench/results/heldout_levels.tsv
(a row per written level and per stochastic level) and the "Held-out set beside
the shared set" section of docs/benchmarks.md, rewritten after every tree so an
interrupted run still leaves what it measured. Exit 0 (it reports; it does not
gate). Run by `make bench` (tests/bench/run.sh) with --shared.
Env: BUILD, SYLVA_DATA, SYLVA_BENCH_TREES (shared folders to keep), SYLVA_HELDOUT
(a comma-separated subset of held-out names).
"""
import json, os, re, struct, subprocess, sys, tempfile, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402
from fidelity import trees as shared_trees, companions, root, data, bake, sv_dir, sveval, res_dir  # noqa: E402
import heldout  # noqa: E402

mosimplify = os.path.join(sv_dir, "mosimplify")
chain_check = os.path.join(root, "tests", "tools", "chain_check.py")
LAMBDAS = (0.5, 0.25, 0.1)


def sv(ref, cand, scale):
    """sveval's soft IoU at 64 and 32 px and the candidate's triangles."""
    cmd = [sveval, ref, cand, "--views", "24", "--byte-color"]
    if scale != 1.0:
        cmd += ["--ref-scale", repr(scale)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    g = lambda k: float(re.search(k + r"=([0-9.]+)", out).group(1))  # noqa: E731
    return g("soft64_iou"), g("soft32_iou"), int(g("cand_tris"))


def sloppy_at(src, out_dir, ratio, tris):
    """mosimplify --sloppy as near tris as it gets (stochastic_peers.py's
    bisection, up to 8 tries): (soft64, triangles)."""
    os.makedirs(out_dir, exist_ok=True)
    obj = os.path.join(out_dir, "sloppy.obj")

    def run(r):
        subprocess.run([mosimplify, src, obj, "--ratio", "%.6f" % min(r, 1.0), "--sloppy"],
                       check=True, capture_output=True)
        s64, _, n = sv(src, obj, 1.0)
        return s64, n
    lo, hi, r, best, last = 0.0, None, ratio, None, None
    for _ in range(8):
        last = run(r)
        iou, n = last
        if n <= 1.02 * tris and (best is None or abs(n - tris) < abs(best[1] - tris)):
            best = last
        if 0.95 * tris <= n <= 1.02 * tris or (n < tris and r >= 1.0):
            break
        if n < tris:
            lo = r
            r = min(1.0, 2 * r) if hi is None else (lo + hi) / 2
        else:
            hi = r
            r = (lo + hi) / 2
    return best or last


def cutoffs(glb):
    b = open(glb, "rb").read()
    g = json.loads(b[20:20 + struct.unpack_from("<I", b, 12)[0]])
    return [m["alphaCutoff"] if "alphaCutoff" in m else 0.5 for m in g.get("materials", [])
            if m.get("alphaMode") == "MASK"]


def run_bake(files, spec, out):
    sp = out + ".spec.json"
    with open(sp, "w") as f:
        json.dump(spec, f)
    t0 = time.time()
    p = subprocess.run([bake, "bake"] + files + ["--spec", sp, "--out", out],
                       capture_output=True, text=True)
    if p.returncode not in (0, 3):
        raise RuntimeError("bake failed (%d): %s" % (p.returncode, p.stderr[-300:]))
    return json.load(open(os.path.join(out, "report.json"))), time.time() - t0


def figures(kind, name, files, units, tmp):
    src = files[0]
    scale = heldout.ref_scale(units)
    base = os.path.join(tmp, re.sub(r"[^A-Za-z0-9]+", "_", name))
    row = {"set": kind, "tree": name, "units": units, "levels": [], "stoch": []}
    rep, secs = run_bake(files, {"import": {"units": units}}, base + "-default")
    out = base + "-default"
    row["seconds"] = secs
    row["triangles"] = rep["input"]["mesh"]["triangles"]
    uc = rep["input"].get("up_check", {})
    row["up"] = "%s%s" % (rep["input"].get("up", "?"), " (rotated)" if uc.get("rotated") else "")
    row["chain"] = [(l["name"], l["triangles"], l["switch_pixels"]) for l in rep["lods"]]
    p = subprocess.run([sys.executable, chain_check, os.path.join(out, "report.json")],
                       capture_output=True, text=True)
    msg = p.stdout.strip().split(": ", 1)[-1] if p.stdout.strip() else p.stderr.strip()[-200:]
    row["chain_check"] = "ok" if p.returncode == 0 else msg.replace("\n", "; ")
    cuts_all = []
    for l in rep["lods"]:
        acc = {a["pixels"]: a["iou_mean"] for a in l["accuracy"]}
        s64, s32, _ = sv(src, os.path.join(out, l["file"]), scale)
        cuts = cutoffs(os.path.join(out, l["file"]))
        cuts_all += cuts
        row["levels"].append({"file": l["file"], "triangles": l["triangles"],
                              "ours64": acc.get(64), "ours32": acc.get(32),
                              "sv64": s64, "sv32": s32, "cutoffs": cuts})
    row["cutoffs"] = cuts_all
    # the stochastic levels against meshoptimizer's sloppy simplifier
    spec = {"import": {"units": units}, "method": "stochastic",
            "stochastic": {"levels": list(LAMBDAS)}, "lod": {"chain": False},
            "evaluate": {"sizes": [64], "supersample": 4}}
    try:
        srep, _ = run_bake(files, spec, base + "-stoch")
    except RuntimeError as e:
        row["stoch_error"] = str(e)
        srep = {"lods": []}
    total = srep.get("input", {}).get("mesh", {}).get("imported_triangles") or row["triangles"]
    for l in srep["lods"]:
        if l.get("source") != "stochastic":
            continue
        s64, _, _ = sv(src, os.path.join(base + "-stoch", l["file"]), scale)
        p64, ptris = sloppy_at(src, base + "-sloppy", l["triangles"] / total, l["triangles"])
        row["stoch"].append({"lambda": l.get("lambda"), "triangles": l["triangles"],
                             "sv64": s64, "sloppy64": p64, "sloppy_tris": ptris})
    return row


def summarise(r):
    lv = r["levels"]
    d64 = [abs(l["ours64"] - l["sv64"]) for l in lv if l["ours64"] is not None]
    d32 = [abs(l["ours32"] - l["sv32"]) for l in lv if l["ours32"] is not None]
    o64 = [l["ours64"] - l["sv64"] for l in lv if l["ours64"] is not None]
    o32 = [l["ours32"] - l["sv32"] for l in lv if l["ours32"] is not None]
    margin = [s["sv64"] - s["sloppy64"] for s in r["stoch"]]
    return {"d64": max(d64, default=float("nan")), "d32": max(d32, default=float("nan")),
            "o": max(o64 + o32, default=float("nan")),
            "cut_lo": min(r["cutoffs"], default=None), "cut_hi": max(r["cutoffs"], default=None),
            "cut_bad": sum(not (0.1 <= c <= 0.9) for c in r["cutoffs"]),
            "margin": min(margin, default=None)}


def write(rows, pending):
    os.makedirs(res_dir, exist_ok=True)
    with open(os.path.join(res_dir, "heldout.tsv"), "w") as f:
        f.write("set\ttree\tunits\ttriangles\tup\tchain\tchain_check\tmax_abs_d64\tmax_abs_d32\t"
                "max_ours_minus_sveval\tcutoff_min\tcutoff_max\tcutoffs_outside\t"
                "stoch_minus_sloppy_min\tbake_seconds\n")
        for r in rows:
            s = summarise(r)
            f.write("%s\t%s\t%s\t%d\t%s\t%s\t%s\t%.4f\t%.4f\t%+.4f\t%s\t%s\t%d\t%s\t%.1f\n" % (
                r["set"], r["tree"], r["units"], r["triangles"], r["up"],
                ", ".join("%s:%d:%.0f" % c for c in r["chain"]), r["chain_check"],
                s["d64"], s["d32"], s["o"],
                "" if s["cut_lo"] is None else "%.3f" % s["cut_lo"],
                "" if s["cut_hi"] is None else "%.3f" % s["cut_hi"], s["cut_bad"],
                "" if s["margin"] is None else "%+.4f" % s["margin"], r["seconds"]))
    with open(os.path.join(res_dir, "heldout_levels.tsv"), "w") as f:
        f.write("set\ttree\tkind\tlevel\ttriangles\tours64\tsveval64\tours32\tsveval32\tcutoffs\t"
                "sloppy64\tsloppy_tris\n")
        for r in rows:
            for l in r["levels"]:
                f.write("%s\t%s\tdefault\t%s\t%d\t%.4f\t%.4f\t%.4f\t%.4f\t%s\t\t\n" % (
                    r["set"], r["tree"], l["file"], l["triangles"], l["ours64"] or 0, l["sv64"],
                    l["ours32"] or 0, l["sv32"], ",".join("%.3f" % c for c in l["cutoffs"])))
            for s in r["stoch"]:
                f.write("%s\t%s\tstochastic\t%g\t%d\t\t%.4f\t\t\t\t%.4f\t%d\n" % (
                    r["set"], r["tree"], s["lambda"], s["triangles"], s["sv64"], s["sloppy64"],
                    s["sloppy_tris"]))
    md = ["<!-- heldout:begin (tests/bench/heldout_figures.py writes this section) -->",
          "## Held-out set beside the shared set (issue 40)", "",
          "The held-out trees (`tests/bench/heldout.py`: ez-tree 1.1.0 presets not used elsewhere, "
          "Sapling presets of Debian's blender 3.4, sweethome3d-furniture models other than the "
          "shared ones; chosen before any was baked, never tuned on) and the shared trees, each "
          "baked with `{\"import\": {\"units\": U}}`. Chain: each kept level, finest first, as "
          "name (triangles, largest px drawn at). Chain rules: `tests/tools/chain_check.py`. "
          "|Δ64|, |Δ32|: the largest |ours − sveval| over the written level files (sveval soft IoU, "
          "24 views); ours − sv: the largest signed difference at 64 or 32 px (issue 40: ≤ 0.01). "
          "Cutoffs: the range of every MASK alphaCutoff written (n outside [0.1, 0.9]). "
          "Stoch − sloppy: the smallest sveval margin at 64 px of the stochastic levels "
          "λ 0.5/0.25/0.1 over `mosimplify --sloppy` at the same triangles (issue 40: ≥ −0.02).", "",
          "| set | tree | units | triangles | up | chain | chain rules | \\|Δ64\\| | \\|Δ32\\| | "
          "ours − sv | cutoffs | stoch − sloppy | bake (s) |",
          "| --- | --- | --- | ---: | --- | --- | --- | ---: | ---: | ---: | --- | ---: | ---: |"]
    for r in rows:
        s = summarise(r)
        chain = ", ".join("%s (%d, %.0f)" % c for c in r["chain"])
        cuts = "—" if s["cut_lo"] is None else "%.3f–%.3f (%d)" % (s["cut_lo"], s["cut_hi"], s["cut_bad"])
        md.append("| %s | %s | %s | %d | %s | %s | %s | %.3f | %.3f | %+.3f | %s | %s | %.1f |" % (
            r["set"], r["tree"], r["units"], r["triangles"], r["up"], chain, r["chain_check"],
            s["d64"], s["d32"], s["o"], cuts,
            "—" if s["margin"] is None else "%+.3f" % s["margin"], r["seconds"]))
    md += ["", "Stochastic levels against meshopt_simplifySloppy (sveval soft IoU at 64 px; "
           "triangles in brackets):", "",
           "| set | tree | λ 0.5 ours / sloppy | λ 0.25 ours / sloppy | λ 0.1 ours / sloppy |",
           "| --- | --- | --- | --- | --- |"]
    for r in rows:
        by = {s["lambda"]: s for s in r["stoch"]}
        cells = []
        for lam in LAMBDAS:
            s = by.get(lam)
            cells.append("—" if not s else "%.3f (%d) / %.3f (%d)" % (
                s["sv64"], s["triangles"], s["sloppy64"], s["sloppy_tris"]))
        md.append("| %s | %s | %s |" % (r["set"], r["tree"], " | ".join(cells)))
    md.append("")
    for kind in ("held-out", "shared"):
        rs = [r for r in rows if r["set"] == kind]
        if not rs:
            continue
        ss = [summarise(r) for r in rs]
        md.append("%s (%d trees): chain rules ok on %d; every level within 0.02 of sveval at 64 and "
                  "32 px on %d; ours − sveval ≤ 0.01 on %d; every cutoff in [0.1, 0.9] on %d; "
                  "stochastic ≥ sloppy − 0.02 on %d." % (
                      kind, len(rs), sum(r["chain_check"] == "ok" for r in rs),
                      sum(s["d64"] <= 0.02 and s["d32"] <= 0.02 for s in ss),
                      sum(s["o"] <= 0.01 for s in ss), sum(s["cut_bad"] == 0 for s in ss),
                      sum(s["margin"] is not None and s["margin"] >= -0.02 for s in ss)))
        md.append("")
    if pending:
        md += ["Not measured in this run: %s." % ", ".join(pending), ""]
    md.append("<!-- heldout:end -->")
    write_section(os.path.join(root, "docs", "benchmarks.md"), "heldout", md)


def main():
    args = sys.argv[1:]
    subprocess.run(["make", "-s", "-C", sv_dir], check=True, capture_output=True)
    todo = []
    if "--shared-only" not in args:
        want = os.environ.get("SYLVA_HELDOUT")
        want = set(want.split(",")) if want else None
        todo += [("held-out", n, fl, u) for n, fl, u in heldout.generate()
                 if want is None or n in want]
    if "--shared" in args or "--shared-only" in args:
        for d, mesh, units in shared_trees():
            folder = os.path.join(data, d)
            if d.startswith("eztree_"):
                units = heldout.EZTREE_UNITS  # ../shared/data/README.md: ~0.2 m a unit, as the held-out ez-trees
            todo.append(("shared", d, [os.path.join(folder, mesh)] + companions(folder, mesh), units))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, (kind, name, files, units) in enumerate(todo):
            t0 = time.time()
            try:
                r = figures(kind, name, files, units, tmp)
            except (RuntimeError, subprocess.CalledProcessError) as e:
                print("heldout_figures: %s: %s" % (name, e), file=sys.stderr)
                continue
            rows.append(r)
            s = summarise(r)
            print("heldout_figures: %-8s %-34s %d levels, chain %s, |d64| %.3f |d32| %.3f, cutoffs bad %d, "
                  "stoch-sloppy %s, %.0f s" % (kind, name, len(r["chain"]), r["chain_check"], s["d64"],
                                               s["d32"], s["cut_bad"],
                                               "—" if s["margin"] is None else "%+.3f" % s["margin"],
                                               time.time() - t0), flush=True)
            write(rows, ["%s %s" % (k, n) for k, n, _, _ in todo[i + 1:]])
            # the bake folders of a finished tree are not needed any more
            subprocess.run(["rm", "-rf"] + [os.path.join(tmp, f) for f in os.listdir(tmp)])
    print("heldout_figures: wrote bench/results/heldout.tsv, heldout_levels.tsv and docs/benchmarks.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
