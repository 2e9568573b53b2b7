"""Synthesize logic-analyzer captures of an RS485 bus: UART waveforms from bytes, with faults.

A capture is one byte per sample (sigrok's `binary` input format, unit size 1): bit 0 is line
0, bit 1 is line 1. Each line carries bursts of bytes separated by gaps; the faults are the
ones a real capture shows and that must not change which bytes a UART reads:
- the sender's clock is off by up to +-1.5 % per byte (an Arduino at 16 MHz is off by 2.1 %
  at 115200 bps; a receiver sampling mid-bit tolerates about 4 %),
- short glitches (a tenth of a bit) just after bit edges, away from the mid-bit sample point,
- glitches on the idle line (a receiver sees a start bit that is high at mid-bit: framing error),
- protocol-level noise made of valid UART bytes: random garbage, false headers, frames with a
  bad checksum, an unknown mode, a wrong size, frames cut short by silence.
`expected_frames` states what the bytes hold, by the Python stream parser, with `finish` at
every gap long enough for the decoder to call the line quiet.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from nurimc.protocol import BY_MODE, StreamParser, build_frame

QUIET_BYTES = 4  # the decoder's default `quiet` option: idle byte times that end a partial frame


@dataclass
class Line:
    """What one wire carries: (gap before it in bit times, bytes sent back to back) bursts."""

    bursts: list[tuple[float, bytes]] = field(default_factory=list)


def random_frame(rng: random.Random, kinds: tuple[str, ...]) -> bytes:
    modes = [m for m, cls in BY_MODE.items() if cls.SPEC.kind in kinds]
    mode = rng.choice(modes)
    size = BY_MODE[mode].SPEC.size
    frame_id = rng.choice([0, 1, 2, 7, 254, 255] if "command" in kinds else [0, 1, 2, 7, 254])
    return build_frame(frame_id, mode, bytes(rng.randrange(256) for _ in range(size - 2)))


def noise_burst(rng: random.Random) -> bytes:
    """Bytes that are noise to the protocol (some of them begin like a frame)."""
    good = random_frame(rng, ("command", "request", "answer"))
    choice = rng.randrange(6)
    if choice == 0:
        return bytes(rng.randrange(256) for _ in range(rng.randint(1, 9)))
    if choice == 1:
        return b"\xff" * rng.randint(1, 3) + b"\xfe" * rng.randint(0, 2)
    if choice == 2:  # bad checksum
        return good[:4] + bytes([good[4] ^ rng.randrange(1, 256)]) + good[5:]
    if choice == 3:  # unknown mode
        return good[:5] + bytes([rng.choice([0x00, 0x11, 0x55, 0xA5 + 0x10, 0xEE])]) + good[6:]
    if choice == 4:  # wrong size
        return good[:3] + bytes([rng.choice([0, 1, 9, 200])]) + good[4:]
    return good[: rng.randint(2, len(good) - 1)]  # cut short


def pause(rng: random.Random) -> float:
    """A gap before a burst, in bit times: short (the line stays busy: fewer than three idle byte
    times, where glitches may fall) or, one time in ten, long enough to count as quiet."""
    return rng.uniform(60, 150) if rng.random() < 0.1 else rng.uniform(3, 28)


def traffic(rng: random.Random, exchanges: int, two_lines: bool) -> tuple[Line, Line]:
    """A host asking and commanding, controllers answering, noise in between.

    One line: everything on line 0 (a half-duplex RS485 pair). Two lines: the host's side on
    line 0, the controllers' on line 1.
    """
    host, ctrl = Line(), Line()
    for _ in range(exchanges):
        frame = random_frame(rng, ("command", "request"))
        if rng.random() < 0.15:  # a frame split by a short pause inside it (a slow adapter)
            cut = rng.randint(1, len(frame) - 1)
            host.bursts += [(pause(rng), frame[:cut]), (rng.uniform(0.5, 2.5), frame[cut:])]
        else:
            host.bursts.append((pause(rng), frame))
        other = ctrl if two_lines else host
        if rng.random() < 0.7:
            other.bursts.append((pause(rng), random_frame(rng, ("answer",))))
        if rng.random() < 0.35:
            noisy = rng.choice([host, other])
            noisy.bursts.append((pause(rng), noise_burst(rng)))
    host.bursts.append((60, b""))  # end quiet: the decoder resolves what it holds, as finish() does
    ctrl.bursts.append((60, b""))
    return host, ctrl


def expected_frames(line: Line) -> list[bytes]:
    """Every frame the line's bytes hold, by the Python stream parser (finish at quiet gaps)."""
    parser, frames = StreamParser(), []
    for gap, data in line.bursts:
        if gap >= QUIET_BYTES * 10 + 5:  # the UART reports `quiet` idle byte times: the decoder finishes
            frames += parser.finish()
        frames += parser.feed(data)
    frames += parser.finish()
    # built without range checks: the parser takes out-of-range values as they are, so must we
    return [build_frame(m.id, m.SPEC.mode, m.SPEC.layout.pack(*m[1:])) for m in frames]


def waveform(line: Line, rng: random.Random, samplerate: int, baud: int, glitches: bool) -> tuple[bytearray, list[int]]:
    """The line's logic levels, one sample per entry, and where each burst starts (samples)."""
    bit = samplerate / baud
    levels = bytearray()
    starts = []
    t = 0.0  # in samples, fractional

    def level_to(until: float, value: int) -> None:
        end = round(until)
        if end > len(levels):
            levels.extend(bytes([value]) * (end - len(levels)))

    for gap, data in line.bursts:
        gap_start = t
        t += gap * bit
        level_to(t, 1)
        if glitches and 4 <= gap < 30 and rng.random() < 0.5:  # an idle glitch, 1.5+ bits from either side
            at = rng.uniform(gap_start + 1.5 * bit, t - 2.5 * bit)
            for i in range(round(at), round(at + max(1.0, 0.1 * bit))):
                levels[i] = 0
        starts.append(round(t))
        for byte in data:
            width = bit * (1 + rng.uniform(-0.015, 0.015))
            bits = [0] + [(byte >> i) & 1 for i in range(8)] + [1]
            for k, value in enumerate(bits):
                level_to(t + (k + 1) * width, value)
                if glitches and 0 < k < 9 and rng.random() < 0.06:  # just after the edge, not at mid-bit
                    at = t + (k + rng.uniform(0.05, 0.12)) * width
                    for i in range(round(at), round(at + max(1.0, 0.08 * width))):
                        if i < len(levels):
                            levels[i] ^= 1
            t += 10 * width
    return levels, starts


def capture(lines: list[Line], rng: random.Random, samplerate: int, baud: int, glitches: bool = True) -> bytes:
    """The samples of up to eight lines (bit n = line n), idle-high, padded to the longest."""
    waves = [waveform(line, rng, samplerate, baud, glitches)[0] for line in lines]
    length = max(len(w) for w in waves) + round(20 * samplerate / baud)
    out = bytearray(length)
    for n, wave in enumerate(waves):
        wave.extend(b"\x01" * (length - len(wave)))
        mask = 1 << n
        for i, value in enumerate(wave):
            if value:
                out[i] |= mask
    return bytes(out)
