"""The driver loop of a sweep: submit tasks by priority, handle results as they arrive.

Tasks form a small dynamic graph: a finished task's callback may add new tasks (a
finished factorisation adds one evaluation per map). At most ``executor.slots`` tasks are
in flight, so the driver — not a first-in-first-out queue — decides what runs next
(lower ``priority`` first: evaluations before new factorisations, so cells land early and
coefficients do not pile up). Callbacks run in the driver, one at a time: they are where
results are written to disk, atomically, as they arrive.

Failures:

* an :class:`~envfit.base._errors.EnvfitError` raised by a task (a bad map, memory) stops the
  sweep at once and is re-raised with the task's label;
* a lost worker (killed process, dask ``KilledWorker``) loses that task only; the other
  tasks go on, and at the end :class:`~envfit.base._errors.ExecutorError` says how many tasks were
  lost and to re-run (finished cells are on disk, a re-run computes only the rest);
* anything else is a bug and propagates with its traceback.

Example
-------
>>> from envfit.batch._executor import LocalExecutor
>>> seen = []
>>> def more(r):
...     seen.append(r)
...     return [Task(0, abs, (-r,), label="abs", on_done=seen.append)] if r < 0 else []
>>> drive(LocalExecutor(1), [Task(1, min, (-2, 5), label="min", on_done=more)])
>>> seen
[-2, 2]
"""
from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable

from envfit.base import EnvfitError, ExecutorError

__all__ = ["Task", "drive"]

_counter = itertools.count()


@dataclass(order=True)
class Task:
    """``fn(*args)`` on a worker, then ``on_done(result)`` in the driver (which may return
    more tasks). ``args`` may be a zero-argument callable, called only when the task is
    submitted (so large arguments are built late and freed early)."""
    priority: int
    fn: Callable = field(compare=False)
    args: Any = field(compare=False, default=())
    label: str = field(compare=False, default="task")
    on_done: Callable[[Any], Iterable["Task"] | None] | None = field(compare=False, default=None)
    seq: int = field(default_factory=lambda: next(_counter))


def drive(executor, tasks: Iterable[Task]) -> None:
    """Run ``tasks`` (and those their callbacks add) on ``executor``; see the module doc."""
    heap: list[Task] = []
    for t in tasks:
        heapq.heappush(heap, t)
    pending: dict[Any, Task] = {}
    lost: list[tuple[Task, BaseException]] = []
    try:
        while heap or pending:
            slots = executor.slots
            while heap and len(pending) < slots:
                task = heapq.heappop(heap)
                args = task.args() if callable(task.args) else task.args
                try:
                    pending[executor.submit(task.fn, *args)] = task
                except Exception as exc:   # e.g. a process pool broken by a killed worker
                    if not executor.is_lost_worker(exc):
                        raise
                    lost.extend((t, exc) for t in [task, *heap])
                    heap.clear()
            if not pending:
                break
            done, _ = executor.wait_any(pending)
            for fut in done:
                task = pending.pop(fut)
                try:
                    result = executor.result(fut)
                except EnvfitError as exc:
                    raise type(exc)(f"{task.label}: {exc}") from None
                except Exception as exc:
                    if not executor.is_lost_worker(exc):
                        raise
                    lost.append((task, exc))
                    continue
                if task.on_done is not None:
                    for t in task.on_done(result) or ():
                        heapq.heappush(heap, t)
    finally:
        for fut in pending:
            try:
                fut.cancel()
            except Exception:  # pragma: no cover - best effort
                pass
    if lost:
        first_task, first_exc = lost[0]
        why = " ".join(str(first_exc).split())[:200] or type(first_exc).__name__
        raise ExecutorError(
            f"{len(lost)} task(s) lost with their worker (first: {first_task.label}: "
            f"{type(first_exc).__name__}: {why}); {getattr(executor, 'lost_hint', '')}"
            f"finished cells are saved — run the same command again to compute the rest")
