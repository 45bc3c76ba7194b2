"""The inspector's websocket refuses handshakes from pages of other sites."""

from __future__ import annotations

import urllib.request

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from inspector.origin import install_origin_check, same_origin


@pytest.mark.parametrize(
    "origin, host, expected",
    [
        (None, "127.0.0.1:8080", True),
        ("http://127.0.0.1:8080", "127.0.0.1:8080", True),
        ("http://LOCALHOST:8080", "localhost:8080", True),
        ("http://127.0.0.1", "127.0.0.1:80", True),
        ("http://127.0.0.1:8081", "127.0.0.1:8080", False),
        ("http://localhost:8080", "127.0.0.1:8080", False),
        ("https://evil.example", "127.0.0.1:8080", False),
        ("null", "127.0.0.1:8080", False),
        ("file://", "127.0.0.1:8080", False),
        ("http://127.0.0.1:8080", None, False),
    ],
)
def test_same_origin(origin, host, expected):
    assert same_origin(origin, host) is expected


def test_a_viser_server_refuses_a_cross_origin_websocket_and_serves_its_own():
    import viser

    install_origin_check()
    install_origin_check()  # idempotent
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        port = server.get_port()
        url = f"ws://127.0.0.1:{port}"
        protocol = [f"viser-v{viser.__version__}"]
        with connect(url, origin=f"http://127.0.0.1:{port}", subprotocols=protocol, open_timeout=10):
            pass
        with connect(url, subprotocols=protocol, open_timeout=10):  # a program, not a browser page
            pass
        with pytest.raises(InvalidStatus) as refused:
            with connect(url, origin="https://evil.example", subprotocols=protocol, open_timeout=10):
                pass
        assert refused.value.response.status_code == 403
        assert urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10).status == 200
    finally:
        server.stop()
