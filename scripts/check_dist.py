#!/usr/bin/env python3
"""Check what users install: the wheel and the npm tarball that `make dist` put in DIST.

Usage: check_dist.py DIST

- the wheel carries the console's page, its third-party files with their licences, py.typed;
- installed alone into a clean venv (no source tree on sys.path, run from a scratch folder) the
  CLI works on a simulated bus, and `nurimc dashboard` names the missing extra in one line;
- `nurimc record` names the `record` extra when mcap is missing, and with that extra alone (no
  Cyclone DDS) writes a recording that `nurimc inspect` reads;
- with `nurimc[dashboard]` it serves the console, and every file the page names answers 200;
- the npm tarball installs into a scratch project and imports from Node (ESM).
Prints one line per check and `check-dist: N passed, N failed`.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tarfile
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request
import venv
import zipfile
from collections.abc import Callable
from pathlib import Path

PING_ID0 = "fffe00025da0"  # the frame the TS check encodes (spec/protocol.json: ping ID 0)
WHEEL_MUST_HOLD = (
    "nurimc/py.typed",
    "nurimc/cli/locale/ko/LC_MESSAGES/nurimc.mo",  # the CLI in Korean (docs/cli.md, Language)
    "nurimc/dashboard/static/index.html",
    "nurimc/dashboard/static/app.js",
    "nurimc/dashboard/static/views/motors.js",
    "nurimc/dashboard/static/core/i18n.js",
    "nurimc/dashboard/static/locales/ko.js",
    "nurimc/dashboard/static/generated/spec.js",
    "nurimc/dashboard/static/nurimc.browser.js",
    "nurimc/dashboard/static/vendor/uplot/uPlot.esm.js",
    "nurimc/dashboard/static/vendor/uplot/uPlot.min.css",
    "nurimc/dashboard/static/vendor/uplot/LICENSE",
)


class Checks:
    def __init__(self) -> None:
        self.passed = 0
        self.failed = 0

    def run(self, name: str, check: Callable[[], str | None]) -> None:
        started = time.monotonic()
        try:
            detail = check()
        except Exception as error:  # every failure is reported, then the next check runs
            self.failed += 1
            print(f"FAIL {name}: {error}", flush=True)
            return
        self.passed += 1
        print(f"ok   {name} ({time.monotonic() - started:.1f} s){': ' + detail if detail else ''}", flush=True)


def run(cmd: list[str], cwd: Path, env: dict[str, str] | None = None, timeout: float = 300) -> str:
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}: {(proc.stderr or proc.stdout)[-1500:]}")
    return proc.stdout


def clean_env() -> dict[str, str]:
    """The caller's environment without anything that would point Python at the source tree."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env.update(NO_COLOR="1", COLUMNS="200")
    env.pop("NURIMC_PORT", None)
    return env


def one(dist: Path, pattern: str) -> Path:
    found = sorted(dist.glob(pattern))
    if len(found) != 1:
        raise RuntimeError(f"expected one {pattern} in {dist}, found {[p.name for p in found]}")
    return found[0]


def check_wheel_contents(wheel: Path) -> str:
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = [n for n in WHEEL_MUST_HOLD if n not in names]
    licences = [n for n in names if ".dist-info/licenses/" in n]
    if missing:
        raise RuntimeError(f"the wheel lacks {missing} (run scripts/dashboard-assets.sh before building)")
    if not any(n.endswith("licenses/LICENSE") for n in licences):
        raise RuntimeError(f"the wheel's licence files are incomplete: {licences}")
    vendored = sorted(n for n in names if "/vendor/" in n and n.endswith("/LICENSE"))
    # every third-party folder the page loads from carries its licence (uPlot today, any added later)
    folders = {n.rsplit("/", 1)[0] for n in names if "/static/vendor/" in n}
    unlicensed = sorted(f for f in folders if f"{f}/LICENSE" not in names)
    if unlicensed or not folders:
        raise RuntimeError(f"third-party folders without a LICENSE: {unlicensed or 'no vendor folder at all'}")
    return f"{len(names)} files; licences: {', '.join(licences + vendored)}"


def check_tarball_contents(tarball: Path) -> str:
    with tarfile.open(tarball) as archive:
        names = set(archive.getnames())
    wanted = ("package/LICENSE", "package/dist/index.js", "package/dist/nurimc.browser.js")
    missing = [n for n in wanted if n not in names]
    if missing:
        raise RuntimeError(f"the npm tarball lacks {missing}")
    return f"{len(names)} files"


def page_assets(base: str) -> list[str]:
    """Every file the page names: HTML src/href, JS static and dynamic imports, CSS url(), recursively."""
    seen: dict[str, int] = {}
    queue = [urllib.parse.urljoin(base, "index.html")]
    patterns = (
        re.compile(r"""(?:src|href)=["']([^"'#?]+)["']"""),
        re.compile(r"""(?:^|[\s;])import\s[^;]*?from\s*["'](\.[^"']+)["']""", re.M),
        re.compile(r"""import\(\s*["'](\.[^"']+)["']\s*\)"""),
        re.compile(r"""url\(\s*["']?(?!data:)([^"')]+)["']?\s*\)"""),
    )
    while queue:
        url = queue.pop()
        if url in seen:
            continue
        with urllib.request.urlopen(url, timeout=10) as answer:  # raises HTTPError on 404
            seen[url] = answer.status
            body = answer.read().decode("utf-8", "replace")
        if url.endswith((".html", ".js", ".css")):
            for pattern in patterns:
                for ref in pattern.findall(body):
                    target = urllib.parse.urljoin(url, ref)
                    if "://" in ref or not target.startswith(base):
                        continue  # external links are not the page's files
                    queue.append(target)
    bad = {u: s for u, s in seen.items() if s != 200}
    if bad:
        raise RuntimeError(f"not 200: {bad}")
    return sorted(u[len(base) :] for u in seen)


def serve_console(nurimc: Path, scratch: Path, env: dict[str, str]) -> str:
    proc = subprocess.Popen(
        [str(nurimc), "dashboard", "--sim", "--listen", "127.0.0.1:0"],
        cwd=scratch,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()  # `ready: http://127.0.0.1:PORT/`
        match = re.search(r"ready: (http://\S+/)", line)
        if not match:
            proc.kill()
            raise RuntimeError(f"no ready line: {line!r} {proc.communicate(timeout=10)[1][-1000:]}")
        assets = page_assets(match.group(1))
        if not {"vendor/uplot/uPlot.esm.js", "vendor/uplot/uPlot.min.css", "app.js"} <= set(assets):
            raise RuntimeError(f"the crawl missed the page's files: {assets}")
        return f"{len(assets)} files, all 200: {' '.join(assets)}"
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def main(dist: Path) -> int:
    dist = dist.resolve()
    checks = Checks()
    wheel = one(dist, "nurimc-*.whl")
    tarball = one(dist, "nurimc-*.tgz")
    one(dist, "nurimc-*.tar.gz")
    checks.run("wheel contents", lambda: check_wheel_contents(wheel))
    checks.run("npm tarball contents", lambda: check_tarball_contents(tarball))

    with tempfile.TemporaryDirectory(prefix="nurimc-dist-") as tmp:
        scratch = Path(tmp)
        env = clean_env()
        target = scratch / "venv"
        venv.EnvBuilder(with_pip=True, clear=True).create(target)
        python, nurimc = target / "bin" / "python", target / "bin" / "nurimc"
        pip = [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]

        def install_base() -> str:
            run([*pip, str(wheel)], scratch, env)
            where = run([str(python), "-c", "import nurimc; print(nurimc.__file__)"], scratch, env).strip()
            if not where.startswith(str(target)):
                raise RuntimeError(f"imported nurimc from {where}, not from the clean venv")
            return where

        def cli_smoke() -> str:
            version = run([str(nurimc), "version"], scratch, env).strip()
            status = [str(nurimc), "--port", "sim://?ids=1,2", "--id", "1", "--json", "status"]
            state = json.loads(run(status, scratch, env))
            if state.get("id") != 1 or "position_deg" not in state.get("state", {}):
                raise RuntimeError(f"unexpected status: {state}")
            korean_env = {**env, "LANGUAGE": "", "LC_ALL": "", "LC_MESSAGES": "", "LANG": "ko_KR.UTF-8"}
            korean = run([str(nurimc), "--help"], scratch, korean_env)
            if "사용법:" not in korean:
                raise RuntimeError(f"LANG=ko_KR.UTF-8 nurimc --help is not in Korean: {korean[:200]!r}")
            return f"nurimc {version}; status from sim:// ok; help in Korean"

        def extra_hint() -> str:
            proc = subprocess.run(
                [str(nurimc), "dashboard", "--sim", "--listen", "127.0.0.1:0"],
                cwd=scratch,
                env=env,
                capture_output=True,
                text=True,
                timeout=60,
            )
            lines = proc.stderr.strip().splitlines()
            if proc.returncode != 2 or len(lines) != 1 or "nurimc[dashboard]" not in lines[0]:
                raise RuntimeError(f"exit {proc.returncode}, stderr {proc.stderr!r}")
            return lines[0]

        def install_extra() -> None:
            run([*pip, f"{wheel}[dashboard]"], scratch, env)

        def record_hint() -> str:
            mcap = scratch / "run.mcap"
            proc = subprocess.run(
                [str(nurimc), "--port", "sim://?ids=1", "record", "--mcap", str(mcap), "--seconds", "0.3"],
                cwd=scratch,
                env=env,
                capture_output=True,
                text=True,
                timeout=60,
            )
            lines = proc.stderr.strip().splitlines()
            if proc.returncode != 2 or len(lines) != 1 or "nurimc[record]" not in lines[0]:
                raise RuntimeError(f"exit {proc.returncode}, stderr {proc.stderr!r}")
            return lines[0]

        def record_without_dds() -> str:
            """`record` with the record extra alone (mcap, no Cyclone DDS): a file inspect reads."""
            run([*pip, f"{wheel}[record]"], scratch, env)
            dds = subprocess.run([str(python), "-c", "import cyclonedds"], cwd=scratch, env=env, capture_output=True)
            if dds.returncode == 0:
                raise RuntimeError("cyclonedds is installed in the clean venv: the check would prove nothing")
            mcap = scratch / "run.mcap"
            record = [str(nurimc), "--port", "sim://?ids=1,2", "record", "--mcap", str(mcap), "--seconds", "0.5"]
            wrote = run(record, scratch, env)
            summary = json.loads(run([str(nurimc), "--json", "inspect", str(mcap)], scratch, env))
            if summary.get("motors") != ["motor_1", "motor_2"] or not summary.get("messages"):
                raise RuntimeError(f"unexpected recording: {wrote!r} {summary}")
            return f"{summary['messages']} messages, motors {summary['motors']}"

        checks.run("clean venv: pip install the wheel (no extras)", install_base)
        checks.run("clean venv: CLI on a simulated bus", cli_smoke)
        checks.run("clean venv: `nurimc dashboard` without the extra names it", extra_hint)
        checks.run("clean venv: `nurimc record` without mcap names the record extra", record_hint)
        checks.run("clean venv: `nurimc record` with the record extra only (no DDS)", record_without_dds)
        checks.run("clean venv: pip install 'nurimc[dashboard]'", install_extra)
        checks.run(
            "clean venv: the console serves every file its page names", lambda: serve_console(nurimc, scratch, env)
        )

        project = scratch / "npm-project"
        project.mkdir()
        (project / "package.json").write_text(json.dumps({"name": "scratch", "private": True, "type": "module"}))
        (project / "check.mjs").write_text(
            'import * as nurimc from "nurimc";\n'
            'import * as node from "nurimc/node";\n'
            'const frame = nurimc.toHex(nurimc.encode(nurimc.make("request_ping", 0, {})));\n'
            'if (typeof node.NodeSerialPort !== "function") throw new Error("nurimc/node lacks NodeSerialPort");\n'
            "// serialport is an optional peer: not installed, opening a port says what to install\n"
            'const why = await node.NodeSerialPort.open("/dev/null", 9600).then(() => "opened", (e) => e.message);\n'
            'if (!why.includes("npm install serialport")) throw new Error(`no serialport: ${why}`);\n'
            "console.log(frame);\n"
        )

        def npm_install() -> str:
            npm = ["npm", "install", "--no-audit", "--no-fund", "--prefer-offline", "--loglevel=error"]
            run([*npm, str(tarball)], project, env)
            if (project / "node_modules" / "serialport").exists():  # the codec alone: no native install scripts
                raise RuntimeError("npm install nurimc installed serialport (it is an optional peer dependency)")
            return tarball.name

        def npm_import() -> str:
            frame = run(["node", "check.mjs"], project, env).strip()
            if frame != PING_ID0:
                raise RuntimeError(f"ping ID 0 encoded as {frame!r}, expected {PING_ID0!r}")
            return f"ping ID 0 = {frame}"

        checks.run("scratch npm project: npm install the tarball", npm_install)
        checks.run("scratch npm project: import nurimc and nurimc/node", npm_import)

    print(f"check-dist: {checks.passed} passed, {checks.failed} failed")
    return 1 if checks.failed else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(Path(sys.argv[1])))
