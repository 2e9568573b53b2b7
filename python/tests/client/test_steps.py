"""Procedures stepped by hand, without a driver (issue 17): feed each action its result and
assert the next action. Discovery, ID and baud changes, and the integrity rules of
docs/protocol.md (busy window, stale answers, the broadcast re-ask), plus what a procedure
does when its driver throws a failure in or closes it (docs/drivers.md)."""

from __future__ import annotations

import pytest

from nurimc.core.actions import Receive, Send, SetHostBaud, WaitUntil
from nurimc.core.buscore import FENCES, BusCore
from nurimc.core.timing import MAX_RESPONSE_TIME, Timing
from nurimc.errors import CallTimeout, ControllerBusy, IdInUse, NoAnswer, RateRefused, SettingNotApplied
from nurimc.procedures.config import change_baud, change_id
from nurimc.procedures.discovery import Found, Progress, RateSkipped, discover
from nurimc.procedures.group import read_states_broadcast
from nurimc.procedures.motor import MotorProcedures, MotorState
from nurimc.protocol import (
    BROADCAST_ID,
    Firmware,
    Message,
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
    s = Stepper(discover(core, rates=[115200, 9600], lines=False))
    assert s.baud() == 9600  # the most likely rate first, whatever order was given
    assert s.notes == [Progress(9600, 0, 2, None, ())]
    assert s.sent() == BROADCAST_PING
    window = TIMING.answer_deadline(6, 6, 9600, MAX_RESPONSE_TIME)
    begun = window - TIMING.wire_time(5, 9600)  # silence by then: nobody at this rate
    assert s.receive(Ping(5).encode()).until == pytest.approx(100.0 + begun)
    assert s.expect(Receive).until == pytest.approx(100.0 + window)  # an answer began: the whole window
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


def test_discovery_walks_ids_only_where_answers_collide_at_the_pace_the_broadcast_measured() -> None:
    core = bus_core(9600)
    s = Stepper(discover(core, rates=[9600], lines=False))
    s.baud()
    assert s.sent() == BROADCAST_PING
    s.clock += 0.0075  # the garble ends 7.5 ms after the broadcast was written
    s.receive(b"\xff\xfe\x00\x07\x13")  # two answers on top of each other
    s.silence()
    char = 10 / 9600
    # every answer began one frame before the last byte; two characters and the latency of slack
    wait = 0.0075 - 6 * char + 2 * char + TIMING.latency
    found: list[Found] = []
    for device_id in range(255):
        assert s.notes[-1] == Progress(9600, 0, 1, device_id, tuple(found))
        assert s.sent() == RequestFirmware(device_id).encode()
        receive = s.expect(Receive)
        assert receive.until == pytest.approx(s.clock + wait)  # only until an answer would have begun
        if device_id == 7:
            s.receive(Firmware(7, 3).encode())
            found.append(Found(7, 9600, 3))
        elif device_id == 9:
            s.receive(broken(Firmware(9, 4).encode()))
            s.silence()  # garbled: not yet a find (asked alone after the walk)
        elif device_id == 12:
            s.silence()  # ID 12 answers late: during the next ID's request, and is found all the same
        elif device_id == 13:
            s.receive(Firmware(12, 5).encode())
            s.silence()
            found.append(Found(12, 9600, 5))
        else:
            s.silence()
    # only the garbled ID is asked again, alone (the walk's answers named their firmware): it
    # garbles every time, so two controllers share it; the IDs before it need not be asked
    for _ in range(3):  # retried, then reported without a version
        assert s.sent() == RequestFirmware(9).encode()
        s.receive(broken(Firmware(9, 4).encode()))
        s.silence()
    assert s.baud() == 9600  # back to the old rate: a collision is not asked a third time
    assert s.result() == [Found(7, 9600, 3), Found(9, 9600, None, collision=True), Found(12, 9600, 5)]
    assert core.timing is TIMING


def test_discovery_asks_alone_the_ids_a_garble_in_the_walk_may_come_from() -> None:
    """Garbled bytes while ID 3 is walked: late answers of IDs 1 and 2 (a serial server held a
    request back) on top of each other. No collision is reported for ID 3: once the answers
    still owed are settled, ID 3, then the IDs walked before it, are asked alone."""
    core = bus_core(9600)
    s = Stepper(discover(core, rates=[9600], ids=range(5), lines=False))
    s.baud()
    for device_id in range(5):
        assert s.sent() == RequestFirmware(device_id).encode()
        if device_id == 3:
            s.receive(broken(Firmware(1, 1).encode()) + b"\x00")
        s.silence()
    s.silence()  # the answers IDs 0-3 may still send: none came
    for device_id in (3, 2, 1, 0):  # the walked ID first, then the ones before it, latest first
        assert s.sent() == RequestFirmware(device_id).encode()
        if device_id in (1, 2):
            s.receive(Firmware(device_id, 7).encode())
        else:
            s.silence()
            for _ in range(2):  # retried: silence, so nobody there
                assert s.sent() == RequestFirmware(device_id).encode()
                s.silence()
    assert s.baud() == 9600
    assert s.result() == [Found(1, 9600, 7), Found(2, 9600, 7)]


def test_discovery_skips_a_rate_the_port_refuses_with_one_note_and_goes_on() -> None:
    core = bus_core(57600)
    s = Stepper(discover(core, rates=[115200, 9600]))
    assert s.expect(SetHostBaud) == SetHostBaud(9600)
    s.fail(RateRefused("the adapter at /dev/ttyUSB0 cannot be set to 9600 bps ([Errno 22] Invalid argument)"))
    assert core.baudrate == 57600  # the port kept its rate, and so did the bus
    assert s.notes == [
        RateSkipped(9600, "the adapter at /dev/ttyUSB0 cannot be set to 9600 bps ([Errno 22] Invalid argument)")
    ]
    assert s.baud() == 115200  # the scan goes on
    assert s.sent() == BROADCAST_PING
    s.silence()
    assert s.baud() == 57600
    assert s.result() == []


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
    whole = Stepper(discover(core, rates=[9600, 115200], lines=False))
    kinds = play_discovery(whole, core)
    assert whole.result() == [Found(5, 9600, 1)]
    assert kinds == [SetHostBaud, Send, SetHostBaud, Send, SetHostBaud, Send, SetHostBaud]
    for index in range(len(kinds) - 1):  # the last action is the return to the old rate itself
        core = bus_core(57600)
        s = Stepper(discover(core, rates=[9600, 115200], lines=False))
        play_discovery(s, core, index)
        s.fail(failure)
        assert s.expect(SetHostBaud) == SetHostBaud(57600), index  # the only thing left to do: go back
        with pytest.raises(type(failure)):
            s.baud()
        assert core.baudrate == 57600 and core.timing is TIMING
    s = Stepper(discover(core, rates=[9600, 115200], lines=False))
    play_discovery(s, core, len(kinds) - 1)
    with pytest.raises(type(failure)):  # the switch back itself failed: nothing left to try
        s.fail(failure)


def test_a_port_that_stays_dead_reports_the_first_failure_and_the_old_rate() -> None:
    # the port fails mid-scan and then fails the switch back as well: the caller sees the first
    # failure (with a note that the host could not go back), and the bus's rate is the old one,
    # which is also what the port was last told (host and port agree)
    core = bus_core(57600)
    s = Stepper(discover(core, rates=[9600, 115200], lines=False))
    play_discovery(s, core, 3)  # at 115,200 bps, mid-scan
    first = OSError("port gone")
    s.fail(first)
    assert s.expect(SetHostBaud) == SetHostBaud(57600)
    with pytest.raises(OSError) as raised:
        s.fail(OSError("still gone"))
    assert raised.value is first
    assert any("could not return the host to 57600 bps" in note for note in raised.value.__notes__)
    assert core.baudrate == 57600


# -- configuration -------------------------------------------------------------------------
def test_change_id_checks_both_ids_writes_once_and_verifies_after_the_busy_window() -> None:
    core = bus_core(9600, busy_window=0.2)
    core.response_times[1] = 0.0005
    s = Stepper(change_id(core, 1, 2))
    assert s.sent() == RequestPing(2).encode()  # the new ID must be free
    s.silence()
    assert s.sent() == RequestPing(2).encode()
    s.silence()
    assert core.owes(2, Ping)
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())
    started = s.clock
    assert s.sent(wire_time=0.001) == SetId(1, 2).encode()
    finished = started + 0.001  # the write returned; the bytes still take their wire time
    busy_end = finished + TIMING.wire_time(len(SetId(1, 2).encode()), 9600) + TIMING.latency + 0.2
    # the free-ID pings may still be answered late: a fence of another kind rules that out first
    assert s.sent() == RequestFirmware(2).encode()
    s.receive(Firmware(2, 40).encode())
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


def rate_checked(s: Stepper[int]) -> None:
    """A baud change first checks that the port can run at the new rate: there and back, nothing sent."""
    assert s.baud() == 115200
    assert s.baud() == 9600


def target_checked(s: Stepper[int], rate: int = 115200) -> None:
    """Then that no controller at the new rate has the ID already (nurimc.procedures.collisions): there, one
    ping, silence, and back."""
    assert s.baud() == rate
    assert s.sent() == RequestPing(1).encode()
    s.silence()
    assert s.baud() == 9600


def test_change_baud_is_refused_when_the_id_answers_at_the_new_rate() -> None:
    core = bus_core(9600, busy_window=0.05)
    s = Stepper(change_baud(core, 1, 115200))
    rate_checked(s)
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())
    assert s.baud() == 115200
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())  # another controller with ID 1 at 115200 bps
    with pytest.raises(IdInUse, match="ID 1 already answers at 115200 bps"):
        s.baud()
    assert core.baudrate == 9600


def test_change_baud_to_a_rate_the_adapter_refuses_sends_nothing() -> None:
    core = bus_core(9600, busy_window=0.05)
    s = Stepper(change_baud(core, 1, 250000))
    assert s.expect(SetHostBaud) == SetHostBaud(250000)
    with pytest.raises(RateRefused, match=r"ID 1 was not changed \(at 250000 bps it would be out of reach\)"):
        s.fail(RateRefused("the adapter at /dev/ttyUSB0 cannot be set to 250000 bps"))
    assert core.baudrate == 9600


def test_change_baud_switches_the_host_and_verifies_at_the_new_rate() -> None:
    core = bus_core(9600, busy_window=0.05)
    s = Stepper(change_baud(core, 1, 115200))
    rate_checked(s)
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())
    target_checked(s)
    assert s.sent() == SetBaud(1, baud_index(115200)).encode()
    assert s.baud() == 115200
    assert s.sent() == RequestPing(1).encode()
    s.receive(Ping(1).encode())
    assert s.result() == 115200 and core.baudrate == 115200


@pytest.mark.parametrize("failure", [OSError("port gone"), CallTimeout("took too long")])
def test_change_baud_interrupted_after_the_switch_puts_the_host_back(failure: BaseException) -> None:
    core = bus_core(9600, busy_window=0.05)
    s = Stepper(change_baud(core, 1, 115200))
    rate_checked(s)
    s.sent()
    s.receive(Ping(1).encode())
    target_checked(s)
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
    rate_checked(s)
    s.sent()
    s.receive(Ping(1).encode())
    target_checked(s)
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


def lost_answer(core: BusCore, device_id: int = 1) -> Stepper[Message]:
    """A position read whose answer did not come in time (it may still come, late)."""
    first = Stepper(core.ask(RequestPosition(device_id), retries=0))
    first.sent()
    with pytest.raises(NoAnswer):
        first.silence()
    assert core.owes(device_id, PositionFeedback)
    return first


def test_a_late_answer_is_ruled_out_by_a_fence_and_never_returned_by_the_next_request() -> None:
    core = bus_core(115200)
    first = lost_answer(core)
    second = Stepper(core.ask(RequestPosition(1)), clock=first.clock)
    assert second.sent() == RequestPing(1).encode()  # a fence: its answer is no position
    second.receive(PositionFeedback(1, 0, 111, 0, 0).encode())  # the late answer comes first: dropped
    assert second.sent() == RequestPosition(1).encode()
    second.receive(Ping(1).encode() + PositionFeedback(1, 0, 222, 0, 0).encode())  # the fence's, then ours
    assert second.result() == PositionFeedback(1, 0, 222, 0, 0)
    assert core.stats.fences == 1 and core.stats.quiet_waits == 0 and core.stats.stale_frames == 2
    assert not core._owed


def test_a_lost_answer_costs_the_next_read_one_fence_not_a_quiet_period() -> None:
    core = bus_core(115200)
    first = lost_answer(core)
    second = Stepper(core.ask(RequestPosition(1)), clock=first.clock)
    assert second.sent() == RequestPing(1).encode()
    # the fence is answered: the controller answers in order, so the lost answer never comes
    second.receive(Ping(1).encode())
    assert second.sent() == RequestPosition(1).encode()
    assert second.waits == [] and second.clock - first.clock < 0.001
    second.receive(PositionFeedback(1, 0, 5, 0, 0).encode())
    third = Stepper(core.ask(RequestPosition(1)), clock=second.clock)
    assert third.expect(Send).data == RequestPosition(1).encode()  # nothing owed any more: no fence


def test_unanswered_fences_fall_back_to_waiting_the_late_answer_out() -> None:
    core = bus_core(115200)
    first = lost_answer(core)
    owed_until = core._owed[1][0].until
    assert owed_until == pytest.approx(first.clock + core.late_answer)
    second = Stepper(core.ask(RequestPosition(1)), clock=first.clock)
    for _ in range(FENCES):
        assert second.sent() == RequestPing(1).encode()
        second.receive(b"")
    assert second.expect(Receive).until == pytest.approx(owed_until)  # the quiet period, once
    second.receive(b"")
    assert second.sent() == RequestPosition(1).encode() and core.stats.quiet_waits == 1


def test_a_fence_answered_by_an_older_fence_is_not_taken_for_its_own() -> None:
    core = bus_core(115200)
    first = lost_answer(core)
    second = Stepper(core.ask(RequestPosition(1), retries=0), clock=first.clock)
    second.sent()  # fence 1: no answer in time
    second.receive(b"")
    second.sent()  # fence 2
    # fence 1's answer, late: it proves the position answer (asked before fence 1) is settled
    second.receive(Ping(1).encode())
    assert second.sent() == RequestPosition(1).encode()
    # owed now: fence 2's answer (it may still come) and this request's own, nothing older
    assert [o.kind for o in core._owed[1]] == [Ping, PositionFeedback]


def test_an_answer_to_an_earlier_attempt_answers_the_call_and_the_next_call_fences_the_other() -> None:
    core = bus_core(115200)
    s = Stepper(core.ask(RequestPosition(1), retries=1))
    s.sent()
    s.silence()  # attempt 1: nothing in time
    s.sent()
    s.receive(PositionFeedback(1, 0, 7, 0, 0).encode())  # attempt 1's answer, late, or attempt 2's
    assert s.result() == PositionFeedback(1, 0, 7, 0, 0)
    nxt = Stepper(core.ask(RequestPosition(1)), clock=s.clock)
    assert nxt.sent() == RequestPing(1).encode()  # one answer may still be on its way: fenced first


def test_a_duplicated_answer_is_given_time_to_show_before_the_same_request() -> None:
    core = bus_core(9600)
    s = Stepper(core.ask(RequestPosition(1)))
    s.sent()
    s.receive(PositionFeedback(1, 0, 7, 0, 0).encode())
    taken = s.clock
    nxt = Stepper(core.ask(RequestPosition(1)), clock=taken)
    assert [w.when for w in nxt.waits if type(w) is WaitUntil] == [pytest.approx(taken + 2 * TIMING.wire_time(1, 9600))]
    other = Stepper(core.ask(RequestPing(1)), clock=taken)  # another request: no copy to fear
    assert other.waits == []


def test_broadcast_read_asks_a_missing_motor_again_behind_a_fence() -> None:
    core = bus_core(1_000_000, busy_window=0.03)
    motors = [MotorProcedures(core, 1), MotorProcedures(core, 2), MotorProcedures(core, 3)]
    s = Stepper(read_states_broadcast(motors, slot=2))
    assert s.sent() == BROADCAST_POSITION
    s.receive(PositionFeedback(1, 0, 100, 0, 0).encode())
    # the last in the stagger has answered: ID 2's answer is late, no need to wait the window out
    s.receive(PositionFeedback(3, 0, 300, 0, 0).encode())
    assert s.sent() == RequestPing(2).encode()  # a fence: ID 2 may still answer the broadcast
    s.receive(PositionFeedback(2, 0, 150, 0, 0).encode())  # there it is, late: dropped
    assert s.sent() == RequestPosition(2).encode()
    s.receive(Ping(2).encode() + PositionFeedback(2, 0, 200, 0, 0).encode())  # the fence's, then ours
    states = s.result()
    assert list(states) == [1, 2, 3]
    assert [s.device_position for s in states.values() if isinstance(s, MotorState)] == [1.0, 2.0, 3.0]
    assert not core._owed  # nothing left owed: the next broadcast asks everyone again


def test_broadcast_read_is_whole_even_when_a_motor_never_answers() -> None:
    core = bus_core(1_000_000, busy_window=0.03)
    motors = [MotorProcedures(core, 1), MotorProcedures(core, 2)]
    s = Stepper(read_states_broadcast(motors, slot=2))
    s.sent()
    s.receive(PositionFeedback(2, 0, 200, 0, 0).encode())
    for _ in range(FENCES):
        assert s.sent() == RequestPing(1).encode()
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
