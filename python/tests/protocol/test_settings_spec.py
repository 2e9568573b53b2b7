"""The generated settings map (spec/settings.json -> nurimc.protocol._settings) agrees with the library."""

from __future__ import annotations

from nurimc.procedures.settings import SETTINGS
from nurimc.protocol import SPECS
from nurimc.protocol._settings import SETTINGS as GENERATED


def test_every_library_setting_is_in_the_spec_map_with_the_same_messages() -> None:
    generated = {s["name"]: s for s in GENERATED}
    assert set(generated) == set(SETTINGS)
    for name, setting in SETTINGS.items():
        row = generated[name]
        assert (row["command"], row["request"], row["answer"], row["field"]) == (
            setting.command,
            setting.request,
            setting.answer,
            setting.field,
        ), name


def test_scales_ranges_and_value_names_are_the_fields_own() -> None:
    for row in GENERATED:
        field = next(f for f in SPECS[row["answer"]].fields if f.name == row["field"])
        assert (row["scale"], row["min"], row["max"]) == (field.scale, field.min, field.max)
        assert row["values"] == dict(field.values)
        assert (row["input"] == "choice") == bool(field.values)
