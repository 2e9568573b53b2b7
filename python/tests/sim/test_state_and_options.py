"""The simulator's state directory, its options and its endpoints' ownership, checked from outside."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
import serial

import nurimc.sim  # noqa: F401 - registers the sim:// handler
from nurimc.protocol.sniff import SniffedFrame, Sniffer
from nurimc.sim import SimBus
from nurimc.sim.options import OptionError, parse_ids
from nurimc.sim.profile import load_profiles
from nurimc.sim.store import StateError

from .wirehelp import ask, command, frame, position, u16


def _state_file(tmp_path: Path, **changes: object) -> Path:
    """A state directory written by a real simulator, then edited."""
    bus = SimBus(state_dir=tmp_path, eeprom_time=0.0)
    bus.add_controller(1)
    bus.close()
    path = tmp_path / "bus.json"
    data = json.loads(path.read_text())
    data["controllers"][0]["settings"].update(changes)
    path.write_text(json.dumps(data))
    return tmp_path


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"ratio": 0}, "'ratio': 0 is out of range"),
        ({"resolution": 0}, "'resolution': 0 is out of range"),
        ({"baud_index": 18}, "'baud_index': 18 is out of range"),
        ({"position_kp": 255}, "'position_kp': 255 is out of range"),
        ({"id": -1}, "'id': -1 is out of range"),
        ({"control": True}, "'control': True is not an integer"),
        ({"rated_speed": "3000"}, "'rated_speed': '3000' is not an integer"),
        ({"colour": 3}, "'colour' is not a setting"),
    ],
)
def test_a_bad_state_file_is_refused_with_the_file_and_the_field(
    tmp_path: Path, changes: dict[str, object], field: str
) -> None:
    state = _state_file(tmp_path, **changes)
    with pytest.raises(StateError) as caught:
        SimBus(state_dir=state)
    message = str(caught.value)
    assert "\n" not in message
    assert str(state / "bus.json") in message and "slot 0" in message and field in message


def test_a_missing_setting_or_product_is_refused(tmp_path: Path) -> None:
    state = _state_file(tmp_path)
    data = json.loads((state / "bus.json").read_text())
    del data["controllers"][0]["settings"]["ratio"]
    (state / "bus.json").write_text(json.dumps(data))
    with pytest.raises(StateError, match="field 'ratio' is missing"):
        SimBus(state_dir=state)
    data["controllers"][0] = {"product": "warp", "settings": {}}
    (state / "bus.json").write_text(json.dumps(data))
    with pytest.raises(StateError, match="'product' is 'warp'"):
        SimBus(state_dir=state)


def test_the_cli_refuses_a_bad_state_file_in_one_line(tmp_path: Path) -> None:
    state = _state_file(tmp_path, resolution=0)
    done = subprocess.run(
        [sys.executable, "-m", "nurimc.sim", "--state", str(state)], capture_output=True, text=True, timeout=30
    )
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "'resolution': 0 is out of range" in done.stderr
    assert "Traceback" not in done.stderr


def test_one_simulator_per_state_directory_and_stale_temporaries_go(tmp_path: Path) -> None:
    stale = tmp_path / ".bus-deadbeef.tmp"
    stale.write_text("half a file")
    first = SimBus(state_dir=tmp_path, eeprom_time=0.0)
    first.add_controller(1)
    assert not stale.exists()
    with pytest.raises(StateError, match="in use by another running simulator"):
        SimBus(state_dir=tmp_path)
    port = first.open_serial(timeout=0.3)
    for speed in (1000, 1100, 1200):
        command(port, 1, "set_rated_speed", u16(speed))
        assert ask(port, 1, 0xA6) == u16(speed)
    first.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bus.json", "bus.lock"]  # no temporaries left
    second = SimBus(state_dir=tmp_path)
    assert second.add_controller(1).settings.rated_speed == 1200
    second.close()


def test_a_link_owned_by_a_live_simulator_is_refused_and_kept(tmp_path: Path) -> None:
    link = tmp_path / "tty"
    owner = SimBus()
    owner.add_controller(1)
    endpoint = owner.serve_pty(link=str(link))
    intruder = SimBus()
    intruder.add_controller(2)
    try:
        with pytest.raises(FileExistsError, match="still in use"):
            intruder.serve_pty(link=str(link))
        assert os.readlink(link) == endpoint.path
        assert not intruder.links  # the refused endpoint let go of its bus
        with serial.Serial(str(link), 9600, timeout=0.3) as port:
            assert ask(port, 1, 0xA0) == b""
    finally:
        endpoint.stop()
        owner.close()
    assert not link.exists()
    link.symlink_to("/dev/pts/999999")  # what a killed simulator leaves: a link to a vanished pty
    taken = intruder.serve_pty(link=str(link))
    try:
        assert os.readlink(link) == taken.path
    finally:
        taken.stop()
        intruder.close()


def test_ids_are_ids_never_counts() -> None:
    assert parse_ids("1") == [1]
    assert parse_ids("1,") == [1]
    assert parse_ids("0,1,2") == [0, 1, 2]
    assert parse_ids("0-3") == [0, 1, 2, 3]
    assert parse_ids("1,5-7") == [1, 5, 6, 7]
    assert parse_ids("0-253") == list(range(254))
    for bad in ("255", "3-1", "x", "0-254,1"):
        with pytest.raises(OptionError):
            parse_ids(bad)


def test_sim_url_ids_1_is_the_controller_at_id_1() -> None:
    with serial.serial_for_url("sim://?ids=1", timeout=0.3) as port:
        assert ask(port, 1, 0xA0) == b""
        assert ask(port, 0, 0xA0, patience=0.2) is None


def test_speed_zero_rule_from_a_profile_file_or_an_option(tmp_path: Path) -> None:
    spec = json.loads((Path(__file__).parents[3] / "spec" / "profiles.json").read_text())
    spec["profiles"]["mc"]["speed_zero"] = "ignore"
    spec["profiles"]["mc"]["factory_defaults"]["position_kp"] = 77
    path = tmp_path / "profiles.json"
    path.write_text(json.dumps(spec))
    profiles = load_profiles(path)
    assert profiles["mc"].speed_zero == "ignore" and profiles["blmc-h"].speed_zero == "stop"  # stop: the default
    stopping = dict(profiles, mc=replace(profiles["mc"], speed_zero="stop"))
    for bus in (SimBus(profiles=stopping, eeprom_time=0.0), SimBus(speed_zero="stop", eeprom_time=0.0)):
        bus.add_controller(1)
        port = bus.open_serial(timeout=0.3)
        command(port, 1, "set_resolution", u16(1000))
        command(port, 1, "position_speed", bytes([0]) + u16(18000) + u16(600))  # 180 deg at 60 RPM
        bus.advance(bus.now() + 0.5)
        command(port, 1, "position_speed", bytes([0]) + u16(18000) + u16(0))  # speed 0: stop
        stopped_at = position(port, 1)
        assert 5 < stopped_at < 175
        bus.advance(bus.now() + 1.0)
        assert abs(position(port, 1) - stopped_at) < 2  # held near where it was, not on to 180
        bus.close()
    bus = SimBus(profiles=profiles)
    assert bus.add_controller(1).settings.position_kp == 77  # the profile's factory gains
    bus.close()


@pytest.mark.parametrize(
    ("content", "error"),
    [
        ('{"profiles": {"mc": {"speed_zero": "brake"}}}', "speed_zero is 'brake'"),
        ('{"profiles": {"warp": {}}}', "unknown product 'warp'"),
        ('{"profiles": {"mc": {"factory_defaults": {"position_kp": 0}}}}', "position_kp: 'position_kp': 0"),
        ('{"profiles": {"mc": {"busy_window_s": -1}}}', "busy_window_s is -1"),
        ("[1]", "no 'profiles' object"),
        ("{", "not JSON"),
    ],
)
def test_a_bad_profile_file_is_refused(tmp_path: Path, content: str, error: str) -> None:
    path = tmp_path / "p.json"
    path.write_text(content)
    with pytest.raises(ValueError, match=error.replace("(", r"\(")):
        load_profiles(path)


def _start(args: list[str], endpoints: int) -> tuple[subprocess.Popen[str], list[str]]:
    """Start `nurimc sim`; return it and its first `endpoints` ready paths."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "nurimc.sim", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert proc.stdout is not None
    ready: list[str] = []
    for line in proc.stdout:
        if line.startswith("ready: "):
            ready.append(line.removeprefix("ready: ").strip())
            if len(ready) == endpoints:
                return proc, ready
    proc.wait(timeout=60)
    raise AssertionError(proc.stderr.read() if proc.stderr else "no ready lines")


def test_cli_monitor_hears_the_hosts_requests_and_commands(tmp_path: Path) -> None:
    link, monitor = tmp_path / "tty", tmp_path / "mon"
    proc, ready = _start(["--link", str(link), "--monitor", str(monitor), "--ids", "1"], 2)
    try:
        assert ready == [str(link), str(monitor)]
        with (
            serial.Serial(str(monitor), 9600, timeout=0.3) as sniffer,
            serial.Serial(str(link), 9600, timeout=0.5) as host,
        ):
            host.write(frame(1, 0xA1))
            assert len(host.read(12)) == 12  # half duplex: the answer before the next frame
            host.write(frame(1, 0x01, bytes([0]) + u16(9000) + u16(100)))
            heard = Sniffer().feed(sniffer.read(4096), 0.0)
        names = [f"{h.direction} {h.event.message.name}" for h in heard if isinstance(h.event, SniffedFrame)]
        assert names == [
            "host -> id 1 request_position",
            "id 1 -> host position_feedback",
            "host -> id 1 position_speed",
        ]
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=60)
    assert proc.returncode == 0
    assert not link.exists() and not monitor.exists()


def test_an_endpoint_asleep_in_select_wakes_for_bytes_another_thread_delivers(tmp_path: Path) -> None:
    """Bytes that reach a pty's host from another thread (another host, the physics tick) are
    written out at once, not when the endpoint's select() times out."""
    bus = SimBus()
    bus.add_controller(1)
    bus.wait_hint = lambda cap=0.05: 5.0  # type: ignore[method-assign]  # sleep long unless woken
    watcher = bus.serve_monitor(link=str(tmp_path / "mon"))
    try:
        with serial.Serial(str(tmp_path / "mon"), 9600, timeout=1.0) as monitor:
            host = bus.open_serial(timeout=0.5)
            host.write(frame(1, 0xA0))
            assert monitor.read(6) == frame(1, 0xA0)  # heard from the in-process host's thread
            assert monitor.read(6) == frame(1, 0xD0)  # the answer, delivered by that host's read
            assert host.read(6) == frame(1, 0xD0)
    finally:
        watcher.stop()
        bus.close()


def test_a_stale_link_to_a_pty_number_this_process_now_serves_is_replaced(tmp_path: Path) -> None:
    """After kill -9 the next simulator may get the old pty numbers crosswise: a leftover link
    that points at our own other endpoint is stale, not someone else's."""
    bus = SimBus()
    bus.add_controller(1)
    main = bus.serve_pty(link=str(tmp_path / "tty"))
    (tmp_path / "mon").symlink_to(main.path)  # the killed simulator's monitor link, number reused
    monitor = bus.serve_monitor(link=str(tmp_path / "mon"))
    try:
        assert os.readlink(tmp_path / "mon") == monitor.path != main.path
        with pytest.raises(FileExistsError, match="still in use"):
            bus.serve_pty(link=str(tmp_path / "tty"))  # but a live link of ours is not taken over
        assert os.readlink(tmp_path / "tty") == main.path
    finally:
        monitor.stop()
        main.stop()
        bus.close()
