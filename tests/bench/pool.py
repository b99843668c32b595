#!/usr/bin/env python3
"""pool.py — issue 20 item 1's figure: daemon jobs per minute for small bakes
with sylvad's resident worker pool (worker_pool = on, a `sylva-bake zygote`
per worker thread forking each bake) and without it (one exec of sylva-bake
per job), in one run on the same machine.

For each input (a one-triangle OBJ; the eztree aspen when $SYLVA_DATA has
it) and each mode, a fresh sylvad (temporary store, default worker count =
cores) gets
  1. N jobs one at a time (upload, wait until done; distinct inputs: a
     comment line numbers each copy, so no two share a key): the latency of
     each; the first (with the pool it starts a zygote) apart, the median of
     the others "after the first" (the second worker thread's first job,
     which starts its zygote, is one of them: the median is robust to it);
  2. then N more at once: jobs per minute = N / (first upload .. last done),
     the zygotes already running, as in a daemon that has served a job.
The spec is cheap (crossed quads alone, a 256-texel atlas, 4 views at 64 px):
what is measured is what a job costs around the bake. Writes
bench/results/pool.tsv and the "Worker pool" section of docs/benchmarks.md.

With SYLVA_POOL_BASELINE=DIR (a build folder of an older sylva, e.g. the
daemon before the pool, commit f6aa7ca^, built in a worktree), its sylvad
runs the same one-triangle jobs in the same run, with its own defaults: the
ratio issue 20 asks for ("3x today's jobs per minute") measured, not quoted.

Run by `make bench` (tests/bench/run.sh). Env: BUILD, SYLVA_DATA,
SYLVA_POOL_JOBS (N, default 20), SYLVA_POOL_BASELINE.
"""
import json, os, shutil, statistics, subprocess, sys, tempfile, time, urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from docsection import write_section  # noqa: E402

root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
build = os.path.join(root, os.environ.get("BUILD", "build"))
data = os.environ.get("SYLVA_DATA", os.path.join(root, "..", "shared", "data"))
res_dir = os.path.join(root, "bench", "results")
N = int(os.environ.get("SYLVA_POOL_JOBS", "20"))
SPEC = {"method": "crossed_quads", "lod": {"chain": False}, "bake": {"max_atlas": 256},
        "evaluate": {"views": 4, "sizes": [64]}}
TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def start(tmp, pool, bdir=None):
    """A fresh sylvad; pool None: bdir's daemon with its own defaults."""
    run = tempfile.mkdtemp(prefix="daemon-%s-" % pool, dir=tmp)  # a fresh store and port file
    store = os.path.join(run, "store")
    portf = os.path.join(run, "port")
    log = open(os.path.join(run, "daemon.log"), "w")
    mode = ["--worker-pool", pool] if pool else []
    p = subprocess.Popen([os.path.join(bdir or build, "sylvad"), "--listen", "127.0.0.1:0", "--store",
                          store, "--port-file", portf] + mode + ["--queue-per-client", "1000",
                          "--log-level", "info"], stderr=log)
    for _ in range(200):
        if os.path.exists(portf) and open(portf).read().strip():
            break
        time.sleep(0.05)
    return p, "http://127.0.0.1:%s" % open(portf).read().strip()


def stop(p):
    p.terminate()
    p.wait(timeout=60)


def submit(url, mesh, files):
    args = ["curl", "-s", "-F", "spec=%s;type=application/json" % json.dumps(SPEC),
            "-F", "mesh=@" + mesh] + sum((["-F", "file=@" + f] for f in files), [])
    out = subprocess.run(args + [url + "/v1/bakes"], capture_output=True, check=True).stdout
    return json.loads(out)["key"]


def wait_done(url, key):
    while True:
        with urllib.request.urlopen("%s/v1/bakes/%s?wait=30" % (url, key), timeout=60) as r:
            st = json.loads(r.read())["state"]
        if st in ("done", "failed", "cancelled"):
            if st != "done":
                raise RuntimeError("bake %s: %s" % (key, st))
            return


def variants(tmp, name, text, files, count, first):
    """count copies of a mesh, each with its own comment line (its own key)."""
    out = []
    for i in range(first, first + count):
        d = os.path.join(tmp, "in", "%s-%d" % (name[0], i))
        os.makedirs(d, exist_ok=True)
        m = os.path.join(d, name[1])
        with open(m, "w") as f:
            f.write(text + "\n# pool bench job %d\n" % i)
        out.append((m, files))
    return out


def measure(tmp, pool, inputs, bdir=None):
    p, url = start(tmp, pool, bdir)
    try:
        lat = []
        for m, fs in inputs[:N]:
            t = time.time()
            wait_done(url, submit(url, m, fs))
            lat.append(time.time() - t)
        t0 = time.time()
        keys = [submit(url, m, fs) for m, fs in inputs[N:]]
        for k in keys:
            wait_done(url, k)
        burst = time.time() - t0
    finally:
        stop(p)
    return {"jpm": N / burst * 60, "burst": burst, "lat": lat}


def workers():
    return os.cpu_count() or 1


def main():
    os.makedirs(res_dir, exist_ok=True)
    cases = [("one triangle", ("tri", "tri.obj"), TRI, [])]
    aspen = os.path.join(data, "eztree_aspen_small")
    if os.path.exists(os.path.join(aspen, "aspen_small.obj")):
        comp = [os.path.join(aspen, f) for f in sorted(os.listdir(aspen))
                if f.endswith((".mtl", ".png", ".jpg"))]
        cases.append(("eztree_aspen_small", ("aspen", "aspen_small.obj"),
                      open(os.path.join(aspen, "aspen_small.obj")).read(), comp))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, name, text, comp in cases:
            res = {}
            for k, pool in enumerate(("on", "off")):
                # fresh inputs per mode: a key baked once is served from the store
                ins = variants(tmp, name, text, comp, 2 * N, 1000 * k)
                res[pool] = measure(tmp, pool, ins)
                r = res[pool]
                after = r["lat"][1:] or r["lat"]
                r["first"] = r["lat"][0]
                r["median"] = statistics.median(after)
                r["mean"] = statistics.mean(after)
                print("%-20s pool %-3s %6.1f jobs/min (%d at once: %.1f s); one at a time: first %.2f s, "
                      "median after %.2f s" % (label, pool, r["jpm"], N, r["burst"], r["first"],
                                               r["median"]), flush=True)
            rows.append((label, res))
        base = os.environ.get("SYLVA_POOL_BASELINE")
        if base:
            ins = variants(tmp, cases[0][1], cases[0][2], cases[0][3], 2 * N, 9000)
            r = measure(tmp, None, ins, os.path.abspath(base))
            after = r["lat"][1:] or r["lat"]
            r["first"], r["median"], r["mean"] = r["lat"][0], statistics.median(after), statistics.mean(after)
            baseline = (base, r)
            print("baseline %s %6.1f jobs/min (%d at once: %.1f s); median after %.2f s" % (
                base, r["jpm"], N, r["burst"], r["median"]), flush=True)
        else:
            baseline = None
    with open(os.path.join(res_dir, "pool.tsv"), "w") as f:
        f.write("input\tpool\tjobs_per_min\tburst_s\tfirst_s\tmedian_after_s\tmean_after_s\n")
        for label, res in rows:
            for pool in ("on", "off"):
                r = res[pool]
                f.write("%s\t%s\t%.1f\t%.2f\t%.3f\t%.3f\t%.3f\n" % (label, pool, r["jpm"], r["burst"],
                        r["first"], r["median"], r["mean"]))
    load = os.getloadavg()[0]
    md = ["<!-- pool:begin (tests/bench/pool.py writes this section) -->",
          "### Worker pool: daemon jobs per minute (issue 20 item 1)", "",
          "Small bakes through sylvad (%d worker threads, one per core) with `worker_pool = on` "
          "(each thread's `sylva-bake zygote` forks the bake) and `off` (one exec of sylva-bake per "
          "job), spec `%s`, a fresh daemon per row. \"One at a time\": %d distinct uploads, each "
          "when the previous was done (upload to done, as a client sees it); the first job starts "
          "the thread's zygote, the median is of the others. \"%d at once\": %d more, then wait "
          "for all; jobs per minute from the first upload to the last done (the zygotes already "
          "running). Load average at the end: %.1f on %d cores (a shared machine: figures move "
          "with it)." %
          (workers(), json.dumps(SPEC), N, N, N, load, workers()), "",
          "| input | pool | %d at once: jobs/min | one at a time: first job | median after the first "
          "| jobs/min ratio on/off | latency ratio off/on |" % N,
          "| --- | --- | --- | --- | --- | --- | --- |"]
    for label, res in rows:
        on, off = res["on"], res["off"]
        for pool in ("on", "off"):
            r = res[pool]
            md.append("| %s | %s | %.1f | %.2f s | %.2f s | %s | %s |" % (
                label, pool, r["jpm"], r["first"], r["median"],
                "%.2f×" % (on["jpm"] / off["jpm"]) if pool == "on" else "",
                "%.2f×" % (off["median"] / on["median"]) if pool == "on" else ""))
    if baseline:
        base, b = baseline
        on = rows[0][1]["on"]
        rev = subprocess.run(["git", "-C", base, "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True).stdout.strip() or "?"
        md += ["", "Against an older daemon in the same run (`SYLVA_POOL_BASELINE`: a build of commit %s, "
               "with its own defaults), one-triangle jobs:" % rev,
               "", "| daemon | %d at once: jobs/min | median after the first | jobs/min ratio now/then "
               "| latency ratio then/now |" % N, "| --- | --- | --- | --- | --- |",
               "| then (%s) | %.1f | %.2f s | | |" % (rev, b["jpm"], b["median"]),
               "| now (pool on) | %.1f | %.2f s | %.2f× | %.2f× |" % (
                   on["jpm"], on["median"], on["jpm"] / b["jpm"], b["median"] / on["median"])]
    md.append("<!-- pool:end -->")
    write_section(os.path.join(root, "docs", "benchmarks.md"), "pool", md)
    print("pool: wrote bench/results/pool.tsv and docs/benchmarks.md")


if __name__ == "__main__":
    if not shutil.which("curl"):
        sys.exit("pool.py: curl missing")
    sys.exit(main())
