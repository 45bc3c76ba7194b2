"""Refusing websocket connections opened by pages of other sites.

A browser lets any page open a websocket to ``127.0.0.1``; without a check, a page of
another site open in the same browser could drive the inspector (cross-site websocket
hijacking). Browsers always send an ``Origin`` header with a websocket handshake, and a
page served by the inspector itself has the origin of the address it was loaded from, which
is the ``Host`` the handshake names. So a handshake whose ``Origin`` does not name the same
host and port as its ``Host`` header is answered ``403 Forbidden``. Handshakes without an
``Origin`` (programs, not browsers) are let through.

viser (1.1) has no hook for this: :func:`install_origin_check` wraps the
``process_request`` callback that viser hands to ``websockets.asyncio.server.serve``, the
function it calls at each start, so the check runs before viser sees the connection.
"""

from __future__ import annotations

import functools
import http
import inspect
from typing import Any, Callable
from urllib.parse import urlsplit

import websockets.asyncio.server

__all__ = ["install_origin_check", "same_origin"]

_MARK = "_radcons_origin_check"


def same_origin(origin: str | None, host: str | None) -> bool:
    """True when a handshake's ``Origin`` names the ``Host`` it was sent to (or is absent).

    Parameters
    ----------
    origin : str or None
        The ``Origin`` header, e.g. ``"http://127.0.0.1:8080"``.
    host : str or None
        The ``Host`` header, e.g. ``"127.0.0.1:8080"``.
    """
    if origin is None:
        return True
    if host is None or origin == "null":
        return False
    parts = urlsplit(origin)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        return False
    default = 443 if parts.scheme == "https" else 80
    wanted = urlsplit(f"//{host}")
    return (parts.hostname.lower(), parts.port or default) == ((wanted.hostname or "").lower(), wanted.port or default)


def _guarded(process_request: Callable[..., Any] | None) -> Callable[..., Any]:
    async def check(connection: Any, request: Any) -> Any:
        headers = request.headers
        if headers.get("Upgrade", "").lower() == "websocket" and not same_origin(
            headers.get("Origin"), headers.get("Host")
        ):
            return connection.respond(http.HTTPStatus.FORBIDDEN, "websocket from another origin refused\n")
        if process_request is None:
            return None
        answer = process_request(connection, request)
        return await answer if inspect.isawaitable(answer) else answer

    return check


def install_origin_check() -> None:
    """Make every websocket server started from now on refuse cross-origin handshakes.

    Idempotent; affects the websocket servers of this process (viser's).
    """
    serve = websockets.asyncio.server.serve
    if getattr(serve, _MARK, False):
        return

    @functools.wraps(serve)
    def guarded_serve(*args: Any, **kwargs: Any) -> Any:
        kwargs["process_request"] = _guarded(kwargs.get("process_request"))
        return serve(*args, **kwargs)

    setattr(guarded_serve, _MARK, True)
    websockets.asyncio.server.serve = guarded_serve
