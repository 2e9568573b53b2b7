"""A program's readings from the bus service's poll schedule, taken in rounds (docs/service.md).

`record` (and any loop that used to read the bus itself) subscribes here instead: the service
reads each motor once per due time for every subscriber, and the program takes what came.
"""

from __future__ import annotations

import threading
import time

from ..errors import NurimcError
from ..procedures.motor import MotorState
from .core import BusService, ClientInfo, Sample, Subscription

#: the subscription rate of "as fast as the bus allows" (--rate 0): every motor read again at once
AS_FAST = 1000.0


class ServiceReadings:
    """Readings of `ids` at `rate_hz` (0: as fast as the bus allows) from `service`'s polls.

    `take(timeout)` hands the readings that came since the last take, waiting until every motor
    has a new one (one round) or `timeout` (real seconds; with a service stepped on virtual time
    give 0 and step the service first). A failed read is the error, as `group.read_states` gives."""

    def __init__(self, service: BusService, ids: list[int], rate_hz: float, client: ClientInfo | None = None) -> None:
        self.service = service
        self._cond = threading.Condition()
        self._latest: dict[int, MotorState | NurimcError] = {}
        self._new: dict[int, MotorState | NurimcError] = {}
        self.count = len(set(ids))
        rate = rate_hz if rate_hz > 0 else AS_FAST
        self.subscription: Subscription = service.subscribe(ids, rate, self._sample, client=client)

    def _sample(self, sample: Sample) -> None:
        value: MotorState | NurimcError = (
            sample.state if sample.state is not None else NurimcError(sample.error or f"ID {sample.id} did not answer")
        )
        with self._cond:
            self._latest[sample.id] = value
            self._new[sample.id] = value
            self._cond.notify_all()

    def latest(self) -> dict[int, MotorState | NurimcError]:
        """The last reading of each motor (or why it failed)."""
        with self._cond:
            return dict(self._latest)

    def take(self, timeout: float) -> dict[int, MotorState | NurimcError]:
        end = time.monotonic() + timeout
        with self._cond:
            while len(self._new) < self.count:
                left = end - time.monotonic()
                if left <= 0:
                    break
                self._cond.wait(left)
            new, self._new = self._new, {}
        return new

    def close(self) -> None:
        self.subscription.cancel()
