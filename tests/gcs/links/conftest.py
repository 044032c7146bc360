"""Fixtures for the link tests: a simulated fleet on free loopback ports (UDP, and TCP when
asked) and a pseudo-terminal pair made by socat, the two ends of a serial cable."""

from __future__ import annotations

import shutil
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from sim import FleetOptions, HomePose, SimFleet, VehicleConfig

HOMES = [HomePose(-35.3632, 149.1652), HomePose(-35.3633, 149.1653), HomePose(-35.3634, 149.1654)]


@pytest.fixture
def make_fleet() -> Iterator:
    fleets: list[SimFleet] = []

    def make(count: int = 1, **options) -> SimFleet:
        options.setdefault("base_port", 0)
        options.setdefault("speedup", 10.0)
        # ready to arm at once: these tests are about links, not about an autopilot's start-up
        fleet = SimFleet(HOMES[:count], VehicleConfig(boot_scale=0.0), FleetOptions(**options)).start()
        fleets.append(fleet)
        return fleet

    yield make
    for fleet in fleets:
        fleet.stop()


class SerialCable:
    """Two linked pseudo-terminals (`vehicle_end`, `station_end`) made by socat; `unplug()` and
    `plug()` make both disappear and come back, as a USB radio pulled out and put back."""

    def __init__(self, folder: Path) -> None:
        self.vehicle_end = str(folder / "vehicle")
        self.station_end = str(folder / "station")
        self._process: subprocess.Popen | None = None

    def plug(self) -> None:
        self._process = subprocess.Popen(["socat", f"pty,raw,echo=0,link={self.vehicle_end}",
                                          f"pty,raw,echo=0,link={self.station_end}"], stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 5.0
        while not (Path(self.vehicle_end).exists() and Path(self.station_end).exists()):
            assert time.monotonic() < deadline, "socat made no pseudo-terminals"
            time.sleep(0.02)

    def unplug(self) -> None:
        if self._process is not None:
            self._process.terminate()
            self._process.wait(5)
            self._process = None
        deadline = time.monotonic() + 5.0
        while Path(self.station_end).exists() and time.monotonic() < deadline:
            time.sleep(0.02)


@pytest.fixture
def serial_cable(tmp_path) -> Iterator[SerialCable]:
    assert shutil.which("socat"), "socat is installed by tools/setup --test"
    cable = SerialCable(tmp_path)
    cable.plug()
    yield cable
    cable.unplug()
