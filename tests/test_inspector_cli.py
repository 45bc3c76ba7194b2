"""``radcons inspect`` as a process: bad addresses end it at once with one line and exit
status 2; Ctrl+C and SIGTERM stop it; nothing is left in the temporary folder."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from inspector.address import listen_port
from radcons.errors import InputError

# ----------------------------------------------------------------------------- addresses


@pytest.fixture()
def busy_port():
    """A port on 127.0.0.1 that another socket listens on."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen()
        yield sock.getsockname()[1]


@pytest.mark.parametrize(
    "host, port, message",
    [
        ("127.0.0.1", 99999, "--port 99999: not a port number"),
        ("127.0.0.1", -1, "--port -1: not a port number"),
        ("no-such-host.invalid", 0, "--host 'no-such-host.invalid': no such address"),
        ("999.1.2.3", 0, "--host '999.1.2.3': no such address"),
        ("192.0.2.1", 0, "--host 192.0.2.1: not an address of this machine"),  # TEST-NET-1
    ],
)
def test_bad_addresses_are_refused(host, port, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        listen_port(host, port)


def test_a_port_asked_for_must_be_free_and_none_asked_takes_a_free_one(busy_port):
    with pytest.raises(InputError, match=f"--port {busy_port}: in use"):
        listen_port("127.0.0.1", busy_port)
    chosen = listen_port("127.0.0.1", None)
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        probe.bind(("127.0.0.1", chosen))  # free indeed
    any_port = listen_port("127.0.0.1", 0)
    assert 0 < any_port <= 65535


# ----------------------------------------------------------------------------- the command


def _inspect(tmp_path: Path, *args: str) -> subprocess.Popen:
    """``radcons inspect ARGS`` with its own temporary folder (``TMPDIR``)."""
    temp = tmp_path / "tmp"
    temp.mkdir(exist_ok=True)
    env = {**os.environ, "TMPDIR": str(temp), "PYTHONUNBUFFERED": "1"}
    command = [sys.executable, "-m", "radcons.cli", "inspect", "--record-dir", str(tmp_path / "rec"), *args]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)


def _leftovers(tmp_path: Path) -> list[str]:
    return sorted(path.name for path in (tmp_path / "tmp").iterdir())


@pytest.mark.parametrize(
    "args, message",
    [
        (["--port", "99999"], "radcons: error: --port 99999: not a port number (0 to 65535)"),
        (["--host", "no-such-host.invalid"], "radcons: error: --host 'no-such-host.invalid': no such address"),
        (["--host", "192.0.2.1"], "radcons: error: --host 192.0.2.1: not an address of this machine"),
        (["--port", "BUSY"], "radcons: error: --port BUSY: in use on 127.0.0.1"),
    ],
)
def test_bad_addresses_end_the_command_with_one_line(tmp_path, busy_port, args, message):
    args = [arg.replace("BUSY", str(busy_port)) for arg in args]
    message = message.replace("BUSY", str(busy_port))
    process = _inspect(tmp_path, *args)
    out, err = process.communicate(timeout=60)  # a hang fails here
    assert process.returncode == 2, err
    assert err.strip().splitlines() == [err.strip()] and err.startswith(message), err
    assert "radcons inspector:" not in out  # it never listened
    assert _leftovers(tmp_path) == []


@pytest.mark.slow
@pytest.mark.parametrize("signum", ["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("when", ["starting", "running"])
def test_ctrl_c_and_sigterm_stop_the_inspector_while_starting_or_running(tmp_path, when, signum):
    """Ctrl+C (SIGINT) or SIGTERM right after the address is printed (``start`` is still
    waiting for a page, and would then show the pair and build the panels) or once it runs:
    the process ends with status 0, the port is free again and nothing is left in the
    temporary folder. How fast it ends is measured by ``benchmarks/bench_inspector.py``."""
    import signal
    import time

    from inspector.recording import free_port

    port = free_port()
    temp = tmp_path / "tmp"
    temp.mkdir()
    process = subprocess.Popen(
        [sys.executable, "-m", "radcons.cli", "inspect", "--port", str(port), "--record-dir", str(tmp_path / "rec")],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env={**os.environ, "TMPDIR": str(temp)},
    )
    try:
        for line in process.stdout:
            if line.startswith("radcons inspector:"):
                break
        else:
            pytest.fail("radcons inspect ended before listening")
        if when == "running":
            time.sleep(6.0)  # past the 3 s grace: the panels are built and the pair is loading
        process.send_signal(getattr(signal, signum))
        assert process.wait(timeout=60) == 0
        with socket.socket() as probe:
            assert probe.connect_ex(("127.0.0.1", port)) != 0
        assert list(temp.iterdir()) == []
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
