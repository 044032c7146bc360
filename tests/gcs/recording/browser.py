"""Headless Chromium driven through its DevTools protocol (websockets), for the web-viewer test."""

from __future__ import annotations

import asyncio
import base64
import json
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

CHROMIUM = Path("/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
         "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
         "--window-size=1600,1000"]


def _json(url: str):
    with urllib.request.urlopen(url, timeout=5) as reply:
        return json.loads(reply.read())


class Browser:
    """One headless Chromium with one page; `screenshots(url, ...)` loads a URL and captures PNGs."""

    def __init__(self, port: int) -> None:
        self.port = port
        # Chromium's helper processes can still be writing its profile as the browser exits (ci47:
        # "Directory not empty: 'Default'" at clean-up); what they leave is a temporary folder
        self.profile = tempfile.TemporaryDirectory(prefix="gcs-chromium-", ignore_cleanup_errors=True)
        self.proc = subprocess.Popen([str(CHROMIUM), *FLAGS, f"--remote-debugging-port={port}",
                                      f"--user-data-dir={self.profile.name}", "about:blank"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 30
        while True:
            try:
                self.page_ws = next(t["webSocketDebuggerUrl"] for t in _json(f"http://127.0.0.1:{port}/json")
                                    if t["type"] == "page")
                return
            except (OSError, StopIteration, ValueError) as err:
                if time.monotonic() > deadline or self.proc.poll() is not None:
                    self.close()
                    raise RuntimeError("chromium did not start its DevTools endpoint") from err
                time.sleep(0.2)

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.profile.cleanup()

    def visit(self, url: str, until, timeout_s: float = 90.0, every_s: float = 2.0) -> tuple[bytes, str, bool]:
        """Load `url`, then take a screenshot every `every_s` until `until(png_bytes)` is true or the
        time is up; returns (last png, page title, whether `until` held)."""
        return asyncio.run(self._visit(url, until, timeout_s, every_s))

    async def _visit(self, url, until, timeout_s, every_s):
        import websockets

        async with websockets.connect(self.page_ws, max_size=64 * 2**20) as ws:
            counter = 0

            async def call(method: str, **params):
                nonlocal counter
                counter += 1
                mine = counter
                await ws.send(json.dumps({"id": mine, "method": method, "params": params}))
                while True:
                    message = json.loads(await ws.recv())
                    if message.get("id") == mine:
                        if "error" in message:
                            raise RuntimeError(f"{method}: {message['error']}")
                        return message["result"]

            await call("Page.enable")
            await call("Emulation.setDeviceMetricsOverride", width=1600, height=1000, deviceScaleFactor=1, mobile=False)
            await call("Page.navigate", url=url)
            deadline = time.monotonic() + timeout_s
            png, ok = b"", False
            while time.monotonic() < deadline:
                await asyncio.sleep(every_s)
                png = base64.b64decode((await call("Page.captureScreenshot", format="png"))["data"])
                if until(png):
                    ok = True
                    break
            title = (await call("Runtime.evaluate", expression="document.title"))["result"].get("value", "")
            return png, title, ok
