"""Where the CoT goes: `tcp://HOST[:PORT]` (a TAK server's plain CoT input, 8087 by default),
`tls://HOST[:PORT]` (its TLS input with a client certificate, 8089) or `udp://GROUP[:PORT]` (the
mesh's SA multicast group, 239.2.3.1:6969; a unicast address works too), as a checked
`TakDestination` and the pytak configuration that opens it.

Everything is checked before a flight: the URL, and for TLS the certificate, key and CA files,
by building the TLS context once (`check_tls`); a ValueError carries the one line to show."""

from __future__ import annotations

import ipaddress
import os
import ssl
import warnings
from configparser import ConfigParser, SectionProxy
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from urllib.parse import urlsplit

from gcs.tak.pytak_module import get_ssl_ctx, get_tls_config

__all__ = ["DEFAULT_PORTS", "TakDestination", "TakProtocol", "TakTls", "check_tls", "parse_tak_url"]

DEFAULT_PORTS = {"tcp": 8087, "tls": 8089, "udp": 6969}
PASSWORD_ENV = "GCS_TAK_CERT_PASSWORD"


class TakProtocol(str, Enum):
    """How each event is written: CoT XML (every TAK client and server reads it), or TAK protocol
    version 1 (protobuf, takproto: the mesh's or the stream's framing, by the address)."""

    XML = "xml"
    PROTOBUF = "protobuf"


@dataclass(frozen=True)
class TakTls:
    """The client side of `tls://`: a certificate (PEM, with `key_file` or the key in the same
    file, or a PKCS#12 `.p12`), its password ($GCS_TAK_CERT_PASSWORD), the CA that signed the
    server's certificate (None: the system's), and `insecure` to skip the server's host name."""

    cert_file: str
    key_file: str | None = None
    ca_file: str | None = None
    password: str | None = None
    insecure: bool = False


@dataclass(frozen=True)
class TakDestination:
    scheme: str
    host: str
    port: int
    tls: TakTls | None = None
    interface: str | None = None
    protocol: TakProtocol = TakProtocol.XML

    def __str__(self) -> str:
        return f"{self.scheme}://{self.host}:{self.port}"

    @property
    def stream(self) -> bool:
        """TCP or TLS: a connection that opens, drops and comes back (UDP has none)."""
        return self.scheme != "udp"

    def pytak_config(self) -> SectionProxy:
        """The pytak settings that open this destination (`pytak.protocol_factory`) and write to
        it (`pytak.TXWorker`): UDP is write-only, multicast leaves from `interface`."""
        scheme = "udp+wo" if self.scheme == "udp" else self.scheme
        values = {"COT_URL": f"{scheme}://{self.host}:{self.port}",
                  "TAK_PROTO": "1" if self.protocol is TakProtocol.PROTOBUF else "0"}
        if self.interface is not None:
            values["PYTAK_MULTICAST_LOCAL_ADDR"] = self.interface
        if self.tls is not None:
            values["PYTAK_TLS_CLIENT_CERT"] = self.tls.cert_file
            values["PYTAK_TLS_CLIENT_KEY"] = self.tls.key_file or ("" if _pkcs12(self.tls) else self.tls.cert_file)
            values["PYTAK_TLS_CLIENT_CAFILE"] = self.tls.ca_file or _system_ca_file()
            values["PYTAK_TLS_CLIENT_PASSWORD"] = self.tls.password or ""
            if self.tls.insecure:
                values["PYTAK_TLS_DONT_CHECK_HOSTNAME"] = "1"
        config = ConfigParser(interpolation=None)
        config["tak"] = {key: value for key, value in values.items() if value}
        return config["tak"]


def _pkcs12(tls: TakTls) -> bool:
    return tls.cert_file.lower().endswith((".p12", ".pfx"))


def _system_ca_file() -> str:
    paths = ssl.get_default_verify_paths()
    for candidate in (paths.cafile, paths.openssl_cafile):
        if candidate and os.path.exists(candidate):
            return candidate
    return ""


def parse_tak_url(url: str, *, tls: TakTls | None = None, interface: str | None = None,
                  protocol: TakProtocol = TakProtocol.XML) -> TakDestination:
    """A checked destination; ValueError with one line for a bad URL. The TLS options apply to a
    tls:// URL only, the interface to a udp:// one."""
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in DEFAULT_PORTS:
        raise ValueError(f"--tak {url!r}: expected tcp://HOST:PORT (a TAK server), tls://HOST:PORT (with "
                         "--tak-cert) or udp://239.2.3.1:6969 (the mesh)")
    if not parts.hostname:
        raise ValueError(f"--tak {url!r} has no host (e.g. {scheme}://127.0.0.1:{DEFAULT_PORTS[scheme]})")
    try:
        port = parts.port or DEFAULT_PORTS[scheme]
    except ValueError:
        raise ValueError(f"--tak {url!r} has a bad port") from None
    if parts.path not in ("", "/") or parts.query or parts.username:
        raise ValueError(f"--tak {url!r}: no user, path or query expected")
    if scheme == "tls" and tls is None:
        raise ValueError(f"--tak {url}: a TAK server's TLS input needs a client certificate: give --tak-cert")
    if scheme == "udp" and interface is not None:
        try:
            ipaddress.IPv4Address(interface)
        except ValueError:
            raise ValueError(f"--tak-interface {interface!r}: expected this machine's IPv4 address") from None
    return TakDestination(scheme, parts.hostname, port, tls if scheme == "tls" else None,
                          interface if scheme == "udp" else None, protocol)


def check_tls(destination: TakDestination) -> None:
    """Build the destination's TLS context once, as every connection will: ValueError naming the
    file that cannot be used."""
    tls = destination.tls
    if tls is None:
        return
    for option, path in (("--tak-cert", tls.cert_file), ("--tak-key", tls.key_file), ("--tak-ca", tls.ca_file)):
        if path is not None and not Path(path).is_file():
            raise ValueError(f"{option} {path}: no such file")
    if _pkcs12(tls) and not tls.password:
        raise ValueError(f"--tak-cert {tls.cert_file}: a .p12 opens with its password: set ${PASSWORD_ENV}")
    config = destination.pytak_config()
    if not config.get("PYTAK_TLS_CLIENT_CAFILE"):
        raise ValueError("--tak-ca: this system has no CA bundle: give the CA that signed the TAK server's certificate")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            get_ssl_ctx(get_tls_config(config))
    except (ValueError, SyntaxError, SystemError) as exc:
        hint = f" (is ${PASSWORD_ENV} right?)" if tls.password else ""
        raise ValueError(f"--tak-cert {tls.cert_file}: cannot load the client certificate and its key{hint}: "
                         f"{_cause(exc)}") from None
    except ssl.SSLError as exc:
        raise ValueError(f"--tak-ca {config.get('PYTAK_TLS_CLIENT_CAFILE')}: not a CA certificate ({exc.reason or exc})"
                         ) from None


def _cause(exc: BaseException) -> str:
    while exc.__cause__ is not None:
        exc = exc.__cause__
    text = getattr(exc, "reason", None) or str(exc) or type(exc).__name__
    return str(text)
