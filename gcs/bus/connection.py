"""Broker addresses: `mqtt://[user[:password]@]host[:port]` or `mqtts://...` with TLS options."""

from __future__ import annotations

import os
import socket
import ssl
from dataclasses import dataclass
from urllib.parse import unquote, urlsplit

import aiomqtt

__all__ = ["Broker", "TlsOptions", "parse_broker_url"]

# Without TCP_NODELAY a small publish sent right after another waits for the broker's delayed
# ACK (40 ms on Linux): the bus sends many small messages from concurrent tasks.
_NO_DELAY = ((socket.IPPROTO_TCP, socket.TCP_NODELAY, 1),)


@dataclass(frozen=True)
class TlsOptions:
    """TLS for mqtts://: the CA that signed the broker's certificate (None = the system's), an
    optional client certificate and key, and `insecure` to skip the host name check (tests only)."""

    ca_file: str | None = None
    cert_file: str | None = None
    key_file: str | None = None
    insecure: bool = False


@dataclass(frozen=True)
class Broker:
    host: str
    port: int
    tls: TlsOptions | None = None
    username: str | None = None
    password: str | None = None

    def client(self, identifier: str, will: aiomqtt.Will | None = None, timeout_s: float = 5.0,
               keepalive_s: int = 10) -> aiomqtt.Client:
        tls_params = None
        if self.tls is not None:
            tls_params = aiomqtt.TLSParameters(ca_certs=self.tls.ca_file, certfile=self.tls.cert_file,
                                               keyfile=self.tls.key_file, cert_reqs=ssl.CERT_REQUIRED,
                                               tls_version=ssl.PROTOCOL_TLS_CLIENT)
        client = aiomqtt.Client(self.host, self.port, username=self.username, password=self.password,
                                identifier=identifier, will=will, timeout=timeout_s, keepalive=keepalive_s,
                                tls_params=tls_params, tls_insecure=self.tls.insecure if self.tls else None,
                                socket_options=_NO_DELAY)
        client.pending_calls_threshold = 100  # the bus batches its publishes; no warning below that
        return client

    def __str__(self) -> str:
        user = f"{self.username}@" if self.username else ""
        return f"{'mqtts' if self.tls else 'mqtt'}://{user}{self.host}:{self.port}"


def parse_broker_url(url: str, *, username: str | None = None, password: str | None = None,
                     tls: TlsOptions | None = None) -> Broker:
    """A `Broker` from a URL; explicit credentials win over the URL's, and the password falls back
    to $GCS_MQTT_PASSWORD. ValueError with one clear line for anything else."""
    parts = urlsplit(url)
    if parts.scheme not in ("mqtt", "mqtts"):
        raise ValueError(f"broker URL {url!r} must start with mqtt:// or mqtts://")
    if not parts.hostname:
        raise ValueError(f"broker URL {url!r} has no host (e.g. mqtt://127.0.0.1:1883)")
    try:
        port = parts.port or (8883 if parts.scheme == "mqtts" else 1883)
    except ValueError:
        raise ValueError(f"broker URL {url!r} has a bad port") from None
    if parts.path not in ("", "/") or parts.query:
        raise ValueError(f"broker URL {url!r}: no path or query expected")
    username = username if username is not None else (unquote(parts.username) if parts.username else None)
    password = password if password is not None else (unquote(parts.password) if parts.password else None)
    if username is not None and password is None:
        password = os.environ.get("GCS_MQTT_PASSWORD")
    if parts.scheme == "mqtts":
        tls = tls or TlsOptions()
    elif tls is not None:
        raise ValueError("TLS options need an mqtts:// URL")
    return Broker(parts.hostname, port, tls, username, password)
