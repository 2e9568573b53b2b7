"""The package's version: one place below every layer, so that any layer may say it (the bus
service's handshake, a recording's library field, `nurimc --version`). python/pyproject.toml
carries the same number (tests/packaging checks they agree)."""

__version__ = "0.1.0"
