"""A flight on a TAK map (ATAK, WinTAK, iTAK, a TAK server): Cursor-on-Target built from the plan,
the vehicles' telemetry and the flight's events (`cot`, pure; `publisher`, what is sent when),
sent to a TAK server over TCP or TLS or to the mesh's UDP multicast group (`destination`,
`sender`), by a watcher of `gcs fly` (`flight_feed.TakFeed`) or of a second station on the fleet
bus (`bus_feed`). docs/tak.md.

The CoT is made and sent with pytak (and takproto for TAK protocol 1), which only the modules
that need it import (through `gcs.tak.pytak_module`), so a command loads it only when given
`--tak`; `settings` is light."""
