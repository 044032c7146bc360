"""PX4 SITL (v1.15.3, built-in SIH simulator) as a test peer: `Px4Sitl` starts one instance with
the peers folder's `run-sitl` (its README lists ports, start-up times and quirks) and stops it.

The shared bundle's `bin/px4-*` module aliases are plain files where PX4 expects symbolic links
to `px4` (rcS then fails with "px4-param: Permission denied"), so the first start makes a private
copy of the bundle with the links restored; the binary and its start-up files are used as they
are. PX4 does not exit with its parent: `stop()` kills it, and deletes its working folder.

The station talks to an instance on its GCS port (`udpout:127.0.0.1:18570+I`: PX4 answers the
first address that speaks to it, for good); parameters are set beforehand through the instance's
API port (14580+I), so the GCS port is still free for the station."""

from __future__ import annotations

import fcntl
import os
import shutil
import struct
import subprocess
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import pytest

from tests.peers.ardupilot import peers_dir
from tests.peers.process import InstanceClaim, SitlProcess, claim, exclusive, hold, port_free, udp_bound

#: PX4's simulated battery drains 100 % over SIM_BAT_DRAIN seconds of armed vehicle time (its
#: default, 60 s, then stops at SIM_BAT_MIN_PCT 50 %); an hour keeps it well above the reserve
#: for a whole search
STEADY_BATTERY = {"SIM_BAT_DRAIN": 3600.0, "SIM_BAT_MIN_PCT": 5.0}

_BUNDLE_COPY = Path(tempfile.gettempdir()) / f"gcs-px4-bundle-{os.getuid()}"
#: The tests' `px4-rc.params` and `px4-rc.mavlink`, which rcS sources from PATH before its own
#: (PX4's place for an instance's own parameters and streams): no flight log, no developer's
#: extra streams. Measured idle at a speed-up of 5 with a client reading the GCS link: PX4 0.58
#: of a core and the client 0.14 with the bundle's files, 0.45 and 0.07 (224 messages a second
#: instead of 1,533) with these.
RC_OVERRIDES = Path(__file__).parent / "px4_rc"
#: A PX4's speed-up (docs/tests.md, "Speed-ups"): with RC_OVERRIDES about 0.09 of a core per unit
#: (measured at 5), so some three quarters of a core at 8; at 10 a station's upload was refused
#: ("IGN MISSION_ITEM: No transfer"): PX4 times a transfer out after 5 s of its own time.
PX4_SPEEDUP = 8.0
KIND = "px4"


class _NoPorts(Exception):
    """PX4 ran but did not open its MAVLink ports; `log` is the tail of its output."""

    def __init__(self, log: str) -> None:
        super().__init__(log)
        self.log = log


def px4_dir() -> Path:
    return peers_dir() / "px4"


def require_px4() -> Path:
    folder = px4_dir()
    if not (folder / "run-sitl").exists():
        pytest.skip(f"PX4 SITL not found at {folder} (set GCS_PEERS_DIR to the peers folder)")
    if shutil.which("bc") is None:
        raise RuntimeError("PX4's rcS needs bc for a speed-up (tools/setup --test installs it)")
    return folder


def _bundle() -> Path:
    """A copy of the PX4 bundle whose module aliases are symbolic links to `px4` (made once, by
    one test process while the others wait)."""
    src = require_px4()
    with exclusive("px4-bundle"):
        return _bundle_copy(src)


def _bundle_copy(src: Path) -> Path:
    if (_BUNDLE_COPY / "bin" / "px4").exists() and (_BUNDLE_COPY / "bin" / "px4-param").is_symlink():
        return _BUNDLE_COPY
    staging = Path(tempfile.mkdtemp(prefix="gcs-px4-bundle-"))
    shutil.copytree(src / "etc", staging / "etc")
    shutil.copy2(src / "run-sitl", staging / "run-sitl")
    (staging / "bin").mkdir()
    shutil.copy2(src / "bin" / "px4", staging / "bin" / "px4")
    shutil.copy2(src / "bin" / "px4-alias.sh", staging / "bin" / "px4-alias.sh")
    for alias in (src / "bin").glob("px4-*"):
        if alias.name != "px4-alias.sh":
            (staging / "bin" / alias.name).symlink_to("px4")
    for path in (staging / "run-sitl", staging / "bin" / "px4", staging / "bin" / "px4-alias.sh"):
        path.chmod(0o755)
    for root, dirs, files in os.walk(staging / "etc"):
        for name in dirs + files:
            target = Path(root) / name
            if not target.is_symlink():
                target.chmod(target.stat().st_mode | 0o200)
    shutil.rmtree(_BUNDLE_COPY, ignore_errors=True)
    staging.rename(_BUNDLE_COPY)
    return _BUNDLE_COPY


def _free(instance: int) -> bool:
    """Whether no PX4 server runs as `instance` (it holds a POSIX lock on /tmp/px4_lock-N while it
    does, wherever it was started from) and the instance's ports are free."""
    with open(f"/tmp/px4_lock-{instance}", "a") as lock:
        try:
            fcntl.lockf(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return False
        fcntl.lockf(lock, fcntl.LOCK_UN)
    return all(port_free(p + instance, udp=True) for p in (18570, 14580, 14280, 13030, 19450))


def claim_instance(instance: int | None = None) -> InstanceClaim:
    """`instance`, or the lowest free instance number, held for this process (see
    `tests.peers.process`; PX4 itself refuses a second `-i N` on the machine)."""
    if instance is not None:
        return claim(KIND, _free, count=1, first=instance)
    return claim(KIND, _free, count=20)


def _hold_udp_14550(alone: bool) -> IO[str]:
    """Every PX4 instance sends to 127.0.0.1:14550 until a station calls it on its GCS port, so a
    station that listens there must have the only PX4 running: an `alone` instance holds this
    lock alone, every other one shared."""
    return hold("px4-14550", alone=alone)


@dataclass
class Px4Sitl(SitlProcess):
    """One PX4 SITL process; `gcs_connection` is the station's link to it. `alone`: no other PX4
    instance of these tests runs meanwhile (for a station listening on UDP 14550)."""

    vehicle: str = "copter"
    home: tuple[float, float, float] = (47.2771883, 11.4039709, 584.0)
    sysid: int = 1
    speedup: float = PX4_SPEEDUP
    params: dict[str, float | int] = field(default_factory=dict)  # int: an INT32 parameter
    instance: int | None = None
    alone: bool = False
    process: subprocess.Popen | None = None
    workdir: Path | None = None
    claim: InstanceClaim | None = None
    _udp_14550: IO[str] | None = None

    @property
    def gcs_port(self) -> int:
        assert self.instance is not None
        return 18570 + self.instance

    @property
    def gcs_connection(self) -> str:
        return f"udpout:127.0.0.1:{self.gcs_port}"

    @property
    def api_connection(self) -> str:
        assert self.instance is not None
        return f"udpout:127.0.0.1:{14580 + self.instance}"

    @property
    def payload_connection(self) -> str:
        """The payload (camera) port: what PX4 hears there it forwards to the station, and back."""
        assert self.instance is not None
        return f"udpout:127.0.0.1:{14280 + self.instance}"

    def start(self) -> Px4Sitl:
        """Start PX4 and wait for its MAVLink ports; once more, on a fresh instance, when they do
        not open in 90 s, warning with its log's tail (the real CI of 1118e4d: a fleet's second PX4
        never opened them; until d69ed74 the wait probed the port by binding it, which a PX4 binding
        it at that moment fails on), and then fail with the tail of both logs."""
        requested = self.instance
        try:
            return self._start()
        except _NoPorts as first:
            warnings.warn(f"PX4 did not open its MAVLink ports in 90 s, started once more: {first.log}", stacklevel=2)
            self.instance = requested
            try:
                return self._start()
            except _NoPorts as second:
                raise AssertionError(f"PX4 did not open its MAVLink ports, twice: {first.log}\n---\n{second.log}") \
                    from None

    def _start(self) -> Px4Sitl:
        bundle = _bundle()
        self._udp_14550 = _hold_udp_14550(self.alone)
        self.claim = claim_instance(self.instance)
        self.instance = self.claim.number
        self.workdir = Path(tempfile.mkdtemp(prefix=f"px4-{self.vehicle}-{self.instance}-"))
        env = dict(os.environ, SPEEDUP=f"{self.speedup:g}", WIPE="1", SYSID=str(self.sysid),
                   PX4_SITL_HOME=str(self.workdir), PATH=f"{RC_OVERRIDES}{os.pathsep}{os.environ['PATH']}")
        lat, lon, alt = self.home[:3]
        log = open(self.workdir / "px4.log", "wb")
        self.process = subprocess.Popen([str(bundle / "run-sitl"), self.vehicle, str(self.instance), f"{lat:.7f}",
                                         f"{lon:.7f}", f"{alt:g}"], env=env, stdout=log, stderr=subprocess.STDOUT,
                                        cwd=self.workdir, start_new_session=True)
        log.close()
        # rcS runs a client process per parameter: on a loaded machine PX4 takes well over 30 s
        deadline = time.monotonic() + 90.0
        while not udp_bound(self.gcs_port):  # the GCS port is bound once PX4's mavlink is up
            if self.process.poll() is not None:
                log_text = (self.workdir / "px4.log").read_text()[-2000:]
                self.stop()
                raise RuntimeError(f"PX4 exited at start: {log_text}")
            if time.monotonic() > deadline:
                log_text = (self.workdir / "px4.log").read_text(errors="replace")[-2000:]
                self.stop()  # PX4 does not end with its parent
                raise _NoPorts(log_text)
            time.sleep(0.05)
        if self.params:
            self._set_params()
        return self

    def stop(self) -> None:
        super().stop()
        if self._udp_14550 is not None:
            self._udp_14550.close()
            self._udp_14550 = None

    def _set_params(self) -> None:
        """PARAM_SET through the API port, confirmed by PARAM_VALUE, before the station connects."""
        os.environ.setdefault("MAVLINK20", "1")
        from pymavlink import mavutil

        conn = mavutil.mavlink_connection(self.api_connection, source_system=250, source_component=190)
        try:
            for name, value in self.params.items():
                # an int goes as MAV_PARAM_TYPE_INT32, its bytes in the float field (PX4's encoding)
                is_int = isinstance(value, int)
                wire = struct.unpack("<f", struct.pack("<i", value))[0] if is_int else float(value)
                for _ in range(50):
                    conn.mav.param_set_send(self.sysid, 1, name.encode(), wire, 6 if is_int else 9)
                    msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
                    if msg is None or msg.param_id.rstrip("\x00") != name:
                        continue
                    got = struct.unpack("<i", struct.pack("<f", msg.param_value))[0] if is_int else msg.param_value
                    if abs(got - value) < 1e-6:
                        break
                else:
                    raise RuntimeError(f"PX4 did not confirm {name} = {value}")
        finally:
            conn.close()
