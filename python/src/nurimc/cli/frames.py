"""decode, encode, sniff, replay: frames by hand and on the wire."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import typer

from ..client.log import replay as replay_log
from ..protocol import SPECS, DecodeError, Message, StreamParser, decode, make, units
from .app import app
from .common import emit, fail, open_bus, options, table


def _describe(message: Message) -> dict[str, Any]:
    return {
        "message": message.name,
        "id": message.id,
        "hex": message.encode().hex(" ") if _valid(message) else "",
        "fields": message.fields(),
        "physical": message.physical(),
    }


def _valid(message: Message) -> bool:
    return all(f.min <= getattr(message, f.name) <= f.max for f in message.SPEC.fields)


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


@app.command(name="decode")
def decode_(
    ctx: typer.Context, hex_bytes: list[str] = typer.Argument(..., help="Hex bytes, '-' for stdin, or a file.")
) -> None:
    """Decode frames: fields in physical units, or what is wrong.

    Example: nurimc decode FF FE 00 07 76 01 00 46 50 03 E8
    """
    o = options(ctx)
    data = _hex_arguments(hex_bytes)
    try:
        frames, problems = [decode(data)], []
    except DecodeError as error:
        parser = StreamParser()
        frames = parser.feed(data) + parser.finish()
        problems = [f"{error.kind}: {error}"] if not frames else []
        if frames and parser.stats.dropped_bytes:
            problems.append(f"{parser.stats.dropped_bytes} bytes are not part of any valid frame")
    rows = table(None, "message", "ID", "field", "wire", "value")
    for message in frames:
        physical = message.physical()
        fields: dict[str, int | str] = {**message.fields()} or {"—": ""}
        for i, (name, raw) in enumerate(fields.items()):
            unit = next((f.unit for f in message.SPEC.fields if f.name == name), "")
            erratum = message.name == "speed_feedback" and name == "position"
            note = " (0.1° units as printed, erratum 6)" if erratum else ""
            rows.add_row(
                message.name if i == 0 else "",
                str(message.id) if i == 0 else "",
                name,
                str(raw),
                f"{physical.get(name, '')} {unit}{note}".strip(),
            )
    for problem in problems:
        rows.add_row("[red]error[/]", "", "", "", problem)
    emit(o, {"frames": [_describe(m) for m in frames], "errors": problems}, rows)
    if problems and not frames:
        raise typer.Exit(2)


@app.command()
def encode(
    ctx: typer.Context,
    message: str = typer.Argument(..., help=f"Message name: {', '.join(SPECS)}."),
    values: list[str] = typer.Argument(
        None, help="field=value: wire integers or with a unit (180deg, 100rpm, 2s, 8A)."
    ),
    device_id: int = typer.Option(0, "--to", help="ID to address (255 = broadcast)."),
) -> None:
    """Build a frame with the right checksum.

    Example: nurimc encode position_speed direction=0 position=180deg speed=100rpm --to 0
    """
    o = options(ctx)
    spec = SPECS.get(message)
    if spec is None:
        fail(f"unknown message {message!r}; messages: {', '.join(SPECS)}")
    fields: dict[str, int] = {}
    for item in values or []:
        name, _, text = item.partition("=")
        field = next((f for f in spec.fields if f.name == name), None)
        if field is None or not text:
            fail(f"{item!r}: give field=value with a field of {message}: {', '.join(spec.field_names) or 'none'}")
        try:
            names = {n: raw for raw, n in field.values}
            fields[name] = (
                names[text]
                if text in names
                else int(text)
                if text.lstrip("-").isdigit()
                else units.to_wire(units.parse_quantity(text, field.unit), field.scale)
            )
        except ValueError:
            fail(f"{item!r}: not a number or a value with a unit")
    frame = make(message, device_id, **fields).encode()
    emit(o, {"hex": frame.hex(), "message": message, "id": device_id, "fields": fields}, frame.hex(" ").upper())


@app.command()
def sniff(
    ctx: typer.Context, duration: float = typer.Option(0, help="Stop after this many seconds (0: Ctrl+C).")
) -> None:
    """Listen without sending and decode everything on the bus, with timestamps.

    Example: nurimc --port /dev/ttyUSB0 --baud 115200 sniff
    """
    o = options(ctx)
    parser, seen = StreamParser(), []
    start = time.monotonic()
    with open_bus(o) as bus:
        try:
            while not duration or time.monotonic() - start < duration:
                data = bus.transport.read(64, 0.05)
                for m in parser.feed(data) if data else parser.finish():
                    t = time.monotonic() - start
                    seen.append({"t": round(t, 6), **_describe(m)})
                    if not o.json:
                        print(f"{t:10.4f}  id={m.id:<3} {m.name:24s} {m.physical()}", flush=True)
        except KeyboardInterrupt:
            pass
    emit(o, {"frames": seen, "dropped_bytes": parser.stats.dropped_bytes})


@app.command()
def replay(ctx: typer.Context, log: str = typer.Argument(..., help="A traffic log (Bus(log_path=...)).")) -> None:
    """Decode a traffic log.

    Example: nurimc replay traffic.log
    """
    o = options(ctx)
    if not Path(log).is_file():
        fail(f"no such log file: {log}")
    rows = table(log, "t (s)", "dir", "frame")
    entries = []
    for entry in replay_log(log):
        message = entry.get("message")
        text = f"{message.name} id={message.id} {message.physical()}" if message else f"[red]{entry['error']}[/]"
        rows.add_row(str(entry.get("t", "")), entry.get("dir", ""), text)
        entries.append({k: (_describe(v) if k == "message" else v) for k, v in entry.items()})
    emit(o, entries, rows)
