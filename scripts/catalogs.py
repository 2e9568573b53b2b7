#!/usr/bin/env python3
"""The CLI's message catalogs (python/src/nurimc/cli/locale/*/LC_MESSAGES/nurimc.po -> .mo).

    .venv/bin/python scripts/catalogs.py            compile every .po to its .mo (Babel)
    .venv/bin/python scripts/catalogs.py --update   add the texts the CLI now has to each .po
                                                    (kept translations stay; gone texts are dropped)
    .venv/bin/python scripts/catalogs.py --check    exit 1 if a text has no Korean or a .mo is stale

The texts are the CLI's help (walked from the click command tree), click's own words and the
templates and messages in nurimc/cli/messages.py (docs/cli.md, Language). The compiled .mo files
are committed, so a fresh clone and the wheel work without Babel; the check keeps them current.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

from babel.messages.catalog import Catalog
from babel.messages.mofile import read_mo, write_mo
from babel.messages.pofile import read_po, write_po

LOCALE = Path(__file__).resolve().parents[1] / "python/src/nurimc/cli/locale"
LANGUAGES = ("ko", "en")  # en: the texts as written, so that LANGUAGE=en:ko means English


def wanted() -> list[tuple[str, str | None]]:
    """(text, context) for every text the CLI translates, in a stable order."""
    import typer.main

    from nurimc.cli.app import app
    from nurimc.cli.i18n import help_texts
    from nurimc.cli.messages import CLICK_TEXTS, CONTEXT, MESSAGES, PATTERNS, SETTING_CONTEXT, SETTING_NAMES

    texts: list[tuple[str, str | None]] = []
    for text in help_texts(typer.main.get_command(app)):
        texts.append((text, None))
    texts += [(t, None) for t in CLICK_TEXTS]
    texts += [(t, CONTEXT) for t in (*PATTERNS, *MESSAGES)]
    texts += [(t, SETTING_CONTEXT) for t in SETTING_NAMES]
    return list(dict.fromkeys(texts))


def po_path(lang: str) -> Path:
    return LOCALE / lang / "LC_MESSAGES" / "nurimc.po"


def load(lang: str) -> Catalog:
    path = po_path(lang)
    if not path.exists():
        return Catalog(locale=lang, domain="nurimc", project="nurimc", fuzzy=False)
    with path.open("rb") as file:
        return read_po(file, locale=lang, domain="nurimc")


def save(lang: str, catalog: Catalog) -> None:
    path = po_path(lang)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as file:
        write_po(file, catalog, width=0, omit_header=False, no_location=True)


def update(lang: str, translations: dict[tuple[str, str | None], str] | None = None) -> Catalog:
    old = load(lang)
    new = Catalog(locale=lang, domain="nurimc", project="nurimc", fuzzy=False)
    for text, context in wanted():
        kept = old.get(text, context)
        string = kept.string if kept is not None and kept.string else ""
        if lang == "en":  # each text as itself: gettext chains every language LANGUAGE lists, and a
            string = text  # text missing here would be taken from the next one (en:ko would show Korean)
        elif translations and (text, context) in translations:
            string = translations[(text, context)]
        new.add(text, string, context=context)
    save(lang, new)
    return new


def compiled(catalog: Catalog) -> bytes:
    out = io.BytesIO()
    write_mo(out, catalog)
    return out.getvalue()


def mo_entries(data: bytes) -> dict[tuple[str, str | None], str]:
    return {(m.id, m.context): m.string for m in read_mo(io.BytesIO(data)) if m.id}  # type: ignore[misc]


def compile_all() -> None:
    for lang in LANGUAGES:
        (po_path(lang).with_suffix(".mo")).write_bytes(compiled(load(lang)))


def check() -> list[str]:
    problems = []
    for lang in LANGUAGES:
        catalog = load(lang)
        mo = po_path(lang).with_suffix(".mo")
        if not mo.exists() or mo_entries(mo.read_bytes()) != mo_entries(compiled(catalog)):
            problems.append(f"{mo} is not compiled from its .po: run scripts/catalogs.py")
        if lang == "en":
            continue
        for text, context in wanted():
            entry = catalog.get(text, context)
            if entry is None or not entry.string:
                problems.append(f"{lang}: no translation of {text!r}: run scripts/catalogs.py --update, translate")
    return problems


def main() -> int:
    if "--update" in sys.argv:
        for lang in LANGUAGES:
            update(lang)
        compile_all()
        return 0
    if "--check" in sys.argv:
        problems = check()
        for problem in problems:
            print(problem, file=sys.stderr)
        return 1 if problems else 0
    compile_all()
    return 0


if __name__ == "__main__":
    sys.exit(main())
