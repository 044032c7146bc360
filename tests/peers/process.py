"""What every SITL peer shares: a process started in a working folder of its own, stopped (and
its folder deleted) when the `with` block ends."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Self


class SitlProcess:
    """Mixin for a dataclass with `process` and `workdir` fields and a `start()` returning self."""

    process: subprocess.Popen | None
    workdir: Path | None

    def start(self) -> Self:
        raise NotImplementedError

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5)
        self.process = None
        if self.workdir is not None:
            shutil.rmtree(self.workdir, ignore_errors=True)
            self.workdir = None

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
