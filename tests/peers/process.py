"""What every SITL peer shares: a process started in a working folder of its own, stopped (and
its folder deleted) when the `with` block ends."""

from __future__ import annotations

import shutil
import socket
import subprocess
from pathlib import Path
from typing import Self


def port_free(port: int, *, udp: bool = False) -> bool:
    """Whether a loopback TCP (or UDP) port can be bound now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM if udp else socket.SOCK_STREAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def stop_process(process: subprocess.Popen) -> None:
    """Terminate, and kill what does not end within 10 s."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(5)


class SitlProcess:
    """Mixin for a dataclass with `process` and `workdir` fields and a `start()` returning self."""

    process: subprocess.Popen | None
    workdir: Path | None

    def start(self) -> Self:
        raise NotImplementedError

    def stop(self) -> None:
        if self.process is not None:
            stop_process(self.process)
        self.process = None
        if self.workdir is not None:
            shutil.rmtree(self.workdir, ignore_errors=True)
            self.workdir = None

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
