"""pytak, imported once without the warnings it prints about optional extras (aiohttp for its
HTTP transports) that gcs does not use; with the two TLS helpers it does not re-export."""

import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    import pytak
    from pytak.client_functions import get_ssl_ctx, get_tls_config

__all__ = ["get_ssl_ctx", "get_tls_config", "pytak"]
