"""MAVLink 2 signing on the station side: keys from files and passphrases, signed traffic both
ways against signing simulated vehicles, refusal of unsigned, wrongly signed, replayed and
forged traffic, and provisioning with `gcs signing` (SETUP_SIGNING) over TCP."""

from __future__ import annotations

import asyncio
import hashlib
import subprocess
import sys

import pytest

from gcs.links import CommandError, LinkState, MavLink, SigningKey, mavlink
from gcs.links.signing import SignedCodec, enable_signing, signing_timestamp
from tests.peers.ports import free_udp_port

PASSPHRASE = "correct horse battery staple"
KEY = SigningKey.from_passphrase(PASSPHRASE)


def test_keys_from_files_and_passphrases(tmp_path):
    assert KEY.secret == hashlib.sha256(PASSPHRASE.encode()).digest()  # MAVProxy / QGroundControl convention
    (tmp_path / "hex.key").write_text(KEY.secret.hex() + "\n")
    (tmp_path / "raw.key").write_bytes(KEY.secret)
    (tmp_path / "phrase.key").write_text(PASSPHRASE + "\n")
    for name in ("hex.key", "raw.key", "phrase.key"):
        assert SigningKey.from_file(tmp_path / name) == KEY
    assert KEY.fingerprint == hashlib.sha256(KEY.secret).hexdigest()[:8] and KEY.secret.hex() not in repr(KEY)
    (tmp_path / "empty.key").write_text("\n")
    with pytest.raises(ValueError, match="is empty"):
        SigningKey.from_file(tmp_path / "empty.key")
    with pytest.raises(ValueError, match="cannot read signing key file"):
        SigningKey.from_file(tmp_path / "missing.key")
    with pytest.raises(ValueError, match="32 bytes"):
        SigningKey(b"short")


def _packet(key: SigningKey, timestamp: int, *, system: int = 1) -> bytes:
    codec = mavlink.MAVLink(None, srcSystem=system, srcComponent=1)
    enable_signing(codec, key, 7, sign_outgoing=True)
    codec.signing.timestamp = timestamp
    return bytes(mavlink.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(codec))


def test_forged_replayed_and_stale_packets_are_refused_without_locking_out_the_sender():
    receiver = SignedCodec(None, srcSystem=255, srcComponent=190)
    receiver.robust_parsing = True
    enable_signing(receiver, KEY, 1, sign_outgoing=False)
    now = signing_timestamp()

    def accepted(packet: bytes) -> bool:
        [msg] = receiver.parse_buffer(packet)
        return msg.get_type() == "HEARTBEAT"

    forged = _packet(SigningKey.from_passphrase("wrong"), now + 10**9)  # far-future timestamp, wrong key
    assert not accepted(forged)
    good = _packet(KEY, now + 10)
    assert accepted(good)  # pymavlink alone would now refuse it: the forged timestamp was stored
    assert not accepted(good)  # a replay
    assert not accepted(_packet(KEY, now - 2 * 60 * 100_000, system=2))  # a new stream two minutes old
    unsigned = bytes(mavlink.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(mavlink.MAVLink(None, 3, 1)))
    assert not accepted(unsigned)


def test_signed_station_and_signed_vehicles_talk_and_everything_is_signed(make_fleet):
    fleet = make_fleet(2, signing_key=KEY.secret)
    signed = []

    async def main():
        async with MavLink(fleet.connection_strings()[0], signing=KEY) as a, \
                MavLink(fleet.connection_strings()[1], signing=KEY) as b:
            for link in (a, b):
                link.subscribe(lambda msg: signed.append(msg._signed))
            assert await a.command(1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout_s=0.5) == 0
            assert await b.command(2, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout_s=0.5) == 0

    asyncio.run(main())
    assert fleet.vehicle(1).armed and fleet.vehicle(2).armed
    assert signed and all(signed)
    assert fleet.link(1).rejected == 0


@pytest.mark.parametrize("vehicle_key", [None, SigningKey.from_passphrase("another").secret])
def test_traffic_not_signed_with_our_key_is_refused_and_reported(make_fleet, vehicle_key):
    port = free_udp_port()
    fleet = make_fleet(signing_key=vehicle_key, out=(("127.0.0.1", port),))  # the vehicle pushes to us
    seen = []

    async def main():
        async with MavLink(f"udpin:127.0.0.1:{port}", signing=KEY) as link:
            link.on_status(seen.append)
            with pytest.raises(CommandError):
                await link.command(1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout_s=0.3, retries=1)
            assert 1 not in link.systems and link.guard.refused.get(1, 0) > 0

    asyncio.run(main())
    # a vehicle without a key accepts signed messages (it cannot check them); one with another key refuses them
    assert fleet.vehicle(1).armed is (vehicle_key is None)
    refusals = [s for s in seen if s.state is LinkState.SIGNATURE_REFUSED]
    assert len(refusals) == 1 and "system 1" in refusals[0].detail  # told once, not once per message


def _gcs(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], capture_output=True, text=True, timeout=120)


def test_gcs_signing_provisions_vehicles_over_tcp_and_removes_the_key(make_fleet, tmp_path):
    fleet = make_fleet(2, tcp=True)
    connect = [arg for conn in fleet.tcp_connection_strings() for arg in ("--connect", conn)]
    key_file = tmp_path / "station.key"
    key_file.write_text(KEY.secret.hex())

    done = _gcs("signing", *connect, "--signing-key", str(key_file), "--wait", "2")
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count(f"signs with key {KEY.fingerprint}, refuses unsigned requests") == 2
    assert [fleet.link(i).signing_key for i in (1, 2)] == [KEY.secret, KEY.secret]

    wrong = _gcs("signing", *connect, "--signing-passphrase", "another", "--wait", "1", "--remove")
    assert wrong.returncode == 2 and wrong.stderr.count("\n") == 1
    assert "heard, but not signed with key" in wrong.stderr

    removed = _gcs("signing", *connect, "--signing-key", str(key_file), "--wait", "2", "--remove")
    assert removed.returncode == 0, removed.stdout + removed.stderr
    assert removed.stdout.count("signing removed") == 2
    assert [fleet.link(i).signing_key for i in (1, 2)] == [None, None]


def test_gcs_signing_bad_input_is_one_line(tmp_path):
    missing = _gcs("signing", "--connect", "tcp:127.0.0.1:1", "--signing-key", str(tmp_path / "nope"))
    assert missing.returncode == 2 and missing.stderr.startswith("error: cannot read signing key file")
    no_key = _gcs("signing", "--connect", "tcp:127.0.0.1:1")
    assert no_key.returncode == 2 and "--signing-key" in no_key.stderr and no_key.stderr.count("\n") == 1
    refused = _gcs("signing", "--connect", "udpin:127.0.0.1:1", "--signing-passphrase", "x", "--wait", "0.5")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1
