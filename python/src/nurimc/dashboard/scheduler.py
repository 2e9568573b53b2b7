"""The console's job queue: which page's command goes to the bus next (no bus, no I/O).

Each page (websocket connection) has its own queue, at most MAX_PENDING long; the bus thread
takes one job from each page in turn, so a page that floods the console waits behind itself,
not in front of the others. The emergency stop is not queued behind anything: submitting it
bumps the generation, answers every queued command of every page with "cancelled" without
touching the bus, and it is the next job taken. A command that names an older generation (a
page that had not yet heard of the stop) is refused, so nothing from before the stop can move
a motor after it.
"""

from __future__ import annotations

import threading
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from . import commands as c

MAX_PENDING = 256  # commands one page may have waiting for the bus; more get "busy, try again"
CANCELLED = "cancelled by the emergency stop (it was sent before the stop; nothing was done)"

Done = Callable[[Any, str | None], None]  # (result, error message)


@dataclass
class Job:
    command: c.Command
    done: Done
    owner: object  # the page (connection) that sent it
    generation: int
    extra: list[Done] = field(default_factory=list)  # further pages waiting on the same emergency stop

    def finish(self, result: Any, error: str | None) -> None:
        for done in (self.done, *self.extra):
            done(result, error)


class Scheduler:
    """Per-page queues served round robin, the emergency stop first. Thread-safe; `cond` is the
    one condition the bus thread sleeps on (new jobs and other wake-ups notify it)."""

    def __init__(self, max_pending: int = MAX_PENDING) -> None:
        self.max_pending = max_pending
        self.cond = threading.Condition()
        self.generation = 0  # bumped by every emergency stop
        self._queues: OrderedDict[object, deque[Job]] = OrderedDict()  # in turn order
        self._stop: Job | None = None
        self._cancelled: list[Job] = []  # answered "cancelled" once the stop has gone out
        #: set while an emergency stop waits or runs: long jobs check it to end early
        self.stop_requested = threading.Event()

    def __bool__(self) -> bool:
        return self._stop is not None or bool(self._queues)

    def pending(self, owner: object) -> int:
        with self.cond:
            return len(self._queues.get(owner, ()))

    def submit(
        self,
        command: c.Command,
        done: Done,
        owner: object = None,
        generation: int | None = None,
        received: Callable[[int], None] | None = None,
    ) -> None:
        """Queue a command; `done` is always called exactly once, from any thread. For an
        emergency stop, `received(new generation)` is called at once; the commands it cancels
        are answered by the bus thread once the stop has gone out (finish_cancelled), so
        thousands of replies delay neither the receipt nor the stop."""
        refusal: str | None = None
        stop_generation = 0
        with self.cond:
            if isinstance(command, c.EmergencyStop):
                self.stop_requested.set()
                self.generation += 1
                for queue in self._queues.values():
                    self._cancelled.extend(queue)
                self._queues.clear()
                if self._stop is not None:  # one stop already waiting: this page waits on it too
                    self._stop.extra.append(done)
                else:
                    self._stop = Job(command, done, owner, self.generation)
                self.cond.notify_all()
                stop_generation = self.generation
            elif generation is not None and generation < self.generation:
                refusal = f"refused: sent before emergency stop #{self.generation}; press the button again"
            elif len(self._queues.get(owner, ())) >= self.max_pending:
                refusal = f"busy: {self.max_pending} commands from this page are waiting for the bus; try again shortly"
            else:
                self._queues.setdefault(owner, deque()).append(Job(command, done, owner, self.generation))
                self.cond.notify_all()
        if received is not None and isinstance(command, c.EmergencyStop):
            received(stop_generation)
        if refusal is not None:
            done(None, refusal)

    def finish_cancelled(self) -> None:
        """Answer "cancelled" to every command an emergency stop dropped (after the stop ran)."""
        with self.cond:
            cancelled, self._cancelled = self._cancelled, []
        for job in cancelled:
            job.finish(None, CANCELLED)

    def take(self) -> Job | None:
        """The next job (the stop first, then one page after another), or None. Call with `cond` held."""
        if self._stop is not None:
            job, self._stop = self._stop, None
            return job
        if not self._queues:
            return None
        owner, queue = next(iter(self._queues.items()))
        job = queue.popleft()
        del self._queues[owner]
        if queue:  # its turn again after every other page's
            self._queues[owner] = queue
        return job

    def forget(self, owner: object) -> None:
        """A page went away: its queued commands are dropped, not carried out for no one."""
        with self.cond:
            gone = list(self._queues.pop(owner, ()))
        for job in gone:
            job.finish(None, "dropped: the page closed")
