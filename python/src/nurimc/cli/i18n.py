"""The CLI's language: English, or Korean when the environment asks for it.

Standard gettext: the catalogs are `locale/<lang>/LC_MESSAGES/nurimc.po`, compiled to `.mo`
(committed beside them; `scripts/catalogs.py` compiles them and a test checks they are
current). The language comes from LANGUAGE, LC_ALL, LC_MESSAGES and LANG, read by gettext
itself from the environment, so the C library's ko_KR locale need not be generated
(`LANG=ko_KR.UTF-8` is enough). click's and typer's own words ("Options", "default: …") go
through gettext's default function, so `activated()` points the process's text domain at ours
for the duration of a call; typer's copy of click writes "Usage:" and the help option's text
without gettext, which `translate_help` covers. Every language LANGUAGE lists is chained by
gettext, so the `en` catalog holds each text as itself (LANGUAGE=en:ko is English).

What is translated (docs/cli.md, Language):
- help texts: the click command tree is translated as it is built (`translate_help`), keyed by
  the English text as the code writes it;
- what the CLI prints: `tr()` looks a line up as it is, then as an instance of one of the
  message templates (`messages.PATTERNS`, e.g. `{name}: {value} is not a number; give
  {wanted}`), so the library's messages (English by design: docs/library.md, Errors) are shown
  in Korean without the library knowing about languages. `--json` output is never translated.
"""

from __future__ import annotations

import gettext
import re
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from typing import Any

from .messages import CONTEXT, PATTERNS, SETTING_CONTEXT

DOMAIN = "nurimc"
LOCALE_DIR = str(Path(__file__).with_name("locale"))
FIELD = re.compile(r"\{(\w+)\}")
#: fields that are a number (a file's line number, a count): a template such as "{where} line {line}" must not
#: take "Expecting value: line 1 column 1" or "the RSA line has no ..." for one
NUMBERED = frozenset({"line", "count"})
DIGITS = r"\d+"


def catalog() -> gettext.NullTranslations:
    """The catalog the environment asks for (none, or `en`: the texts as written)."""
    return gettext.translation(DOMAIN, LOCALE_DIR, fallback=True)


def _(message: str) -> str:
    """A fixed text in the language in use."""
    return catalog().gettext(message) if message else message


@cache
def _pattern(template: str) -> re.Pattern[str]:
    parts = FIELD.split(template)
    regex = "".join(
        re.escape(p) if i % 2 == 0 else f"(?P<{p}>{DIGITS if p in NUMBERED else '.*?'})" for i, p in enumerate(parts)
    )
    return re.compile(regex + r"\Z", re.DOTALL)


def setting_label(name: str) -> str:
    """A setting's name as `status` shows it: in Korean the document's words with the name the
    user types beside it (`위치제어기 Kp (position-kp)`), in English the name itself."""
    label = catalog().pgettext(SETTING_CONTEXT, name)
    return name if label == name else f"{label} ({name})"


def tr(text: str, depth: int = 0) -> str:
    """A line the CLI prints, in the language in use: a catalog entry as it is, or an instance
    of a template whose parts are translated in turn (a cause list inside a no-answer line)."""
    found = catalog()
    if not isinstance(found, gettext.GNUTranslations) or not text or depth > 12:
        return text
    exact = found.pgettext(CONTEXT, text)
    if exact != text:
        return exact
    for template in PATTERNS:
        match = _pattern(template).match(text)
        if match is None:
            continue
        parts = {k: tr(v, depth + 1) for k, v in match.groupdict().items()}
        try:
            translated = found.pgettext(CONTEXT, template).format(**parts)
        except (KeyError, IndexError, ValueError):  # a broken translation never hides the message
            continue
        if translated != text:  # a generic template ("{where}: {problem}") may change nothing
            return translated
    return text


def translate_help(command: Any) -> Any:
    """A click command tree with its help texts (commands, options, arguments) translated.

    typer's copy of click writes "Usage: " and the help option's "Show this message and exit."
    without gettext: the tree's formatter and help option are given the translated words."""
    base = command.context_class
    usage = _("Usage:") + " "
    formatter = type(
        "TranslatedFormatter",
        (base.formatter_class,),
        {
            "write_usage": lambda self, prog, args="", prefix=None: base.formatter_class.write_usage(
                self, prog, args, usage if prefix is None else prefix
            )
        },
    )
    command.context_class = type("TranslatedContext", (base,), {"formatter_class": formatter})
    make_help_option = command.get_help_option

    def get_help_option(ctx: Any) -> Any:
        option = make_help_option(ctx)
        if option is not None and isinstance(option.help, str):
            option.help = _(option.help)
        return option

    command.get_help_option = get_help_option
    for attr in ("help", "short_help", "epilog"):
        text = getattr(command, attr, None)
        if isinstance(text, str) and text:
            setattr(command, attr, _(text))
    for param in getattr(command, "params", []):
        text = getattr(param, "help", None)
        if isinstance(text, str) and text:
            param.help = _(text)
    for sub in getattr(command, "commands", {}).values():
        translate_help(sub)
    return command


def help_texts(command: Any) -> Iterator[str]:
    """Every help text of a click command tree (for the catalog and its completeness test)."""
    for attr in ("help", "short_help", "epilog"):
        text = getattr(command, attr, None)
        if isinstance(text, str) and text:
            yield text
    for param in getattr(command, "params", []):
        text = getattr(param, "help", None)
        if isinstance(text, str) and text:
            yield text
    for sub in getattr(command, "commands", {}).values():
        yield from help_texts(sub)


@contextmanager
def activated() -> Iterator[None]:
    """click's and typer's own texts through our catalog for the duration of a CLI call."""
    gettext.bindtextdomain(DOMAIN, LOCALE_DIR)
    previous = gettext.textdomain()
    gettext.textdomain(DOMAIN)
    try:
        yield
    finally:
        gettext.textdomain(previous)
