"""`gcs replay`: bad files are one error line; `--web` serves a viewer that Chromium renders."""

from __future__ import annotations

import io
import os
import select
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from gcs.cli import main
from gcs.recording.plan import map_to_rgb
from gcs.recording.replay import viewer_command
from tests.gcs.recording.browser import Browser
from tests.gcs.recording.conftest import RecordedRun
from tests.peers.ports import free_port

ROOT = Path(__file__).parents[3]


def _one_error_line(capsys, argv: list[str]) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    return lines[0]


def test_missing_recording_is_one_error_line(tmp_path: Path, capsys):
    assert "no such recording" in _one_error_line(capsys, ["replay", str(tmp_path / "nope.rrd")])


def test_non_rrd_files_are_one_error_line(tmp_path: Path, capsys):
    text = tmp_path / "plan.json"
    text.write_text("{}")
    assert "expected a .rrd file" in _one_error_line(capsys, ["replay", str(text)])
    fake = tmp_path / "fake.rrd"
    fake.write_bytes(b"PK\x03\x04 not a recording")
    assert "bad header" in _one_error_line(capsys, ["replay", str(fake)])
    assert "not a file" in _one_error_line(capsys, ["replay", str(tmp_path)])


def test_viewer_program_is_found():
    cmd = viewer_command()
    assert Path(cmd[0]).exists()
    version = subprocess.run(cmd + ["--version"], capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and "0.41" in version.stdout


def _pixels_near(png: bytes, colour: np.ndarray, tolerance: int = 25) -> int:
    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int64)
    return int((np.abs(image - colour.astype(np.int64)).sum(axis=-1) < tolerance).sum())


def recording_visible(png: bytes) -> bool:
    """The TEP map is on screen: many pixels of the prior's 0.5 colour and of the key regions' 0.9."""
    return (_pixels_near(png, map_to_rgb(np.array([[0.5]]))[0, 0]) > 3000
            and _pixels_near(png, map_to_rgb(np.array([[0.9]]))[0, 0]) > 300)


def _read_line(proc: subprocess.Popen, timeout_s: float) -> str:
    ready, _, _ = select.select([proc.stdout], [], [], timeout_s)
    assert ready, "gcs replay --web printed nothing"
    return proc.stdout.readline()


#: Chromium draws Rerun's viewer with its software rasteriser, about a core (ci34); beside three
#: workers' flights at load 5 it had not drawn the recording in 120 s (ci36)
@pytest.mark.cpu_alone
def test_web_replay_serves_the_recording_to_headless_chromium(chromium, recorded_run: RecordedRun, tmp_path: Path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "replay", str(recorded_run.rrd), "--web"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    browser = None
    try:
        line = _read_line(proc, 60)
        assert line.startswith(f"serving {recorded_run.rrd} at http://127.0.0.1:"), line
        url = line.split(" at ")[1].split()[0]
        web_port = int(url.split(":")[2].split("/")[0])
        browser = Browser(free_port())
        png, title, ok = browser.visit(url, recording_visible, timeout_s=120)
        (tmp_path / "viewer.png").write_bytes(png)
        assert title == "Rerun Viewer"
        assert ok, f"the viewer never showed the recording: see {tmp_path / 'viewer.png'}"
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0
        with pytest.raises(OSError):
            socket.create_connection(("127.0.0.1", web_port), timeout=1).close()
    finally:
        if browser is not None:
            browser.close()
        if proc.poll() is None:  # a failed test: still stopped by Ctrl-C, which stops its rerun server too
            proc.send_signal(signal.SIGINT)  # (killed, it left that server serving for 40 minutes, ci36)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def test_blank_page_is_not_taken_for_the_recording():
    blank = io.BytesIO()
    Image.new("RGB", (1600, 1000), (13, 16, 17)).save(blank, format="PNG")
    assert not recording_visible(blank.getvalue())
