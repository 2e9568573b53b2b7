"""What both buses build from their keyword options: the core and the byte listeners."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..core.buscore import BusCore
from ..core.timing import Timing
from ..transport import Transport
from ..transport.trafficlog import FrameRecorder, TrafficLog


class Listeners:
    """The bus's listeners (python-can style): every byte sent and received goes to each."""

    def __init__(self, log_path: str | None, tracer: FrameRecorder | None, more: Sequence[FrameRecorder]) -> None:
        self.items: list[FrameRecorder] = list(more)
        if tracer is not None:
            self.items.append(tracer)
        if log_path:
            self.items.append(TrafficLog(log_path))

    def close(self) -> None:
        for listener in self.items:
            listener.close()


def make_core(transport: Transport, retries: int, timing: Timing | None, options: dict[str, Any]) -> BusCore:
    """The BusCore both buses build from their keyword options (see Bus)."""
    core = BusCore(baudrate=transport.baudrate, retries=retries, timing=timing or Timing(latency=transport.latency))
    if "busy_window" in options:
        core.busy_window = options.pop("busy_window")
    core.busy_windows.update(options.pop("busy_windows", None) or {})
    if "late_answer" in options:
        core.late_answer = options.pop("late_answer")
    if "retry_pause" in options:
        core.retry_pause = options.pop("retry_pause")
    if options:
        raise TypeError(f"unknown bus option(s): {', '.join(sorted(options))}")
    return core
