"""Every handshake with a dask scheduler is bounded (issue 22, item 6).

Hostile endpoints on 127.0.0.1 only — a listener that accepts and never answers, an HTTP
server, one that sends garbage bytes, a closed port — each give one ExecutorError line
within a short, explicit timeout (no hang, no MemoryError traceback). No cluster is
started here (a worker's address given as the scheduler's is in test_executor_dask.py).
"""
from __future__ import annotations

import importlib.util
import socket
import threading
import time

import numpy as np
import pytest

import envfit.cli as cli
from envfit.base._errors import ExecutorError, ParameterError
from envfit.batch._executor import DEFAULT_DASK_TIMEOUT, DaskExecutor, dask_timeout, make_executor
from envfit.maps._io import save_envmap

#: every test but the timeout's parsing talks to an endpoint through dask.distributed
needs_distributed = pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                                       reason="dask.distributed is not installed")

T = 1.0             # the handshake limit used by these tests, seconds
SLACK = 8.0         # thread start, the distributed import, a loaded 2-core machine


class Endpoint:
    """A TCP server on 127.0.0.1 that treats each connection with ``behave(conn)``."""

    def __init__(self, behave):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.address = "tcp://127.0.0.1:%d" % self.sock.getsockname()[1]
        self.conns: list[socket.socket] = []
        self.accepted = 0
        self.behave = behave
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:       # closed by close()
                return
            self.accepted += 1
            self.conns.append(conn)
            try:
                self.behave(conn)
            except OSError:
                pass

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


def silent(conn):
    """Accept and never answer (the connection stays open)."""


def http(conn):
    """Read the request, answer like a web server, close."""
    conn.settimeout(2.0)
    try:
        conn.recv(65536)
    except OSError:
        pass
    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Type: text/plain\r\n"
                 b"Content-Length: 11\r\nConnection: close\r\n\r\nbad request")
    conn.close()


def garbage(conn):
    """Random bytes (seeded), then silence with the connection open."""
    conn.sendall(np.random.default_rng(22).integers(0, 256, 4096, dtype=np.uint8).tobytes())


@pytest.fixture
def endpoint():
    made = []

    def make(behave):
        made.append(Endpoint(behave))
        return made[-1]

    yield make
    for e in made:
        e.close()


def bounded(address, timeout=T):
    """Run DaskExecutor(address) on a helper thread (a regression hangs that thread, not the
    suite); return (the ExecutorError's text, seconds taken)."""
    box = {}

    def target():
        try:
            box["ex"] = DaskExecutor(address, timeout=timeout)
        except BaseException as exc:  # noqa: BLE001 - inspected below
            box["error"] = exc

    t0 = time.monotonic()
    th = threading.Thread(target=target, daemon=True)
    th.start()
    th.join(timeout + SLACK)
    took = time.monotonic() - t0
    assert not th.is_alive(), f"DaskExecutor({address!r}) still waiting after {took:.1f} s"
    assert isinstance(box.get("error"), ExecutorError), box
    return str(box["error"]), took


@needs_distributed
def test_silent_listener_times_out(endpoint):
    e = endpoint(silent)
    msg, took = bounded(e.address)
    assert e.accepted >= 1                      # TCP connected: the wait is the handshake
    assert T * 0.9 <= took < T + SLACK          # it waited for the limit, and no longer
    assert "no answer to dask's handshake within 1 s" in msg and "ENVFIT_DASK_TIMEOUT" in msg
    assert "\n" not in msg


@needs_distributed
def test_http_server_is_not_dask(endpoint):
    e = endpoint(http)
    msg, took = bounded(e.address)
    assert e.accepted >= 1 and took < T + SLACK
    # distributed reads "HTTP/1.1" as a frame length of ~3.5e18 bytes: a MemoryError, caught
    assert "does not speak dask's protocol" in msg and "\n" not in msg


@needs_distributed
def test_garbage_bytes_are_not_dask(endpoint):
    e = endpoint(garbage)
    msg, took = bounded(e.address)
    assert e.accepted >= 1 and took < T + SLACK
    assert ("does not speak dask's protocol" in msg
            or "no answer to dask's handshake" in msg) and "\n" not in msg


@needs_distributed
def test_closed_port_is_refused():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()                                   # nothing listens there now
    msg, took = bounded(f"tcp://127.0.0.1:{port}")
    assert "connection refused" in msg and took < T + SLACK


def test_timeout_read_from_the_environment(monkeypatch):
    monkeypatch.delenv("ENVFIT_DASK_TIMEOUT", raising=False)
    assert dask_timeout() == DEFAULT_DASK_TIMEOUT == 10.0
    monkeypatch.setenv("ENVFIT_DASK_TIMEOUT", "0.5")
    assert dask_timeout() == 0.5
    for bad in ("0", "-3", "soon", "nan", "inf"):
        monkeypatch.setenv("ENVFIT_DASK_TIMEOUT", bad)
        with pytest.raises(ParameterError, match="ENVFIT_DASK_TIMEOUT must be a positive"):
            dask_timeout()


@needs_distributed
def test_make_executor_waits_the_environments_timeout(monkeypatch, endpoint):
    monkeypatch.setenv("ENVFIT_DASK_TIMEOUT", "0.5")
    e = endpoint(silent)
    t0 = time.monotonic()
    with pytest.raises(ExecutorError, match=r"within 0\.5 s"):
        make_executor("dask", scheduler=e.address)   # make_executor reads the variable
    assert time.monotonic() - t0 < 0.5 + SLACK


@needs_distributed
def test_malformed_addresses_are_parameter_errors():
    for bad, why in [("http://127.0.0.1:80", "unknown address scheme"),
                     ("tcp://127.0.0.1:99999", "out of range"),
                     ("tcp://127.0.0.1", "missing port")]:
        with pytest.raises(ParameterError, match=why):
            DaskExecutor(bad, timeout=T)


@needs_distributed
def test_cli_one_line_exit_2(monkeypatch, endpoint, tmp_path, capsys):
    monkeypatch.setenv("ENVFIT_DASK_TIMEOUT", str(T))
    rng = np.random.default_rng(0)
    path = str(save_envmap(tmp_path / "m.exr", rng.random((16, 32, 3)).astype(np.float32)))
    for behave in (silent, http):
        e = endpoint(behave)
        t0 = time.monotonic()
        rc = cli.main(["table2", path, "--s", "1.5", "--n", "40", "--executor", "dask",
                       "--scheduler", e.address, "--quiet"])
        err = capsys.readouterr().err.strip()
        assert rc == 2 and time.monotonic() - t0 < T + SLACK
        assert len(err.splitlines()) == 1 and "Traceback" not in err
        assert err.startswith("envfit table2: error: cannot reach the dask scheduler at "
                              + e.address)


@needs_distributed
def test_refusal_named_when_the_retry_loop_ends_cancelled():
    """On a loaded machine distributed's retry loop can end in its own cancelled last attempt:
    the OSError's chain then holds a CancelledError, not the refusal. A plain TCP probe still
    names the refusal (and does not invent one where something listens)."""
    import asyncio

    from envfit.batch._executor import _connect_failure

    def cancelled_oserror():
        try:
            try:
                raise asyncio.CancelledError()
            except BaseException as c:
                raise OSError("Timed out trying to connect") from c
        except OSError as e:
            return e

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()                                   # closed: refused
    assert _connect_failure(cancelled_oserror(), 0.8,
                            f"tcp://127.0.0.1:{port}").startswith("connection refused")
    with socket.socket() as listener:           # something listens: not a refusal
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        msg = _connect_failure(cancelled_oserror(), 0.8,
                               f"tcp://127.0.0.1:{listener.getsockname()[1]}")
        assert "refused" not in msg and "CancelledError" in msg
