#!/usr/bin/env python3
"""Build the Arduino library zip, install it as the IDE would, and build every example with the
real Arduino AVR core (Debian: arduino-core-avr, arduino-mk, gcc-avr) for an Uno and a Mega.

    build_examples.py OUTDIR [--record FILE]

OUTDIR gets the zip, a sketchbook with the zip installed into libraries/ (extracted: what "Add
.ZIP Library" and `arduino-cli lib install --zip-path` do), each example's firmware
(OUTDIR/<board>/<example>/<example>.elf) and sizes.json (flash and RAM of each build). Each
example is built twice: with arduino-mk (the firmware the emulated runs use) and with
arduino-builder, the Arduino IDE's build engine (library discovery as the IDE does it,
-warnings all; its size report is recorded as ide_flash / ide_ram). --record
also writes the sizes to FILE (benchmarks/results/arduino-sizes.json).

Debian 12's core (1.8.7) uses DECIMAL_DIG in WString.cpp, which avr-gcc 5.4's <float.h> defines
only for C, not C++ (the Arduino IDE ships avr-gcc 7.3); it is defined here as the compiler's
__DECIMAL_DIG__, which is what newer <float.h> does. The other flags are the IDE's (platform.txt).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import make_library

ARDUINO = Path("/usr/share/arduino")
BOARDS = {
    # name: (Arduino.mk settings, flash and RAM of the part as boards.txt gives them)
    "uno": (["BOARD_TAG=uno"], 32256, 2048),
    "mega": (["BOARD_TAG=mega", "BOARD_SUB=atmega2560"], 253952, 8192),
}
FQBN = {"uno": "arduino:avr:uno", "mega": "arduino:avr:mega:cpu=atmega2560"}
STACK_RESERVE = 256  # RAM left for the stack and the serial interrupt: a build that leaves less fails
CXX_FLAGS = "-std=gnu++11 -fno-threadsafe-statics -flto -DDECIMAL_DIG=__DECIMAL_DIG__"


def install_zip(archive: Path, sketchbook: Path) -> Path:
    """Extract the zip into sketchbook/libraries, checking the layout the IDE requires."""
    libraries = sketchbook / "libraries"
    if libraries.exists():
        shutil.rmtree(libraries)
    libraries.mkdir(parents=True)
    with zipfile.ZipFile(archive) as zf:
        tops = {name.split("/", 1)[0] for name in zf.namelist()}
        if len(tops) != 1:
            raise SystemExit(f"{archive}: one top folder expected, found {sorted(tops)}")
        zf.extractall(libraries)
    lib = libraries / tops.pop()
    props = dict(line.split("=", 1) for line in (lib / "library.properties").read_text().splitlines() if "=" in line)
    for key in ("name", "version", "author", "maintainer", "sentence", "paragraph", "category", "architectures"):
        if not props.get(key):
            raise SystemExit(f"library.properties: {key} missing")
    if "url" not in props:  # Arduino IDE 1.x refuses a library.properties without the key
        raise SystemExit("library.properties: url missing")
    if not re.fullmatch(r"\d+\.\d+\.\d+", props["version"]):
        raise SystemExit(f"library.properties: version {props['version']} is not x.y.z")
    for example in (lib / "examples").iterdir():
        if not (example / f"{example.name}.ino").is_file():
            raise SystemExit(f"{example}: the IDE needs {example.name}.ino inside it")
    json.loads((lib / "library.json").read_text())  # PlatformIO's manifest parses
    return libraries


def build(example: Path, board: str, libraries: Path, objdir: Path) -> dict[str, int]:
    settings, flash_max, ram_max = BOARDS[board]
    cmd = [
        "make", "-s", "-f", str(ARDUINO / "Arduino.mk"), f"ARDUINO_DIR={ARDUINO}", f"ARDMK_DIR={ARDUINO}",
        "AVR_TOOLS_DIR=/usr", *settings, "ARDUINO_LIBS=nurimc", f"USER_LIB_PATH={libraries}",
        f"OBJDIR={objdir}", f"CXXFLAGS_STD={CXX_FLAGS}",
    ]  # fmt: skip
    done = subprocess.run(cmd, cwd=example, capture_output=True, text=True, check=False)
    elf = objdir / f"{example.name}_.elf"
    if done.returncode != 0 or not elf.is_file():
        errors = [line for line in done.stderr.splitlines() if "error" in line or "region" in line]
        raise SystemExit(f"{example.name} for {board} did not build:\n" + "\n".join(errors[-20:]))
    shutil.copy2(elf, objdir / f"{example.name}.elf")
    sizes = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True).stdout
    section = {m.group(1): int(m.group(2)) for m in re.finditer(r"^\.(\w+)\s+(\d+)", sizes, re.MULTILINE)}
    flash = section.get("text", 0) + section.get("data", 0)
    ram = section.get("data", 0) + section.get("bss", 0)
    if flash > flash_max or ram > ram_max - STACK_RESERVE:
        raise SystemExit(f"{example.name} for {board}: flash {flash}/{flash_max}, RAM {ram}/{ram_max} "
                         f"(at most {ram_max - STACK_RESERVE}: {STACK_RESERVE} bytes stay for the stack)")  # fmt: skip
    return {"flash": flash, "flash_max": flash_max, "ram": ram, "ram_max": ram_max}


def build_like_the_ide(example: Path, board: str, libraries: Path, objdir: Path) -> dict[str, int]:
    """The same example through arduino-builder, the Arduino IDE's own build engine: its library
    discovery must accept the installed package, and at -warnings all nothing of ours may warn."""
    objdir.mkdir(parents=True, exist_ok=True)
    (objdir.parent.parent / "core-cache").mkdir(exist_ok=True)
    cmd = [
        "arduino-builder", "-compile", "-warnings", "all", "-hardware", str(ARDUINO / "hardware"),
        "-tools", str(ARDUINO / "hardware" / "tools"), "-libraries", str(libraries), "-fqbn", FQBN[board],
        "-build-path", str(objdir), "-build-cache", str(objdir.parent.parent / "core-cache"),
        "-prefs=compiler.cpp.extra_flags=-DDECIMAL_DIG=__DECIMAL_DIG__",
        str(example / f"{example.name}.ino"),
    ]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    output = done.stdout + done.stderr
    ours = [
        line for line in output.splitlines() if ("nurimc" in line and "warning" in line) or "nvalid library" in line
    ]
    flash = re.search(r"Sketch uses (\d+) bytes", output)
    ram = re.search(r"Global variables use (\d+) bytes", output)
    if done.returncode != 0 or ours or not flash or not ram:
        raise SystemExit(
            f"{example.name} for {board} with arduino-builder:\n" + "\n".join((ours or output.splitlines())[-20:])
        )
    return {"ide_flash": int(flash.group(1)), "ide_ram": int(ram.group(1))}


def main(argv: list[str]) -> int:
    if not argv or (len(argv) == 3 and argv[1] != "--record") or len(argv) not in (1, 3):
        print(__doc__, file=sys.stderr)
        return 2
    out = Path(argv[0]).resolve()
    out.mkdir(parents=True, exist_ok=True)
    _, archive = make_library.build(out / "package")
    libraries = install_zip(archive, out / "sketchbook")
    results: dict[str, dict[str, dict[str, int]]] = {}
    for board in BOARDS:
        for example in sorted((libraries / "nurimc" / "examples").iterdir()):
            sizes = build(example, board, libraries, out / board / example.name)
            sizes |= build_like_the_ide(example, board, libraries, out / "ide" / board / example.name)
            results.setdefault(board, {})[example.name] = sizes
            print(f"{board:5s} {example.name:18s} flash {sizes['flash']:6d} / {sizes['flash_max']}  "
                  f"RAM {sizes['ram']:5d} / {sizes['ram_max']}")  # fmt: skip
    text = json.dumps({"toolchain": "Debian 12 arduino-core-avr 1.8.7, avr-gcc 5.4.0, -Os -flto", "sizes": results},
                      indent=2) + "\n"  # fmt: skip
    (out / "sizes.json").write_text(text)
    if len(argv) == 3:
        Path(argv[2]).write_text(text)
    print(f"{archive.name}: installed and every example built for {', '.join(BOARDS)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
