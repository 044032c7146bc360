"""MAVLink 2 message signing on the station side (mavlink.io, "Message Signing").

A signing key is 32 secret bytes shared by the station and its vehicles. It comes from a file
holding 64 hex digits (or 32 raw bytes), or from a passphrase hashed with SHA-256, the
convention of MAVProxy (`signing setup PASSPHRASE`) and QGroundControl, so the same passphrase
gives the same key in every station. A vehicle learns the key from SETUP_SIGNING sent over a
link that is trusted (USB, or a bench link before the flight).

With a key, every message the station sends is signed, and a message that arrives unsigned or
with a signature that does not check (wrong key, replayed or stale timestamp) is refused:
`SignatureGuard` counts refusals per system id so the operator can be told once."""

from __future__ import annotations

import hashlib
import hmac
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

from gcs.links.mavlink_codec import mavlink

__all__ = ["SIGNING_EPOCH_S", "SigningKey", "SignatureGuard", "signing_timestamp", "setup_signing_message"]

SIGNING_EPOCH_S = 1420070400  # timestamps count 10 microsecond units from 2015-01-01 00:00 UTC
KEY_BYTES = 32
_UNSIGNED_ALLOWED = frozenset({mavlink.MAVLINK_MSG_ID_RADIO_STATUS})  # SiK radios cannot sign their own status


def signing_timestamp(now_s: float | None = None) -> int:
    """The current signing timestamp (10 us units since 2015-01-01)."""
    now_s = time.time() if now_s is None else now_s
    return int((max(now_s, SIGNING_EPOCH_S) - SIGNING_EPOCH_S) * 100_000)


@dataclass(frozen=True, slots=True)
class SigningKey:
    """A 32-byte secret; `fingerprint` names it in messages without revealing it."""

    secret: bytes = field(repr=False)

    def __post_init__(self) -> None:
        if len(self.secret) != KEY_BYTES:
            raise ValueError(f"a signing key has {KEY_BYTES} bytes, not {len(self.secret)}")

    @property
    def fingerprint(self) -> str:
        return hashlib.sha256(self.secret).hexdigest()[:8]

    @property
    def is_zero(self) -> bool:
        return not any(self.secret)

    @classmethod
    def from_passphrase(cls, passphrase: str) -> SigningKey:
        if not passphrase:
            raise ValueError("empty signing passphrase")
        return cls(hashlib.sha256(passphrase.encode()).digest())

    @classmethod
    def from_text(cls, text: str) -> SigningKey:
        """64 hex digits are the key itself; any other text is a passphrase."""
        text = text.strip()
        if len(text) == 2 * KEY_BYTES:
            try:
                return cls(bytes.fromhex(text))
            except ValueError:
                pass
        return cls.from_passphrase(text)

    @classmethod
    def from_file(cls, path: str | os.PathLike) -> SigningKey:
        """A key file: 32 raw bytes, 64 hex digits, or a passphrase on its first line."""
        try:
            data = Path(path).read_bytes()
        except OSError as exc:
            raise ValueError(f"cannot read signing key file {path}: {exc.strerror or exc}") from None
        if len(data) == KEY_BYTES:
            try:
                data.decode("ascii")
            except UnicodeDecodeError:
                return cls(data)
        try:
            text = data.decode("utf-8").splitlines()[0] if data.strip() else ""
        except UnicodeDecodeError:
            raise ValueError(f"signing key file {path}: neither 32 raw bytes nor text") from None
        if not text.strip():
            raise ValueError(f"signing key file {path} is empty")
        return cls.from_text(text)


def setup_signing_message(target_system: int, key: SigningKey, *, target_component: int = 0,
                          now_s: float | None = None) -> mavlink.MAVLink_message:
    """SETUP_SIGNING provisioning `key` (an all-zero key removes signing on ArduPilot)."""
    return mavlink.MAVLink_setup_signing_message(target_system, target_component, list(key.secret),
                                                 signing_timestamp(now_s))


class SignedCodec(mavlink.MAVLink):
    """pymavlink's codec with the signature checked before the replay timestamp is stored:
    pymavlink stores a stream's timestamp before it compares the signature, so one forged
    packet with a far-future timestamp would lock that stream out. A receiving codec given the
    `sender` codec moves the sender's clock up to the newest authentic timestamp it sees, as the
    specification asks: a vehicle whose clock runs ahead (SITL at a speed-up, or one that met a
    station with a fast clock) would otherwise refuse our packets as more than a minute old."""

    sender: mavlink.MAVLink | None = None

    def check_signature(self, msgbuf: bytearray, srcSystem: int, srcComponent: int) -> bool:
        signing = self.signing
        assert signing.secret_key is not None
        digest = hashlib.sha256(signing.secret_key + bytes(msgbuf[:-6])).digest()[:6]
        if not hmac.compare_digest(digest, bytes(msgbuf[-6:])):
            return False
        tlow, thigh = self.mav_sign_unpacker.unpack(msgbuf[-12:-6])
        timestamp = tlow + (thigh << 32)
        stream = (msgbuf[-13], srcSystem, srcComponent)
        last = signing.stream_timestamps.get(stream)
        if last is not None and timestamp <= last:
            return False  # replayed or reordered
        if last is None and timestamp + 60 * 100_000 < signing.timestamp:
            return False  # a new stream more than a minute in the past
        signing.stream_timestamps[stream] = timestamp
        signing.timestamp = max(signing.timestamp, timestamp)
        if self.sender is not None:
            self.sender.signing.timestamp = max(self.sender.signing.timestamp, timestamp)
        return True


def enable_signing(codec: mavlink.MAVLink, key: SigningKey, link_id: int, *, sign_outgoing: bool) -> None:
    """Sign what `codec` sends (when `sign_outgoing`) and refuse what it receives unsigned."""
    s = codec.signing
    s.secret_key = key.secret
    s.link_id = link_id & 0xFF
    s.sign_outgoing = sign_outgoing
    s.timestamp = signing_timestamp()
    s.allow_unsigned_callback = lambda _codec, msg_id: msg_id in _UNSIGNED_ALLOWED


@dataclass
class SignatureGuard:
    """Counts the messages refused for their signature, by the system id in their header."""

    refused: dict[int, int] = field(default_factory=dict)

    def note(self, raw: bytes) -> int | None:
        """Record one refused packet (pymavlink's BAD_DATA bytes); its system id, if readable."""
        sysid = _sysid_of(raw)
        if sysid is not None:
            self.refused[sysid] = self.refused.get(sysid, 0) + 1
        return sysid


def _sysid_of(raw: bytes) -> int | None:
    if len(raw) >= 10 and raw[0] == mavlink.PROTOCOL_MARKER_V2:
        return raw[5]
    if len(raw) >= 6 and raw[0] == mavlink.PROTOCOL_MARKER_V1:
        return raw[3]
    return None
