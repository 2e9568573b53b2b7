#!/usr/bin/env python3
"""Make the example capture (sigrok/examples/nurimc-example.sr) and the screenshot of its decode
(docs/screenshots/sigrok-cli.png): a host pinging, reading and moving a controller at ID 1 on one
half-duplex line at 115200 bps, with a glitch, a frame with a bad checksum and two stray bytes.

Usage: .venv/bin/python sigrok/examples/make_example.py   (needs sigrok-cli and ImageMagick)
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE.parent / "tests"))
from synth import Line, capture  # noqa: E402 - the test folder holds the synthesizer

from nurimc.protocol import Ping, PositionFeedback, PositionSpeed, RequestPing, RequestPosition  # noqa: E402

BAUD, RATE = 115200, 2_000_000


def main() -> int:
    move = PositionSpeed(id=1, direction=0, position=9000, speed=300).encode()
    bad = bytearray(RequestPosition(id=1).encode())
    bad[4] ^= 0x10  # a flipped bit in the checksum
    line = Line(
        [
            (20, RequestPing(id=1).encode()),
            (8, Ping(id=1).encode()),
            (30, bytes(bad)),
            (12, b"\x3c\x00"),
            (20, RequestPosition(id=1).encode()),
            (8, PositionFeedback(id=1, direction=0, position=4500, speed=301, current=12).encode()),
            (30, move),
            (60, b""),
        ]
    )
    samples = capture([line], random.Random(1), RATE, BAUD)
    env = dict(os.environ, SIGROKDECODE_DIR=str(HERE.parent))
    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "capture.bin"
        raw.write_bytes(samples)
        session = HERE / "nurimc-example.sr"
        cmd = ["sigrok-cli", "-I", f"binary:samplerate={RATE}", "-i", str(raw), "-C", "0=RS485", "-o", str(session)]
        subprocess.run(cmd, check=True)
    decode = ["sigrok-cli", "-i", str(session.relative_to(ROOT)), "-P", f"uart:rx=RS485:baudrate={BAUD},nurimc"]
    shown = [*decode, "-A", "nurimc"]
    text = subprocess.run(shown, check=True, capture_output=True, text=True, env=env, cwd=ROOT).stdout
    page = "$ SIGROKDECODE_DIR=sigrok " + " ".join(shown) + "\n" + text
    (HERE / "nurimc-example.txt").write_text(page)
    png = ROOT / "docs" / "screenshots" / "sigrok-cli.png"
    lines = page.rstrip().splitlines()
    size = f"{max(len(line) for line in lines) * 8 + 24}x{len(lines) * 17 + 24}"
    subprocess.run(
        ["convert", "-size", size, "xc:#1e1e1e", "-fill", "#e0e0e0", "-font", "DejaVu-Sans-Mono", "-pointsize", "13",
         "-annotate", "+12+24", "\n".join(lines), str(png)],
        check=True,
    )  # fmt: skip
    print(f"wrote {session.relative_to(ROOT)}, {png.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
