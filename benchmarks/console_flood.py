"""The console under a slowloris flood (issue 39, item 5 "done when"): N half-open connections
(request headers begun, never finished) held against `nurimc dashboard --sim`, then: does a new
page load, does a new websocket get its hello, and how long does the open page's E-STOP take to
be confirmed (its reply)?

    .venv/bin/python benchmarks/console_flood.py [--connections 20000] [--out benchmarks/results/console_flood.json]

The holders run in several child processes (each process has its own descriptor limit).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing
import os
import platform
import re
import resource
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from websockets.sync.client import connect
from websockets.typing import Origin

PER_HOLDER = 4000
LISTEN = ("--listen", "127.0.0.1:0")


def hold(port: int, count: int, ready: Any, stop: Any) -> None:
    _soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    held: list[socket.socket] = []
    opened = 0
    for _ in range(count):
        try:
            conn = socket.socket()
            conn.setblocking(False)
            conn.connect_ex(("127.0.0.1", port))
            held.append(conn)
            opened += 1
        except OSError:
            break
    time.sleep(0.5)
    for conn in held:
        with contextlib.suppress(OSError):
            conn.send(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")
    ready.put(opened)
    stop.wait()


def ask(ws: Any, op: str, **fields: Any) -> tuple[dict[str, Any], float]:
    began = time.monotonic()
    ws.send(json.dumps({"op": op, "req": op, **fields}))
    while True:
        message = json.loads(ws.recv(timeout=60))
        if message.get("type") == "reply" and message.get("req") == op:
            return message, time.monotonic() - began


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--connections", type=int, default=20000)
    parser.add_argument("--out", default=str(Path(__file__).parent / "results" / "console_flood.json"))
    args = parser.parse_args()
    child = subprocess.Popen(
        [sys.executable, "-c", "from nurimc.cli.app import main; main()", "dashboard", "--sim", *LISTEN],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert child.stdout is not None
    line = child.stdout.readline()
    match = re.search(r"ready: http://(\S+)/", line)
    if not match:
        sys.exit(f"the console did not start: {line}")
    host = match.group(1)
    port = int(host.rpartition(":")[2])
    result: dict[str, Any] = {"connections": args.connections, "host_busy": True, "cpus": os.cpu_count()}
    stop = multiprocessing.Event()
    holders: list[multiprocessing.Process] = []
    try:
        page = connect(f"ws://{host}/ws", origin=Origin(f"http://{host}"), max_size=None).__enter__()
        assert ask(page, "discover", rates=[57600, 115200])[0]["ok"]
        json.loads(page.recv(timeout=10))
        ready: Any = multiprocessing.Queue()
        began = time.monotonic()
        left = args.connections
        while left > 0:
            n = min(PER_HOLDER, left)
            holder = multiprocessing.Process(target=hold, args=(port, n, ready, stop), daemon=True)
            holder.start()
            holders.append(holder)
            left -= n
        opened = sum(ready.get(timeout=300) for _ in holders)
        result["opened"] = opened
        result["flood_seconds"] = round(time.monotonic() - began, 2)
        began = time.monotonic()
        with socket.create_connection(("127.0.0.1", port), timeout=30) as conn:
            conn.sendall(f"GET / HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n".encode())
            data = b""
            while chunk := conn.recv(65536):
                data += chunk
        result["new_page_status"] = data.split(b"\r\n", 1)[0].decode()
        result["new_page_seconds"] = round(time.monotonic() - began, 3)
        began = time.monotonic()
        with connect(f"ws://{host}/ws", origin=Origin(f"http://{host}"), max_size=None, open_timeout=30) as fresh:
            hello = json.loads(fresh.recv(timeout=30))
        result["new_websocket_hello"] = hello.get("type") == "hello"
        result["new_websocket_seconds"] = round(time.monotonic() - began, 3)
        reply, took = ask(page, "estop")
        result["estop_ok"] = bool(reply["ok"])
        result["estop_seconds"] = round(took, 3)
        result["console_alive"] = child.poll() is None
        page.close()
    finally:
        stop.set()
        for holder in holders:
            holder.join(30)
        child.terminate()
        output, _ = child.communicate(timeout=30)
        lines = [text for text in output.splitlines() if text.strip()]
        result["console_output_lines"] = len(lines)
        result["console_tracebacks"] = sum("Traceback" in text for text in lines)
    result["python"] = platform.python_version()
    result["when"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    result["note"] = "2-core host shared with 8 other agents (busy); all on loopback"
    print(json.dumps(result, indent=2))
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
