"""`nurimc sim --background`: serve in a detached process, return once it is ready.

The quick start used to run `nurimc sim ... &` and then `scan` at once; the scan could come
before the link existed ("port ... not found"). With --background the command itself waits: it
forks before anything is built, the child builds and serves as usual, and the parent prints the
child's lines up to its `ready:` lines, then one line with the child's process ID and returns
(exit 0). When the child fails first, the parent shows its error and returns its exit code.

After the ready lines the child's stdout and stderr go to /dev/null, so
nothing it prints later lands in the user's terminal and the pipe to the parent is closed. The
child runs in its own session: closing the terminal does not end it; `kill PID` (SIGTERM) does.
"""

from __future__ import annotations

import os
import sys
from typing import TextIO

from ..cli.i18n import tr

#: Seconds the parent waits for the child's ready lines before it gives up (a busy machine
#: builds a large simulated bus in well under this).
READY_CEILING = 120.0

_state: dict[str, int] = {}


def detach() -> None:
    """Fork. The parent relays the child's start-up output (stdout to stdout, stderr to stderr)
    and exits; the child returns and goes on (its stdout and stderr are pipes to the parent
    until `ready()`)."""
    out_read, out_write = os.pipe()
    err_read, err_write = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: the simulator
        os.close(out_read)
        os.close(err_read)
        os.setsid()
        os.dup2(out_write, 1)
        os.dup2(err_write, 2)
        os.close(out_write)
        os.close(err_write)
        devnull = os.open(os.devnull, os.O_RDONLY)
        os.dup2(devnull, 0)
        os.close(devnull)
        _state["child"] = 1
        return
    os.close(out_write)
    os.close(err_write)
    sys.exit(_relay(pid, {out_read: sys.stdout, err_read: sys.stderr}))


def _relay(pid: int, streams: dict[int, TextIO]) -> int:
    """The parent: copy the child's lines to ours until its pipes close (ready, or the child
    ended), then say how to stop it or return its exit code."""
    import select
    import time

    deadline = time.monotonic() + READY_CEILING
    saw_ready = False
    open_fds = list(streams)
    while open_fds:
        left = deadline - time.monotonic()
        if left <= 0:
            for fd in open_fds:
                os.close(fd)
            sys.stderr.write(tr(f"nurimc sim: not ready after {READY_CEILING:g} s; stop it with: kill {pid}") + "\n")
            return 1
        readable, _, _ = select.select(open_fds, [], [], min(left, 0.5))
        for fd in readable:
            chunk = os.read(fd, 65536)
            if not chunk:
                os.close(fd)
                open_fds.remove(fd)
                continue
            saw_ready = saw_ready or b"ready: " in chunk
            stream = streams[fd]
            stream.buffer.write(chunk)
            stream.flush()
    if not saw_ready:  # it ended before it was ready: its error is above
        _, status = os.waitpid(pid, 0)
        return os.waitstatus_to_exitcode(status) or 1
    print(tr(f"nurimc sim: running in the background; stop it with: kill {pid}"))
    sys.stdout.flush()
    return 0


def ready() -> None:
    """In the child, after the ready lines: stop writing to the parent (it then returns)."""
    if not _state.get("child"):
        return
    sys.stdout.flush()
    sys.stderr.flush()
    target = os.open(os.devnull, os.O_WRONLY)
    os.dup2(target, 1)
    os.dup2(target, 2)
    os.close(target)
