"""The web console: `nurimc dashboard` serves a page that discovers, plots, drives and tunes motors.

The server owns the serial port (one worker thread runs every bus transaction); browsers talk to
it over one websocket per page. See docs/dashboard.md.
"""

from .security import ListenAddress, SecurityPolicy, parse_listen
from .server import DashboardConfig, create_app

__all__ = ["DashboardConfig", "ListenAddress", "SecurityPolicy", "create_app", "parse_listen"]
