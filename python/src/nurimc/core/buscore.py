"""The bus client's sans-I/O core: request/answer exchanges as procedures.

Both the sync Bus and the AsyncBus hold one BusCore and run its procedures with their own
driver, so the matching, retry, timeout, busy-window and stale-answer rules exist once.
The rules are written down in docs/protocol.md ("Busy window", "Stale answers").
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from ..errors import ControllerBusy, CorruptedAnswer, NoAnswer, RateRefused, UnexpectedAnswer
from ..protocol import (
    BROADCAST_ID,
    Command,
    Message,
    Ping,
    Request,
    RequestFirmware,
    RequestPing,
    StreamParser,
    answer_class,
    build_frame,
    product_line,
)
from ..protocol.host import EEPROM_WRITES, LATE_ANSWER, RETRIES, RETRY_PAUSE, busy_window
from .actions import Discard, Now, Procedure, Receive, Send, Sent, SetHostBaud, Wait, WaitUntil
from .timing import Timing

ALL_IDS = range(255)


@dataclass
class BusStats:
    """Counters over the life of a bus: what the wire did to us."""

    requests: int = 0
    answers: int = 0
    retries: int = 0
    no_answer: int = 0
    echo_frames: int = 0  # our own request seen again (adapters that echo)
    stale_frames: int = 0  # valid frames that answer nothing we asked now (late, early, or not ours)
    dropped_bytes: int = 0  # noise and broken frames
    busy_waits: int = 0  # frames held back until a controller's EEPROM busy window ended
    quiet_waits: int = 0  # requests held back until a late answer came or could no longer come
    fences: int = 0  # requests of another kind sent first, to rule out a late answer (Stale answers)

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


@dataclass(slots=True)
class Owed:
    """An answer an ID may still send: of class `kind`, to a request sent in order `order`; none
    is expected after `until` (host clock)."""

    kind: type[Message]
    until: float
    order: int


#: fences tried before a request falls back to waiting out the answers its ID owes
FENCES = 2
#: requests whose frame and answer class are kept (a bus asks few different things, again and again)
PLANS = 1024
# actions without fields: one of each serves every yield (frozen, so nobody can change them)
NOW = Now()
DISCARD = Discard()


@dataclass
class BusCore:
    baudrate: int = 9600
    timing: Timing = field(default_factory=Timing)
    retries: int = RETRIES  # extra attempts for a request that got no valid answer
    retry_pause: float = RETRY_PAUSE
    #: known response time (seconds) per controller ID; unknown IDs get timing.assumed_response_time
    response_times: dict[int, float] = field(default_factory=dict)
    stats: BusStats = field(default_factory=BusStats)
    #: EEPROM busy window for every ID of this bus (None: from each ID's product profile)
    busy_window: float | None = None
    #: EEPROM busy window per ID, ahead of busy_window
    busy_windows: dict[int, float] = field(default_factory=dict)
    #: product profile per ID, as motor handles declared it (for the default busy window)
    products: dict[int, str] = field(default_factory=dict)
    #: how late an answer may be, beyond its deadline, and still be told apart from a fresh one
    late_answer: float = LATE_ANSWER
    #: control state per ID as last sent or read: True = released (off), False = on
    control_released: dict[int, bool] = field(default_factory=dict)
    #: commands sent per ID (the broadcast ID counts for every motor): a motor at rest with none
    #: since its last reading has not moved (nurimc.procedures.multiturn)
    commands_sent: dict[int, int] = field(default_factory=dict)
    # host-clock time each ID's busy window ends (kept after it ends, to name the error right)
    _busy_until: dict[int, float] = field(default_factory=dict)
    _busy_all_until: float = 0.0
    _waits_pending: float = 0.0  # the latest busy time not yet waited out (0: nothing to wait for)
    #: answers each ID may still send, in the order their requests were sent (Stale answers)
    _owed: dict[int, list[Owed]] = field(default_factory=dict)
    _sent_count: int = 0
    #: per ID: (answer class, host time) of the last answer taken, for the duplicate guard
    #: per ID: the last answer seen from it and when (host clock), for the duplicate rule
    _last_seen: dict[int, tuple[Message, float]] = field(default_factory=dict)
    _now: float = 0.0  # host time the last bytes were received
    #: seconds from the last broadcast request's write call to the last byte heard after it (None: silence)
    broadcast_span: float | None = None
    #: per request: (its frame, its answer class, the answer's length), worked out once (docs/performance.md)
    _plans: dict[Request, tuple[bytes, type[Message], int]] = field(default_factory=dict, repr=False)

    # -- busy windows ------------------------------------------------------------------------
    def window(self, device_id: int) -> float:
        """The EEPROM busy window of an ID (docs/protocol.md, Busy window, rule 2)."""
        if device_id == BROADCAST_ID:
            return max([self.window(i) for i in {*self.busy_windows, *self.products}] + [self._default_window()])
        if device_id in self.busy_windows:
            return self.busy_windows[device_id]
        if self.busy_window is not None:
            return self.busy_window
        return busy_window(self.products.get(device_id, "mc"))

    def _default_window(self) -> float:
        return self.busy_window if self.busy_window is not None else busy_window("mc")

    def busy_until(self, device_id: int) -> float:
        """Host-clock time the ID may be sent a frame again (0: any time)."""
        if device_id == BROADCAST_ID:
            return max([self._busy_all_until, *self._busy_until.values()])
        return max(self._busy_all_until, self._busy_until.get(device_id, 0.0))

    def _wait_until_free(self, ids: Iterable[int]) -> Procedure[None]:
        if not self._waits_pending:
            return
        when = max(self.busy_until(i) for i in ids)
        now = yield NOW
        if when > now:
            self.stats.busy_waits += 1
            now = yield WaitUntil(when)
        if now >= self._waits_pending:
            self._waits_pending = 0.0

    def _mark_busy(self, commands: Sequence[Command], sent: Sent, nbytes: int) -> None:
        end = sent.finished + self.timing.wire_time(nbytes, self.baudrate) + self.timing.latency
        for command in commands:
            name = command.name  # by name: the same message has another mode in another line
            if name == "set_control":
                self._note_control(command.id, command.fields()["control"] == 1)
            if name not in EEPROM_WRITES:
                continue
            ids = [command.id]
            if name == "set_id":
                new_id = command.fields()["new_id"]
                ids.append(new_id)
                if command.id in self.control_released:
                    self.control_released[new_id] = self.control_released.pop(command.id)
            elif name == "factory_reset" and command.id != BROADCAST_ID:
                ids.append(0)  # it comes back as ID 0
                self.control_released.pop(command.id, None)
            for device_id in ids:
                until = end + self.window(device_id)
                if device_id == BROADCAST_ID:
                    self._busy_all_until = max(self._busy_all_until, until)
                else:
                    self._busy_until[device_id] = max(self._busy_until.get(device_id, 0.0), until)
                self._waits_pending = max(self._waits_pending, until)

    def _note_control(self, device_id: int, released: bool) -> None:
        if device_id == BROADCAST_ID:
            for known in {*self.control_released, *self.products}:
                self.control_released[known] = released
        else:
            self.control_released[device_id] = released

    def _recently_busy(self, device_id: int, sent_at: float) -> bool:
        """Was this request sent within one more window after the ID's busy window ended?"""
        until = self.busy_until(device_id)
        return bool(until) and sent_at < until + self.window(device_id)

    # -- owed (possibly late) answers: docs/protocol.md, Stale answers -------------------------
    def _owe(self, device_id: int, kind: type[Message], until: float) -> Owed:
        self._sent_count += 1
        owed = Owed(kind, until, self._sent_count)
        self._owed.setdefault(device_id, []).append(owed)
        return owed

    def forget_expired(self, now: float) -> None:
        for device_id in list(self._owed):
            left = [o for o in self._owed[device_id] if o.until > now]
            if left:
                self._owed[device_id] = left
            else:
                del self._owed[device_id]

    def owes(self, device_id: int, kind: type[Message]) -> bool:
        """May this ID still send an answer of this class to an earlier request?"""
        return any(o.kind is kind for o in self._owed.get(device_id, ()))

    def _resolve(self, message: Message) -> bool:
        """An answer came: it answers the earliest request still owed an answer of its class (or
        a later one), and a controller answers in order, so everything owed before that request
        has come or never will. True if the ID owed such an answer."""
        owed = self._owed.get(message.id)
        if not owed:
            return False
        for index, entry in enumerate(owed):
            if entry.kind is type(message):
                del owed[: index + 1]
                if not owed:
                    del self._owed[message.id]
                return True
        return False

    def _settle_frame(self, message: Message) -> bool:
        """Count a frame as stale; True if it was an answer some ID still owed (or a copy of the
        last one seen from that ID: a duplicate answers nothing, so it resolves nothing)."""
        self.stats.stale_frames += 1
        if isinstance(message, Request):
            return False
        last = self._last_seen.get(message.id)
        self._last_seen[message.id] = (message, self._now)
        if last is not None and last[0] == message:
            return True
        return self._resolve(message)

    def _take(self, message: Message) -> None:
        """`message` is taken as the answer to a request of this call."""
        self._resolve(message)
        self._last_seen[message.id] = (message, self._now)

    def _duplicate_gap(self, ids: Iterable[int], kind: type[Message]) -> Procedure[None]:
        """A copy of the last answer (a repeating adapter or line) follows it back to back: before
        asking the same ID the same thing again, let the copy's first byte arrive, so the discard
        before the request takes it (what is left of it can no longer form a frame)."""
        taken = [
            t for i in ids if (last := self._last_seen.get(i)) is not None and type(last[0]) is kind for t in last[1:]
        ]
        if not taken:
            return
        gap = max(taken) + 2 * self.timing.wire_time(1, self.baudrate)
        now = yield NOW
        if now < gap:
            yield WaitUntil(gap)

    def _fence(self, device_id: int, kind: type[Message]) -> Procedure[None]:
        """Before asking an ID for `kind` while it may still send a late `kind` answer: ask it
        something whose answer is of another class. Its answer proves (answers come in order)
        that the late one came or never will; if no fence is answered, wait the owed answers out."""
        now = yield NOW
        self.forget_expired(now)
        if not self.owes(device_id, kind):
            return
        fence_cls = RequestFirmware if kind is Ping else RequestPing
        answer_cls = answer_class(fence_cls)
        frame = fence_cls(device_id).encode()
        deadline = self.timing.answer_deadline(
            len(frame), answer_cls.SPEC.size + 4, self.baudrate, self.response_times.get(device_id)
        )
        for _ in range(FENCES):
            self.stats.fences += 1
            yield from self._wait_until_free([device_id])
            yield from self._discard()
            sent: Sent = yield Send(frame)
            self._owe(device_id, answer_cls, sent.finished + deadline + self.late_answer)
            parser = StreamParser()
            while self.owes(device_id, kind):
                # no more than the fence's answer: a read returns as soon as that much has come
                data = yield Receive(max(1, answer_cls.SPEC.size + 4 - parser.pending), sent.finished + deadline)
                if data:
                    self._now = yield NOW
                for message in parser.feed(data) if data else parser.finish():
                    if message.id == device_id and isinstance(message, Request):
                        self.stats.echo_frames += 1
                    else:
                        self._settle_frame(message)
                if not data:
                    break
            self.stats.dropped_bytes += parser.stats.dropped_bytes
            if not self.owes(device_id, kind):
                return
        yield from self._quiet([device_id], kind)

    def wait_out(self, ids: Iterable[int], kind: type[Message] | None = None) -> Procedure[None]:
        """Listen until the answers these IDs still owe (of `kind`, or any) came or cannot come
        (docs/protocol.md, Stale answers, A3): afterwards none of them can answer a new request
        with an old answer, and asking them needs no fence."""
        yield from self._quiet(list(ids), kind)

    def _quiet(self, ids: Iterable[int], kind: type[Message] | None = None) -> Procedure[None]:
        """Listen until the answers these IDs still owe (of `kind`, or any) came or cannot come."""
        if not self._owed:
            return
        now = yield NOW
        parser = StreamParser()
        counted = False
        while True:
            self.forget_expired(now)
            waiting = [o.until for i in ids for o in self._owed.get(i, ()) if kind is None or o.kind is kind]
            if not waiting:
                break
            if not counted:
                self.stats.quiet_waits += 1
                counted = True
            data = yield Receive(64, max(waiting))
            if data:
                self._now = yield NOW
            for message in parser.feed(data) if data else parser.finish():
                self._settle_frame(message)
            now = yield NOW
        self.stats.dropped_bytes += parser.stats.dropped_bytes

    def _discard(self) -> Procedure[None]:
        data = yield DISCARD
        if data:
            yield from self._discarded(data)

    def _discarded(self, data: bytes) -> Procedure[None]:
        """Settle what a discard dropped (answers that came late count as what they answer)."""
        self._now = yield NOW
        parser = StreamParser()
        for message in [*parser.feed(data), *parser.finish()]:
            if isinstance(message, Request):
                self.stats.echo_frames += 1
            else:
                self._settle_frame(message)
        self.stats.dropped_bytes += parser.stats.dropped_bytes

    # -- exchanges ---------------------------------------------------------------------------
    def ask(self, request: Request, retries: int | None = None, *, own_pending: bool = False) -> Procedure[Message]:
        """Send a request and return its answer; retried, since reading twice is harmless.

        An answer to an earlier attempt of this call is an answer to this call; a late answer
        owed to an earlier call is ruled out first by a fence (docs/protocol.md, Stale answers).
        `own_pending`: answers the ID still owes belong to this call too (a broadcast read
        asking its missing motors again)."""
        attempts = 1 + (self.retries if retries is None else retries)
        self.in_its_line(request)
        rid = request.id
        plan = self._plans.get(request)
        if plan is None:
            plan = self._plan(request)
        frame, cls, answer_len = plan
        response_time = self.response_times.get(rid)
        deadline = self.timing.answer_deadline(len(frame), answer_len, self.baudrate, response_time)
        # the common case costs no action: nothing owed by this ID (no fence), no answer of this
        # class taken from it before (no gap), no EEPROM busy window pending (no wait)
        if not own_pending and rid in self._owed:
            yield from self._fence(rid, cls)
        last = self._last_seen.get(rid)
        if last is not None and type(last[0]) is cls:  # _duplicate_gap for one ID, inline
            gap = last[1] + 2 * self.timing.wire_time(1, self.baudrate)
            if (yield NOW) < gap:
                yield WaitUntil(gap)
        return (yield from self.attempts(request, plan, deadline, attempts))

    def attempts(
        self,
        request: Request,
        plan: tuple[bytes, type[Message], int],
        deadline: float,
        attempts: int,
        sent: Sent | None = None,
        data: bytes | None = None,
    ) -> Procedure[Message]:
        """`ask`'s attempts once its fence and gap are done. `sent` (and `data`, what the first
        read returned, if it ran): the first attempt's discard and write were already carried out
        (the sync fast path, drivers/fastpath.py, hands a request over here when its answer is not
        the plain one), so it goes on from there."""
        frame, cls, answer_len = plan
        rid = request.id
        failure: Exception | None = None
        first_sent: float | None = None
        stats = self.stats
        for attempt in range(1, attempts + 1):
            if attempt > 1:
                stats.retries += 1
                yield Wait(self.retry_pause)
            if sent is None:
                if self._waits_pending:
                    yield from self._wait_until_free([rid])
                held = yield DISCARD  # _discard, inline: the usual discard finds nothing
                if held:
                    yield from self._discarded(held)
                sent = yield Send(frame)
            first_sent = sent.started if first_sent is None else first_sent
            stats.requests += 1
            until = sent.finished + deadline
            sent = None
            self._owe(rid, cls, until + self.late_answer)
            parser = StreamParser(line=request.LINE)  # the answer in the request's product line
            others: list[Message] = []
            while True:
                if data is None:
                    data = yield Receive(max(1, answer_len - parser.pending), until)
                    if data:
                        self._now = yield NOW
                frames = parser.feed(data) if data else parser.finish()
                for message in frames:
                    if type(message) is cls and message.id == rid:
                        # the earliest attempt's answer, or a later one's: what is still owed stays owed
                        self._take(message)
                        self.stats.answers += 1
                        self.stats.dropped_bytes += parser.stats.dropped_bytes
                        return message
                    if type(message) is type(request) and message.id == rid:
                        self.stats.echo_frames += 1
                    elif not self._settle_frame(message):
                        others.append(message)
                if not data:
                    break
                data = None
            data = None
            self.stats.dropped_bytes += parser.stats.dropped_bytes
            failure = self._failure(request, attempt, parser, others, first_sent)
        self.stats.no_answer += 1
        assert failure is not None
        raise failure

    def _plan(self, request: Request) -> tuple[bytes, type[Message], int]:
        """A request's frame, answer class and answer length (kept for the next time it is asked)."""
        cls = answer_class(type(request))
        plan = (request.encode(), cls, cls.SPEC.size + 4)
        if len(self._plans) >= PLANS:
            self._plans.clear()
        self._plans[request] = plan
        return plan

    def _failure(
        self, request: Request, attempts: int, parser: StreamParser, others: list[Message], sent_at: float
    ) -> Exception:
        name, rid, baud = request.name, request.id, self.baudrate
        if others:
            seen = ", ".join(f"{m.name} from ID {m.id}" for m in others[:3])
            return UnexpectedAnswer(
                f"asked ID {rid} for {name} at {baud} bps but got {seen}: another controller or program "
                "is talking on the bus, or two controllers share an ID"
            )
        s = parser.stats
        if s.dropped_bytes:
            detail = f"{s.dropped_bytes} bytes without a valid frame"
            if s.bad_checksum:
                detail += f", {s.bad_checksum} bad checksum{'s' if s.bad_checksum > 1 else ''}"
            return CorruptedAnswer(name, rid, baud, attempts, detail)
        if self._recently_busy(rid, sent_at):
            return ControllerBusy(name, rid, baud, attempts, self.window(rid))
        return NoAnswer(name, rid, baud, attempts)

    def in_its_line(self, message: Message) -> None:
        """WrongLineError if the message is of another product line than its ID's known product and
        its bytes mean something else there (docs/protocol.md, Product lines). A frame that is the
        same message in both lines (a ping, the shared motion codes) goes through."""
        product = self.products.get(message.id)
        if product is not None:
            target = product_line(product)
            if not target.means_the_same(message):
                target.check(message)

    def tell(self, *commands: Command) -> Procedure[None]:
        """Send commands back to back in one write, once every addressed ID's busy window has
        ended. Never repeated: commands get no answer, so a repeat could not be told from the
        first (and a relative move would move twice)."""
        if not commands:
            return
        for command in commands:
            self.in_its_line(command)
        yield from self._wait_until_free({c.id for c in commands})
        data = b"".join(c.encode() for c in commands)
        sent: Sent = yield Send(data)
        for command in commands:  # what a motor was told since a reading (nurimc.procedures.multiturn's rest rule)
            self.commands_sent[command.id] = self.commands_sent.get(command.id, 0) + 1
        self._mark_busy(commands, sent, len(data))

    def broadcast_ask(
        self,
        request_cls: type[Request],
        window: float,
        expect: int | None = None,
        ids: Sequence[int] | None = None,
        ordered: bool = False,
        start_within: float | None = None,
    ) -> Procedure[tuple[list[Message], int]]:
        """Send a request to ID 0xFF and collect every answer within `window` seconds
        (or until `expect` answers from distinct IDs, or one from each of `ids`, have come).

        Outside the document's §17 (which gives requests IDs 0-254 only), but controllers answer
        it each after its own response time: answers collide unless those are staggered.
        With `ids`, only their answers count and each missing one is left owed, for a
        follow-up ask(..., own_pending=True). `ordered`: the IDs answer in the order given
        (staggered response times), so once the last one has answered, an earlier one that has
        not is late and the window need not run out. Returns (answers, bytes that formed no frame).
        """
        cls = answer_class(request_cls)
        wanted: set[int] | None = None
        if ids is not None:
            self.forget_expired((yield NOW))
            # an ID that may still send a late answer of this class cannot be told from its fresh
            # one here: its answer only settles what it owes, and it is asked again on its own
            wanted = {i for i in ids if not self.owes(i, cls)}
            expect = len(set(ids))
        yield from self._duplicate_gap(self._last_seen if ids is None else ids, cls)
        yield from self._wait_until_free([BROADCAST_ID])
        yield from self._discard()
        sent: Sent = yield Send(build_frame(BROADCAST_ID, request_cls.SPEC.mode, b""))
        if ids is not None:
            for device_id in set(ids):
                self._owe(device_id, cls, sent.finished + window + self.late_answer)
        parser, answers, heard, settled = StreamParser(line=request_cls.LINE), list[Message](), set[int](), set[int]()
        self.broadcast_span = None
        until = sent.finished + (window if start_within is None else min(window, start_within))
        while True:
            data = yield Receive(cls.SPEC.size + 4, until)
            if data:
                self._now = yield NOW
                self.broadcast_span = self._now - sent.started  # from before the write: never short
                until = sent.finished + window
            for message in parser.feed(data) if data else parser.finish():
                if type(message) is cls and (wanted is None or message.id in wanted) and message.id not in heard:
                    self._take(message)
                    answers.append(message)
                    heard.add(message.id)
                elif not isinstance(message, Request) and self._settle_frame(message) and message.id in (ids or ()):
                    settled.add(message.id)
            if not data or (expect is not None and len(heard | settled) >= expect):
                break
            if ordered and ids and ids[-1] in heard | settled:
                break  # the last to answer has: any missing answer is late (left owed)
        self.stats.dropped_bytes += parser.stats.dropped_bytes
        return answers, parser.stats.dropped_bytes

    def probe(self, request: Request, start_within: float) -> Procedure[tuple[list[Message], bool]]:
        """Send `request` and listen only until an answer would have begun (`start_within`
        seconds after the write returned), or, once bytes have begun, until a whole answer could
        have come. For walking IDs at the wire's pace (discovery). Returns every answer of the
        request's class heard, from any ID (a late answer to an earlier probe names its ID), and
        whether bytes came that formed no frame (answers on top of each other)."""
        cls = answer_class(type(request))
        size = cls.SPEC.size + 4
        char = self.timing.wire_time(1, self.baudrate)
        parser, got = StreamParser(), list[Message]()
        held = yield DISCARD  # what came since the last probe: late answers still count
        if held:
            early = StreamParser()
            for message in [*early.feed(held), *early.finish()]:
                if type(message) is cls:
                    self._resolve(message)
                    got.append(message)
        sent: Sent = yield Send(request.encode())
        self.stats.requests += 1
        until = sent.finished + start_within
        self._owe(request.id, cls, until + self.timing.wire_time(size, self.baudrate) + self.late_answer)
        began = False
        while True:
            data = yield Receive(max(1, size - parser.pending), until)
            if data and not began:
                began = True
                self._now = yield NOW
                until = max(until, self._now + (size + 1) * char + self.timing.latency)
            for message in parser.feed(data) if data else parser.finish():
                if type(message) is cls:
                    self._resolve(message)
                    got.append(message)
                elif isinstance(message, Request):
                    self.stats.echo_frames += 1
                else:
                    self._settle_frame(message)
            if not data or any(m.id == request.id for m in got):
                break
        self.stats.dropped_bytes += parser.stats.dropped_bytes
        return got, parser.stats.dropped_bytes > 0

    def return_to_baud(self, rate: int, failure: BaseException) -> Procedure[None]:
        """Cleanup after `failure` (docs/drivers.md): switch back to `rate`. If the port fails that
        too (gone for good), the first failure stays the one reported, with a note saying so."""
        try:
            yield from self.set_baud(rate)
        except Exception as also:
            failure.add_note(f"nurimc: could not return the host to {rate} bps: {also}")

    def check_rate(self, rate: int, consequence: str = "") -> Procedure[None]:
        """Raise RateRefused (with `consequence` added) if the port cannot run at `rate`: the
        host switches to it and back, nothing is sent (docs/library.md, refused rates)."""
        if rate == self.baudrate:
            return
        old = self.baudrate
        try:
            yield from self.set_baud(rate)
        except RateRefused as refused:
            raise RateRefused(f"{refused}; {consequence}" if consequence else str(refused)) from refused
        yield from self.set_baud(old)

    def set_baud(self, rate: int) -> Procedure[None]:
        """Switch the host's rate. Answers still owed at the old rate are forgotten: at another
        rate they can only arrive as broken bytes, never as a frame to be taken for fresh."""
        refused = False
        try:
            yield SetHostBaud(rate)
        except RateRefused:  # the port kept its rate (the transport put it back): so does the bus
            refused = True
            raise
        finally:  # a port that failed otherwise has still taken the rate as its setting (pyserial)
            if not refused:
                if rate != self.baudrate:
                    self._owed.clear()
                    self._last_seen.clear()
                self.baudrate = rate
