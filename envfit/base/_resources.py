"""Memory budget: check before allocating, fail with a clear message instead of swapping."""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

from envfit.base._errors import MemoryBudgetError, ParameterError
from envfit.defaults import SOLVERS

__all__ = ["machine_cores", "interpolator_nbytes", "iterative_nbytes", "iterative_coarse_nodes", "largest_feasible_n", "SOLVERS", "available_memory_bytes", "check_memory", "format_bytes", "memory_budget_bytes",
           "budget_words", "time_limit_seconds", "time_limit_words", "MIN_TIME_LIMIT",
           "plan_memory", "largest_n_within", "Stage", "Plan", "peak_rss_bytes",
           "rss_bytes"]

#: fraction of the available memory one allocation plan may take
MEMORY_FRACTION = 0.8


def machine_cores() -> int:
    """Cores this process may run on (the CPU affinity mask, else ``os.cpu_count()``)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


def available_memory_bytes() -> int:
    """Memory that can be allocated now: ``MemAvailable`` from /proc/meminfo (else total
    RAM), lowered to what the address-space limit (``ulimit -v``, RLIMIT_AS) leaves beyond
    this process's current size and to what a cgroup v2 ``memory.max`` leaves beyond its
    ``memory.current`` (a container's limit).

    The environment variable ``ENVFIT_MEMORY_LIMIT`` (bytes, or with a K/M/G/T suffix)
    overrides it, e.g. to reserve memory for other processes or to test the guard.
    """
    env = os.environ.get("ENVFIT_MEMORY_LIMIT")
    if env:
        return _parse_size(env)
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        except (ValueError, OSError, AttributeError):  # pragma: no cover - exotic platforms
            avail = 8 * 2**30
    for limit in (_address_space_left(), _cgroup_left()):
        if limit is not None:
            avail = min(avail, limit)
    return int(avail)


def _parse_size(text: str) -> int:
    units = {"K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}
    s = str(text).strip().upper().rstrip("B")
    mult = units.get(s[-1:], 1)
    try:
        value = float(s[:-1] if s[-1:] in units else s)
    except ValueError:
        value = float("nan")
    if not value >= 0 or value == float("inf"):
        raise ParameterError(f"ENVFIT_MEMORY_LIMIT must be a size such as 500M or 16G, got {text!r}")
    return int(value * mult)


def _address_space_left() -> int | None:
    """RLIMIT_AS (``ulimit -v``) minus this process's virtual size, or None if unlimited."""
    try:
        import resource
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY or soft <= 0:
            return None
        with open("/proc/self/status") as fh:
            vm = next((int(line.split()[1]) * 1024 for line in fh if line.startswith("VmSize:")), 0)
        return max(0, int(soft) - vm)
    except (ImportError, OSError, ValueError):  # pragma: no cover - non-Linux
        return None


def _cgroup_left() -> int | None:
    """cgroup v2 ``memory.max`` minus ``memory.current``, or None without a limit."""
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            top = fh.read().strip()
        if top == "max":
            return None
        with open("/sys/fs/cgroup/memory.current") as fh:
            used = int(fh.read().strip())
        return max(0, int(top) - used)
    except (OSError, ValueError):
        return None


def format_bytes(n: float) -> str:
    """Human-readable size, e.g. ``3.2 GB`` (decimal units, as the paper's '3.2 GB').

    >>> format_bytes(3.2e9), format_bytes(8e18), format_bytes(512)
    ('3.2 GB', '8.0 EB', '512 B')
    """
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB", "EB", "ZB"):
        if abs(n) < 1000 or unit == "ZB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1000.0
    return f"{n:.1f} ZB"  # pragma: no cover


def budget_words() -> str:
    """Where the memory budget comes from, as the messages say it: ``80% of available
    memory``, or ``80% of ENVFIT_MEMORY_LIMIT=1G`` when the variable sets it (its text as
    given: what the user set, not what the machine has).

    >>> budget_words().startswith("80% of ")
    True
    """
    env = os.environ.get("ENVFIT_MEMORY_LIMIT", "").strip()
    where = f"ENVFIT_MEMORY_LIMIT={env}" if env else "available memory"
    return f"{int(MEMORY_FRACTION * 100)}% of {where}"


#: the smallest ``ENVFIT_TIME_LIMIT`` taken (seconds): planning a run (measuring the machine's
#: rates, :func:`envfit.sh._plan.machine_rates`) takes a good part of a second already
MIN_TIME_LIMIT = 1.0


def time_limit_seconds(default: float) -> float:
    """The time limit of planned work: ``ENVFIT_TIME_LIMIT`` (seconds, at least
    :data:`MIN_TIME_LIMIT`; ``0``, ``none`` or ``inf``: no limit) or ``default``.

    Raises :class:`ParameterError` in one line naming the variable and its value for a value
    that is not a number of seconds or is below :data:`MIN_TIME_LIMIT` (no work fits it).
    """
    text = os.environ.get("ENVFIT_TIME_LIMIT", "").strip()
    if not text:
        return float(default)
    if text.lower() in ("none", "inf", "0"):
        return math.inf
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not v > 0:
        raise ParameterError(f"ENVFIT_TIME_LIMIT must be a number of seconds (or 'none'), "
                             f"got {text!r}")
    if v < MIN_TIME_LIMIT:
        raise ParameterError(f"ENVFIT_TIME_LIMIT={text} is below {MIN_TIME_LIMIT:g} s, less "
                             f"than planning any run takes: give seconds >= "
                             f"{MIN_TIME_LIMIT:g}, or 'none' for no limit")
    return v


def time_limit_words(limit: float) -> str:
    """The limit as the messages say it: ``the 900 s limit (ENVFIT_TIME_LIMIT)`` for the
    default, ``the 1.5 s limit (ENVFIT_TIME_LIMIT=1.5)`` when the variable sets it."""
    text = os.environ.get("ENVFIT_TIME_LIMIT", "").strip()
    secs = f"{limit:g} s" if limit < 1e4 else f"{limit:.1e} s"
    return f"the {secs} limit (ENVFIT_TIME_LIMIT{'=' + text if text else ''})"


def memory_budget_bytes() -> int:
    """What one allocation plan may take: :data:`MEMORY_FRACTION` of :func:`available_memory_bytes`."""
    return int(available_memory_bytes() * MEMORY_FRACTION)


def check_memory(nbytes: int, what: str, *, hint: str = "") -> None:
    """Raise :class:`MemoryBudgetError` if ``nbytes`` exceeds the memory budget.

    ``what`` names the work (e.g. ``"the 20000x20000 kernel matrix"``); ``hint`` can say
    what would fit (e.g. ``"the largest N that fits is 15000"``).
    """
    budget = memory_budget_bytes()
    if nbytes > budget:
        msg = (f"{what} needs {format_bytes(nbytes)} but only {format_bytes(budget)} "
               f"can be used ({budget_words()})")
        if hint:
            msg += f"; {hint}"
        raise MemoryBudgetError(msg)


def largest_n_within(nbytes_of, budget: int, upper: int) -> int:
    """Largest N in [0, upper] with ``nbytes_of(N) <= budget`` (``nbytes_of`` increasing).

    >>> largest_n_within(lambda n: 8 * n * n, 800, 10 ** 9)
    10
    """
    lo, hi = 0, int(upper)
    if nbytes_of(hi) <= budget:
        return hi
    while hi - lo > 1:                      # nbytes_of(lo) <= budget < nbytes_of(hi), or lo = 0
        mid = (lo + hi) // 2
        if nbytes_of(mid) <= budget:
            lo = mid
        else:
            hi = mid
    return lo if nbytes_of(lo) <= budget else 0


def _size_model(kernel: bool, channels: int, solver: str, per_n: int, fixed: int):
    """The planned bytes as a function of N (increasing), as :func:`plan_memory` accounts them."""
    if kernel:
        def nbytes_of(k: int) -> int:
            return interpolator_nbytes(k, channels, solver) + per_n * k + fixed
    else:
        def nbytes_of(k: int) -> int:
            return 8 * k * (3 + channels) + per_n * k + fixed
    return nbytes_of


def _what_needs(n: int, total: int, kernel: bool, solver: str) -> str:
    """What needs ``total`` bytes at N = n, in words, for :func:`plan_memory`'s message."""
    if kernel and solver == "cholesky":
        return f"the {n}x{n} float64 kernel matrix and the N-sized arrays need {format_bytes(total)}"
    if kernel:
        return (f"the iterative solver's sparse preconditioner, near-field matrix and "
                f"N-sized arrays need {format_bytes(total)}")
    return f"the {n} points, values and per-point temporaries need {format_bytes(total)}"


def plan_memory(n: int, what: str, *, channels: int = 1, kernel: bool = True,
                per_n_bytes: int = 0, fixed_bytes: int = 0, n_name: str = "N",
                smallest: int = 2, solver: str = "cholesky") -> int:
    r"""The one memory guard for work whose size grows with N: call it with the largest N
    of a run **before** anything of size N (sample points, values, kernel matrices) is made.

    Accounts for

    * ``kernel=True``: :func:`interpolator_nbytes` for ``solver`` — ``"cholesky"``: the N x N
      float64 kernel matrix (factorised in place), the O(N C) arrays (N x 3 points, N x C
      values and coefficients, node copies) and the fixed evaluation-block / LAPACK
      workspace; ``"iterative"``: O(N k) (:func:`iterative_nbytes`); ``"auto"``: dense
      where it fits, else iterative;
      ``kernel=False``: the N x 3 points and N x C values, ``8 N (3 + C)``;
    * ``per_n_bytes`` more per N (weights, lookup blocks, temporaries of the caller);
    * ``fixed_bytes`` that do not depend on N (the map on its scale, pixel directions, the
      reconstruction).

    Raises :class:`~envfit.base._errors.MemoryBudgetError` with one line naming what does not
    fit, the sizes and the largest N that fits (``n_name`` names the parameter, e.g.
    ``"fit_n"``), e.g. ``table2 at N = 1000000000: the 1000000000x1000000000 float64 kernel
    matrix and the N-sized arrays need 8.0 EB but only 15.2 GB can be used (80% of available
    memory); the largest N that fits is 43500``. Returns the planned bytes.

    Costs O(log N) arithmetic, no allocation: it is safe for any N.

    >>> try:
    ...     plan_memory(10 ** 9, "table2", channels=3)
    ... except MemoryBudgetError as e:
    ...     print(str(e).split(" but ")[0])
    table2 at N = 1000000000: the 1000000000x1000000000 float64 kernel matrix and the N-sized arrays need 8.0 EB
    >>> plan_memory(1000, "a small fit", channels=3) < 2 ** 30
    True
    """
    n = int(n)
    solver = _check_solver(solver)
    nbytes_of = _size_model(kernel, max(1, int(channels)), solver, int(per_n_bytes),
                            int(fixed_bytes))
    total = nbytes_of(n)
    budget = memory_budget_bytes()
    if total <= budget:
        return total
    fits = largest_n_within(nbytes_of, budget, n)
    msg = (f"{what} at {n_name} = {n}: {_what_needs(n, total, kernel, solver)} but only "
           f"{format_bytes(budget)} can be used ({budget_words()}); ")
    if fits >= smallest:
        msg += f"the largest {n_name} that fits is {fits}"
    else:
        msg += (f"not even {n_name} = {smallest} fits (the map and fixed buffers alone need "
                f"{format_bytes(nbytes_of(0))}): free memory or raise ENVFIT_MEMORY_LIMIT")
    raise MemoryBudgetError(msg)


#: fixed allowance (bytes) for evaluation temporaries, LAPACK/BLAS buffers, bookkeeping
_WORKSPACE_BYTES = 96 * 2**20


# SOLVERS, the interpolator's linear solvers, is envfit.defaults', imported above
#: the iterative path's memory model: near pairs per node, local Lagrange neighbours k
_ITER_NEAR, _ITER_K = 48, 60


def iterative_coarse_nodes(n: int) -> int:
    """m, the iterative solver's coarse-level size at N nodes: N / 40 within [400, 3000],
    at most N / 4 (measured at N = 80 000, s = 1.5: m = 400 / 1000 / 2000 gave 13 / 9 / 7
    CG iterations; its dense factor is 8 m^2 bytes, <= 72 MB)."""
    n = int(n)
    return int(max(1, min(max(400, n // 40), 3000, n // 4)))


def _check_solver(solver: str) -> str:
    if solver not in SOLVERS:
        raise ParameterError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    return solver


def iterative_nbytes(n: int, nchannels: int = 1) -> int:
    """Memory of the iterative path (:mod:`envfit.sobolev._iterative`): O(N k), no N x N array.

    CSR entries at 12 bytes (value + int32 index) ``x 1.3`` (construction's transient copy):
    the near part of the product (~2 x 48 per row, both triangles) and the symmetrised local
    Lagrange preconditioner (<= 2 k per row, k = 60) ``+ 8 N (14 C + 24)`` (values, CG's
    vectors per channel, node arrays and angles, the kd-tree) ``+ 8 N 2 k`` (neighbour
    indices and coefficients while building) ``+ 8 m^2`` (the coarse factor,
    :func:`iterative_coarse_nodes`) ``+`` 64 MiB (SH transforms, temporaries).
    """
    n, c = int(n), max(1, int(nchannels))
    coarse = 8 * iterative_coarse_nodes(n) ** 2
    sparse = 12 * n * (2 * _ITER_NEAR + 2 * _ITER_K) * 1.3
    return int(sparse + 8 * n * (14 * c + 24) + 16 * n * _ITER_K + coarse + 64 * 2**20)


def interpolator_nbytes(n: int, nchannels: int = 1, solver: str = "cholesky") -> int:
    """Memory an interpolator of N nodes needs.

    ``solver="cholesky"``: the N x N factor plus O(N C) arrays, ``8 N^2`` (float64 matrix,
    factorised in place) ``+ 8 N (4 C + 16)`` (values, coefficients, node arrays, cached
    diag of K^-1) ``+`` a fixed 96 MiB for evaluation blocks (<= 64 MiB) and LAPACK/BLAS
    buffers. ``"iterative"``: :func:`iterative_nbytes`. ``"auto"``: the dense figure where
    it fits the budget (:func:`memory_budget_bytes`), else the iterative one (``auto``
    goes iterative where the dense matrix would not fit).
    """
    n = int(n)
    solver = _check_solver(solver)
    dense = 8 * n * n + 8 * n * (4 * int(nchannels) + 16) + _WORKSPACE_BYTES
    if solver == "cholesky" or (solver == "auto" and dense <= memory_budget_bytes()):
        return dense
    return iterative_nbytes(n, nchannels)


def largest_feasible_n(budget_bytes: float, nchannels: int = 1, solver: str = "cholesky") -> int:
    """Largest N with ``interpolator_nbytes(N, C, solver) <= budget_bytes`` (dense: root of
    the quadratic; iterative and auto: the iterative path's linear model)."""
    if _check_solver(solver) != "cholesky":
        return largest_n_within(lambda k: iterative_nbytes(k, nchannels), int(budget_bytes),
                                10 ** 12)
    b = 8.0 * (4 * nchannels + 16)
    rest = float(budget_bytes) - _WORKSPACE_BYTES
    if rest <= 0:
        return 0
    n = int((-b + math.sqrt(b * b + 32.0 * rest)) / 16.0)
    while n > 0 and interpolator_nbytes(n, nchannels) > budget_bytes:
        n -= 1
    while interpolator_nbytes(n + 1, nchannels) <= budget_bytes:
        n += 1
    return n


@dataclass(frozen=True)
class Stage:
    """One stage of a command's work and its predicted cost, before it runs.

    ``nbytes``: its peak memory beyond the plan's resident bytes (the map and what every stage
    keeps); ``seconds``: its predicted wall time on one core of a 2020s x86 server (a model
    calibrated on envfit's own measurements: a rough figure, within ~2x on a loaded machine);
    ``detail``: what dominates it (e.g. ``"SH coefficients to l = 2047"``); ``option``: the
    command-line option that sizes it, when one does (e.g. ``"--lmax"``, in
    :func:`envfit.sh._plan.check_sh_plan`'s refusals).
    """

    name: str
    nbytes: int
    seconds: float = 0.0
    detail: str = ""
    option: str = ""


@dataclass
class Plan:
    """The stages of a command with their predicted peaks, checked against the memory budget
    (:func:`memory_budget_bytes`) before any of them runs.

    The stages run one after the other: the plan's peak is ``resident`` plus the largest
    stage's ``nbytes``, its time the sum of the stages' seconds.

    >>> p = Plan("advise", [Stage("fit", 10 ** 6, 2.0), Stage("power", 3 * 10 ** 6, 5.0)],
    ...          resident=10 ** 6)
    >>> p.peak(), p.seconds(), p.worst().name, p.fits(5 * 10 ** 6), p.fits(3 * 10 ** 6)
    (4000000, 7.0, 'power', True, False)
    """

    what: str
    stages: list = field(default_factory=list)
    resident: int = 0

    def peak(self) -> int:
        """Predicted peak bytes: resident + the largest stage."""
        return int(self.resident + max((s.nbytes for s in self.stages), default=0))

    def seconds(self) -> float:
        """Predicted total seconds."""
        return float(sum(s.seconds for s in self.stages))

    def worst(self) -> Stage:
        """The stage of the peak."""
        return max(self.stages, key=lambda s: s.nbytes)

    def fits(self, budget: int | None = None) -> bool:
        """Whether the peak is within ``budget`` (default :func:`memory_budget_bytes`)."""
        return self.peak() <= (memory_budget_bytes() if budget is None else int(budget))

    def check(self, hint: str = "") -> None:
        """Raise :class:`MemoryBudgetError` (one line: the stage, its peak, the budget and
        ``hint``) unless the plan fits the budget."""
        budget = memory_budget_bytes()
        if self.peak() <= budget:
            return
        w = self.worst()
        msg = (f"{self.what}: {w.name}" + (f" ({w.detail})" if w.detail else "")
               + f" needs {format_bytes(self.peak())} but only {format_bytes(budget)} can be "
               f"used ({budget_words()})")
        raise MemoryBudgetError(msg + (f"; {hint}" if hint else ""))

    def lines(self) -> list[str]:
        """One line per stage: name, predicted peak (resident included) and seconds."""
        return [f"{s.name}: {format_bytes(self.resident + s.nbytes)}, ~{s.seconds:.0f} s"
                + (f" ({s.detail})" if s.detail else "") for s in self.stages]

    def to_dict(self) -> dict:
        """The plan for JSON: stages with predicted peak bytes and seconds."""
        return {"what": self.what, "resident_bytes": int(self.resident),
                "peak_bytes": self.peak(), "seconds": self.seconds(),
                "stages": [{"name": s.name, "peak_bytes": int(self.resident + s.nbytes),
                            "seconds": float(s.seconds), "detail": s.detail}
                           for s in self.stages]}


def rss_bytes() -> int:
    """This process's resident memory now (``VmRSS`` of /proc/self/status); 0 if unknown."""
    return _status_bytes("VmRSS:")


def _status_bytes(key: str) -> int:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(key):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def peak_rss_bytes() -> int:
    """This process's peak resident memory so far (``VmHWM`` of /proc/self/status, else
    ``ru_maxrss``); 0 where neither is known."""
    peak = _status_bytes("VmHWM:")
    if peak:
        return peak
    try:
        import resource
        return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024
    except (ImportError, OSError):  # pragma: no cover - non-POSIX
        return 0
