#!/usr/bin/env python3
"""client_refetch_proxy.py — a tiny HTTP proxy for client_refetch.sh (test tool).

Usage: client_refetch_proxy.py UPSTREAM_URL PORT_FILE

Forwards every request to UPSTREAM_URL unchanged, except the first artifact
download of each key: before forwarding it, the proxy DELETEs that (done) bake
on the upstream, so the real daemon answers the download with a real 404 —
what a client sees when the node that baked a key dies between "done" and the
download and its balancer fails over to a node that never had the key.
Listens on a free loopback port and writes it to PORT_FILE.
"""
import http.server
import os
import re
import sys
import threading
import urllib.error
import urllib.request

UPSTREAM, PORT_FILE = sys.argv[1].rstrip("/"), sys.argv[2]
HOP = {"connection", "keep-alive", "transfer-encoding", "te", "trailer", "upgrade",
       "proxy-authorization", "proxy-authenticate", "content-length", "host", "expect"}
ARTIFACT = re.compile(r"^/v1/bakes/([0-9a-f]{64})/artifacts/")
deleted = set()
lock = threading.Lock()


def call(method, path, body=None, headers=None):
    req = urllib.request.Request(UPSTREAM + path, data=body, headers=headers or {},
                                 method=method)
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            return r.status, r.getheaders(), r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers.items(), e.read()


class Proxy(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, fmt, *args):
        pass

    def forward(self):
        length = int(self.headers.get("Content-Length") or 0)
        body = self.rfile.read(length) if length else None
        m = ARTIFACT.match(self.path)
        if self.command == "GET" and m:
            with lock:
                first = m.group(1) not in deleted
                deleted.add(m.group(1))
            if first:
                call("DELETE", "/v1/bakes/" + m.group(1))
        headers = {k: v for k, v in self.headers.items() if k.lower() not in HOP}
        status, rh, data = call(self.command, self.path, body, headers)
        self.send_response(status)
        for k, v in rh:
            if k.lower() not in HOP:
                self.send_header(k, v)
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    do_GET = do_PUT = do_POST = do_DELETE = forward


server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Proxy)
with open(PORT_FILE + ".tmp", "w") as f:
    f.write(str(server.server_address[1]))
os.rename(PORT_FILE + ".tmp", PORT_FILE)
server.serve_forever()
