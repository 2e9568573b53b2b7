"""The C library's POSIX port and the Python library refuse each other's port (issue 39, item 4).

    .venv/bin/python c/tests/lock_test.py c/build/lock_probe

A pseudo-terminal stands in for the adapter. Python holds it (nurimc's transport takes an
exclusive flock): the C probe gets NURIMC_E_BUSY. The C probe holds it: Python's Bus.open says
"port ... is busy". Each released, the other opens it.
"""

from __future__ import annotations

import os
import subprocess
import sys


def probe(binary: str, path: str) -> tuple[int, str]:
    done = subprocess.run([binary, path], capture_output=True, text=True, timeout=30)
    return done.returncode, done.stdout.strip()


def main() -> int:
    from nurimc.drivers.sync import Bus
    from nurimc.errors import PortError

    binary = sys.argv[1]
    master, slave = os.openpty()
    path = os.ttyname(slave)
    os.close(slave)
    failures: list[str] = []

    def expect(what: str, ok: bool) -> None:
        print(("ok   " if ok else "FAIL ") + what)
        if not ok:
            failures.append(what)

    bus = Bus.open(path, 9600)
    code, said = probe(binary, path)
    expect(f"C open while Python holds the port: busy (got {said!r}, exit {code})", (code, said) == (1, "busy"))
    bus.close()
    code, said = probe(binary, path)
    expect(f"C open once Python let go: ok (got {said!r})", (code, said) == (0, "ok"))

    holder = subprocess.Popen([binary, path, "hold"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None
        expect("C holds the port", holder.stdout.readline().strip() == "ok")
        try:
            Bus.open(path, 9600).close()
            expect("Python open while C holds the port: refused", False)
        except PortError as error:
            expect(f"Python open while C holds the port: {error}", "is busy" in str(error))
    finally:
        assert holder.stdin is not None
        holder.stdin.close()
        holder.wait(timeout=30)
    Bus.open(path, 9600).close()
    expect("Python open once C let go: ok", True)
    os.close(master)
    print("lock test:", "all passed" if not failures else f"{len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
