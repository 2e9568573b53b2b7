"""Procedures stepped by hand, without a driver (issue 17): feed each action its result and
assert the next action. Discovery, ID and baud changes, and the integrity rules of
docs/protocol.md (busy window, stale answers, the broadcast re-ask), plus what a procedure
does when its driver throws a failure in or closes it (docs/drivers.md)."""

from __future__ import annotations

import pytest

from nurimc.client.actions import Receive, Send, SetHostBaud, WaitUntil
from nurimc.client.core import BusCore
from nurimc.client.timing import MAX_RESPONSE_TIME, Timing
from nurimc.config import change_baud, change_id
from nurimc.discovery import WALK_RESPONSE_TIME, Found, Progress, discover
from nurimc.errors import CallTimeout, ControllerBusy, IdInUse, NoAnswer, SettingNotApplied
from nurimc.group import read_states_broadcast
from nurimc.motor import MotorProcedures, MotorState
from nurimc.protocol import (
    BROADCAST_ID,
    Firmware,
    Ping,
    PositionFeedback,
    RequestFirmware,
    RequestPing,
    RequestPosition,
    SetBaud,
    SetControl,
    SetId,
    baud_index,
    build_frame,
    decode,
)

from .stepping import Stepper

TIMING = Timing(latency=0.001, margin=0.002)
BROADCAST_PING = build_frame(BROADCAST_ID, RequestPing.SPEC.mode, b"")
BROADCAST_POSITION = build_frame(BROADCAST_ID, RequestPosition.SPEC.mode, b"")


def bus_core(baudrate: int = 9600, **options: object) -> BusCore:
    return BusCore(baudrate=baudrate, timing=TIMING, **options)  # type: ignore[arg-type]


def broken(frame: bytes) -> bytes:
    return frame[:-1] + bytes([frame[-1] ^ 0x55])  # a checksum that no longer matches


# -- discovery -----------------------------------------------------------------------------
def test_discovery_pings_each_rate_once_confirms_and_returns_to_the_old_rate() -> None:
    core = bus_core(57600)
    s = Stepper(discover(core, rates=[115200, 9600]))
    assert s.baud() == 9600  # the most likely rate first, whatever order was given
    assert s.notes == [Progress(9600, 0, 2, None, ())]
    assert s.sent() == BROADCAST_PING
    window = TIMING.answer_deadline(6, 6, 9600, MAX_RESPONSE_TIME)
    assert s.receive(Ping(5).encode()).until == pytest.approx(100.0 + window)
    s.silence()
    assert s.baud() == 115200
    assert s.sent() == BROADCAST_PING
    s.silence()  # nobody at 115200: no ID walk, since nothing came back garbled
    assert s.baud() == 9600  # back to where ID 5 answered, to confirm it
    assert s.sent() == RequestFirmware(5).encode()
    s.receive(Firmware(5, 12).encode())
    assert s.baud() == 57600
    assert s.result() == [Found(5, 9600, 12)]
    assert core.baudrate == 57600 and core.timing is TIMING


def test_discovery_walks_ids_only_where_answers_collide() -> None:
    core = bus_core(9600)
    s = Stepper(discover(core, rates=[9600]))
    s.baud()
    assert s.sent() == BROADCAST_PING
    s.receive(b"\xff\xfe\x00\x07\x13")  # two answers on top of each other
    s.silence()
    walk_deadline = TIMING.answer_deadline(6, 6, 9600, WALK_RESPONSE_TIME)
    found: list[Found] = []
    for device_id in range(255):
        assert s.notes[-1] == Progress(9600, 0, 1, device_id, tuple(found))
        assert s.sent() == RequestPing(device_id).encode()
        receive = s.expect(Receive)
        assert receive.until == pytest.approx(s.clock + walk_deadline)  # short: the walk's own timing
        if device_id == 7:
            s.receive(Ping(7).encode())
            found.append(Found(7, 9600, None))
        elif device_id == 9:
            s.receive(broken(Ping(9).encode()))
            s.silence()
            found.append(Found(9, 9600, None, collision=True))
        else:
            s.silence()
    assert core.timing is TIMING  # the walk's timing is put back
    assert s.baud() == 9600
    assert s.sent() == RequestFirmware(7).encode()
    s.receive(Firmware(7, 3).encode())
    assert s.baud() == 9600
    assert s.sent() == RequestFirmware(9).encode()
    s.silence()
    s.sent()
    s.silence()
    s.sent()
    s.silence()  # retried, then reported without a version
    assert s.baud() == 9600
    assert s.result() == [Found(7, 9600, 3), Found(9, 9600, None, collision=True)]


def play_discovery(s: Stepper[list[Found]], core: BusCore, limit: int | None = None) -> list[type]:
    """Carry out up to `limit` bus actions of a discovery (ID 5 answers at 9,600 bps only)."""
    kinds: list[type] = []
    while not s.done and (limit is None or len(kinds) < limit):
        kinds.append(type(s.action))
        if type(s.action) is SetHostBaud:
            s.baud()
        elif type(s.action) is Send:
            data = s.sent()
            if core.baudrate == 9600:
                s.receive(
                    {BROADCAST_PING: Ping(5).encode(), RequestFirmware(5).encode(): Firmware(5, 1).encode()}[data]
                )
            s.silence()
        else:
            raise AssertionError(s.action)
    return kinds


@pytest.mark.parametrize("failure", [OSError("port gone"), CallTimeout("took too long"), KeyboardInterrupt()])
def test_a_failure_thrown_in_at_any_bus_action_of_discovery_restores_the_rate(failure: BaseException) -> None:
    core = bus_core(57600)
    whole = Stepper(discover(core, rates=[9600, 115200]))
    kinds = play_discovery(whole, core)
    assert whole.result() == [Found(5, 9600, 1)]
    assert kinds == [SetHostBaud, Send, SetHostBaud, Send, SetHostBaud, Send, SetHostBaud]
    for index in range(len(kinds) - 1):  # the last action is the return to the old rate itself
        core = bus_core(57600)
        s = Stepper(discover(core, rates=[9600, 115200]))
        play_discovery(s, core, index)
        s.fail(failure)
        assert s.expect(SetHostBaud) == SetHostBaud(57600), index  # the only thing left to do: go back
        with pytest.raises(type(failure)):
            s.baud()
        assert core.baudrate == 57600 and core.timing is TIMING
    s = Stepper(discover(core, rates=[9600, 115200]))
    play_discovery(s, core, len(kinds) - 1)
    with pytest.raises(type(failure)):  # the switch back itself failed: nothing left to try
        s.fail(failure)


def test_a_port_that_stays_dead_reports_the_first_failure_and_the_old_rate() -> None:
    # the port fails mid-scan and then fails the switch back as well: the caller sees the first
    # failure (with a note that the host could not go back), and the bus's rate is the old one,
    # which is also what the port was last told (host and port agree)
    core = bus_core(57600)
    s = Stepper(discover(core, rates=[9600, 115200]))
    play_discovery(s, core, 3)  # at 115,200 bps, mid-scan
    first = OSError("port gone")
    s.fail(first)
    assert s.expect(SetHostBaud) == SetHostBaud(57600)
    with pytest.raises(OSError) as raised:
        s.fail(OSError("still gone"))
    assert raised.value is first
    assert any("could not return the host to 57600 bps" in note for note in raised.value.__notes__)
    assert core.baudrate == 57600


def test_a_discovery_closed_mid_walk_puts_its_timing_back() -> None:
    core = bus_core(9600)
    s = Stepper(discover(core, rates=[9600]))
    s.baud()
    s.sent()
    s.receive(b"\x00\x13")  # garbled: walk
    s.silence()
    s.sent()  # pinging ID 0 with the walk's timing
    assert core.timing is not TIMING
    s.procedure.close()  # abandoned: no further action, but no wrong state either
    assert core.timing is TIMING


# -- configuration -------------------------------------------------------------------------
def test_change_id_checks_both_ids_writes_once_and_verifies_after_the_busy_window() -> None:
    core = bus_core(9600, busy_window=0.2)
    core.response_times[1] = 0.0005
    s = Stepper(change_id(core, 1, 2))
    assert s.sent() == RequestPing(2).encode()  # the new ID must be free
    s.silence()
    assert s.sent() == RequestPing(2).encode()
    s.silence()
    owed = core._pending[2].until
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())
    started = s.clock
    assert s.sent(wire_time=0.001) == SetId(1, 2).encode()
    finished = started + 0.001  # the write returned; the bytes still take their wire time
    busy_end = finished + TIMING.wire_time(len(SetId(1, 2).encode()), 9600) + TIMING.latency + 0.2
    # the free-ID pings may still be answered late: that is waited out before ID 2 is asked again
    assert s.receive(b"").until == owed
    assert s.sent() == RequestPing(2).encode()  # verified at the new ID ...
    # ... once the busy window is over
    assert [w.when for w in s.waits if type(w) is WaitUntil] == [pytest.approx(busy_end)]
    assert s.clock >= busy_end > started
    s.receive(Ping(2).encode())
    assert s.result() is None
    assert 1 not in core.response_times


def test_change_id_is_refused_when_the_new_id_answers() -> None:
    s = Stepper(change_id(bus_core(), 1, 2))
    assert s.sent() == RequestPing(2).encode()
    with pytest.raises(IdInUse, match="ID 2 already answers"):
        s.receive(Ping(2).encode())


def test_change_baud_switches_the_host_and_verifies_at_the_new_rate() -> None:
    core = bus_core(9600, busy_window=0.05)
    s = Stepper(change_baud(core, 1, 115200))
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())
    assert s.sent() == SetBaud(1, baud_index(115200)).encode()
    assert s.baud() == 115200
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())
    assert s.result() == 115200 and core.baudrate == 115200


@pytest.mark.parametrize("failure", [OSError("port gone"), CallTimeout("took too long")])
def test_change_baud_interrupted_after_the_switch_puts_the_host_back(failure: BaseException) -> None:
    core = bus_core(9600, busy_window=0.05)
    s = Stepper(change_baud(core, 1, 115200))
    s.sent()
    s.receive(Ping(1).encode())
    s.sent()
    s.baud()
    s.expect(Send)
    s.fail(failure)  # the verifying ping at the new rate could not be written
    assert s.expect(SetHostBaud) == SetHostBaud(9600)
    with pytest.raises(type(failure)):
        s.baud()
    assert core.baudrate == 9600


def test_change_baud_that_did_not_take_says_where_the_controller_is() -> None:
    core = bus_core(9600, busy_window=0.05)
    s = Stepper(change_baud(core, 1, 115200))
    s.sent()
    s.receive(Ping(1).encode())
    s.sent()
    assert s.baud() == 115200
    while type(s.action) is not SetHostBaud:  # silence at the new rate for the whole verify window
        s.sent()
        s.silence()
    assert s.baud() == 9600  # the old rate is searched first
    assert s.sent() == RequestPing(1).encode()
    with pytest.raises(SettingNotApplied, match="answers at 9600 bps"):
        s.receive(Ping(1).encode())
    assert core.baudrate == 9600


# -- integrity rules (docs/protocol.md) ---------------------------------------------------
def test_busy_window_holds_motion_after_release_until_the_window_ends() -> None:
    core = bus_core(9600, busy_window=0.15)
    motor = MotorProcedures(core, 1)
    motor._relative = False  # position mode known: absolute
    s = Stepper(motor.release())
    assert s.sent() == SetControl(1, 1).encode()
    released_busy = s.clock + TIMING.wire_time(6 + 1, 9600) + TIMING.latency + 0.15
    assert s.done and core.busy_until(1) == pytest.approx(released_busy)

    other = Stepper(core.ask(RequestPosition(2)), clock=s.clock)  # another ID is not held back
    assert other.sent() == RequestPosition(2).encode() and other.waits == []

    m = Stepper(motor.move_to(30, rpm=60), clock=s.clock)
    assert m.expect(Send).data == SetControl(1, 0).encode()  # control on again first ...
    assert [w.when for w in m.waits if type(w) is WaitUntil] == [pytest.approx(released_busy)]
    assert len(m.waits) == 1 and m.clock >= released_busy
    m.sent()
    enabled_busy = core.busy_until(1)
    assert enabled_busy > released_busy
    move = m.sent()  # ... then the move, after that write's own window
    assert decode(move) == motor.make_move_to(30, rpm=60)
    assert m.clock >= enabled_busy and m.done


def test_a_late_answer_is_waited_out_and_never_returned_by_the_next_request() -> None:
    core = bus_core(115200)
    first = Stepper(core.ask(RequestPosition(1), retries=0))
    first.sent()
    with pytest.raises(NoAnswer):
        first.silence()
    owed_until = core._pending[1].until
    assert owed_until == pytest.approx(first.clock + core.late_answer)

    second = Stepper(core.ask(RequestPosition(1)), clock=first.clock)
    quiet = second.expect(Receive)  # no request while an answer to the last one may still come
    assert quiet.until == pytest.approx(owed_until)
    second.receive(PositionFeedback(1, 0, 111, 0, 0).encode())  # there it is: late, and dropped
    assert second.sent() == RequestPosition(1).encode()
    second.receive(PositionFeedback(1, 0, 222, 0, 0).encode())
    assert second.result() == PositionFeedback(1, 0, 222, 0, 0)
    assert core.stats.quiet_waits == 1 and core.stats.stale_frames == 1 and not core._pending


def test_a_late_answer_that_never_comes_costs_the_quiet_period_once() -> None:
    core = bus_core(115200)
    first = Stepper(core.ask(RequestPosition(1), retries=0))
    first.sent()
    with pytest.raises(NoAnswer):
        first.silence()
    owed_until = core._pending[1].until
    second = Stepper(core.ask(RequestPosition(1)), clock=first.clock)
    second.receive(b"")
    assert second.clock == owed_until
    assert second.sent() == RequestPosition(1).encode()
    second.receive(PositionFeedback(1, 0, 5, 0, 0).encode())
    third = Stepper(core.ask(RequestPosition(1)), clock=second.clock)
    assert third.expect(Send)  # nothing owed any more: straight to the request


def test_an_answer_to_an_earlier_attempt_answers_the_call_and_the_next_call_waits_for_the_other() -> None:
    core = bus_core(115200)
    s = Stepper(core.ask(RequestPosition(1), retries=1))
    s.sent()
    s.silence()  # attempt 1: nothing in time
    s.sent()
    s.receive(PositionFeedback(1, 0, 7, 0, 0).encode())  # attempt 1's answer, late, or attempt 2's
    assert s.result() == PositionFeedback(1, 0, 7, 0, 0)
    nxt = Stepper(core.ask(RequestPosition(1)), clock=s.clock)
    assert type(nxt.action) is Receive  # one answer may still be on its way: wait for it first


def test_broadcast_read_asks_a_missing_motor_again_and_takes_its_late_answer() -> None:
    core = bus_core(1_000_000, busy_window=0.03)
    motors = [MotorProcedures(core, 1), MotorProcedures(core, 2), MotorProcedures(core, 3)]
    s = Stepper(read_states_broadcast(motors, slot=2))
    assert s.sent() == BROADCAST_POSITION
    s.receive(PositionFeedback(1, 0, 100, 0, 0).encode())
    s.receive(PositionFeedback(3, 0, 300, 0, 0).encode())
    s.receive(b"")  # the window ends without ID 2
    assert s.expect(Send).data == RequestPosition(2).encode()  # asked again at once: no quiet wait
    s.sent()
    s.receive(PositionFeedback(2, 0, 200, 0, 0).encode())  # the broadcast's late answer, or the re-ask's
    states = s.result()
    assert list(states) == [1, 2, 3]
    assert [s.device_position for s in states.values() if isinstance(s, MotorState)] == [1.0, 2.0, 3.0]
    assert type(Stepper(core.ask(RequestPosition(2))).action) is Receive  # the other answer is still owed


def test_broadcast_read_is_whole_even_when_a_motor_never_answers() -> None:
    core = bus_core(1_000_000, busy_window=0.03)
    motors = [MotorProcedures(core, 1), MotorProcedures(core, 2)]
    s = Stepper(read_states_broadcast(motors, slot=2))
    s.sent()
    s.receive(PositionFeedback(2, 0, 200, 0, 0).encode())
    s.silence()
    for _ in range(3):
        assert s.sent() == RequestPosition(1).encode()
        s.silence()
    states = s.result()
    assert list(states) == [1, 2]
    assert isinstance(states[1], NoAnswer) and isinstance(states[2], MotorState)


def test_a_broadcast_settings_command_makes_every_id_wait() -> None:
    for device_id in (0, 4, 200):
        core = bus_core(115200, busy_window=0.1)
        MotorProcedures(core, 4, product="blmc-h")
        core.busy_windows[4] = 0.25  # the largest window of any ID: a broadcast waits for it
        s = Stepper(core.tell(SetControl(BROADCAST_ID, 1)))
        s.sent()
        end = s.clock + TIMING.wire_time(7, 115200) + TIMING.latency + 0.25
        ask = Stepper(core.ask(RequestPosition(device_id)), clock=s.clock)
        assert [w.when for w in ask.waits if type(w) is WaitUntil] == [pytest.approx(end)], device_id
        assert ask.expect(Send).data == RequestPosition(device_id).encode()


def test_silence_right_after_a_settings_write_is_busy_not_wiring() -> None:
    core = bus_core(115200, busy_window=0.05, retries=1)
    Stepper(core.tell(SetControl(1, 0))).sent()
    s = Stepper(core.ask(RequestPosition(1)))
    s.sent()
    s.silence()
    s.sent()
    with pytest.raises(ControllerBusy, match="busy writing its settings"):
        s.silence()
    far = Stepper(core.ask(RequestPosition(1), retries=0), clock=s.clock + 1.0)  # long after: the usual checklist
    far.silence()  # the quiet period for the answers still owed
    far.sent()
    with pytest.raises(NoAnswer) as err:
        far.silence()
    assert not isinstance(err.value, ControllerBusy) and "wires" in str(err.value)
