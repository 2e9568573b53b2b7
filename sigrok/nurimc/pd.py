# SPDX-License-Identifier: GPL-2.0-or-later
# This file is part of nurimc's sigrok protocol decoder (sigrok/nurimc/COPYING).
#
# This program is free software; you can redistribute it and/or modify it under the terms of
# the GNU General Public License as published by the Free Software Foundation; either version 2
# of the License, or (at your option) any later version.

import json

import sigrokdecode as srd

from .tables import BROADCAST_ID, HEADER, MAX_SIZE, MESSAGES

# Annotation classes, in the order of `annotations` below.
(
    A_HEADER,
    A_ID,
    A_SIZE,
    A_CHECKSUM,
    A_CHECKSUM_BAD,
    A_MODE,
    A_FIELD,
    A_HOST,
    A_CONTROLLER,
    A_GARBAGE,
    A_ERROR,
) = range(11)
B_FRAMES, B_LOG = range(2)
LINE_NAMES = ("RX", "TX")
HOST_KINDS = ("command", "request")


def _decimals(scale):
    """Digits after the point that a field of this step needs: 0.01 -> 2, 0.1 -> 1, 100 -> 0."""
    text = repr(scale)
    return len(text.split(".")[1]) if "." in text and scale < 1 else 0


def physical(field, value):
    """A field's wire value in its unit ("90.00 deg", "cw", "3.0 A")."""
    _name, _width, scale, unit, names = field
    if value in names:
        return names[value]
    text = f"{value * scale:.{_decimals(scale)}f}" if scale != 1 else str(value)
    return text + (" " + unit if unit else "")


class Decoder(srd.Decoder):
    api_version = 3
    id = "nurimc"
    name = "nurimc"
    longname = "Nurirobot MC-RS485"
    desc = "Nurirobot MC / BLMC-H motor controller protocol on RS485."
    license = "gplv2+"
    inputs = ["uart"]  # noqa: RUF012 - libsigrokdecode wants lists
    outputs = ["nurimc"]  # noqa: RUF012
    tags = ["Embedded/industrial"]  # noqa: RUF012
    options = ({"id": "quiet", "desc": "Idle byte times that end a partial frame", "default": 4},)
    annotations = (
        ("header", "Header"),
        ("id", "ID"),
        ("size", "Size"),
        ("checksum", "Checksum good"),
        ("checksum-bad", "Checksum bad"),
        ("mode", "Mode"),
        ("field", "Field"),
        ("host", "Host frame"),
        ("controller", "Controller frame"),
        ("garbage", "Garbage (resync)"),
        ("error", "Rejected frame / UART error"),
    )
    annotation_rows = (
        ("parts", "Parts", (A_HEADER, A_ID, A_SIZE, A_CHECKSUM, A_CHECKSUM_BAD, A_MODE, A_FIELD)),
        ("frames", "Frames", (A_HOST, A_CONTROLLER)),
        ("errors", "Errors", (A_GARBAGE, A_ERROR)),
    )
    binary = (
        ("frames", "Whole frames (raw bytes)"),
        ("log", "nurimc traffic log (JSON lines)"),
    )

    def __init__(self):
        self.reset()

    def reset(self):
        self.samplerate = None
        self.held = ([], [])  # per line: [(byte, ss, es)] that may begin a frame
        self.idle = [0, 0]
        self.garbage = [None, None]  # per line: [ss, es, bytes] of the run being dropped
        self.roles = [None, None]  # per line: 'host' / 'controller' once a frame told us
        self.lines_seen = set()

    def start(self):
        self.out_ann = self.register(srd.OUTPUT_ANN)
        self.out_binary = self.register(srd.OUTPUT_BINARY)
        self.out_python = self.register(srd.OUTPUT_PYTHON)

    def metadata(self, key, value):
        if key == srd.SRD_CONF_SAMPLERATE:
            self.samplerate = value

    def decode(self, ss, es, data):
        ptype, line, pdata = data
        if ptype == "FRAME":
            self.lines_seen.add(line)
            self.idle[line] = 0
            value, valid = pdata
            if valid:
                self.held[line].append((value, ss, es))
                self.resolve(line, False)
            else:  # a UART would flag the byte: never part of a frame
                self.put(
                    ss,
                    es,
                    self.out_ann,
                    [A_ERROR, ["UART frame error (glitch or wrong baud rate)", "UART frame error", "FE"]],
                )
        elif ptype == "IDLE":
            self.idle[line] += 1
            if self.idle[line] == self.options["quiet"]:
                self.resolve(line, True)  # the line went quiet: a partial frame will not complete
                self.flush_garbage(line)  # and the garbage before the silence is shown now

    # --- the stream rule: where a whole valid frame starts, take it; else drop one byte -----------
    def resolve(self, line, final):
        held = self.held[line]
        while held:
            if held[0][0] != HEADER[0]:
                self.drop(line)
                continue
            if len(held) < 2:
                if not final:
                    return
                self.drop(line)
                continue
            if held[1][0] != HEADER[1]:
                self.drop(line)
                continue
            if len(held) < 4:
                if not final:
                    return
                self.drop(line)
                continue
            size = held[3][0]
            if size < 2 or size > MAX_SIZE:
                self.reject(line, 4, f"size {size}: no message has it")
                continue
            if len(held) < 6:
                if not final:
                    return
                self.drop(line)
                continue
            mode = held[5][0]
            entry = MESSAGES.get(mode)
            if entry is None:
                self.reject(line, 6, f"unknown mode 0x{mode:02X}")
                continue
            if entry[2] != size:
                self.reject(line, 6, f"wrong size {size} for {entry[0]} (needs {entry[2]})")
                continue
            length = size + 4
            if len(held) < length:
                if not final:
                    return
                self.drop(line)
                continue
            if sum(b for b, _, _ in held[2:length]) & 0xFF == 0xFF:
                self.frame(line, held[:length], entry)
                del held[:length]
                continue
            expected = ~(held[2][0] + size + mode + sum(b for b, _, _ in held[6:length])) & 0xFF
            self.put(
                held[4][1],
                held[4][2],
                self.out_ann,
                [
                    A_CHECKSUM_BAD,
                    [f"Checksum 0x{held[4][0]:02X} bad (0x{expected:02X} expected)", "Checksum bad", "C!"],
                ],
            )
            self.reject(line, length, f"bad checksum in a {entry[0]} frame")

    def drop(self, line):
        """The first held byte is not the start of a frame: count it as garbage."""
        byte, ss, es = self.held[line].pop(0)
        run = self.garbage[line]
        if run is None:
            self.garbage[line] = [ss, es, [byte]]
        else:
            run[1] = es
            run[2].append(byte)
            if len(run[2]) >= 16:
                self.flush_garbage(line)

    def flush_garbage(self, line):
        run = self.garbage[line]
        if run is None:
            return
        self.garbage[line] = None
        ss, es, data = run
        shown = " ".join(f"{b:02X}" for b in data)
        plural = "s" if len(data) > 1 else ""
        self.put(
            ss,
            es,
            self.out_ann,
            [A_GARBAGE, [f"Garbage: {len(data)} byte{plural} {shown} (resync)", f"Garbage {shown}", "G"]],
        )

    def reject(self, line, length, reason):
        """A header whose frame is not valid: say why over its bytes, then drop its first byte."""
        held = self.held[line]
        last = held[min(length, len(held)) - 1]
        self.put(held[0][1], last[2], self.out_ann, [A_ERROR, ["Rejected: " + reason, "Rejected", "R"]])
        self.drop(line)

    # --- a whole valid frame ----------------------------------------------------------------------
    def frame(self, line, part, entry):
        self.flush_garbage(line)
        name, kind, size, fields = entry
        role = "host" if kind in HOST_KINDS else "controller"
        self.roles[line] = role
        frame_id = part[2][0]
        put = self.put
        ann = self.out_ann
        put(part[0][1], part[1][2], ann, [A_HEADER, ["Header FF FE", "Header", "H"]])
        who = "broadcast" if frame_id == BROADCAST_ID and kind == "command" else f"ID {frame_id}"
        put(part[2][1], part[2][2], ann, [A_ID, [who, "ID", "I"]])
        put(part[3][1], part[3][2], ann, [A_SIZE, [f"Size {size}", "Size", "S"]])
        put(part[4][1], part[4][2], ann, [A_CHECKSUM, [f"Checksum 0x{part[4][0]:02X} good", "Checksum", "C"]])
        put(part[5][1], part[5][2], ann, [A_MODE, [f"Mode 0x{part[5][0]:02X} {name}", name, f"{part[5][0]:02X}"]])
        shown = []
        values = {}
        offset = 6
        for field in fields:
            width = field[1]
            value = 0
            for b, _, _ in part[offset : offset + width]:
                value = value << 8 | b
            text = physical(field, value)
            values[field[0]] = value
            shown.append(f"{field[0]}={text}")
            put(part[offset][1], part[offset + width - 1][2], ann, [A_FIELD, [f"{field[0]}: {text}", text]])
            offset += width
        where = f" ({LINE_NAMES[line]} line)" if len(self.lines_seen) > 1 else ""
        head = f"{role}{where}: {name} id={frame_id}"
        texts = [" ".join([head, *shown]), head, f"{name} id={frame_id}", name]
        ss, es = part[0][1], part[-1][2]
        put(ss, es, ann, [A_HOST if role == "host" else A_CONTROLLER, texts])
        raw = bytes(b for b, _, _ in part)
        put(ss, es, self.out_binary, [B_FRAMES, raw])
        t = ss / self.samplerate if self.samplerate else float(ss)
        direction = "tx" if role == "host" else "rx"
        log = json.dumps({"t": round(t, 6), "dir": direction, "hex": raw.hex()}) + "\n"
        put(ss, es, self.out_binary, [B_LOG, log.encode("ascii")])
        put(ss, es, self.out_python, [name, frame_id, values, raw])
