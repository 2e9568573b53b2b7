"""RFC 2217 (Telnet COM-PORT-OPTION) for the simulator's TCP server, sans-I/O.

A TCP client that starts with a Telnet negotiation (IAC WILL/DO/WONT/SB ...) is an RFC 2217
client (pyserial's ``rfc2217://``): it sets its serial rate with SET-BAUDRATE, and its data has
every 0xFF byte doubled, both ways. A client whose first bytes are anything else (a frame's
FF FE header included: IAC DONT is an answer, never how a Telnet client starts) talks raw bytes
at the server's rate (``socket://``). `detect` tells the two apart; `Rfc2217Session` reads a
client's bytes into data and commands, answers the commands, and escapes the data sent back.

What the simulator models: a link rate (any rate; the controllers at other rates hear noise),
8 data bits, no parity, 1 stop bit, no flow control. A request for anything else is answered
with what the link really is (the client sees its request refused); DTR, RTS and BREAK are kept
and echoed (they change nothing on an RS485 bus).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

# Telnet (RFC 854, 855) and its options
IAC = 255
DONT = 254
DO = 253
WONT = 252
WILL = 251
SB = 250
SE = 240
BINARY = 0  # RFC 856
ECHO = 1
SGA = 3  # suppress go-ahead
COM_PORT_OPTION = 44  # RFC 2217

# RFC 2217 commands, client to server (the server's answer is the same number + 100)
SIGNATURE = 0
SET_BAUDRATE = 1
SET_DATASIZE = 2
SET_PARITY = 3
SET_STOPSIZE = 4
SET_CONTROL = 5
NOTIFY_LINESTATE = 6
NOTIFY_MODEMSTATE = 7
FLOWCONTROL_SUSPEND = 8
FLOWCONTROL_RESUME = 9
SET_LINESTATE_MASK = 10
SET_MODEMSTATE_MASK = 11
PURGE_DATA = 12
SERVER_OFFSET = 100

DATASIZE_8 = 8
PARITY_NONE = 1
STOPSIZE_1 = 1
PURGE_RECEIVE = 1  # the server's buffer of data received from the serial line (to the client)
PURGE_TRANSMIT = 2
PURGE_BOTH = 3
#: modem state: CTS and DSR up (a powered adapter)
MODEMSTATE = 0x10 | 0x20
SIGNATURE_TEXT = b"nurimc simulator"

#: longest subnegotiation kept (RFC 2217's are a few bytes; a client that never ends one costs no memory)
MAX_SUBNEGOTIATION = 256
#: the options this server agrees to, on its side (WILL) and on the client's (DO)
ACCEPTED = frozenset({BINARY, SGA, COM_PORT_OPTION})
#: the second byte that makes a first IAC the start of Telnet (a frame starts FF FE: IAC DONT)
TELNET_STARTS = frozenset({WILL, DO, WONT, SB})


def detect(first: bytes) -> bool | None:
    """True: a Telnet (RFC 2217) client; False: raw bytes; None: too few bytes to tell yet."""
    if not first:
        return None
    if first[0] != IAC:
        return False
    if len(first) < 2:
        return None
    return first[1] in TELNET_STARTS


def escape(data: bytes) -> bytes:
    """Data for the client: every 0xFF doubled."""
    return data.replace(b"\xff", b"\xff\xff")


def _sub(command: int, value: bytes) -> bytes:
    """An RFC 2217 subnegotiation from the server (its IAC bytes doubled)."""
    return bytes((IAC, SB, COM_PORT_OPTION, command + SERVER_OFFSET)) + escape(value) + bytes((IAC, SE))


@dataclass
class ControlState:
    """DTR, RTS and BREAK as the client last set them (RS485 has none: kept and echoed)."""

    dtr: bool = True
    rts: bool = True
    brk: bool = False


class Rfc2217Session:
    """One RFC 2217 client. `feed(bytes)` returns the bytes for the bus in the order they came,
    with the commands between them applied at their place: a SET-BAUDRATE between two frames
    changes the rate of the second only. Answers go to `reply` (already Telnet-encoded).

    `get_baud`/`set_baud` read and set the link's rate; `purge` empties what waits for the client.
    """

    def __init__(
        self,
        get_baud: Callable[[], int],
        set_baud: Callable[[int], None],
        write: Callable[[bytes], None],
        reply: Callable[[bytes], None],
        purge: Callable[[], None],
    ) -> None:
        self._get_baud = get_baud
        self._set_baud = set_baud
        self._write = write
        self._reply = reply
        self._purge = purge
        self.we: set[int] = set()  # options enabled on our side
        self.they: set[int] = set()  # options enabled on the client's side
        self.control = ControlState()
        self.suspended = False  # the client asked us to hold the data for it (FLOWCONTROL-SUSPEND)
        self.signature = b""  # the client's, if it sent one
        self._state = "data"  # data, iac, option (after WILL..DONT), sub, sub-iac
        self._verb = 0
        self._data = bytearray()
        self._sub = bytearray()
        self._overlong = False

    def feed(self, chunk: bytes) -> None:
        for byte in chunk:
            state = self._state
            if state == "data":
                if byte == IAC:
                    self._state = "iac"
                else:
                    self._data.append(byte)
            elif state == "iac":
                if byte == IAC:
                    self._data.append(IAC)
                    self._state = "data"
                elif byte in (WILL, WONT, DO, DONT):
                    self._verb = byte
                    self._state = "option"
                elif byte == SB:
                    self._sub.clear()
                    self._overlong = False
                    self._state = "sub"
                else:  # NOP, GA, AYT, ... and a stray SE: nothing to do on a serial link
                    self._state = "data"
            elif state == "option":
                self._negotiate(self._verb, byte)
                self._state = "data"
            elif state == "sub":
                if byte == IAC:
                    self._state = "sub-iac"
                else:
                    self._sub_byte(byte)
            else:  # sub-iac
                if byte == IAC:
                    self._sub_byte(IAC)
                    self._state = "sub"
                elif byte == SE:
                    self._state = "data"
                    if not self._overlong:  # an overlong one is dropped whole, never read cut short
                        self._subnegotiation(bytes(self._sub))
                else:  # a broken subnegotiation: drop it, read on as data
                    self._state = "data"
        self._flush_data()

    def _sub_byte(self, byte: int) -> None:
        if len(self._sub) < MAX_SUBNEGOTIATION:
            self._sub.append(byte)
        else:
            self._overlong = True

    def _flush_data(self) -> None:
        if self._data:
            data = bytes(self._data)
            self._data.clear()
            self._write(data)

    def _negotiate(self, verb: int, option: int) -> None:
        if verb in (WILL, WONT):  # about the client's side: we answer DO / DONT
            mine, yes, no = self.they, DO, DONT
        else:  # DO / DONT: about our side: we answer WILL / WONT
            mine, yes, no = self.we, WILL, WONT
        if verb in (WILL, DO):
            if option not in ACCEPTED:
                self._reply(bytes((IAC, no, option)))
            elif option not in mine:  # answer a change only, so two sides never loop
                mine.add(option)
                self._reply(bytes((IAC, yes, option)))
        elif option in mine:
            mine.discard(option)
            self._reply(bytes((IAC, no, option)))

    def _subnegotiation(self, sub: bytes) -> None:
        if len(sub) < 2 or sub[0] != COM_PORT_OPTION:
            return  # another option's subnegotiation: not ours
        self._flush_data()  # the data before the command goes out at the old settings
        command, value = sub[1], sub[2:]
        if command == SIGNATURE:
            if value:
                self.signature = value
            else:
                self._reply(_sub(SIGNATURE, SIGNATURE_TEXT))
        elif command == SET_BAUDRATE:
            if len(value) >= 4:
                rate = struct.unpack("!I", value[:4])[0]
                if rate:  # 0 asks for the rate
                    self._set_baud(rate)
            self._reply(_sub(SET_BAUDRATE, struct.pack("!I", self._get_baud())))
        elif command == SET_DATASIZE:
            self._reply(_sub(SET_DATASIZE, bytes((DATASIZE_8,))))
        elif command == SET_PARITY:
            self._reply(_sub(SET_PARITY, bytes((PARITY_NONE,))))
        elif command == SET_STOPSIZE:
            self._reply(_sub(SET_STOPSIZE, bytes((STOPSIZE_1,))))
        elif command == SET_CONTROL:
            self._reply(_sub(SET_CONTROL, bytes((self._control(value[0] if value else 0),))))
        elif command == NOTIFY_MODEMSTATE:  # a poll
            self._reply(_sub(NOTIFY_MODEMSTATE, bytes((MODEMSTATE,))))
        elif command == NOTIFY_LINESTATE:
            self._reply(_sub(NOTIFY_LINESTATE, b"\x00"))
        elif command == FLOWCONTROL_SUSPEND:
            self.suspended = True
        elif command == FLOWCONTROL_RESUME:
            self.suspended = False
        elif command in (SET_LINESTATE_MASK, SET_MODEMSTATE_MASK):
            self._reply(_sub(command, value[:1] or b"\x00"))
        elif command == PURGE_DATA:
            kind = value[0] if value else PURGE_BOTH
            if kind in (PURGE_RECEIVE, PURGE_BOTH):
                self._purge()
            self._reply(_sub(PURGE_DATA, bytes((kind,))))

    def _control(self, value: int) -> int:
        """SET-CONTROL: the state after the request, as RFC 2217 numbers it."""
        state = self.control
        if value in (5, 6):
            state.brk = value == 5
        elif value in (8, 9):
            state.dtr = value == 8
        elif value in (11, 12):
            state.rts = value == 11
        if value in (4, 5, 6):
            return 5 if state.brk else 6
        if value in (7, 8, 9):
            return 8 if state.dtr else 9
        if value in (10, 11, 12):
            return 11 if state.rts else 12
        if 13 <= value <= 19:
            return 14  # inbound flow control: none
        return 1  # outbound flow control (0..3 and anything else): none
