"""ArduCopter / ArduPlane SITL as a test peer: `ArduPilotSitl` starts one instance with
`run-sitl` (its README lists ports, start-up times and quirks), pushing MAVLink to a UDP port
of ours and listening on its TCP ports, and stops it again.

Tests that use it carry the `autopilot` marker; `require_ardupilot()` skips them, saying why,
only where the peers folder is absent."""

from __future__ import annotations

import os
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from tests.peers.ports import free_udp_port
from tests.peers.process import InstanceClaim, SitlProcess, claim, port_free, tcp_listening

REPO = Path(__file__).resolve().parents[2]
KIND = "ardupilot"


def peers_dir() -> Path:
    return Path(os.environ.get("GCS_PEERS_DIR", REPO.parent / "shared" / "peers"))


def ardupilot_dir() -> Path:
    return peers_dir() / "ardupilot"


def require_ardupilot() -> Path:
    folder = ardupilot_dir()
    if not (folder / "run-sitl").exists():
        pytest.skip(f"ArduPilot SITL not found at {folder} (set GCS_PEERS_DIR to the peers folder)")
    return folder


def _ports_free(instance: int) -> bool:
    """Whether the instance's TCP ports (5760 + 10 I, 5762 + 10 I, 5763 + 10 I) and its RC input
    (UDP 5501 + 10 I) are free."""
    return (all(port_free(5760 + 10 * instance + k) for k in (0, 2, 3))
            and port_free(5501 + 10 * instance, udp=True))


def claim_instance(instance: int | None = None) -> InstanceClaim:
    """`instance`, or the lowest free instance number, held for this process (see
    `tests.peers.process`)."""
    if instance is not None:
        return claim(KIND, _ports_free, count=1, first=instance)
    return claim(KIND, _ports_free, count=50)


#: ArduCopter SITL's physics at 800 Hz, not 1200: the least the autopilot arms with at its 400 Hz
#: loop (its pre-arm check wants the gyro at 1.8 times the loop rate: at 400 Hz it refused, "Gyro 0
#: rate 400Hz < loop ratex1.8 720Hz"). The four three-copter flights of test_energy_fleets.py
#: took 139.5 CPU-s instead of 157.6 (docs/tests.md), their verdicts unchanged.
COPTER_PHYSICS = {"SIM_RATE_HZ": 800.0}


@dataclass
class ArduPilotSitl(SitlProcess):
    """One SITL process. `gcs_port`: the UDP port SERIAL1 pushes to (`udpin:127.0.0.1:PORT` on our
    side); `tcp_port`: SERIAL0; `tcp_port_2`: SERIAL2 (a companion computer's port)."""

    vehicle: str = "copter"
    home: tuple[float, float, float, float] = (47.2771883, 11.4039709, 584.0, 90.0)
    sysid: int = 1
    speedup: float = 10.0
    params: dict[str, float] = field(default_factory=dict)
    gcs_port: int | None = None
    instance: int | None = None
    serial2: str | None = None
    process: subprocess.Popen | None = None
    workdir: Path | None = None
    claim: InstanceClaim | None = None

    @property
    def tcp_port(self) -> int:
        assert self.instance is not None
        return 5760 + 10 * self.instance

    @property
    def tcp_port_2(self) -> int:
        assert self.instance is not None
        return 5763 + 10 * self.instance

    @property
    def udp_connection(self) -> str:
        return f"udpin:127.0.0.1:{self.gcs_port}"

    @property
    def tcp_connection(self) -> str:
        return f"tcp:127.0.0.1:{self.tcp_port}"

    def start(self) -> ArduPilotSitl:
        folder = require_ardupilot()
        self.claim = claim_instance(self.instance)
        self.instance = self.claim.number
        self.gcs_port = self.gcs_port or free_udp_port()
        self.workdir = Path(tempfile.mkdtemp(prefix=f"sitl-{self.vehicle}-{self.instance}-"))
        env = dict(os.environ, SPEEDUP=f"{self.speedup:g}", WIPE="1", SYSID=str(self.sysid),
                   SITL_HOME=str(self.workdir))
        params = (COPTER_PHYSICS if self.vehicle == "copter" else {}) | self.params
        if params:
            extra = self.workdir / "extra.parm"
            extra.write_text("".join(f"{k} {v:g}\n" for k, v in params.items()))
            env["EXTRA_PARAMS"] = str(extra)
        lat, lon, alt, hdg = self.home
        args = [str(folder / "run-sitl"), self.vehicle, str(self.instance), f"{lat:.7f}", f"{lon:.7f}", f"{alt:g}",
                f"{hdg:g}", "--serial1", f"udpclient:127.0.0.1:{self.gcs_port}"]
        if self.serial2:
            args += ["--serial2", self.serial2]
        log = open(self.workdir / "sitl.log", "wb")
        self.process = subprocess.Popen(args, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=self.workdir)
        log.close()
        deadline = time.monotonic() + 20.0
        # SERIAL0 listens once the process is up, SERIAL2 a moment later (a camera connecting to it
        # at once was refused, ci41)
        while not tcp_listening(self.tcp_port) or (self.serial2 is None and not tcp_listening(self.tcp_port_2)):
            if self.process.poll() is not None:
                raise RuntimeError(f"SITL exited at start: {(self.workdir / 'sitl.log').read_text()[-2000:]}")
            assert time.monotonic() < deadline, "SITL did not open its TCP ports"
            time.sleep(0.05)
        return self

    def fence_status(self, timeout_s: float = 10.0):
        """The vehicle's FENCE_STATUS (breach count since boot, whether it is outside the fence
        now), asked for on SERIAL0; None when none comes (ArduPilot sends it only while a fence
        is enabled and present)."""
        from pymavlink import mavutil

        link = mavutil.mavlink_connection(self.tcp_connection, source_system=250, source_component=190)
        try:
            if link.wait_heartbeat(timeout=timeout_s) is None:
                return None
            deadline = time.monotonic() + timeout_s
            while time.monotonic() < deadline:
                link.mav.command_long_send(self.sysid, 1, mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                           mavutil.mavlink.MAVLINK_MSG_ID_FENCE_STATUS, 0, 0, 0, 0, 0, 0)
                status = link.recv_match(type="FENCE_STATUS", blocking=True, timeout=1.0)
                if status is not None:
                    return status
            return None
        finally:
            link.close()
