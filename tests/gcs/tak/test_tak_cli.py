"""The TAK options of `gcs fly` and `gcs watch`: bad ones are one `error:` line, exit 2, before
anything is planned, written or flown; `--help` and a flight without `--tak` never load pytak."""

from __future__ import annotations

import subprocess
import sys

import pytest

from gcs.cli import main
from tests.gcs.tak.conftest import SQUARE


@pytest.mark.parametrize(("args", "error"), [
    (["--tak", "ftp://127.0.0.1:8087"], "--tak 'ftp://127.0.0.1:8087': expected tcp://HOST:PORT (a TAK server)"),
    (["--tak", "tls://127.0.0.1:8089"], "--tak tls://127.0.0.1:8089: a TAK server's TLS input needs a client "
                                        "certificate: give --tak-cert"),
    (["--tak-cert", "client.pem"], "--tak-cert needs --tak URL"),
    (["--tak-interface", "127.0.0.1"], "--tak-interface needs --tak URL"),
    (["--tak", "tcp://127.0.0.1", "--tak-ca", "ca.pem"], "--tak-key, --tak-ca and --tak-insecure go with --tak-cert"),
    (["--tak", "tcp://127.0.0.1", "--tak-every-s", "0"], "--tak-every-s must be > 0"),
    (["--tak", "tcp://127.0.0.1", "--tak-every-s", "5", "--tak-stale-s", "5"],
     "--tak-stale-s must be longer than --tak-every-s"),
    (["--tak", "tcp://127.0.0.1", "--tak-name", "north field"], "--tak-name 'north field' must be 1-32 letters"),
    (["--tak", "udp://239.2.3.1", "--tak-interface", "lo"], "--tak-interface 'lo': expected this machine's IPv4"),
    (["--tak", "tcp://127.0.0.1", "--tak-interface", "127.0.0.1"], "--tak-interface is for the mesh"),
])
def test_bad_tak_options_of_gcs_fly_are_one_line_before_anything_is_planned(args, error, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["fly", "--area", str(SQUARE), "--sim", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {error}") and err.count("\n") == 1, err
    assert not out.exists()


def test_a_certificate_that_does_not_open_is_one_line(tak_pki, tmp_path, capsys, monkeypatch):
    certs, _ = tak_pki
    monkeypatch.setenv("GCS_TAK_CERT_PASSWORD", "not the password")
    out = tmp_path / "run"
    assert main(["fly", "--area", str(SQUARE), "--sim", "--out", str(out), "--tak", "tls://127.0.0.1:8089",
                 "--tak-cert", str(certs.client_p12), "--tak-ca", str(certs.ca)]) == 2
    err = capsys.readouterr().err
    assert err == (f"error: --tak-cert {certs.client_p12}: cannot load the client certificate and its key (is "
                   "$GCS_TAK_CERT_PASSWORD right?): Invalid password or PKCS12 data\n")
    assert not out.exists()


@pytest.mark.parametrize(("args", "error"), [
    (["--connect", "tcp:127.0.0.1:5760", "--tak", "tcp://127.0.0.1:8087"], "--tak puts the fleet on the bus on TAK"),
    (["--mqtt", "mqtt://127.0.0.1:1", "--plan", "runs/x"], "--plan goes with --tak"),
    (["--mqtt", "mqtt://127.0.0.1:1", "--tak", "tcp://127.0.0.1:8087", "--return", "2"],
     "--tak watches the fleet: it does not go with --return, --range or --abort"),
    (["--mqtt", "mqtt://127.0.0.1:1", "--tak", "tcp://127.0.0.1:8087", "--plan", "/nonexistent/plan"],
     "plan folder /nonexistent/plan does not exist"),
])
def test_bad_tak_options_of_gcs_watch_are_one_line(args, error, capsys):
    assert main(["watch", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {error}") and err.count("\n") == 1, err


@pytest.mark.parametrize("args", [["fly", "--help"], ["watch", "--help"],
                                  ["fly", "--plan", "/nonexistent/plan", "--sim"]])
def test_pytak_is_loaded_only_with_tak(args):
    run = subprocess.run([sys.executable, "-X", "importtime", "-m", "gcs.cli", *args], capture_output=True, text=True)
    names = {line.split("|")[-1].strip().split(".")[0] for line in run.stderr.splitlines()
             if line.startswith("import time:")}
    assert "gcs" in names and not names & {"pytak", "takproto", "cryptography"}
