"""TAK URLs and client certificates, checked before a flight: one line for each way they can be
wrong."""

from __future__ import annotations

import pytest

from gcs.tak.destination import TakProtocol, TakTls, check_tls, parse_tak_url


def test_urls_get_the_tak_default_ports_and_their_pytak_settings(tak_pki):
    certs, _ = tak_pki
    tcp = parse_tak_url("tcp://tak.example")
    assert (str(tcp), tcp.stream) == ("tcp://tak.example:8087", True)
    assert dict(tcp.pytak_config()) == {"cot_url": "tcp://tak.example:8087", "tak_proto": "0"}
    mesh = parse_tak_url("udp://239.2.3.1", interface="127.0.0.1", protocol=TakProtocol.PROTOBUF)
    assert (str(mesh), mesh.stream) == ("udp://239.2.3.1:6969", False)
    assert dict(mesh.pytak_config()) == {"cot_url": "udp+wo://239.2.3.1:6969", "tak_proto": "1",
                                         "pytak_multicast_local_addr": "127.0.0.1"}
    tls = parse_tak_url("tls://10.1.2.3", tls=TakTls(str(certs.client_cert), str(certs.client_key), str(certs.ca)),
                        interface="127.0.0.1")
    assert str(tls) == "tls://10.1.2.3:8089" and tls.interface is None
    config = tls.pytak_config()
    assert (config["PYTAK_TLS_CLIENT_CERT"], config["PYTAK_TLS_CLIENT_KEY"], config["PYTAK_TLS_CLIENT_CAFILE"]) == \
        (str(certs.client_cert), str(certs.client_key), str(certs.ca))
    assert parse_tak_url("tcp://tak.example:9000", tls=TakTls("x.pem")).tls is None  # TLS options are for tls://


@pytest.mark.parametrize(("url", "error"), [
    ("http://tak.example:8087", "expected tcp://HOST:PORT (a TAK server), tls://HOST:PORT"),
    ("tcp://:8087", "has no host"),
    ("tcp://tak.example:http", "has a bad port"),
    ("tcp://tak.example:8087/cot", "no user, path or query expected"),
    ("tls://tak.example:8089", "needs a client certificate: give --tak-cert"),
])
def test_a_bad_url_is_one_line(url, error):
    with pytest.raises(ValueError, match="^--tak ") as info:
        parse_tak_url(url)
    assert error in str(info.value) and "\n" not in str(info.value)


def test_a_bad_interface_is_one_line():
    with pytest.raises(ValueError, match="--tak-interface 'eth0': expected this machine's IPv4 address"):
        parse_tak_url("udp://239.2.3.1:6969", interface="eth0")


def test_client_certificates_are_loaded_before_the_flight(tak_pki, tmp_path):
    certs, _ = tak_pki

    def tls(cert, key=None, ca=str(certs.ca), password=None) -> None:
        check_tls(parse_tak_url("tls://127.0.0.1:8089", tls=TakTls(cert, key, ca, password)))

    tls(str(certs.client_cert), str(certs.client_key))
    tls(str(certs.client_p12), password=certs.p12_password)
    both = tmp_path / "both.pem"
    both.write_bytes(certs.client_cert.read_bytes() + certs.client_key.read_bytes())
    tls(str(both))  # the key in the certificate's file
    with pytest.raises(ValueError, match=r"--tak-cert .*client.p12: cannot load the client certificate and its key "
                                         r"\(is \$GCS_TAK_CERT_PASSWORD right\?\)"):
        tls(str(certs.client_p12), password="wrong")
    with pytest.raises(ValueError, match=r"client.p12: a .p12 opens with its password: set \$GCS_TAK_CERT_PASSWORD$"):
        tls(str(certs.client_p12))
    with pytest.raises(ValueError, match=r"--tak-cert .*client.pem: cannot load the client certificate and its key"):
        tls(str(certs.client_cert))  # no key anywhere
    with pytest.raises(ValueError, match=r"^--tak-key .*nowhere.key: no such file$"):
        tls(str(certs.client_cert), str(tmp_path / "nowhere.key"))
    with pytest.raises(ValueError, match=r"^--tak-ca .*client.key: not a CA certificate"):
        tls(str(certs.client_cert), str(certs.client_key), ca=str(certs.client_key))
