r"""Where a sweep's tasks run: in this process, a local process pool, or a dask cluster.

A library sweep (:mod:`envfit.batch._library`, :mod:`envfit.batch._library_fit`) is a set of independent
tasks (sample a map, factorise one kernel matrix and solve for every map, evaluate one map)
that a driver submits and whose results it writes to disk as they arrive
(:func:`envfit.batch._scheduler.drive`). An executor is the small interface the driver needs:

``submit(fn, *args) -> future``, ``wait_any(futures) -> (done, not_done)``,
``result(future)``, ``share(obj)`` (ship a large read-only argument once), ``slots`` (how
many tasks may run at once), ``is_lost_worker(exc)`` and ``close()``.

Threads. The heavy steps (numba kernels, LAPACK ``dpotrf``, ducc0 transforms) each use
every core they are given. Running W tasks side by side with all cores each would
oversubscribe the machine by W x, so every task runs under :func:`run_pinned`: BLAS/LAPACK
threads limited with ``threadpoolctl`` and numba's (and so ducc0's) thread count set, to
``threads = cores // W`` — threads per worker x workers <= cores.

``local`` (:class:`LocalExecutor`)
    W = 1: tasks run inline, in this process, with all cores (exactly the single-map
    code path). W > 1: a ``concurrent.futures.ProcessPoolExecutor`` (``spawn`` start
    method: forking a process whose OpenMP/numba thread pools are running is unsafe).
``dask`` (:class:`DaskExecutor`)
    A ``dask.distributed`` client: to a running scheduler (``tcp://HOST:PORT``) or to a
    ``LocalCluster`` of W single-threaded worker processes on loopback. Threads per task:
    per host, cores // (worker threads on that host), the smallest over hosts.
    Optional extra: ``pip install "envfit[dask]"``.

Network handshakes are bounded. Before a client is made for ``tcp://HOST:PORT``,
:func:`identify_scheduler` connects, does dask's comm handshake and asks the endpoint's
``identity``, all within one deadline (distributed's own ``connect`` bounds the TCP connect
but not the handshake read after it: an endpoint that accepts and never answers would hang
the client for ever); the client is then made with ``Client(timeout=...)`` under dask's
``distributed.comm.timeouts.connect``, and a scheduler without workers is waited for as long.
The deadline is :func:`dask_timeout` (``ENVFIT_DASK_TIMEOUT`` seconds, default
:data:`DEFAULT_DASK_TIMEOUT`). A silent listener, an HTTP server, garbage bytes, a closed
port or a non-scheduler dask server each give one :class:`ExecutorError` line.

Example
-------
>>> ex, notes = make_executor("local", workers=1)
>>> fut = ex.submit(sum, [1, 2, 3])
>>> ex.result(fut), ex.slots
(6, 1)
>>> ex.close()
"""
from __future__ import annotations

import asyncio
import concurrent.futures as cf
import functools
import math
import multiprocessing
import os
import threading
from typing import Any, Callable, Iterable

from envfit.base import ExecutorError, ParameterError
from envfit.defaults import EXECUTORS
from envfit.base import MEMORY_FRACTION, available_memory_bytes, format_bytes, machine_cores

__all__ = ["EXECUTORS", "machine_cores", "run_pinned", "plan_workers", "LocalExecutor",
           "DaskExecutor", "make_executor", "dask_timeout", "identify_scheduler",
           "DEFAULT_DASK_TIMEOUT"]

# EXECUTORS ("local", "dask") is envfit.defaults', imported above
DASK_HINT = 'install it with: pip install "envfit[dask]"'
#: seconds allowed for each network handshake with a dask scheduler (``ENVFIT_DASK_TIMEOUT``)
DEFAULT_DASK_TIMEOUT = 10.0


def run_pinned(threads: int, fn: Callable, *args: Any) -> Any:
    """``fn(*args)`` with BLAS/LAPACK (threadpoolctl) and numba limited to ``threads`` threads.

    numba's setting is per calling thread and restored afterwards; the BLAS limit is
    process-wide for the duration (a worker process runs one task per thread it has, and
    all of them ask for the same limit).
    """
    import numba

    threads = max(1, int(threads))
    previous = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        with _controller().limit(limits=threads):
            return fn(*args)
    finally:
        numba.set_num_threads(previous)


@functools.lru_cache(maxsize=1)
def _controller():
    """threadpoolctl's view of this process's BLAS/OpenMP libraries (scanned once: 10 ms)."""
    from threadpoolctl import ThreadpoolController
    return ThreadpoolController()


def plan_workers(requested: int | None, *, cores: int, max_useful: int,
                 bytes_per_task: int = 0) -> tuple[int, list[str]]:
    """Worker count for a local run and notes on what limited it.

    ``requested`` (None: as many as useful — at most ``cores`` and ``max_useful``, the tasks
    that can run side by side) must be within 1 <= K <= ``cores`` (``--workers``' range: more
    processes would only share the cores; ParameterError, one line), and is lowered by
    memory, said in a note: W tasks of
    ``bytes_per_task`` each must fit in the budget (:data:`envfit.base._resources.MEMORY_FRACTION`
    of the available memory).

    >>> plan_workers(None, cores=8, max_useful=3)
    (3, [])
    """
    notes = []
    if requested is not None:
        requested = int(requested)
        if not 1 <= requested <= cores:     # the words of ``--workers`` in --help
            raise ParameterError(f"--workers {requested} is outside 1 <= K <= {cores} (this "
                                 "machine's cores: more would only share them)")
    w = min(cores, max(1, max_useful)) if requested is None else requested
    if bytes_per_task > 0:
        budget = available_memory_bytes() * MEMORY_FRACTION
        fit = max(1, int(budget // bytes_per_task))
        if w > fit:
            notes.append(f"{w} workers would need {format_bytes(w * bytes_per_task)} at once; "
                         f"using {fit}, the most whose tasks ({format_bytes(bytes_per_task)} "
                         f"each) fit the memory budget {format_bytes(budget)}")
            w = fit
    return w, notes


class LocalExecutor:
    """Inline (``workers=1``) or a local process pool; tasks pinned to cores // workers threads."""

    name = "local"
    lost_hint = ("a worker process died (killed, out of memory, or — when called from a "
                 "script — no `if __name__ == \"__main__\":` guard, which process pools "
                 "need; workers=1 runs inline); ")

    def __init__(self, workers: int | None = None):
        cores = machine_cores()
        self.workers = cores if workers is None else int(workers)
        if self.workers < 1:
            raise ParameterError(f"--workers must be at least 1, got {self.workers}")
        self.blas_threads = max(1, cores // self.workers)
        self._pool = None
        if self.workers > 1:
            self._pool = cf.ProcessPoolExecutor(
                max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"))

    @property
    def slots(self) -> int:
        return self.workers

    def describe(self) -> str:
        where = "inline" if self._pool is None else f"{self.workers} processes"
        return f"local ({where}, {self.blas_threads} BLAS/numba thread(s) per task)"

    def submit(self, fn: Callable, *args: Any) -> cf.Future:
        if self._pool is not None:
            return self._pool.submit(run_pinned, self.blas_threads, fn, *args)
        fut: cf.Future = cf.Future()
        try:
            fut.set_result(run_pinned(self.blas_threads, fn, *args))
        except Exception as exc:  # delivered through the future, like a pool would
            fut.set_exception(exc)
        return fut

    def wait_any(self, futures: Iterable) -> tuple[set, set]:
        done, not_done = cf.wait(list(futures), return_when=cf.FIRST_COMPLETED)
        return set(done), set(not_done)

    @staticmethod
    def result(fut) -> Any:
        return fut.result()

    @staticmethod
    def share(obj: Any) -> Any:
        return obj

    @staticmethod
    def is_lost_worker(exc: BaseException) -> bool:
        from concurrent.futures.process import BrokenProcessPool
        return isinstance(exc, (BrokenProcessPool, cf.CancelledError))

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _import_distributed():
    try:
        import distributed
    except ImportError:
        raise ExecutorError(f"--executor dask needs dask.distributed, which is not installed; "
                            f"{DASK_HINT}") from None
    return distributed


def _positive_seconds(value, what: str = "the dask timeout") -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (v > 0 and math.isfinite(v)):
        raise ParameterError(f"{what} must be a positive number of seconds, got {value!r}")
    return v


def dask_timeout() -> float:
    """Seconds allowed for each handshake with a dask scheduler: ``ENVFIT_DASK_TIMEOUT`` (a
    positive number) or :data:`DEFAULT_DASK_TIMEOUT`; anything else is a
    :class:`ParameterError`.
    """
    env = os.environ.get("ENVFIT_DASK_TIMEOUT", "").strip()
    if not env:
        return DEFAULT_DASK_TIMEOUT
    return _positive_seconds(env, "ENVFIT_DASK_TIMEOUT")


async def _identity(address: str, timeout: float) -> Any:
    """Connect (dask comm handshake included) and ask for the endpoint's ``identity``."""
    from distributed.comm import connect
    from distributed.core import send_recv

    comm = await connect(address, timeout=0.8 * timeout)  # retried until then, if refused
    try:
        return await send_recv(comm, op="identity")
    finally:
        comm.abort()


def _run_bounded(make_coro: Callable[[], Any], timeout: float) -> Any:
    """``make_coro()`` run to completion in a fresh event loop on a helper thread (so that
    this works under a running loop too), cancelled after ``timeout`` s
    (:class:`TimeoutError`); the coroutine's own exception is re-raised."""
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = asyncio.run(asyncio.wait_for(make_coro(), timeout))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            box["error"] = exc

    th = threading.Thread(target=target, name="envfit-dask-identify", daemon=True)
    th.start()
    th.join(timeout + 5.0)
    if th.is_alive() or isinstance(box.get("error"), (asyncio.TimeoutError, TimeoutError)):
        raise TimeoutError
    if "error" in box:
        raise box["error"]
    return box["value"]


def _why(exc: BaseException) -> str:
    msg = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {msg[:200]}" if msg else type(exc).__name__


def _connect_failure(exc: OSError, seconds: float, address: str | None = None) -> str:
    """What a failed ``distributed.comm.connect`` to ``address`` means, in a few words."""
    chain, e = [], exc
    while e is not None and len(chain) < 5:
        chain.append(e)
        e = e.__cause__ or e.__context__
    refused = (f"connection refused (nothing listens there; retried for {seconds:.3g} s, "
               "ENVFIT_DASK_TIMEOUT sets the limit)")
    if any(isinstance(e, ConnectionRefusedError) or "Connection refused" in str(e)
           for e in chain):
        return refused
    if address is not None and _tcp_refused(address):
        # distributed's retry loop can end in its own cancelled last attempt (a loaded
        # machine): the chain then holds CancelledError, not the refusal; a plain TCP probe
        # tells the two apart
        return refused
    return _why(chain[-1] if len(chain) > 1 else exc)


def _tcp_refused(address: str) -> bool:
    """True when a plain TCP connect to ``address`` (tcp://HOST:PORT) is refused at once."""
    import socket
    from distributed.comm.addressing import get_address_host_port

    try:
        host, port = get_address_host_port(address)
        socket.create_connection((host, int(port)), timeout=1.0).close()
    except ConnectionRefusedError:
        return True
    except (OSError, ValueError, TypeError):
        return False
    return False


def identify_scheduler(address: str, timeout: float) -> dict:
    """The ``identity`` of the dask scheduler at ``address``, every step (TCP connect, comm
    handshake, the request and its reply) within ``timeout`` seconds in all.

    Raises :class:`ExecutorError` (one line) for a malformed address, a refused or
    silent endpoint, one that answers in another protocol (HTTP, garbage: distributed may
    read its first bytes as a frame length and fail to allocate it, a ``MemoryError``), or a
    dask server that is not a scheduler (a worker, a nanny).
    """
    _check_address(address)
    where = f"cannot reach the dask scheduler at {address}"
    try:
        reply = _run_bounded(lambda: _identity(address, timeout), timeout)
    except TimeoutError:
        raise ExecutorError(f"{where}: no answer to dask's handshake within {timeout:g} s (is "
                            "it a dask scheduler's address? ENVFIT_DASK_TIMEOUT sets the "
                            "limit)") from None
    except OSError as exc:  # refused (retried until the deadline), reset, closed
        raise ExecutorError(f"{where}: {_connect_failure(exc, 0.8 * timeout, address)}") from None
    except Exception as exc:  # its bytes are not dask messages (HTTP, garbage, ...)
        raise ExecutorError(f"{where}: the endpoint does not speak dask's protocol (reading "
                            f"its answer failed: {_why(exc)})") from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        kind = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
        raise ExecutorError(f"{where}: the endpoint answered as {kind!r}, not as a dask "
                            "scheduler (give the scheduler's address, not a worker's)")
    return reply


def _check_address(address: str) -> None:
    """:class:`ParameterError` unless ``address`` parses as a dask address with a port."""
    from distributed.comm.addressing import get_address_host_port, parse_address
    from distributed.comm.registry import get_backend

    try:
        scheme, _ = parse_address(address)
        get_backend(scheme)
        if scheme in ("tcp", "tls", "ws", "wss"):
            port = get_address_host_port(address)[1]
            if not 0 < int(port) < 65536:
                raise ValueError(f"port {port} is out of range")
    except (ValueError, TypeError) as exc:
        raise ParameterError(f"--scheduler {address!r} is not a dask scheduler address "
                             f"({' '.join(str(exc).split())}); expected tcp://HOST:PORT") from None


def _connect_client(distributed, address: str, timeout: float):
    """A ``distributed.Client`` to the scheduler at ``address`` (identified first, see
    :func:`identify_scheduler`), made with ``timeout`` on the connect and the identify;
    waits up to ``timeout`` for a first worker."""
    import dask

    ident = identify_scheduler(address, timeout)
    with dask.config.set({"distributed.comm.timeouts.connect": f"{timeout}s"}):
        try:
            client = distributed.Client(address, timeout=timeout)
        except Exception as exc:
            raise ExecutorError(f"cannot reach the dask scheduler at {address}: "
                                f"{_why(exc)}") from None
    if not ident.get("workers") and not ident.get("n_workers"):
        try:
            client.wait_for_workers(1, timeout=timeout)
        except Exception:
            client.close()
            raise ExecutorError(f"the dask scheduler at {address} has no workers (waited "
                                f"{timeout:g} s, ENVFIT_DASK_TIMEOUT); start some with "
                                f"`dask worker {address}`") from None
    return client


class DaskExecutor:
    """Tasks on a dask.distributed cluster: ``scheduler`` address, an existing ``client``,
    or (neither) a ``LocalCluster`` of ``workers`` single-threaded processes on loopback.

    A worker lost mid-task is reported by dask (``KilledWorker`` once the scheduler's
    ``allowed-failures`` retries are used up, or a lost connection): the driver keeps the
    finished cells and reports the rest as to be re-run.
    """

    name = "dask"

    def __init__(self, scheduler: str | None = None, workers: int | None = None, *,
                 client=None, timeout: float | None = None):
        distributed = _import_distributed()
        self._cluster = None
        self._own_client = client is None
        self.timeout = dask_timeout() if timeout is None else _positive_seconds(timeout)
        if client is not None:
            self.client = client
        elif scheduler:
            self.client = _connect_client(distributed, scheduler, self.timeout)
        else:
            n = machine_cores() if workers is None else int(workers)
            if n < 1:
                raise ParameterError(f"--workers must be at least 1, got {n}")
            self._cluster = distributed.LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                dashboard_address=None, memory_limit=0)
            self.client = distributed.Client(self._cluster)
        from envfit.base import check_same_code, code_state
        check_same_code(self.client.run(code_state), code_state())   # before any task
        self.blas_threads = self._threads_per_task()

    def _threads_per_task(self) -> int:
        """cores // (worker threads on the host), the smallest over hosts (1 if unknown)."""
        try:
            info = self.client.scheduler_info(n_workers=-1)["workers"]
        except TypeError:  # older distributed: no n_workers argument
            info = self.client.scheduler_info()["workers"]
        if not info:
            return 1
        cores = self.client.run(machine_cores)
        per_host: dict[str, list[int]] = {}
        for addr, w in info.items():
            host = w.get("host") or addr.rsplit(":", 1)[0]
            per_host.setdefault(host, [0, 0])
            per_host[host][0] += int(w.get("nthreads", 1))
            per_host[host][1] = max(per_host[host][1], int(cores.get(addr, 1)))
        return max(1, min(c // max(t, 1) for t, c in per_host.values()))

    @property
    def slots(self) -> int:
        return max(1, sum(self.client.nthreads().values()))

    def describe(self) -> str:
        where = (f"LocalCluster at {self.client.scheduler.address}" if self._cluster is not None
                 else f"scheduler {self.client.scheduler.address}")
        return f"dask ({where}, {self.slots} worker thread(s), {self.blas_threads} BLAS thread(s) per task)"

    def submit(self, fn: Callable, *args: Any):
        return self.client.submit(run_pinned, self.blas_threads, fn, *args, pure=False)

    def wait_any(self, futures: Iterable) -> tuple[set, set]:
        distributed = _import_distributed()
        res = distributed.wait(list(futures), return_when="FIRST_COMPLETED")
        return set(res.done), set(res.not_done)

    @staticmethod
    def result(fut) -> Any:
        return fut.result()

    def share(self, obj: Any):
        """Send ``obj`` to the cluster once; the returned future can be passed to tasks."""
        return self.client.scatter([obj], broadcast=True, hash=False)[0]

    @staticmethod
    def is_lost_worker(exc: BaseException) -> bool:
        distributed = _import_distributed()
        lost = [distributed.scheduler.KilledWorker, distributed.comm.CommClosedError,
                cf.CancelledError]
        try:
            from distributed.client import FutureCancelledError
            lost.append(FutureCancelledError)
        except ImportError:  # pragma: no cover - older distributed
            pass
        return isinstance(exc, tuple(lost))

    def close(self) -> None:
        if self._own_client:
            self.client.close()
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def check_executor_choice(kind: str, workers: int | None, scheduler: str | None) -> None:
    """One line (:class:`ParameterError`) for an unknown executor, ``--scheduler`` without
    dask, or ``--workers`` with a remote scheduler — before any work."""
    if kind not in EXECUTORS:
        raise ParameterError(f"unknown executor {kind!r}; choose one of {', '.join(EXECUTORS)}")
    if scheduler and kind != "dask":
        raise ParameterError("--scheduler needs --executor dask")
    if kind == "dask" and scheduler and workers is not None:
        raise ParameterError("--workers sizes a local cluster; with --scheduler the "
                             "cluster's own workers are used")


def make_executor(kind: str | Any = "local", *, workers: int | None = None,
                  scheduler: str | None = None, max_useful: int | None = None,
                  bytes_per_task: int = 0,
                  timeout: float | None = None) -> tuple[Any, list[str]]:
    """An executor (and notes) for ``kind`` = ``"local"`` or ``"dask"``; an executor object
    is returned as is. ``max_useful``/``bytes_per_task`` size a local pool or LocalCluster
    (:func:`plan_workers`); a remote cluster is sized by whoever started it. ``timeout``:
    seconds per handshake with a remote scheduler (None: :func:`dask_timeout`)."""
    if not isinstance(kind, str):
        return kind, []
    check_executor_choice(kind, workers, scheduler)
    if kind == "dask" and scheduler:
        return DaskExecutor(scheduler, timeout=timeout), []
    w, notes = plan_workers(workers, cores=machine_cores(),
                            max_useful=max_useful or machine_cores(),
                            bytes_per_task=bytes_per_task)
    if kind == "dask":
        return DaskExecutor(None, w), notes
    return LocalExecutor(w), notes
