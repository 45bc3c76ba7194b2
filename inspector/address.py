"""The address the inspector listens on, checked before its server starts.

viser (1.1) moves on to the next port when one is taken and keeps trying on any other
error: a port out of range stops its server thread before it reports ready (``radcons
inspect --port 99999`` then waited for ever) and an address that is not this machine's is
tried on a thousand ports. So the address is checked here first, by binding a socket to
it: an unknown host, a host that is not one of this machine's addresses, a port out of
range, a port that needs privileges, or a port asked for by the user that is in use, is an
:class:`~radcons.errors.InputError` naming the option and the problem.
"""

from __future__ import annotations

import errno
import socket

from radcons.errors import InputError

__all__ = ["listen_port", "DEFAULT_PORT", "PORTS_TRIED"]

#: Port used when none is given.
DEFAULT_PORT = 8080
#: Ports tried from :data:`DEFAULT_PORT` on when no port is given.
PORTS_TRIED = 100


def _address(host: str) -> tuple[socket.AddressFamily, tuple]:
    """Socket family and address of ``host`` (port 0)."""
    try:
        family, _, _, _, address = socket.getaddrinfo(host or None, 0, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)[0]
    except (socket.gaierror, UnicodeError) as exc:
        raise InputError(f"--host {host!r}: no such address ({getattr(exc, 'strerror', None) or exc})") from exc
    return family, address


def _free(family: socket.AddressFamily, address: tuple, port: int, host: str) -> int | None:
    """Bind ``address`` with ``port`` as viser will (address reuse on); the port bound, or
    None when it is in use."""
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((address[0], port, *address[2:]))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                return None
            if exc.errno == errno.EADDRNOTAVAIL:
                raise InputError(f"--host {host}: not an address of this machine") from exc
            if exc.errno == errno.EACCES:
                raise InputError(f"--port {port}: needs privileges on this machine (use a port above 1023)") from exc
            raise InputError(f"--host {host} --port {port}: cannot listen there ({exc.strerror or exc})") from exc
        return int(probe.getsockname()[1])


def listen_port(host: str, port: int | None) -> int:
    """The port the server is to listen on, checked to be free now.

    Parameters
    ----------
    host : str
        Address to listen on.
    port : int or None
        The port asked for (0: any free port), which must be free; None: the first free
        one of :data:`PORTS_TRIED` from :data:`DEFAULT_PORT` on.

    Returns
    -------
    int

    Raises
    ------
    InputError
        An unknown host or one not of this machine, a port out of 0..65535, a privileged
        port, a port asked for that is in use, or no free port where none was asked for.
    """
    if port is not None and (isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535):
        raise InputError(f"--port {port}: not a port number (0 to 65535)")
    family, address = _address(host)
    if port is not None:
        bound = _free(family, address, port, host)
        if bound is None:
            raise InputError(f"--port {port}: in use on {host} (leave --port out to take the next free port)")
        return bound
    for candidate in range(DEFAULT_PORT, DEFAULT_PORT + PORTS_TRIED):
        bound = _free(family, address, candidate, host)
        if bound is not None:
            return bound
    raise InputError(f"no free port on {host} from {DEFAULT_PORT} to {DEFAULT_PORT + PORTS_TRIED - 1}; give one with --port")
