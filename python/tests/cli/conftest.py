"""Every CLI test reads English unless it asks for Korean (test_korean.py): LANGUAGE, which
gettext reads first, is set to English whatever the machine's locale. Restore journals
(nurimc.procedures.journal) go to a folder of their own, never the user's state directory: a journal
left by a failing case must not reach another test or run."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def english(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LANGUAGE", "en")


@pytest.fixture(autouse=True, scope="session")
def _state_dir(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    directory = tmp_path_factory.mktemp("nurimc-state")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("NURIMC_STATE_DIR", str(directory))
        yield directory
