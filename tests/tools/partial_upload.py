#!/usr/bin/env python3
"""partial_upload.py — a multipart upload that does not finish, for the
reservation tests (tests/integration/daemon_adversarial.sh).

usage: partial_upload.py PORT DECLARED SEND MODE [SECONDS]
  sends POST /v1/bakes headers declaring Content-Length DECLARED, then SEND
  bytes of a multipart body (a mesh part of '#' bytes), then
  MODE hold:  keeps the connection open SECONDS (default 20), sending nothing
  MODE close: closes the socket at once (EOF in mid-body)
Prints "sent N" once the bytes are written (flushed to stdout)."""
import socket
import sys
import time

port, declared, send, mode = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
hold = float(sys.argv[5]) if len(sys.argv) > 5 else 20.0
b = "sylvaPartialBoundary"
head = ("--%s\r\nContent-Disposition: form-data; name=\"mesh\"; filename=\"p.obj\"\r\n"
        "Content-Type: application/octet-stream\r\n\r\n# mode=ok\n" % b).encode()
body = head + b"#" * max(0, send - len(head))
s = socket.create_connection(("127.0.0.1", port))
s.sendall(("POST /v1/bakes HTTP/1.1\r\nHost: x\r\nContent-Type: multipart/form-data; boundary=%s\r\n"
           "Content-Length: %d\r\n\r\n" % (b, declared)).encode())
s.sendall(body[:send])
print("sent", send, flush=True)
if mode == "hold":
    time.sleep(hold)
s.close()
