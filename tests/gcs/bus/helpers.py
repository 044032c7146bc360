"""A real Mosquitto broker on a free loopback port, and a small scripted fleet feeding the bus."""

from __future__ import annotations

import getpass
import json
import os
import signal
import socket
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gcs.bus import Command, CommandKind, FleetBus, Telemetry
from tests.peers.ports import free_port

MOSQUITTO = "/usr/sbin/mosquitto"
MOSQUITTO_PASSWD = "/usr/bin/mosquitto_passwd"


def ensure_mosquitto() -> None:
    """Install the broker when this machine lacks it (needs root)."""
    if os.path.exists(MOSQUITTO) and os.path.exists(MOSQUITTO_PASSWD):
        return
    subprocess.run(["apt-get", "update"], check=True, capture_output=True)
    subprocess.run(["apt-get", "install", "-y", "mosquitto"], check=True, capture_output=True,
                   env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"})


class Mosquitto:
    """One broker process with a config file written in `workdir`; `restart()` keeps the port and
    the persistence file, so retained messages and persistent sessions survive it."""

    def __init__(self, workdir: Path, extra_config: str = "", allow_anonymous: bool = True) -> None:
        ensure_mosquitto()
        self.workdir = workdir
        self.port = free_port()
        self.config = workdir / "mosquitto.conf"
        self.log = workdir / "mosquitto.log"
        self.config.write_text(
            f"listener {self.port} 127.0.0.1\n"
            f"allow_anonymous {'true' if allow_anonymous else 'false'}\n"
            f"user {getpass.getuser()}\n"
            f"persistence true\npersistence_location {workdir}/\n"
            f"log_dest file {self.log}\nlog_type error\nlog_type warning\nlog_type notice\n"
            "max_queued_messages 100000\nset_tcp_nodelay true\n"
            + extra_config)
        self.process: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> None:
        self.process = subprocess.Popen([MOSQUITTO, "-c", str(self.config)], stdout=subprocess.DEVNULL,
                                        stderr=subprocess.PIPE)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"mosquitto exited: {self.process.stderr.read().decode()} "
                                   f"{self.log.read_text() if self.log.exists() else ''}")
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                return
            except OSError:
                time.sleep(0.02)
        raise RuntimeError("mosquitto did not open its port")

    def stop(self) -> None:
        """SIGTERM: the broker saves its persistence file and exits."""
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            self.process.wait(10)
        self.process = None

    def restart(self) -> None:
        self.stop()
        self.start()


def make_password_file(path: Path, users: dict[str, str]) -> Path:
    path.write_text("")
    for user, password in users.items():
        subprocess.run([MOSQUITTO_PASSWD, "-b", str(path), user, password], check=True, capture_output=True)
    return path


def docs_acl() -> str:
    """The ACL printed in docs/bus.md, so the test checks what users copy."""
    text = (Path(__file__).resolve().parents[3] / "docs" / "bus.md").read_text(encoding="utf-8")
    start = text.index("```text\n# mosquitto ACL") + len("```text\n")
    return text[start:text.index("```", start)]


@dataclass
class ScriptedFleet:
    """UAVs flying straight lines with a draining battery: telemetry every `tick`, events as
    their stages change, and a command handler with the refusals a real fleet gives."""

    bus: FleetBus
    uav_ids: tuple[int, ...] = (1, 2, 3, 4)
    seed: int = 0
    stage: dict[int, str] = field(default_factory=dict)
    ranges: dict[int, int] = field(default_factory=dict)
    commands: list[Command] = field(default_factory=list)
    raised: dict[int, list[dict]] = field(default_factory=dict)
    last_sample: dict[int, Telemetry] = field(default_factory=dict)
    step: float = 0  # ticks so far (a test may set it from the clock)

    def __post_init__(self) -> None:
        rng = np.random.default_rng(self.seed)
        self.heading = {u: float(h) for u, h in zip(self.uav_ids, rng.uniform(0, 360, len(self.uav_ids)))}
        for u in self.uav_ids:
            self.stage[u] = "search"
            self.ranges[u] = 1300.0
            self.raise_event(u, "takeoff", text="airborne")

    def raise_event(self, uav: int, kind: str, reason: str | None = None, text: str = "", **data) -> None:
        seq = self.bus.event(uav, kind, reason=reason, text=text, data=data, stage=self.stage[uav])
        self.raised.setdefault(uav, []).append({"seq": seq, "kind": kind, "reason": reason, "text": text, "data": data})

    def tick(self) -> None:
        self.step += 1
        for u in self.uav_ids:
            sample = Telemetry(u, self.stage[u], lat_deg=45.0 + 1e-5 * self.step * u, lon_deg=7.0 + 1e-5 * self.step,
                               alt_m=30.0, heading_deg=self.heading[u], battery_pct=max(0.0, 100.0 - 0.1 * self.step),
                               range_left_m=self.ranges[u] - self.step, margin_m=125.0)
            self.bus.telemetry(sample)
            self.last_sample[u] = sample

    async def handle(self, command: Command) -> str | None:
        self.commands.append(command)
        targets = list(self.uav_ids) if command.uav is None else [command.uav]
        if command.uav is not None and command.uav not in self.uav_ids:
            return f"unknown UAV {command.uav} (the fleet has {', '.join(map(str, self.uav_ids))})"
        if command.kind is CommandKind.RANGE:
            self.ranges[command.uav] = command.range_m
            return None
        if (command.kind is CommandKind.RETURN and command.uav is not None
                and self.stage[command.uav] in ("return", "rtl")):
            return f"UAV {command.uav} is already returning"
        for u in targets:
            if self.stage[u] == "search":
                self.stage[u] = "return" if command.kind is CommandKind.RETURN else "rtl"
                self.raise_event(u, "return" if command.kind is CommandKind.RETURN else "rtl", reason="mqtt",
                                 text=f"ordered by {command.sender or 'the bus'}")
        return None


def payload_of(message) -> dict:
    return json.loads(message.payload)
