#!/usr/bin/env python3
"""client_tamper_proxy.py — a tiny HTTP proxy for client_tamper.sh.

Usage: client_tamper_proxy.py UPSTREAM_URL PORT_FILE ARTIFACT_NAME

Forwards every request to UPSTREAM_URL unchanged, except that the body of
GET /v1/bakes/<key>/artifacts/<ARTIFACT_NAME> has one byte flipped (headers,
length and ETag are kept, so only a client that hashes the bytes notices).
Listens on a free loopback port and writes it to PORT_FILE. Test tool only.
"""
import http.server
import os
import sys
import urllib.error
import urllib.request

UPSTREAM, PORT_FILE, TARGET = sys.argv[1].rstrip("/"), sys.argv[2], sys.argv[3]
HOP = {"connection", "keep-alive", "transfer-encoding", "te", "trailer", "upgrade",
       "proxy-authorization", "proxy-authenticate", "content-length", "host", "expect"}


class Proxy(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, fmt, *args):  # keep the test output quiet
        pass

    def forward(self):
        length = int(self.headers.get("Content-Length") or 0)
        body = self.rfile.read(length) if length else None
        headers = {k: v for k, v in self.headers.items() if k.lower() not in HOP}
        req = urllib.request.Request(UPSTREAM + self.path, data=body, headers=headers,
                                     method=self.command)
        try:
            with urllib.request.urlopen(req, timeout=120) as r:
                status, rh, data = r.status, r.getheaders(), r.read()
        except urllib.error.HTTPError as e:
            status, rh, data = e.code, e.headers.items(), e.read()
        if (self.command == "GET" and status == 200 and data
                and self.path.split("?")[0].endswith("/artifacts/" + TARGET)):
            data = bytearray(data)
            data[len(data) // 2] ^= 0x01
            data = bytes(data)
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
