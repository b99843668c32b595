#!/usr/bin/env python3
"""body_probe.py — sends one HTTP/1.1 request with a huge or endless body and
reports what the server did with it. Python standard library only.

  body_probe.py PORT METHOD PATH (--length N | --chunked) [--header 'K: V']...
                [--max-bytes B] [--max-seconds S] [--pid PID]

or, from Python: probe(port, method, path, length=N | chunked=True, ...).

--length N declares Content-Length N and sends zeros up to N; --chunked sends
64 KiB chunks without end. The answer is read whenever it arrives, so it is
seen even when the server answers before the body is sent. Sending goes on
until the connection is reset, for at most 1 s after the server's FIN, or up
to B bytes / S seconds.

Returns (prints) one JSON object: status (null if none), answer_s (seconds to
the status line), sent (body bytes the kernel took), sent_after_answer,
closed, seconds, body (the first 300 bytes of the answer's body). closed is
"reset" when a send or receive failed with a reset: the server has closed
its socket and reads nothing more; "eof" when the server sent its FIN but
still took bytes 1 s later (a half-close: it goes on reading); "no" when
neither happened within the limits. With --pid, also the CPU seconds (utime +
stime) the server spent during the probe and its VmRSS (KiB) after. (A
server's socket reads do not show in /proc/PID/io, so what it read is judged
from "sent": once it stops reading, the client can send no more than the two
socket buffers hold.)
"""
import argparse
import errno
import json
import os
import select
import socket
import time

BLOCK = 64 * 1024


def proc_sample(pid):
    """CPU seconds (utime + stime) and VmRSS (KiB) of process pid, or None."""
    if not pid:
        return None
    cpu = rss = None
    try:
        with open('/proc/%d/stat' % pid) as f:
            fields = f.read().rsplit(')', 1)[1].split()
        cpu = (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')
    except (OSError, IndexError, ValueError):
        pass
    try:
        with open('/proc/%d/status' % pid) as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    rss = int(line.split()[1])
    except OSError:
        pass
    return {'cpu': cpu, 'rss': rss}


def _status_of(resp):
    line = resp.split(b'\r\n', 1)[0].split()
    return int(line[1]) if len(line) > 1 and line[1].isdigit() else -1


def probe(port, method, path, length=None, chunked=False, headers=(),
          max_bytes=1 << 30, max_seconds=10.0, pid=0):
    """Sends the request to 127.0.0.1:port; returns the dict described above."""
    head = '%s %s HTTP/1.1\r\nHost: 127.0.0.1\r\n' % (method, path)
    if chunked:
        head += 'Transfer-Encoding: chunked\r\n'
    else:
        head += 'Content-Length: %d\r\n' % length
    for h in headers:
        head += h + '\r\n'
    head += '\r\n'
    if chunked:
        block = b'%x\r\n' % BLOCK + b'\0' * BLOCK + b'\r\n'
    else:
        block = b'\0' * BLOCK

    before = proc_sample(pid)
    t0 = time.monotonic()
    s = socket.create_connection(('127.0.0.1', port))
    s.sendall(head.encode())
    s.setblocking(False)
    pending = b''
    sent = 0              # body bytes (framing included when chunked)
    sent_at_answer = None
    resp = b''
    status = answer_s = None
    eof = reset = False
    reading = sending = True
    stop_at = t0 + max_seconds
    while time.monotonic() <= stop_at and (reading or sending):
        if sending and (sent >= max_bytes or (length is not None and sent >= length)):
            sending = False
        r, w, _ = select.select([s] if reading else [], [s] if sending else [], [], 0.05)
        if r:
            try:
                d = s.recv(65536)
            except OSError as e:
                if e.errno not in (errno.ECONNRESET, errno.EPIPE):
                    raise
                reset = True
                break
            if not d:
                # the server's FIN: keep sending a moment, to see whether it
                # still reads (a half-close) or has closed (then: a reset)
                eof = True
                reading = False
                stop_at = min(stop_at, time.monotonic() + 1.0)
                continue
            resp += d
            if status is None and b'\r\n' in resp:
                status = _status_of(resp)
                answer_s = time.monotonic() - t0
                sent_at_answer = sent
        if w and sending:
            if not pending:
                pending = block if length is None else block[:length - sent]
            try:
                n = s.send(pending)
            except BlockingIOError:
                n = 0
            except OSError as e:
                if e.errno not in (errno.ECONNRESET, errno.EPIPE):
                    raise
                # the server is gone; read what it answered, if anything
                reset = True
                end = time.monotonic() + 1.0
                while reading and time.monotonic() < end:
                    try:
                        if not select.select([s], [], [], 0.05)[0]:
                            continue
                        d = s.recv(65536)
                    except OSError:
                        break
                    if not d:
                        break
                    resp += d
                if status is None and b'\r\n' in resp:
                    status = _status_of(resp)
                    answer_s = time.monotonic() - t0
                    sent_at_answer = sent
                break
            sent += n
            pending = pending[n:]
    seconds = time.monotonic() - t0
    s.close()
    body = resp.split(b'\r\n\r\n', 1)[1] if b'\r\n\r\n' in resp else b''
    out = {'status': status, 'answer_s': None if answer_s is None else round(answer_s, 3),
           'sent': sent, 'sent_after_answer': None if sent_at_answer is None else sent - sent_at_answer,
           'closed': 'reset' if reset else 'eof' if eof else 'no', 'seconds': round(seconds, 3),
           'body': body[:300].decode('utf-8', 'replace')}
    if pid:
        time.sleep(0.2)  # CPU the server still spends after the client is gone
        after = proc_sample(pid)
        if before and after and before['cpu'] is not None and after['cpu'] is not None:
            out['server_cpu_s'] = round(after['cpu'] - before['cpu'], 2)
        if after:
            out['server_rss_kib'] = after['rss']
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('port', type=int)
    ap.add_argument('method')
    ap.add_argument('path')
    ap.add_argument('--length', type=int)
    ap.add_argument('--chunked', action='store_true')
    ap.add_argument('--header', action='append', default=[])
    ap.add_argument('--max-bytes', type=int, default=1 << 30)
    ap.add_argument('--max-seconds', type=float, default=10.0)
    ap.add_argument('--pid', type=int, default=0)
    a = ap.parse_args()
    if a.length is None and not a.chunked:
        ap.error('--length N or --chunked')
    print(json.dumps(probe(a.port, a.method, a.path, a.length, a.chunked, a.header,
                           a.max_bytes, a.max_seconds, a.pid)))


if __name__ == '__main__':
    main()
