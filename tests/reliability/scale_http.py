#!/usr/bin/env python3
"""scale_http.py - issue 22 item 4 through HTTP: a real sylvad on a store that
bench_jobs --prepare filled (N stored + M queued bakes), a no-op worker (the
fake worker's "ok": a file copy), and one keep-alive client asking the status
of random keys without pause until every queued bake is done.

usage: scale_http.py SYLVAD FAKE_WORKER STORE KEYS_FILE N_STORED
Prints one JSON line: start-up seconds, jobs/s dispatched, status p50/p99/max
in ms (HTTP round trips on loopback)."""
import http.client, json, os, random, subprocess, sys, tempfile, time

sylvad, fake, store, keys_file, n_stored = sys.argv[1:6]
queued = [k.strip() for k in open(keys_file) if k.strip()]
tmp = tempfile.mkdtemp()
port_file = os.path.join(tmp, "port")
t0 = time.time()
d = subprocess.Popen([sylvad, "--listen", "127.0.0.1:0", "--store", store, "--port-file", port_file,
                      "--worker", fake, "--workers", "2", "--log-level", "warn",
                      "--queue-max", str(len(queued) + 16), "--drain-timeout", "1"],
                     stderr=open(os.path.join(tmp, "log"), "w"))
try:
    while not (os.path.exists(port_file) and open(port_file).read().strip()):
        if d.poll() is not None or time.time() - t0 > 300:
            sys.exit("sylvad did not start: " + open(os.path.join(tmp, "log")).read()[-500:])
        time.sleep(0.05)
    port = int(open(port_file).read())
    started = time.time()
    startup = started - t0
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    probe = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    rnd = random.Random(1)
    lat, pending, last_probe = [], list(queued), 0.0
    all_keys = queued  # stored keys are not listed: random queued ones, and 404s for unknown
    while pending:
        k = rnd.choice(all_keys)
        s0 = time.perf_counter()
        c.request("GET", "/v1/bakes/" + k)
        r = c.getresponse()
        r.read()
        lat.append((time.perf_counter() - s0) * 1e3)
        if time.time() - last_probe > 0.25:  # which queued bakes are done (FIFO: from the front)
            last_probe = time.time()
            while pending:
                probe.request("GET", "/v1/bakes/" + pending[0])
                st = json.loads(probe.getresponse().read()).get("state")
                if st in ("done", "failed"):
                    pending.pop(0)
                else:
                    break
        if time.time() - started > 600:
            sys.exit("the queue was not dispatched within 600 s")
    dispatch = time.time() - started
    lat.sort()
    n = len(lat)
    print(json.dumps({"stored": int(n_stored), "queued": len(queued), "startup_s": round(startup, 2),
                      "dispatch_s": round(dispatch, 2), "jobs_per_s": round(len(queued) / dispatch, 1),
                      "status_calls": n, "status_p50_ms": round(lat[n // 2], 3),
                      "status_p99_ms": round(lat[int(n * 0.99)], 3), "status_max_ms": round(lat[-1], 2)}))
finally:
    d.terminate()
    d.wait()
