"""decode, encode, sniff, replay: frames by hand and on the wire."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import typer

from ..budgets import READ_LIMITS_HELP
from ..errors import InputError, PortLost
from ..inputs import UNIT_SHOWN, field_value, integer, with_unit
from ..protocol import (
    ALL_LINES,
    SPECS,
    DecodeError,
    FieldSpec,
    Line,
    Message,
    StreamParser,
    UnknownLineError,
    build_frame,
    line,
    wire_bytes,
)
from ..transport.outage import OutageGuard
from ..transport.trafficlog import read_traffic_log
from .common import EXIT_USAGE, STOP, Number, Options, emit, fail, note, open_bus, options, say_line, table
from .common import note as tell

BROADCAST = 0xFF

#: A traffic log line longer than this is not one we wrote (a line holds one read or write).
TO = Number("--to", 0, 255, whole=True)
DURATION = Number("--duration", 0, 86400, "s")


def _describe(message: Message) -> dict[str, Any]:
    return {
        "message": message.name,
        "id": message.id,
        "hex": wire_bytes(message).hex(" "),  # as on the wire: a broadcast request too (docs/protocol.md)
        "fields": message.fields(),
        "physical": message.physical(),
    }


def _shown(value: object, unit: str) -> str:
    return with_unit(value, unit) if isinstance(value, int | float) else str(value)


def _hex_arguments(args: list[str]) -> bytes:
    text = " ".join(args)
    if args == ["-"]:
        text = sys.stdin.read()
    elif len(args) == 1 and Path(args[0]).is_file():
        text = Path(args[0]).read_text()
    cleaned = text.replace("0x", " ").replace(",", " ")
    try:
        return bytes.fromhex(cleaned)
    except ValueError:
        fail("give hex bytes like 'FF FE 00 02 5C A1' (or - for stdin, or a file of hex)")


LINE_HELP = "Product line whose mode table reads the frame: " + ", ".join(ALL_LINES) + " (docs/protocol.md)."


def _line(name: str | None, o: Options | None = None) -> Line:
    """The table frames are read with: the command's --product/--line, else the global
    --product (`nurimc --product rsa decode HEX`), else MC. A product is read with its line's
    table (BLMC-H speaks MC's)."""
    if name is None:
        name = o.product if o is not None and o.product_given else "mc"
    name = LINE_OF_PRODUCT.get(name, name)
    try:
        return line(name)
    except UnknownLineError as error:
        fail(f"--line: {error}")


#: Products whose frames are another product line's (the rest are their own line).
LINE_OF_PRODUCT = {"blmc-h": "mc"}
#: The command's own spelling of the global --product (either name; --line for one release).
LINE_OPTION = ("--product", "--line")


def decode_(
    ctx: typer.Context,
    hex_bytes: list[str] = typer.Argument(..., help="Hex bytes, '-' for stdin, or a file."),
    line_name: str | None = typer.Option(None, *LINE_OPTION, help=LINE_HELP),
) -> None:
    """Decode frames: fields in physical units, or what is wrong.

    Example: nurimc --product rsa decode FF FE 00 07 76 01 00 46 50 03 E8   (an RSA's frame)
    """
    o = options(ctx)
    product_line = _line(line_name, o)
    data = _hex_arguments(hex_bytes)
    try:
        frames, problems = [product_line.decode(data)], []
    except DecodeError as error:
        parser = StreamParser(line=product_line.key)
        frames = parser.feed(data) + parser.finish()
        problems = [f"{error.kind}: {error}"] if not frames else []
        if frames and parser.stats.dropped_bytes:
            problems.append(f"{parser.stats.dropped_bytes} bytes are not part of any valid frame")
    rows = table(None, "message", "ID", "field", "wire", "value")
    if any(m.id == BROADCAST and m.SPEC.max_id != BROADCAST for m in frames):  # docs/protocol.md, Broadcast
        tell("a request to 255 (broadcast): every controller answers it, each after its response time")
    for message in frames:
        physical = message.physical()
        fields: dict[str, int | str] = {**message.fields()} or {"—": ""}
        for i, (name, raw) in enumerate(fields.items()):
            unit = UNIT_SHOWN.get(next((f.unit for f in message.SPEC.fields if f.name == name), ""), "")
            erratum = message.name == "speed_feedback" and name == "position"
            note = " (0.1° units as printed, erratum 6)" if erratum else ""
            rows.add_row(
                message.name if i == 0 else "",
                str(message.id) if i == 0 else "",
                name,
                str(raw),
                f"{_shown(physical.get(name, ''), unit)}{note}".strip(),
            )
    for problem in problems:
        rows.add_row("[red]error[/]", "", "", "", problem)
    emit(o, {"frames": [_describe(m) for m in frames], "errors": problems}, rows)
    if problems and not frames:
        fail(f"no valid frame: {problems[0]}")


def encode(
    ctx: typer.Context,
    message: str = typer.Argument(..., help=f"Message name: {', '.join(SPECS)}."),
    values: list[str] = typer.Argument(
        None,
        help="field=value: a whole number is the wire integer; a decimal (12.5) or a unit (180deg, 100rpm, "
        "2s, 8A) is a physical value, as `set` takes it.",
    ),
    device_id: int = typer.Option(0, "--to", help=f"ID to address ({TO.allowed}; 255 = broadcast).", parser=TO),
    line_name: str | None = typer.Option(None, *LINE_OPTION, help=LINE_HELP),
) -> None:
    """Build a frame with the right checksum.

    Example: nurimc encode position_speed direction=0 position=180deg speed=100rpm --to 0
    """
    o = options(ctx)
    product_line = _line(line_name, o)
    cls = product_line.classes.get(message)
    if cls is None:
        fail(
            f"unknown message {message!r} in the {product_line.title} line; messages: {', '.join(product_line.classes)}"
        )
    spec = cls.SPEC
    fields: dict[str, int] = {}
    for item in values or []:
        name, _, text = item.partition("=")
        field = next((f for f in spec.fields if f.name == name), None)
        if field is None or not text:
            fail(f"{item!r}: give field=value with a field of {message}: {', '.join(spec.field_names) or 'none'}")
        try:
            fields[name] = _wire_value(f"{message}.{name}", field, text)
        except InputError as error:
            fail(str(error))
    built = product_line.make(message, device_id if device_id != BROADCAST or spec.max_id == BROADCAST else 0, **fields)
    if device_id == BROADCAST and spec.max_id != BROADCAST:
        # a request to every controller: outside §17, yet every controller answers it, each after
        # its response time (discovery and the staggered read send it; docs/protocol.md, Broadcast)
        note(f"{message} to 255 (broadcast): every controller answers, each after its response time")
        frame = build_frame(BROADCAST, spec.mode, spec.layout.pack(*built[1:]))
    else:
        frame = built.encode()
    emit(o, {"hex": frame.hex(), "message": message, "id": device_id, "fields": fields}, frame.hex(" ").upper())


def sniff(
    ctx: typer.Context,
    duration: float = typer.Option(
        0, help=f"Stop after this many seconds ({DURATION.allowed}; 0: until Ctrl+C).", parser=DURATION
    ),
    line_name: str | None = typer.Option(None, *LINE_OPTION, help=LINE_HELP),
) -> None:
    """Listen without sending and decode everything on the bus, with timestamps.

    Example: nurimc --port /dev/ttyUSB0 --baud 115200 sniff
    """
    o = options(ctx)
    parser, seen = StreamParser(line=_line(line_name, o).key), []
    start = time.monotonic()
    with open_bus(o, reconnect=True) as bus:
        outage = OutageGuard(bus.transport, say_line)  # lost and back: one line each on stderr
        try:
            while not duration or time.monotonic() - start < duration:
                try:
                    data = bus.transport.read(64, 0.05)
                except PortLost:  # a frame cut in half by the loss is no frame
                    parser = StreamParser()
                    outage.wait_up(0.5)
                    continue
                for m in parser.feed(data) if data else parser.finish():
                    t = time.monotonic() - start
                    seen.append({"t": round(t, 6), **_describe(m)})
                    if not o.json:
                        print(f"{t:10.4f}  id={m.id:<3} {m.name:24s} {m.physical()}", flush=True)
        except STOP:
            pass  # Ctrl+C or SIGTERM: the normal end of listening
        outage.close()
    emit(o, {"frames": seen, "dropped_bytes": parser.stats.dropped_bytes})


def replay(
    ctx: typer.Context,
    log: str = typer.Argument(
        ...,
        help="A traffic log (Bus(log_path=...)), a sigrok capture (.sr), the nurimc sigrok decoder's output, "
        "or an MCAP recording (its summary).",
    ),
    read_limits: str = typer.Option(None, "--read-limits", help=READ_LIMITS_HELP),
) -> None:
    """Decode a traffic log, or a logic-analyzer capture (docs/sigrok.md).

    Example: nurimc replay traffic.log
    """
    from ..budgets import default_budget
    from ..recording.sigrok import read_capture

    o = options(ctx)
    try:
        budget = default_budget().with_text(read_limits or "")
    except ValueError as error:
        fail(str(error), EXIT_USAGE)

    from ..recording.summary import is_mcap

    if is_mcap(log):  # a recording (nurimc record): what it holds (nurimc export for its samples)
        from .recording_cmd import show_summary

        show_summary(o, log)
        return
    rows = table(log, "t (s)", "dir", "frame")
    entries: list[dict[str, Any]] = []
    key = _line(None, o).key  # the global --product: the table the frames are read with
    parsers = {"tx": StreamParser(line=key), "rx": StreamParser(line=key)}
    try:
        capture = read_capture(log, budget=budget)  # None: not a capture, a traffic log
        lines = read_traffic_log(log, budget) if capture is None else capture
    except OSError as error:
        fail(f"{log}: {error.strerror or error}")
    for t, direction, data in lines:
        parser = parsers[direction]
        before = parser.stats.dropped_bytes
        for message in parser.feed(data):
            rows.add_row(str(t), direction, f"{message.name} id={message.id} {message.physical()}")
            entries.append({"t": t, "dir": direction, "message": _describe(message)})
        if parser.stats.dropped_bytes > before:
            noise = f"{parser.stats.dropped_bytes - before} bytes of noise"
            rows.add_row(str(t), direction, f"[red]{noise}[/]")
            entries.append({"t": t, "dir": direction, "error": noise})
    emit(o, entries, rows)


def _wire_value(name: str, field: FieldSpec, text: str) -> int:
    """encode's field=value: a named value, a wire integer, or a physical value with its unit."""
    names = {n: raw for raw, n in field.values}
    if text.strip().lower() in names:
        return names[text.strip().lower()]
    try:
        float(text)
        physical = not text.strip().lstrip("+-").isdigit()  # 12.5 or 1e3: a value, like `set`'s
    except ValueError:  # a unit, or not a number at all
        physical = True
    if physical:
        rounded = field_value(
            text,
            name,
            FieldSpec(field.name, field.width, field.min, field.max, field.unit, field.scale),
            whole=field.scale == 1,  # counts and IDs: no fractions
        )
        assert not isinstance(rounded, str)
        return rounded.wire
    return integer(text, name, field.min, field.max, "(wire units)")


def register(app: typer.Typer) -> None:
    app.command(name="decode")(decode_)
    for command in (encode, sniff, replay):
        app.command()(command)
