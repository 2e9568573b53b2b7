"""One glossary for the console, the CLI and docs/ko (issue 38, Korean): docs/glossary.md's
"One word each" table is read; no Korean text uses a word of its "not" column, and a text whose
English is exactly one of its terms is translated with that term. Setting names are the same
words in the console and in `status`, and numbers with units never read as Korean number words."""

from __future__ import annotations

import functools
import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from babel.messages.pofile import read_po

from nurimc.cli.messages import SETTING_CONTEXT

ROOT = Path(__file__).resolve().parents[3]
GLOSSARY = ROOT / "docs/glossary.md"
STATIC = ROOT / "python/src/nurimc/dashboard/static"
PO = ROOT / "python/src/nurimc/cli/locale/ko/LC_MESSAGES/nurimc.po"


def one_word_each() -> list[tuple[str, str, list[str]]]:
    text = GLOSSARY.read_text(encoding="utf-8").split("## One word each", 1)[1]
    rows = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0] not in ("English", "---") and not set(cells[0]) <= {"-"}:
            rows.append((cells[0], cells[1], [w.strip() for w in cells[2].split(",") if w.strip()]))
    return rows


@functools.cache
def catalog(lang: str) -> dict[str, str]:
    """A console catalog (locales/LANG.js, an ES module), as node reads it."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is needed to read the console's catalogs")
    module = (STATIC / "locales" / f"{lang}.js").as_uri()
    script = f"import({json.dumps(module)}).then((m) => process.stdout.write(JSON.stringify(m.default)))"
    done = subprocess.run([node, "-e", script], capture_output=True, text=True, timeout=120, check=True)
    data: dict[str, str] = json.loads(done.stdout)
    return data


def cli_korean() -> list[tuple[str, str, str | None]]:
    with PO.open("rb") as stream:
        return [
            (m.id, m.string, m.context)
            for m in read_po(stream)
            if m.id and isinstance(m.id, str) and isinstance(m.string, str)
        ]


def korean_surfaces() -> dict[str, str]:
    texts = {f"console {k}": v for k, v in catalog("ko").items()}
    texts |= {f"cli {mid[:40]!r}": text for mid, text, _ in cli_korean()}
    for path in [*sorted((ROOT / "docs/ko").glob("*.md")), ROOT / "README.ko.md"]:
        texts[str(path.relative_to(ROOT))] = path.read_text(encoding="utf-8")
    return texts


def test_the_table_is_there() -> None:
    rows = one_word_each()
    assert len(rows) >= 6 and ("step response", "스텝 응답", ["계단 응답"]) in rows


def test_no_korean_text_uses_an_avoided_word() -> None:
    found = [
        f"{where}: {word!r} (say {korean!r})"
        for _, korean, avoided in one_word_each()
        for word in avoided
        for where, text in korean_surfaces().items()
        if word in text
    ]
    assert found == []


def test_a_term_is_translated_with_its_word_everywhere() -> None:
    en, ko = catalog("en"), catalog("ko")
    wrong = []
    for english, korean, _ in one_word_each():
        for key, text in en.items():
            if text.strip().lower() == english.lower() and korean not in ko[key]:
                wrong.append(f"console {key}: {ko[key]!r} (say {korean!r})")
        for mid, text, _ in cli_korean():
            if mid.strip().lower() == english.lower() and korean not in text:
                wrong.append(f"cli {mid!r}: {text!r} (say {korean!r})")
    assert wrong == []


def test_setting_names_are_the_console_words_in_status() -> None:
    console = catalog("ko")
    labels = {mid: text for mid, text, context in cli_korean() if context == SETTING_CONTEXT}
    assert len(labels) == 16
    assert {name: console[f"setting.{name}"] for name in labels} == labels


@pytest.mark.parametrize("lang", ["ko", "en"])
def test_rates_are_shown_with_their_unit(lang: str) -> None:
    text = catalog(lang)["motors.rateOnly"].replace("{rate}", "9600")
    assert "9600 bps" in text and "9600만" not in text


def test_no_number_placeholder_is_followed_by_man() -> None:
    """`{rate}만` reads as tens of thousands (9600만 = 96 million)."""
    assert [k for k, v in catalog("ko").items() if re.search(r"\{\w+\}만", v)] == []
    assert [mid for mid, text, _ in cli_korean() if re.search(r"\{\w+\}만", text)] == []
