"""The bus client's sans-I/O core: request/answer exchanges as procedures.

Both the sync Bus and the AsyncBus hold one BusCore and run its procedures with their own
driver, so the matching, retry and timeout rules exist once.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import CorruptedAnswer, NoAnswer, UnexpectedAnswer
from ..protocol import BROADCAST_ID, Command, Message, Request, StreamParser, answer_class, build_frame
from .actions import Discard, Procedure, Receive, Send, SetBaud, Wait
from .timing import Timing


@dataclass
class BusStats:
    """Counters over the life of a bus: what the wire did to us."""

    requests: int = 0
    answers: int = 0
    retries: int = 0
    no_answer: int = 0
    echo_frames: int = 0  # our own request seen again (adapters that echo)
    stale_frames: int = 0  # valid frames that answer nothing we asked now
    dropped_bytes: int = 0  # noise and broken frames

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


@dataclass
class BusCore:
    baudrate: int = 9600
    timing: Timing = field(default_factory=Timing)
    retries: int = 2  # extra attempts for a request that got no valid answer
    retry_pause: float = 0.005
    #: known response time (seconds) per controller ID; unknown IDs get timing.assumed_response_time
    response_times: dict[int, float] = field(default_factory=dict)
    stats: BusStats = field(default_factory=BusStats)

    def ask(self, request: Request, retries: int | None = None) -> Procedure[Message]:
        """Send a request and return its answer; retried, since reading twice is harmless."""
        attempts = 1 + (self.retries if retries is None else retries)
        cls = answer_class(type(request))
        frame = request.encode()
        answer_len = cls.SPEC.size + 4
        deadline = self.timing.answer_deadline(
            len(frame), answer_len, self.baudrate, self.response_times.get(request.id)
        )
        failure: Exception | None = None
        for attempt in range(1, attempts + 1):
            if attempt > 1:
                self.stats.retries += 1
                yield Wait(self.retry_pause)
            self.stats.dropped_bytes += len((yield Discard()))
            yield Send(frame)
            self.stats.requests += 1
            parser = StreamParser()
            others: list[Message] = []
            while True:
                data = yield Receive(max(1, answer_len - parser.pending), deadline)
                frames = parser.feed(data) if data else parser.finish()
                for message in frames:
                    if type(message) is cls and message.id == request.id:
                        self.stats.answers += 1
                        self.stats.dropped_bytes += parser.stats.dropped_bytes
                        return message
                    if type(message) is type(request) and message.id == request.id:
                        self.stats.echo_frames += 1
                    else:
                        others.append(message)
                if not data:
                    break
            self.stats.dropped_bytes += parser.stats.dropped_bytes
            self.stats.stale_frames += len(others)
            failure = self._failure(request, attempt, parser, others)
        self.stats.no_answer += 1
        assert failure is not None
        raise failure

    def _failure(self, request: Request, attempts: int, parser: StreamParser, others: list[Message]) -> Exception:
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
        return NoAnswer(name, rid, baud, attempts)

    def tell(self, *commands: Command) -> Procedure[None]:
        """Send commands back to back in one write. Never repeated: commands get no answer, so a
        repeat could not be told from the first (and a relative move would move twice)."""
        yield Send(b"".join(c.encode() for c in commands))

    def broadcast_ask(
        self, request_cls: type[Request], window: float, expect: int | None = None
    ) -> Procedure[tuple[list[Message], int]]:
        """Send a request to ID 0xFF and collect every answer within `window` seconds
        (or until `expect` answers from distinct IDs have come).

        Outside the document's §17 (which gives requests IDs 0-254 only), but controllers answer
        it each after its own response time: answers collide unless those are staggered.
        Returns (answers, bytes that formed no frame).
        """
        cls = answer_class(request_cls)
        self.stats.dropped_bytes += len((yield Discard()))
        yield Send(build_frame(BROADCAST_ID, request_cls.SPEC.mode, b""))
        parser, answers = StreamParser(), []
        while True:
            data = yield Receive(cls.SPEC.size + 4, window)
            for message in parser.feed(data) if data else parser.finish():
                if type(message) is cls:
                    answers.append(message)
            if not data or (expect is not None and len({a.id for a in answers}) >= expect):
                return answers, parser.stats.dropped_bytes

    def set_baud(self, rate: int) -> Procedure[None]:
        yield SetBaud(rate)
        self.baudrate = rate
