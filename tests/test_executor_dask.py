"""The dask executor against a real LocalCluster (2 worker processes, loopback): the same
numbers as the local executor; a worker killed mid-sweep loses no finished cell and a re-run
completes the sweep; the CLI reaches a running scheduler; an unreachable one is one line."""
from __future__ import annotations

import json
import os

import pytest

distributed = pytest.importorskip("distributed")

import dask  # noqa: E402

import envfit.cli as cli  # noqa: E402
from envfit.maps._io import save_envmap  # noqa: E402
from envfit.base._errors import ExecutorError  # noqa: E402
from envfit.batch._executor import DaskExecutor  # noqa: E402
from envfit.batch import LibraryOptions, fit_smoothness_library, run_table2_library  # noqa: E402
from test_library import INLINE, S, N, assert_same_tables, gp_map, killing_sources  # noqa: E402

pytestmark = pytest.mark.dask


@pytest.fixture(scope="module")
def maps():
    return [gp_map(0), gp_map(1), gp_map(2, height=16)]


@pytest.fixture(scope="module")
def client():
    # no retries: a task whose worker dies fails at once (KilledWorker), so the driver's
    # lost-worker path is what the kill test exercises
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           host="127.0.0.1", dashboard_address=None,
                                           silence_logs=50)
        c = distributed.Client(cluster)
        yield c
        c.close()
        cluster.close()


@pytest.fixture(scope="module")
def reference(maps):
    return run_table2_library(maps, S, N, options=INLINE)


def test_dask_gives_the_local_numbers(maps, client, reference, tmp_path):
    ex = DaskExecutor(client=client)
    assert ex.slots == 2 and ex.blas_threads >= 1
    lib = run_table2_library(maps, S, N, options=LibraryOptions(executor=ex), out=tmp_path)
    assert lib.factorizations == len(S) * len(N) and lib.executor.startswith("dask")
    for a, b in zip(lib.maps, reference.maps):
        assert_same_tables(a, b)
    assert len(list(tmp_path.glob("*/cells/*.json"))) == len(maps) * len(S) * len(N)
    local = fit_smoothness_library(maps[2:], n=120, scale="linear", options=INLINE)
    remote = fit_smoothness_library(maps[2:], n=120, scale="linear",
                                    options=LibraryOptions(executor=ex))
    for a, b in zip(local.fits, remote.fits):
        assert a.s == pytest.approx(b.s, rel=1e-10)
        assert a.s_interval == pytest.approx(b.s_interval, rel=1e-10)


def test_killed_worker_keeps_cells_and_rerun_completes(maps, client, reference, tmp_path):
    flag, out = tmp_path / "kill-now", tmp_path / "out"
    srcs = killing_sources(maps, flag)
    ex = DaskExecutor(client=client)
    pids = set(client.run(os.getpid).values())

    def arm(label, cell, resumed):          # after the first cell: the next load kills a worker
        if not (tmp_path / "armed").exists():
            (tmp_path / "armed").touch()
            flag.touch()

    with pytest.raises(ExecutorError, match="lost with their worker"):
        run_table2_library(srcs, S, N, options=LibraryOptions(executor=ex), out=out, on_cell=arm)
    assert not flag.exists()
    finished = list(out.glob("*/cells/*.json"))
    total = len(maps) * len(S) * len(N)
    assert 1 <= len(finished) < total
    client.wait_for_workers(2, timeout=60)
    assert set(client.run(os.getpid).values()) != pids            # the nanny restarted one
    again = run_table2_library(srcs, S, N, options=LibraryOptions(executor=ex), out=out)
    assert again.cells_resumed == len(finished) and again.cells_computed == total - len(finished)
    for a, b in zip(again.maps, reference.maps):
        assert_same_tables(a, b)


def test_cli_runs_on_a_scheduler(maps, client, tmp_path, capsys):
    paths = [str(save_envmap(tmp_path / f"{m.name}.exr", m)) for m in maps[:2]]
    js = tmp_path / "t.json"
    assert cli.main(["table2", *paths, "--s", "1.5", "--n", "40,90", "--executor", "dask",
                     "--scheduler", client.scheduler.address, "--json", str(js), "--quiet"]) == 0
    d = json.loads(js.read_text())
    assert d["factorizations"] == 2 and set(d["maps"]) == {"gp0", "gp1"}
    assert cli.main(["table2", *paths, "--executor", "dask", "--scheduler", client.scheduler.address,
                     "--workers", "1"]) == 2
    assert "--workers sizes a local cluster" in capsys.readouterr().err


def test_a_worker_is_not_a_scheduler(client):
    worker = next(iter(client.scheduler_info()["workers"]))
    with pytest.raises(ExecutorError, match="answered as 'Worker', not as a dask scheduler"):
        DaskExecutor(worker, timeout=5)


def test_unreachable_scheduler_is_one_line():
    with pytest.raises(ExecutorError, match="cannot reach the dask scheduler at tcp://127.0.0.1:9"):
        DaskExecutor("tcp://127.0.0.1:9", timeout=1)


def _stale_here():
    import envfit.base._code as code
    code.IMPORTED_AT = 0.0              # as if envfit had been imported before its files changed
    return True


def _fresh_here(t):
    import envfit.base._code as code
    code.IMPORTED_AT = t
    return True


def test_a_worker_running_stale_envfit_is_refused_before_any_task(client):
    """A long-lived worker that imported envfit before the checkout changed would compute
    with old modules: the executor refuses it in one line as it connects; the same workers
    with current code are taken."""
    import envfit.base._code as code
    assert DaskExecutor(client=client).slots == 2             # same code: taken
    saved = client.run(lambda: __import__("envfit.base._code").base._code.IMPORTED_AT)
    client.run(_stale_here)
    try:
        with pytest.raises(ExecutorError, match="imported before its files changed: restart"):
            DaskExecutor(client=client)
    finally:
        for addr, t in saved.items():
            client.run(_fresh_here, t, workers=[addr])
    assert not any(s["stale"] for s in client.run(code.code_state).values())
