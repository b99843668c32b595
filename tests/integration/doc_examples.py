#!/usr/bin/env python3
"""doc_examples.py - runs every example of the user docs (issue 23).

usage: doc_examples.py --root REPO --build BUILD --data SHARED_DATA --work DIR
                       --prefix INSTALLED_PREFIX_IN_DIR

Every fenced block of README.md and docs/*.md (docs/methods/*.md included)
with a language is an example, and each one is checked:

  sh    run. The blocks of one page run in order, in one bash session with
        `set -e`, in the work directory (shared by all pages, in the order of
        PAGES below), beside the fixture: tree.obj tree.mtl bark.jpg
        leaves.png (the shared aspen, renamed), tree.glb (that aspen as glb),
        spec.json (README's spec example), and symlinks examples/ and build/.
        PATH starts with the installed bin/ (a DESTDIR install), and
        pkg-config and the loader find the installed libsylva. The only
        rewrites: 127.0.0.1:8080 -> the test's free port, /var/tmp/sylva-store
        -> a store in the work directory (and SYLVA_SERVER names the test's
        port: the client's default is 127.0.0.1:8080), `make demo` -> run in the source
        tree, `make test` -> not run (it is what runs this test). A line ending in `# NNN` (an HTTP
        status) must print NNN on a line of its own.
  json  a spec (README.md, docs/spec.md): `sylva-bake check-spec` must accept it;
        or, after `<!-- doc-test: shape WHAT -->`, an output example: every
        key it names must occur in the real document(s) WHAT (a file of the
        work directory, or `status` = the status documents of every bake the
        daemon holds, once finished).
  c     written to the file its first comment names (`/* bake_one.c: ...`),
        for the page's sh blocks to build and run.
A block after `<!-- doc-test: skip REASON -->` is listed with its reason and
not run. Blocks without a language are figures (formats, layouts, sample
output) and are not examples. Exit 0 when every example passed.
"""
import argparse
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import time
import urllib.request

PAGES = ["README.md", "docs/client.md", "docs/api.md", "docs/spec.md", "docs/outputs.md",
         "docs/operations.md", "docs/deploy.md", "docs/testing.md", "docs/lod.md",
         "docs/accuracy.md", "docs/design.md", "docs/reliability.md", "docs/benchmarks.md",
         "docs/methods/billboard_cloud.md", "docs/methods/leaf_clusters.md",
         "docs/methods/slicing.md", "docs/methods/stochastic.md"]
FENCE = re.compile(r"^```(\S*)\s*$")
DIRECTIVE = re.compile(r"<!--\s*doc-test:\s*(\w+)\s*(.*?)\s*-->")
KEYS = re.compile(r'"([A-Za-z_][A-Za-z0-9_]*)"\s*:')


def blocks(path):
    """(line, lang, text, directive) for every fenced block of a page."""
    out, lines = [], open(path, encoding="utf-8").read().split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        start, lang, body = i + 1, m.group(1), []
        i += 1
        while i < len(lines) and not lines[i].startswith("```"):
            body.append(lines[i])
            i += 1
        directive = None
        for back in range(start - 2, max(start - 4, -1), -1):
            d = DIRECTIVE.search(lines[back]) if back >= 0 else None
            if d:
                directive = (d.group(1), d.group(2))
                break
            if back >= 0 and lines[back].strip():
                break
        out.append((start, lang, "\n".join(body) + "\n", directive))
        i += 1
    return out


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def all_keys(doc, acc):
    if isinstance(doc, dict):
        for k, v in doc.items():
            acc.add(k)
            all_keys(v, acc)
    elif isinstance(doc, list):
        for v in doc:
            all_keys(v, acc)
    return acc


def healthy(url):
    try:
        with urllib.request.urlopen(url + "/v1/health", timeout=2) as r:
            return r.status == 200
    except OSError:
        return False


def http_json(url):
    with urllib.request.urlopen(url, timeout=70) as r:
        return json.loads(r.read())


def status_docs(url, deadline):
    """Every bake the daemon lists, each once finished (or at the deadline)."""
    keys = [b["key"] for b in http_json(url + "/v1/bakes?limit=1000")["bakes"]]
    docs = []
    for k in keys:
        while True:
            d = http_json("%s/v1/bakes/%s?wait=10" % (url, k))
            if d["state"] not in ("queued", "running") or time.time() > deadline:
                break
        docs.append(d)
    return docs


def fixture(a, work):
    src = os.path.join(a.data, "eztree_aspen_small")
    obj = open(os.path.join(src, "aspen_small.obj"), encoding="utf-8").read()
    open(os.path.join(work, "tree.obj"), "w").write(
        obj.replace("mtllib aspen_small.mtl", "mtllib tree.mtl"))
    mtl = open(os.path.join(src, "aspen_small.mtl"), encoding="utf-8").read()
    open(os.path.join(work, "tree.mtl"), "w").write(
        mtl.replace("bark_birch_color_1k.jpg", "bark.jpg")
           .replace("leaves_aspen_color.png", "leaves.png"))
    shutil.copy(os.path.join(src, "bark_birch_color_1k.jpg"), os.path.join(work, "bark.jpg"))
    shutil.copy(os.path.join(src, "leaves_aspen_color.png"), os.path.join(work, "leaves.png"))
    readme_specs = [b for b in blocks(os.path.join(a.root, "README.md")) if b[1] == "json"]
    open(os.path.join(work, "spec.json"), "w").write(readme_specs[0][2])
    # tree.glb: the same aspen as one glb (its full-detail level, textures
    # inside); the chain's other levels and their figures are not used, so
    # they are measured cheaply (the full level is the original whatever
    # the evaluation)
    fx = os.path.join(work, ".fixture")
    os.makedirs(fx, exist_ok=True)
    open(os.path.join(fx, "spec.json"), "w").write(
        '{"method": "crossed_quads", "bake": {"max_atlas": 256},'
        ' "evaluate": {"views": 2, "sizes": [64]}}')
    subprocess.run([os.path.join(a.build, "sylva-bake"), "bake", "tree.obj", "tree.mtl",
                    "bark.jpg", "leaves.png", "--spec", os.path.join(fx, "spec.json"),
                    "--out", fx], cwd=work, check=True, stderr=subprocess.DEVNULL)
    shutil.copy(os.path.join(fx, "lod0_full.glb"), os.path.join(work, "tree.glb"))
    os.symlink(os.path.join(a.root, "examples"), os.path.join(work, "examples"))
    os.symlink(a.build, os.path.join(work, "build"))


def main():
    ap = argparse.ArgumentParser()
    for k in ("root", "build", "data", "work", "prefix"):
        ap.add_argument("--" + k, required=True)
    a = ap.parse_args()
    work = a.work
    os.makedirs(work, exist_ok=True)
    fixture(a, work)
    port = free_port()
    url = "http://127.0.0.1:%d" % port
    env = dict(os.environ)
    env["PATH"] = os.path.join(a.prefix, "bin") + ":" + env["PATH"]
    env["PKG_CONFIG_PATH"] = os.path.join(a.prefix, "lib", "pkgconfig")
    env["PKG_CONFIG_SYSROOT_DIR"] = a.prefix[: -len("/usr/local")] if a.prefix.endswith(
        "/usr/local") else a.prefix
    env["LD_LIBRARY_PATH"] = os.path.join(a.prefix, "lib")
    env["SYLVA_ROOT"] = a.root
    env["SYLVA_BUILD"] = os.environ.get("BUILD", "build")
    env["SYLVA_SERVER"] = url  # the client's default (127.0.0.1:8080), rewritten as above
    env.pop("SYLVA_TOKEN", None)
    store = os.path.join(work, "store")
    failures, ran, shapes, specs, skipped = [], 0, 0, 0, []
    daemon = None
    # The README's quick start is what CI runs on a fresh clone (.ci/run):
    # every `make X` of its sh blocks is either run here (demo) or a command
    # line of .ci/run (test), and .ci/run runs the README's test command.
    ci = open(os.path.join(a.root, ".ci", "run"), encoding="utf-8").read()
    readme_make = set()
    for line, lang, text, directive in blocks(os.path.join(a.root, "README.md")):
        for l in text.split("\n") if lang == "sh" else []:
            m = re.match(r"\s*make\s+(\w[\w-]*)", l)
            if m:
                readme_make.add(m.group(1))
                if m.group(1) != "demo" and not re.search(r"(?m)^make %s\b" % m.group(1), ci):
                    failures.append("README.md:%d: `make %s` is not a command .ci/run runs"
                                    % (line, m.group(1)))
    if "test" not in readme_make:
        failures.append("README.md: its sh blocks do not say `make test`, the command .ci/run runs")
    try:
        # README.md starts the daemon (its own example, on the test's port and
        # store); a later page finding none starts one there.
        for page in PAGES:
            path = os.path.join(a.root, page)
            if not os.path.exists(path):
                failures.append("%s: listed in PAGES but missing" % page)
                continue
            script, codes, checks = ["set -e"], [], []
            for line, lang, text, directive in blocks(path):
                where = "%s:%d" % (page, line)
                if directive and directive[0] == "skip":
                    if not directive[1]:
                        failures.append("%s: a skip needs a reason" % where)
                    skipped.append("%s (%s)" % (where, directive[1]))
                    continue
                if lang == "":
                    continue
                if lang == "sh":
                    body = text.replace("127.0.0.1:8080", "127.0.0.1:%d" % port)
                    body = body.replace("/var/tmp/sylva-store", store)
                    # `make test` is the command running this very test (and
                    # .ci/run's: checked above); `make demo` runs from the
                    # source tree, its outputs here, not in the checkout's out/.
                    body = re.sub(r"(?m)^make test\b", ": make test", body)
                    body = re.sub(r"(?m)^make demo\b",
                                  'make -s -C "$SYLVA_ROOT" demo BUILD="$SYLVA_BUILD" DEMO_OUT="$PWD/out/demo"',
                                  body)
                    script.append("echo \"@@ %s $(date +%%s.%%N)\" >&2" % where)
                    script.append(body)
                    for l in text.split("\n"):
                        m = re.search(r"#\s*(\d{3})\s*$", l)
                        if m:
                            codes.append((where, m.group(1)))
                    ran += 1
                elif lang == "c":
                    m = re.match(r"/\*\s*([\w.-]+\.c):", text)
                    if not m:
                        failures.append("%s: a C example must start with /* NAME.c: ..." % where)
                        continue
                    open(os.path.join(work, m.group(1)), "w").write(text)
                    ran += 1
                elif lang == "json":
                    if directive and directive[0] == "shape":
                        checks.append((where, directive[1], text))
                    elif page in ("README.md", "docs/spec.md"):
                        f = os.path.join(work, ".spec-example.json")
                        open(f, "w").write(text)
                        r = subprocess.run([os.path.join(a.build, "sylva-bake"), "check-spec", f],
                                           capture_output=True, text=True)
                        if r.returncode != 0:
                            failures.append("%s: the spec example is refused: %s" %
                                            (where, r.stdout.strip()))
                        specs += 1
                    else:
                        failures.append("%s: a json block needs <!-- doc-test: shape WHAT --> "
                                        "or <!-- doc-test: skip REASON -->" % where)
                else:
                    failures.append("%s: no rule for a ```%s example" % (where, lang))
            if len(script) > 1:
                if page != "README.md" and not healthy(url):
                    os.makedirs(store, exist_ok=True)
                    daemon = subprocess.Popen(
                        ["sylvad", "--listen", "127.0.0.1:%d" % port, "--store", store],
                        env=env, stderr=open(os.path.join(work, "sylvad.log"), "a"))
                    for _ in range(100):
                        if healthy(url):
                            break
                        time.sleep(0.1)
                # Files, not pipes: a daemon started in the background by an
                # example keeps its descriptors after the shell exits.
                outf, errf = os.path.join(work, ".stdout"), os.path.join(work, ".stderr")
                with open(outf, "w") as o, open(errf, "w") as e:
                    rc = subprocess.run(["bash", "-c", "\n".join(script)], cwd=work, env=env,
                                        stdout=o, stderr=e, timeout=600).returncode
                out, err = open(outf).read(), open(errf).read()
                nblocks = sum(1 for s in script if s.startswith('echo "@@'))
                print("== %s: %d sh block(s), exit %d" % (page, nblocks, rc), flush=True)
                marks = [l.split() for l in err.split("\n") if l.startswith("@@ ")]
                ends = [float(m[2]) for m in marks[1:]] + [time.time()]
                for m, end in zip(marks, ends):
                    print("   %s: %.1f s" % (m[1], end - float(m[2])))
                if rc != 0:
                    last = [l for l in err.split("\n") if l.startswith("@@ ")]
                    failures.append("%s: exit %d in the block at %s\n--- stderr:\n%s\n--- stdout:\n%s"
                                    % (page, rc, last[-1].split()[1] if last else "?",
                                       err[-3000:], out[-1500:]))
                out_lines = set(l.strip() for l in out.split("\n"))
                for where, code in codes:
                    if code not in out_lines:
                        failures.append("%s: expected HTTP %s, the output has %s" %
                                        (where, code, sorted(x for x in out_lines
                                                             if re.fullmatch(r"\d{3}", x))))
            for where, what, text in checks:
                shapes += 1
                want = set(KEYS.findall(text))
                have = set()
                if what == "status":
                    for d in status_docs(url, time.time() + 300):
                        all_keys(d, have)
                else:
                    for f in what.split():
                        try:
                            all_keys(json.load(open(os.path.join(work, f))), have)
                        except (OSError, ValueError) as e:
                            failures.append("%s: cannot read %s: %s" % (where, f, e))
                missing = sorted(want - have)
                if missing:
                    failures.append("%s: the example names keys the real %s lacks: %s" %
                                    (where, what, ", ".join(missing)))
    finally:
        subprocess.run(["pkill", "-f", "--", "--store " + store], check=False)
        if daemon:
            daemon.wait()
    print("doc examples: %d run, %d spec(s) checked, %d output shape(s) checked, %d skipped"
          % (ran, specs, shapes, len(skipped)))
    for s in skipped:
        print("  skipped: " + s)
    for f in failures:
        print("FAIL: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
