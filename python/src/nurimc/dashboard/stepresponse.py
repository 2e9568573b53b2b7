"""Step-response figures for tuning: moved to the library (nurimc.stepresponse); kept here so
the console's imports stay as they were."""

from __future__ import annotations

from ..stepresponse import StepFigures, analyse

__all__ = ["StepFigures", "analyse"]
