"""Errors of nurimc. Each message says what went wrong and what to do next.

One root: every error nurimc raises on purpose is a `NurimcError` (defined in
nurimc.protocol.errors so that the protocol package stands alone, and re-exported here);
`ProtocolError` (bytes and wire values) and `InputError` (a value from a person, file or the
network; also a ValueError) are its two branches a caller may want apart (docs/library.md, Errors).
"""

from __future__ import annotations

from .protocol.errors import FieldRangeError, NurimcError, ProtocolError

__all__ = [
    "CallTimeout",
    "UnknownSetting",
    "UsageError",
    "ValueOutOfRange",
    "ConfirmationRequired",
    "CorruptedAnswer",
    "ControllerBusy",
    "IdInUse",
    "InputError",
    "NoAnswer",
    "NotArrived",
    "NurimcError",
    "PortError",
    "ProtocolError",
    "SettingNotApplied",
    "UnexpectedAnswer",
    "UnconfirmedRead",
]


class InputError(NurimcError, ValueError):
    """A value given by a person, a file or the network is not acceptable. The message names the
    input, what was given, and the allowed range with its unit."""


class ValueOutOfRange(InputError, FieldRangeError):
    """A motor or setting value outside what the controller accepts; names the value, its range
    and unit. Both an InputError (NurimcError) and the protocol layer's FieldRangeError."""


class UnknownSetting(InputError, KeyError):
    """A setting name that does not exist; the message lists the settings."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class UsageError(NurimcError, RuntimeError):
    """The library was used in an order it does not support (the message says what to call first)."""


class CallTimeout(NurimcError, TimeoutError):
    """A whole bus call took longer than the timeout it was given and was abandoned (after its
    cleanup ran: docs/drivers.md)."""


class PortError(NurimcError):
    """The serial port could not be opened or used. The message includes the fix."""


class RateRefused(PortError):
    """The port's adapter or driver cannot be set to a rate (termios EINVAL and the like); the
    port keeps the rate it had. Discovery skips such a rate with a note; a controller's rate
    is never changed to one (docs/library.md)."""


class FixedRate(RateRefused):
    """The link runs at one rate whatever the host asks (a `socket://` TCP gateway: its serial
    rate is set on the gateway). Discovery searches once, at `rate` (docs/library.md)."""

    def __init__(self, message: str, rate: int) -> None:
        super().__init__(message)
        self.rate = rate


NO_ANSWER_CAUSES = (
    "the controller is at another baud rate (try `nurimc scan`)",
    "no controller has this ID",
    "A/B wires swapped or loose, or no common ground",
    "missing 120 ohm termination on a long bus",
    "the controller is unpowered or busy writing its settings",
)


class NoAnswer(NurimcError):
    """Nothing valid came back in time."""

    def __init__(self, request: str, device_id: int, baud: int, attempts: int, detail: str = "") -> None:
        causes = "; ".join(NO_ANSWER_CAUSES)
        extra = f" ({detail})" if detail else ""
        super().__init__(
            f"no answer from ID {device_id} to {request} at {baud} bps after {attempts} "
            f"attempt{'s' if attempts != 1 else ''}{extra}. Likely causes: {causes}"
        )
        self.request, self.device_id, self.baud, self.attempts = request, device_id, baud, attempts


class ControllerBusy(NoAnswer):
    """No answer just after the controller's EEPROM busy window: it is still writing its settings."""

    def __init__(self, request: str, device_id: int, baud: int, attempts: int, window: float) -> None:
        super().__init__(request, device_id, baud, attempts)
        self.window = window
        self.args = (
            f"no answer from ID {device_id} to {request} at {baud} bps right after a settings write: "
            f"it is busy writing its settings (EEPROM) longer than its {window * 1000:g} ms busy window; "
            f"give it a longer one (Bus(..., busy_windows={{{device_id}: seconds}})) and try again",
        )


class CorruptedAnswer(NoAnswer):
    """Bytes came back but no valid frame (bad checksum, noise, colliding answers)."""

    def __init__(self, request: str, device_id: int, baud: int, attempts: int, detail: str) -> None:
        super().__init__(request, device_id, baud, attempts, detail)
        self.args = (
            f"corrupted answer from ID {device_id} to {request} at {baud} bps ({detail}). "
            "Likely causes: noise on the line (termination, grounding, cable), two controllers "
            "with the same ID, or a wrong baud rate",
        )


class UnexpectedAnswer(NurimcError):
    """A valid frame came back that does not answer the request."""


class SettingNotApplied(NurimcError):
    """A setting read back differs from what was written: the change did not take."""


class UnconfirmedRead(NurimcError):
    """Reads that a write was to be built from did not agree (noise that passed the checksum):
    nothing was written."""


class IdInUse(NurimcError):
    """The requested new ID already answers on the bus."""


class ConfirmationRequired(NurimcError):
    """A destructive operation was asked for without explicit confirmation."""


class PortLost(PortError):
    """The port went away (adapter unplugged or reset, EIO, broken pipe) and is being reopened in
    the background (Bus.open(..., reconnect=True)); the call was not carried out. Calls fail with
    this at once until the port is back (docs/library.md, "Reconnect")."""


class NotArrived(NurimcError, TimeoutError):
    """A motion did not come to rest (at its target) within the time given: wait_until_arrived()
    or stop(). The message says where the motor is and what to try."""
