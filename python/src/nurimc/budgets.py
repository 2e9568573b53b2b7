"""How much a file reader may take from one file (docs/cli.md, "Limits on files read").

A hostile or broken file (a zip bomb of a sigrok capture, an MCAP chunk that decompresses to
gigabytes, a traffic log of a billion lines) must end in a one-line error within seconds and
bounded memory, never a machine out of memory. Every reader of a file someone hands us takes
a `ReadBudget`; the defaults fit captures and recordings of a bench session many times over,
and each can be raised for a bigger file: `NURIMC_READ_LIMITS="samples=1024,records=5000000"`
(sizes in MiB) or the `--read-limits` option of the commands that read files.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, fields, replace

from .errors import InputError

MIB = 1 << 20
ENV = "NURIMC_READ_LIMITS"
RAISE_HINT = f"raise it with --read-limits NAME=VALUE or {ENV}"
READ_LIMITS_HELP = (
    "Raise the limits on the file read, e.g. samples=1024,records=5000000 (docs/cli.md, Limits on files read)."
)


@dataclass(frozen=True, slots=True)
class ReadBudget:
    #: MiB of decompressed logic samples a capture (.sr) may hold (all channels together)
    samples: int = 64
    #: signal edges on one capture line (a UART byte has at most 10); bounds the decoding time
    edges: int = 2_000_000
    #: logic channels a capture may declare (sigrok's `total probes`)
    probes: int = 64
    #: MiB one MCAP chunk may decompress to (nurimc's recorder writes chunks of about 1 MiB)
    chunk: int = 64
    #: MiB of MCAP chunks decompressed in all by one read
    decompressed: int = 8192
    #: entries (frames, messages, lines) one read may return
    records: int = 1_000_000

    def with_text(self, text: str) -> ReadBudget:
        """This budget with 'name=value,...' applied (InputError, one line, if malformed)."""
        names = {f.name for f in fields(self)}
        changes: dict[str, int] = {}
        for part in filter(None, (p.strip() for p in text.split(","))):
            name, sep, value = part.partition("=")
            name = name.strip().lower()
            if not sep or name not in names:
                raise InputError(f"read limit {part!r}: give NAME=VALUE with NAME one of {', '.join(sorted(names))}")
            try:
                number = int(value.strip())
            except ValueError:
                number = 0
            if number < 1:
                raise InputError(f"read limit {part!r}: the value must be a whole number of 1 or more")
            changes[name] = number
        return replace(self, **changes)

    def over(self, what: str, limit: int, unit: str = "") -> InputError:
        """The one-line error for a file past one of the limits."""
        return InputError(f"{what} over the limit of {limit:,}{unit} ({RAISE_HINT})")


def default_budget() -> ReadBudget:
    """The defaults, with NURIMC_READ_LIMITS applied."""
    return ReadBudget().with_text(os.environ.get(ENV, ""))
