"""`watch` and `sniff` across a port outage: real processes on a port the test cuts and restores."""

from __future__ import annotations

import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from nurimc import Bus
from nurimc.sim import SimBus
from nurimc.sim.faultproxy import FaultProxy

from .outage import BAUD, cuttable_bus

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
CUT = 0.6  # s


def start(*argv: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [NURIMC, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "NO_COLOR": "1"}
    )


def wait_until(test: object, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while not test():  # type: ignore[operator]
        assert time.monotonic() < deadline
        time.sleep(0.02)


def test_watch_says_the_loss_and_the_return_once_and_reads_again(tmp_path: Path) -> None:
    with cuttable_bus("pty", tmp_path) as (_, proxy):
        options = ("--port", proxy.url, "--baud", str(BAUD), "--id", "1", "--json")
        watch = start(*options, "watch", "--interval", "0.05", "--count", "70")
        # the cut comes once watch reads in its loop (a loss while it still sets up, telling the
        # controller's product line, is a one-shot's error: exit 1, nothing sent)
        wait_until(lambda: len(proxy.from_host) >= 6 or watch.poll() is not None, 60)
        assert watch.poll() is None, watch.communicate(timeout=30)
        proxy.cut()
        time.sleep(CUT)
        proxy.restore()
        out, err = watch.communicate(timeout=30)
        assert watch.returncode == 0, err
        assert err.count(" lost (") == 1 and err.count("back after") == 1, err
        assert "Traceback" not in err
        after = [data for cuts, data in proxy.from_host if cuts == 1]
        assert after, "watch read again after the return"
        assert len(json.loads(out)) >= 20


def test_sniff_listens_again_when_its_port_returns(tmp_path: Path) -> None:
    sim = SimBus(wire_timing=False)
    sim.add_controller(id=1, baud=BAUD)
    host_side = sim.serve_tcp(port=0, baud=BAUD)
    listening = sim.serve_tcp(port=0, baud=BAUD, monitor=True)  # hears both directions
    proxy = FaultProxy(listening.address, link=str(tmp_path / "ttySniff")).start()
    talking = threading.Event()
    talking.set()

    def host() -> None:
        with Bus.open(f"socket://127.0.0.1:{host_side.address[1]}", BAUD, latency=0.01) as bus:
            while talking.is_set():
                bus.motor(1).read_state()
                time.sleep(0.02)

    talker = threading.Thread(target=host, daemon=True)
    talker.start()
    try:
        sniff = start("--port", proxy.url, "--baud", str(BAUD), "sniff", "--duration", "4")
        lines: list[str] = []
        assert sniff.stdout is not None
        reader = threading.Thread(target=lambda: lines.extend(sniff.stdout), daemon=True)  # type: ignore[arg-type]
        reader.start()
        wait_until(lambda: len(lines) >= 5, 20)  # listening
        proxy.cut()
        time.sleep(CUT)
        proxy.restore()
        sniff.wait(timeout=30)
        reader.join(timeout=30)
        assert sniff.stderr is not None
        err = sniff.stderr.read()
    finally:
        talking.clear()
        talker.join()
        proxy.stop()
        listening.stop()
        host_side.stop()
        sim.close()
    assert sniff.returncode == 0, err
    assert err.count(" lost (") == 1 and err.count("back after") == 1, err
    times = [float(line.split()[0]) for line in lines if "id=" in line]
    gaps = [(a, b) for a, b in itertools.pairwise(times) if b - a >= CUT * 0.8]
    assert len(gaps) == 1, gaps  # the outage, and frames again after it
    assert times[-1] - gaps[0][1] > 0.3


def test_record_resumes_with_fresh_readings_after_the_port_returns(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    recording = tmp_path / "run.mcap"
    with cuttable_bus("pty", tmp_path) as (_, proxy):
        options = ("--port", proxy.url, "--baud", str(BAUD))
        record = start(*options, "record", "--mcap", str(recording), "--ids", "1", "--rate", "20", "--seconds", "4")
        # the cut comes once record reads in its loop (as watch's test above)
        wait_until(lambda: len(proxy.from_host) >= 6 or record.poll() is not None, 60)
        assert record.poll() is None, record.communicate(timeout=30)
        proxy.cut()
        time.sleep(CUT)
        proxy.restore()
        out, err = record.communicate(timeout=30)
    assert record.returncode == 0, out + err
    assert err.count(" lost (") == 1 and err.count("back after") == 1, err
    with recording.open("rb") as stream:
        messages = make_reader(stream).iter_messages()
        times = [m.log_time / 1e9 for _, channel, m in messages if "joint_states" in channel.topic]
    gaps = [(a, b) for a, b in itertools.pairwise(times) if b - a >= CUT * 0.8]
    assert len(gaps) == 1, gaps  # no joint_states while the port was down (never a stale one)
    assert times[-1] - gaps[0][1] > 0.3  # and fresh ones again after it


def test_the_console_ending_while_its_port_is_down_says_the_motors_could_not_be_stopped(tmp_path: Path) -> None:
    with cuttable_bus("pty", tmp_path) as (_, proxy):
        console = start("--port", proxy.url, "--baud", str(BAUD), "dashboard", "--listen", "127.0.0.1:0")
        assert console.stdout is not None
        assert console.stdout.readline().startswith("ready:")
        proxy.cut()
        assert console.stderr is not None
        said = console.stderr.readline()  # an idle console notices the loss too (it looks every second)
        assert " lost (" in said, said
        console.send_signal(signal.SIGINT)
        _, err = console.communicate(timeout=30)
    assert "at exit: motors could not be stopped" in err, err
    assert "Traceback" not in err
