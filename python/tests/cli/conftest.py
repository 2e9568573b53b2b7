"""The CLI's tests read English unless a test asks for Korean (test_korean.py): LANGUAGE, which
gettext reads first, is set to English for every test here, whatever the machine's locale."""

from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def english(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LANGUAGE", "en")
