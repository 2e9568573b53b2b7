#!/usr/bin/env python3
"""Run a firmware on emulated hardware against the nurimc simulator and check the motor moved.

    run_embedded.py avr BRIDGE FIRMWARE.elf OUTDIR     the Uno sketch on simavr (simavr_bridge),
                                                       UART0 on the simulator's pseudo-terminal
    run_embedded.py qemu FIRMWARE.elf OUTDIR           the Cortex-M example on QEMU's mps2-an385,
                                                       UART0 over TCP to the simulator
    run_embedded.py avr-selftest BRIDGE FIRMWARE.elf   avr_selftest.c on simavr: every message type
                                                       with the tables in AVR flash, its frames
                                                       compared with the Python library's

The simulator (`python -m nurimc.sim`, wire timing on) has one controller at ID 3, 9600 bps; the
firmware must discover it among IDs 0..15, move it to 90 degrees and read it back. The bus
traffic is written to OUTDIR/<name>-traffic.log (a nurimc traffic log: `nurimc replay` reads it).
Passes only if all three agree: the firmware says it reached the target (LED pin / exit status),
the traffic log holds the move to 9000 (0.01 degree) and a later position feedback within 1
degree of it, and the simulator's controller, read afterwards through the Python library, is
within 1 degree of 90.
"""

from __future__ import annotations

import json
import os
import selectors
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ID, BAUD, TARGET, TOLERANCE = 3, 9600, 9000, 100
DEADLINE = 60  # seconds of wall clock for the firmware; it needs about one here


def start_simulator(python: str, endpoint: list[str], log: Path) -> tuple[subprocess.Popen[bytes], str]:
    """The simulator, its -v log (every frame it took or refused, and why) in `log`."""
    cmd = [python, "-m", "nurimc.sim", *endpoint, "--ids", str(ID), "--baud", str(BAUD), "--wire-timing", "-v"]
    with open(log, "wb") as errors:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=errors, cwd=ROOT)
    assert proc.stdout is not None
    sel = selectors.DefaultSelector()
    sel.register(proc.stdout.fileno(), selectors.EVENT_READ)
    seen = b""
    while sel.select(60):
        chunk = os.read(proc.stdout.fileno(), 4096)
        if not chunk:
            break
        seen += chunk
        for line in seen.decode(errors="replace").splitlines():
            if line.startswith("ready:"):
                return proc, line.split(":", 1)[1].strip()
    proc.kill()
    raise SystemExit(f"the simulator did not start; it printed {seen!r}")


class Relay(threading.Thread):
    """A TCP relay between QEMU's serial port and the simulator that logs each chunk with its direction."""

    def __init__(self, simulator: tuple[str, int], log: Path) -> None:
        super().__init__(daemon=True)
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.simulator, self.log = simulator, log
        self.stop = threading.Event()

    def run(self) -> None:
        guest, _ = self.listener.accept()
        bus = socket.create_connection(self.simulator)
        start = time.monotonic()
        sel = selectors.DefaultSelector()
        sel.register(guest, selectors.EVENT_READ, ("tx", bus))  # what the firmware sends
        sel.register(bus, selectors.EVENT_READ, ("rx", guest))
        with open(self.log, "w", encoding="utf-8") as log:
            while not self.stop.is_set():
                for key, _ in sel.select(0.05):
                    direction, peer = key.data
                    data = key.fileobj.recv(4096)  # type: ignore[union-attr]
                    if not data:
                        self.stop.set()
                        break
                    peer.sendall(data)
                    t = round(time.monotonic() - start, 6)
                    log.write(json.dumps({"t": t, "dir": direction, "hex": data.hex()}) + "\n")
        guest.close()
        bus.close()


def check_log(path: Path) -> str:
    """The traffic log holds the move and a later feedback at the target; returns a summary."""
    sys.path.insert(0, str(ROOT / "python" / "src"))
    from nurimc.transport.trafficlog import replay

    moved = reached = False
    frames = 0
    for entry in replay(path):
        message = entry.get("message")
        if message is None:
            continue
        frames += 1
        fields = message.fields()
        if message.name == "position_speed" and message.id == ID and fields["position"] == TARGET:
            moved = fields["direction"] == 0
        if moved and message.name == "position_feedback" and message.id == ID:
            signed = -fields["position"] if fields["direction"] else fields["position"]
            reached = reached or abs(signed - TARGET) <= TOLERANCE
    if not moved:
        raise SystemExit(f"{path}: no position_speed to ID {ID} at {TARGET} in the traffic log")
    if not reached:
        raise SystemExit(f"{path}: no position feedback within {TOLERANCE} of {TARGET} after the move")
    return f"{frames} frames, move and feedback at the target"


def read_back(url: str) -> float:
    sys.path.insert(0, str(ROOT / "python" / "src"))
    from nurimc import Bus

    with Bus.open(url, baudrate=BAUD) as bus:
        position = bus.motor(ID).read_state().device_position
    if abs(position - TARGET / 100) > TOLERANCE / 100:
        raise SystemExit(f"the simulator's motor is at {position} degrees, not {TARGET / 100}")
    return position


def stop(proc: subprocess.Popen[bytes]) -> None:
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()


def run_avr(python: str, bridge: str, firmware: str, out: Path) -> None:
    log = out / "uno-traffic.log"
    with tempfile.TemporaryDirectory(prefix="nurimc-avr-") as tmp:
        link = os.path.join(tmp, "ttyBUS")
        sim, _ = start_simulator(python, ["--link", link], out / "uno-simulator.log")
        try:
            cmd = [bridge, "-d", link, "-b", str(BAUD), "-t", str(DEADLINE), "-l", str(log), firmware]
            done = subprocess.run(cmd, timeout=DEADLINE + 30, check=False)
            if done.returncode != 0:
                raise SystemExit(f"simavr: the sketch did not light its LED (exit {done.returncode})")
            summary = check_log(log)
            position = read_back(link)
        finally:
            stop(sim)
    print(f"uno (simavr): LED on; {log}: {summary}; the simulator reads {position} degrees")


def run_qemu(python: str, firmware: str, out: Path) -> None:
    log = out / "cortex-m-traffic.log"
    sim, address = start_simulator(python, ["--tcp", "0"], out / "cortex-m-simulator.log")
    try:
        host, port = address.rsplit(":", 1)
        relay = Relay((host, int(port)), log)
        relay.start()
        cmd = [
            "qemu-system-arm",
            "-M",
            "mps2-an385",
            "-nographic",
            "-monitor",
            "none",
            "-serial",
            f"tcp:127.0.0.1:{relay.port}",
            "-semihosting-config",
            "enable=on,target=native",
            "-kernel",
            firmware,
        ]
        done = subprocess.run(cmd, timeout=DEADLINE + 30, check=False, capture_output=True, text=True)
        relay.stop.set()
        relay.join(5)
        sys.stdout.write(done.stdout + done.stderr)  # semihosting text
        if done.returncode != 0:
            raise SystemExit(f"qemu: the firmware did not reach the target (exit {done.returncode})")
        summary = check_log(log)
        position = read_back(f"socket://{host}:{port}")
    finally:
        stop(sim)
    print(f"cortex-m (qemu mps2-an385): exit 0; {log}: {summary}; the simulator reads {position} degrees")


def selftest_frames() -> list[bytes]:
    """What avr_selftest.c sends: each type in table order, ID type % 200, field i of type t at
    min + (7t + 13i) mod (max - min + 1), encoded by the Python library."""
    sys.path.insert(0, str(ROOT / "python" / "src"))
    from nurimc.protocol import MESSAGES

    frames = []
    for t, cls in enumerate(MESSAGES.values()):
        values = [f.min + (7 * t + 13 * i) % (f.max - f.min + 1) for i, f in enumerate(cls.SPEC.fields)]
        frames.append(cls(t % 200, *values).encode())
    return frames


def run_avr_selftest(bridge: str, firmware: str) -> None:
    master, slave = os.openpty()
    try:
        done = subprocess.run([bridge, "-d", os.ttyname(slave), "-b", str(BAUD), "-t", "30", firmware],
                              timeout=60, check=False)  # fmt: skip
        os.set_blocking(master, False)
        sent = b""
        while True:
            try:
                chunk = os.read(master, 4096)
            except BlockingIOError:
                break
            if not chunk:
                break
            sent += chunk
    finally:
        os.close(master)
        os.close(slave)
    expected = selftest_frames()
    at = 0
    for frame in expected:  # frame by frame, so a difference names its message
        got = sent[at : at + len(frame)]
        if got != frame:
            raise SystemExit(f"avr self-test: {frame.hex(' ')} expected, the AVR sent {got.hex(' ') or 'nothing'}")
        at += len(frame)
    if at != len(sent):
        raise SystemExit(f"avr self-test: {len(sent) - at} bytes more than the {len(expected)} frames")
    if done.returncode != 0:
        raise SystemExit(f"avr self-test: a check failed on the AVR (exit {done.returncode}, LED off)")
    print(f"avr self-test (simavr, tables in flash): {len(expected)} message types encoded, decoded and parsed; "
          "frames equal the Python library's")  # fmt: skip


def main(argv: list[str]) -> int:
    python = os.environ.get("NURIMC_PYTHON", str(ROOT / ".venv" / "bin" / "python"))
    if len(argv) == 4 and argv[0] == "avr":
        out = Path(argv[3])
        out.mkdir(parents=True, exist_ok=True)
        run_avr(python, argv[1], argv[2], out)
    elif len(argv) == 3 and argv[0] == "avr-selftest":
        run_avr_selftest(argv[1], argv[2])
    elif len(argv) == 3 and argv[0] == "qemu":
        out = Path(argv[2])
        out.mkdir(parents=True, exist_ok=True)
        run_qemu(python, argv[1], out)
    else:
        print(__doc__, file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
