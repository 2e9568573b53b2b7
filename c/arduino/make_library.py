#!/usr/bin/env python3
"""Build the Arduino library (and its zip) from the C library's sources.

Nothing is kept twice in git: the library folder is assembled from c/ every time.

    nurimc/
      library.properties     Arduino library metadata (1.5 layout)
      library.json           PlatformIO manifest
      LICENSE
      src/                   the core (c/src/*.c, c/include/*.h without the POSIX layer) and
                             nurimc_arduino.h (c/arduino/: a bus class on HardwareSerial)
      examples/<name>/<name>.ino   from c/examples/arduino/

The zip holds the folder `nurimc/` at its top, the form the Arduino IDE's "Add .ZIP Library"
and `arduino-cli lib install --zip-path` take.

Usage: make_library.py OUTDIR   (writes OUTDIR/nurimc/ and OUTDIR/nurimc-<version>.zip)
"""

from __future__ import annotations

import json
import re
import shutil
import sys
import zipfile
from pathlib import Path

C = Path(__file__).resolve().parents[1]
ROOT = C.parent
CORE = ["codec.c", "parser.c", "nurimc_tables.c", "units.c"]
HEADERS = ["nurimc.h", "nurimc_messages.h", "nurimc_units.h", "nurimc_host.h", "nurimc_settings.h"]
FIXED_TIME = (2020, 1, 1, 0, 0, 0)  # zip entries carry a fixed time: the same sources, the same zip
# An AVR copies every const object into its RAM at start-up (2 kB on an Uno) unless it is marked
# for program memory. The Arduino copy of the generated table therefore marks its arrays
# NURIMC_FLASH (nurimc.h: PROGMEM on AVR, read back with LPM) and wraps each string in
# NURIMC_TEXT, which leaves the text (names, titles, units: 1.8 kB that string literals would
# keep in RAM) out on AVR. Other architectures get the table as generated.
TEXT_MACRO = """
/* Arduino package (c/arduino/make_library.py): on AVR the tables stay in flash, without text. */
#ifdef __AVR__
#define NURIMC_TEXT(s) ""
#else
#define NURIMC_TEXT(s) s
#endif
"""
FLASH_SWITCH = """/* Arduino package (c/arduino/make_library.py): its tables are in program memory on AVR. */
#if defined(__AVR__) && !defined(NURIMC_TABLES_IN_FLASH)
#define NURIMC_TABLES_IN_FLASH 1
#endif
"""
FLASH_ARRAY = re.compile(r"^((?:static )?const (?:nurimc_field_spec|nurimc_message_spec|uint8_t) \w+\[\w*\]) = \{$")
TABLE_ROW = re.compile(r'^(\s*\{)(".*)$')
STRING = re.compile(r'"((?:[^"\\]|\\.)*)"')


def manifest() -> dict[str, object]:
    """The repository's PlatformIO manifest (c/library.json), for name, version and description."""
    return json.loads((C / "library.json").read_text(encoding="utf-8"))


def properties(meta: dict[str, object]) -> str:
    return "\n".join(
        [
            f"name={meta['name']}",
            f"version={meta['version']}",
            "author=the nurimc authors",
            "maintainer=the nurimc authors",
            "sentence=Nurirobot MC / BLMC-H motor controllers on RS485 (MC-RS485 protocol).",
            "paragraph=Encode, decode and stream-parse every MC-RS485 message, with no allocation; "
            "NurimcBus sends commands and requests over a HardwareSerial port and an RS485 "
            "transceiver's direction pin, with answer deadlines computed from the wire.",
            "category=Device Control",
            "url=",  # the IDE requires the key; there is no public project page to name yet
            "architectures=*",
            "includes=nurimc_arduino.h",
            "",
        ]
    )


def platformio(meta: dict[str, object]) -> str:
    data = {
        "name": meta["name"],
        "version": meta["version"],
        "description": meta["description"],
        "keywords": meta.get("keywords", []),
        "license": meta.get("license", "MIT"),
        "frameworks": ["arduino"],
        "platforms": "*",
        "headers": ["nurimc_arduino.h", "nurimc.h"],
        "examples": [{"name": p.name, "base": f"examples/{p.name}", "files": [f"{p.name}.ino"]} for p in examples()],
    }
    return json.dumps(data, indent=2) + "\n"


def avr_friendly_tables(text: str) -> str:
    """The generated table with every string of a spec row wrapped in NURIMC_TEXT (see TEXT_MACRO)."""
    rows = arrays = 0
    out = []
    for line in text.splitlines(keepends=True):
        array = FLASH_ARRAY.match(line.rstrip("\n"))
        if array:
            arrays += 1
            line = array.group(1) + " NURIMC_FLASH = {\n"
        match = TABLE_ROW.match(line)
        if match:
            rows += 1
            line = match.group(1) + STRING.sub(lambda m: f"NURIMC_TEXT({m.group(0)})", match.group(2)) + "\n"
        out.append(line)
    include = '#include "nurimc.h"\n'
    marked = "".join(out)
    unmarked = re.search(
        r"^(?:static )?const (?:nurimc_field_spec|nurimc_message_spec|uint8_t) [^=\n]*\] = \{", marked, re.M
    )
    if rows < 42 or arrays < 3 or unmarked or include not in text:
        raise SystemExit("c/src/nurimc_tables.c no longer has the layout make_library.py expects; update it")
    return "".join(out).replace(include, include + TEXT_MACRO, 1)


def examples() -> list[Path]:
    return sorted(p for p in (C / "examples" / "arduino").iterdir() if (p / f"{p.name}.ino").is_file())


def build(out: Path) -> tuple[Path, Path]:
    meta = manifest()
    lib = out / str(meta["name"])
    if lib.exists():
        shutil.rmtree(lib)
    (lib / "src").mkdir(parents=True)
    for name in CORE:
        shutil.copy2(C / "src" / name, lib / "src" / name)
    tables = (C / "src" / "nurimc_tables.c").read_text(encoding="utf-8")
    (lib / "src" / "nurimc_tables.c").write_text(avr_friendly_tables(tables), encoding="utf-8")
    for name in HEADERS:
        shutil.copy2(C / "include" / name, lib / "src" / name)
    header = (C / "include" / "nurimc.h").read_text(encoding="utf-8")
    switch = "#if defined(__AVR__) && defined(NURIMC_TABLES_IN_FLASH)\n"
    if switch not in header:
        raise SystemExit("c/include/nurimc.h has no NURIMC_TABLES_IN_FLASH switch; update make_library.py")
    (lib / "src" / "nurimc.h").write_text(header.replace(switch, FLASH_SWITCH + switch, 1), encoding="utf-8")
    shutil.copy2(C / "arduino" / "nurimc_arduino.h", lib / "src" / "nurimc_arduino.h")
    for example in examples():
        (lib / "examples" / example.name).mkdir(parents=True)
        shutil.copy2(example / f"{example.name}.ino", lib / "examples" / example.name)
    shutil.copy2(ROOT / "LICENSE", lib / "LICENSE")
    (lib / "library.properties").write_text(properties(meta), encoding="utf-8")
    (lib / "library.json").write_text(platformio(meta), encoding="utf-8")
    archive = out / f"{meta['name']}-{meta['version']}.zip"
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(lib.rglob("*")):
            info = zipfile.ZipInfo(str(path.relative_to(out)) + ("/" if path.is_dir() else ""), FIXED_TIME)
            info.external_attr = (0o40755 if path.is_dir() else 0o100644) << 16
            zf.writestr(info, b"" if path.is_dir() else path.read_bytes(), zipfile.ZIP_DEFLATED)
    return lib, archive


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: make_library.py OUTDIR", file=sys.stderr)
        return 2
    lib, archive = build(Path(argv[0]))
    print(f"wrote {lib} and {archive}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
