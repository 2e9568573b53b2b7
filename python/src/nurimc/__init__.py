"""nurimc: toolkit for Nurirobot MC and BLMC-H motor controllers (MC-RS485 V1.0.1)."""

__version__ = "0.1.0"
