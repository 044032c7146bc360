"""pymavlink's MAVLink 2 codec (ArduPilot's dialect, a superset of common), imported once with
MAVLINK20 set so every message is framed as MAVLink 2 (signing needs it)."""

from __future__ import annotations

import os

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

__all__ = ["MAVMessage", "mavlink"]

MAVMessage = mavlink.MAVLink_message
