#!/usr/bin/env python3
"""Hold a flood of idle TCP connections against a running `isoremesh serve`
and time `/healthz` meanwhile; prints the median and worst latency and the
server's connection metrics.

Usage: python3 benches/idle_flood.py [HOST:PORT] [CONNECTIONS]
(defaults 127.0.0.1:8080 and 15000; the client needs that many descriptors).
"""
import http.client
import socket
import statistics
import sys
import time

host, port = (sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1:8080").split(":")
port = int(port)
n = int(sys.argv[2]) if len(sys.argv) > 2 else 15000
held = []
t = time.time()
for _ in range(n):
    s = socket.socket()
    s.connect((host, port))
    held.append(s)
print(f"opened {n} idle connections in {time.time() - t:.1f} s")
time.sleep(1)
lat = []
for _ in range(21):
    t = time.time()
    c = http.client.HTTPConnection(host, port, timeout=10)
    c.request("GET", "/healthz")
    r = c.getresponse()
    r.read()
    c.close()
    lat.append((time.time() - t) * 1000)
    assert r.status == 200, r.status
print(f"/healthz: median {statistics.median(lat):.2f} ms, max {max(lat):.2f} ms")
c = http.client.HTTPConnection(host, port)
c.request("GET", "/metrics")
for line in c.getresponse().read().decode().splitlines():
    if line.startswith("isoremesh_connections"):
        print(line)
