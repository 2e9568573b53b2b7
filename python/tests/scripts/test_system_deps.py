"""scripts/system-deps.sh against a fake apt (issue 24, item 11): an install that fails once (its
downloaded archives deleted between dpkg runs) is retried with a fresh download; one that keeps
failing names the package. The fakes stand in for dpkg-query, id and apt-get on PATH."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "scripts/system-deps.sh"

FAKES = {
    # every package is missing; `id -u` says root
    "dpkg-query": "#!/bin/sh\nexit 1\n",
    "id": "#!/bin/sh\necho 0\n",
    # apt-get: logs each call; `install` fails while $STATE/fail-installs > 0, and always for
    # the package named in $STATE/broken; `clean` and `update` succeed
    "apt-get": """#!/bin/bash
echo "apt-get $*" >> "$STATE/log"
[[ " $* " == *" install "* ]] || exit 0
left=$(cat "$STATE/fail-installs")
if [ "$left" -gt 0 ]; then echo $((left - 1)) > "$STATE/fail-installs"; exit 100; fi
broken=$(cat "$STATE/broken")
if [ -n "$broken" ] && [[ " $* " == *" $broken "* ]]; then exit 100; fi
exit 0
""",
}


def run(tmp_path: Path, fail_installs: int, broken: str = "") -> tuple[subprocess.CompletedProcess[str], list[str]]:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for name, text in FAKES.items():
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    (tmp_path / "fail-installs").write_text(str(fail_installs))
    (tmp_path / "broken").write_text(broken)
    (tmp_path / "log").write_text("")
    env = {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}", "STATE": str(tmp_path)}
    proc = subprocess.run(["bash", str(SCRIPT)], capture_output=True, text=True, env=env, timeout=60)
    return proc, (tmp_path / "log").read_text().splitlines()


def test_a_failed_install_is_retried_once_with_a_fresh_download(tmp_path: Path) -> None:
    proc, log = run(tmp_path, fail_installs=1)
    assert proc.returncode == 0, proc.stderr
    assert "retrying once with a fresh download" in proc.stderr
    installs = [i for i, line in enumerate(log) if " install " in line]
    cleans = [i for i, line in enumerate(log) if line.startswith("apt-get clean")]
    assert len(installs) == 2 and len(cleans) == 1 and installs[0] < cleans[0] < installs[1]  # fresh download


def test_a_package_that_keeps_failing_is_named(tmp_path: Path) -> None:
    proc, _ = run(tmp_path, fail_installs=2, broken="valgrind")
    assert proc.returncode == 1
    assert "could not install Debian package(s): valgrind" in proc.stderr
    assert "clang" not in proc.stderr.splitlines()[-1].split(":", 1)[1].split("(")[0]
