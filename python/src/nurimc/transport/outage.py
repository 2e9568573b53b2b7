"""What a long-running tool does about a lost port, in one place (docs/library.md, "Reconnect").

`watch`, `sniff`, `record`, `nurimc ros2` and the console open their bus with reconnect=True
and hold an OutageGuard:

- the loss and the return are said in one line each (`say`);
- while the port is down nothing is queued for later: each call fails at once (PortLost) and
  is dropped, so no stale motion command is ever replayed;
- a stop that could not be sent (a command-timeout hold, an estop) is registered as the first
  frame on the port's return: control off (SetControl 1) to that motor, which stops driving it
  at once whatever it was doing. It is left released (control off), not held: a hold turns
  control on first, an EEPROM write that keeps the controller deaf for up to 300 ms;
- `returned()` is True once after each return: the tool re-reads every motor's state before
  it sends anything else;
- a tool ending while the port is down says which motors it could not stop.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable

from ..errors import PortLost
from ..protocol import SetControl
from .base import Transport
from .reconnect import PortEvent, ReconnectingTransport, reconnecting


def stderr_line(text: str) -> None:
    """How the command-line tools say a loss or a return: one plain line on stderr."""
    print(text, file=sys.stderr, flush=True)


class OutageGuard:
    #: s between two looks at a lost port by a tool that polls (the reopen itself is the transport's)
    recheck = 0.1

    def __init__(self, transport: Transport, say: Callable[[str], None]) -> None:
        self.transport: ReconnectingTransport | None = reconnecting(transport)
        self.say = say
        self._seen = self.transport.returns if self.transport is not None else 0
        #: motors whose stop waits for the port's return (ID -> why), then to be held
        self.stops_on_return: dict[int, str] = {}
        #: motors a tool ending (or failing) could not stop
        self.not_stopped: set[int] = set()
        if self.transport is not None:
            self.transport.watch(self._event)

    def _event(self, event: PortEvent) -> None:
        self.say(event.text)

    @property
    def down(self) -> bool:
        return self.transport is not None and not self.transport.up

    def returned(self) -> bool:
        """True once after each return of the port (then re-read every motor before sending)."""
        if self.transport is None or not self.transport.up or self.transport.returns == self._seen:
            return False
        self._seen = self.transport.returns
        return True

    def wait_up(self, timeout: float) -> bool:
        return self.transport is None or self.transport.wait_up(timeout)

    def stop_failed(self, ids: Iterable[int], error: Exception, ending: bool) -> None:
        """A stop of these motors could not be sent. While the tool goes on and the port is lost,
        control off becomes the first frame on its return; ending, say the motors were not stopped."""
        ids = sorted(set(ids))
        text = ", ".join(map(str, ids))
        if ending or not isinstance(error, PortLost) or self.transport is None:
            self.not_stopped.update(ids)
            self.say(
                f"could not stop ID {text}: {error}. The motors may still be turning: "
                "stop them by other means (cut their power)"
            )
            return
        for device_id in ids:
            self.stops_on_return[device_id] = "stop"
            self.transport.on_return(f"stop {device_id:03d}", SetControl(device_id, 1).encode())
        self.say(f"could not stop ID {text}: the port is lost; control off is sent first when it returns")

    def port_lost_at_exit(self) -> str | None:
        """The line a tool ending while its port is down says (None: the port is up)."""
        if not self.down or self.transport is None:
            return None
        return (
            f"{self.transport.lost_text().split(' and being reopened')[0]} at exit: motors could not be "
            "stopped on the way out; any motor still turning must be stopped by other means (cut its power)"
        )

    def ending(self) -> None:
        """The tool ends: motors whose stop still waits for the port were not stopped; say so."""
        ids = self.take_stops()
        if ids and self.transport is not None:
            for device_id in ids:
                self.transport.on_return(f"stop {device_id:03d}", None)
            self.stop_failed(ids, PortLost(self.transport.lost_text()), ending=True)

    def take_stops(self) -> list[int]:
        """The motors stopped on the return (control off went first), and forget them."""
        ids = sorted(self.stops_on_return)
        self.stops_on_return.clear()
        return ids

    def close(self) -> None:
        if self.transport is not None:
            self.transport.unwatch(self._event)
