"""The Monte Carlo engine shared by every study (the Monte Carlo runs of the thesis, §5).

A study is a list of **cases** (plain dicts of settings, JSON-serialisable) crossed with
run indices ``0 .. runs - 1``.  Each *task* ``(case, run)`` calls the study's task
function ``func(case, rng) -> dict`` with its own generator

    rng = numpy.random.default_rng(numpy.random.SeedSequence([seed, data_id, run]))

where ``data_id`` is a stable 32-bit hash of ``case["data"]`` (the settings that define
the simulated record; the whole case if it has no ``"data"`` entry).  So

* a task's numbers depend only on ``(seed, case data, run)``: identical whatever the
  backend, the number of jobs, the order in which tasks finish, the number of runs or
  the other cases in the study - provided the BLAS thread count is the same (threaded
  BLAS reorders sums: last-bit differences, which an ill-conditioned fit can amplify to
  visible digits; every backend runs its tasks with one BLAS thread, so their records
  agree bit for bit);
* cases that differ only in the method (``case["method"]``) see the *same* record for
  the same run (paired comparison, as in the thesis's Table 1).

Backends: serial (``jobs=1``), joblib/loky processes (``jobs > 1``), or Dask
(``scheduler="tcp://host:port"`` or a ``dask.distributed.Client``).  All three yield
``(task, record)`` pairs into one collector that updates the tqdm bar and appends each
record as one JSON line to ``OUT/results.jsonl`` as soon as it is known, so an
interrupted study resumes where it stopped (``resume=True`` skips the tasks already in
the file) and a rerun with more runs only computes the new ones.

A task that raises is recorded as a failure (``ok: False``, exception type and
message), never a crash of the study; warnings raised inside a task are recorded in
the record (``warnings``), not printed.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hdpbsid.runtime import user_stacklevel

__all__ = [
    "Task",
    "run_tasks",
    "execute_task",
    "task_rng",
    "data_id",
    "case_key",
    "check_runs",
    "check_jobs",
    "load_records",
    "RESULTS_FILE",
]

#: name of the per-task results file inside ``out``
RESULTS_FILE = "results.jsonl"

TaskFunc = Callable[[dict[str, Any], np.random.Generator], dict[str, Any]]


def _canonical(obj: Any) -> str:
    """Canonical JSON text (sorted keys, no spaces) used for hashing and keys."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=repr)


def data_id(case: dict[str, Any]) -> int:
    """Stable 32-bit integer of a case's data settings.

    Parameters
    ----------
    case : dict
        The case; ``case["data"]`` is hashed when present, else the whole case.

    Returns
    -------
    int
        The first four bytes (little-endian) of the SHA-256 of the canonical JSON, the same
        in every process and Python version (unlike ``hash``).

    Examples
    --------
    >>> data_id({"data": {"snr": 20}, "method": "a"}) == data_id({"data": {"snr": 20}})
    True
    """
    data = case.get("data", case)
    digest = hashlib.sha256(_canonical(data).encode()).digest()
    return int.from_bytes(digest[:4], "little")


def case_key(case: dict[str, Any]) -> str:
    """A case's identity for resuming.

    Parameters
    ----------
    case : dict
        The case.

    Returns
    -------
    str
        Its canonical JSON text (sorted keys, no spaces).
    """
    return _canonical(case)


def task_rng(seed: int, case: dict[str, Any], run: int) -> np.random.Generator:
    """The generator of one task (module docstring).

    Parameters
    ----------
    seed : int
        The study's base seed.
    case : dict
        The case.
    run : int
        The Monte Carlo run.

    Returns
    -------
    numpy.random.Generator
        ``default_rng(SeedSequence([seed, data_id(case), run]))``: a task's numbers depend
        only on ``(seed, case data, run)``, whatever the backend or the order of execution.

    Examples
    --------
    >>> a = task_rng(0, {"data": {"snr": 20}, "method": "x"}, 3).standard_normal()
    >>> b = task_rng(0, {"data": {"snr": 20}, "method": "y"}, 3).standard_normal()
    >>> a == b  # the same record for every method of a run
    True
    """
    return np.random.default_rng(np.random.SeedSequence([int(seed), data_id(case), int(run)]))


def check_runs(runs: Any, name: str = "runs") -> int:
    """Check a number of Monte Carlo runs.

    Parameters
    ----------
    runs : int
        At least 1.
    name : str, optional
        The argument's name in the messages.

    Returns
    -------
    int
        ``runs``.

    Raises
    ------
    TypeError
        If ``runs`` is not an integer (or is a bool).
    ValueError
        If ``runs < 1``.
    """
    if isinstance(runs, bool) or not isinstance(runs, int | np.integer):
        raise TypeError(f"{name} must be an integer >= 1, got {type(runs).__name__} {runs!r}")
    if runs < 1:
        raise ValueError(f"{name} must be >= 1, got {runs}")
    return int(runs)


def check_jobs(jobs: Any) -> int:
    """Check a number of local processes.

    Parameters
    ----------
    jobs : int
        At least 1, or -1 for every core.

    Returns
    -------
    int
        The number of processes.

    Raises
    ------
    TypeError
        If ``jobs`` is not an integer (or is a bool).
    ValueError
        If ``jobs`` is 0 or below -1.
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int | np.integer):
        raise TypeError(f"jobs must be an integer >= 1 (or -1), got {type(jobs).__name__}")
    if jobs == -1:
        return os.cpu_count() or 1
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1 or -1 (all cores), got {jobs}")
    return int(jobs)


@dataclass(frozen=True)
class Task:
    """One unit of work: a case at one Monte Carlo run.

    Parameters
    ----------
    index : int
        Position of the case in the study's case list.
    case : dict
        The case's settings.
    run : int
        The Monte Carlo run.
    """

    index: int
    case: dict[str, Any]
    run: int

    @property
    def key(self) -> tuple[str, int]:
        """``(case_key(case), run)``, the task's identity for resuming."""
        return case_key(self.case), self.run


def execute_task(
    func: TaskFunc, study: str, seed: int, case: dict[str, Any], run: int
) -> dict[str, Any]:
    """Run one task and return its record; a failing identification is data, not a crash.

    Parameters
    ----------
    func : callable
        The study's ``task(case, rng) -> dict``.
    study : str
        The study's name.
    seed : int
        The study's base seed.
    case : dict
        The case.
    run : int
        The Monte Carlo run.

    Returns
    -------
    dict
        Plain JSON data: ``study, seed, run, case, ok, time`` (wall seconds), then
        ``result`` (what ``func`` returned) when ``ok``, else ``error_type``, ``error`` and
        ``traceback`` (last lines); ``warnings`` lists the warning messages caught (at most
        10; resource warnings of earlier work in the process are left out, so a record does
        not depend on what ran before it).
    """
    rng = task_rng(seed, case, run)
    rec: dict[str, Any] = {"study": study, "seed": int(seed), "run": int(run), "case": case}
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = func(case, rng)
        except Exception as exc:  # a failed identification is data, not a crash
            rec["ok"] = False
            rec["error_type"] = type(exc).__name__
            rec["error"] = str(exc)
            rec["traceback"] = traceback.format_exc(limit=-3)
        else:
            rec["ok"] = True
            rec["result"] = result
    rec["time"] = time.perf_counter() - t0
    # ResourceWarnings come from the garbage collector finalising objects of earlier work
    # in the process (e.g. a Jupyter client's sockets), not from the task: not recorded, so
    # a task's record does not depend on what the process ran before it
    msgs = sorted(
        {
            f"{w.category.__name__}: {w.message}"
            for w in caught
            if not issubclass(w.category, ResourceWarning)
        }
    )
    rec["warnings"] = msgs[:10]
    return _plain(rec)


def _plain(x: Any) -> Any:
    """numpy scalars/arrays -> Python; complex -> ``[re, im]``; non-finite floats kept
    as ``None`` so that the JSON lines stay standard JSON."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return _plain(x.item())
    if isinstance(x, complex):
        return [_plain(x.real), _plain(x.imag)]
    if isinstance(x, float):
        return x if np.isfinite(x) else None
    if x is None or isinstance(x, bool | int | str):
        return x
    return repr(x)


# -- backends: each yields (task, record) as tasks finish --------------------------------
def _blas_limit() -> Any:
    """One BLAS thread while tasks run in this process, when ``threadpoolctl`` is
    installed (else a no-op).  Monte Carlo parallelism is over tasks: the workers already
    use the cores, and a threaded BLAS inside each would oversubscribe them (small
    matrices gain nothing from threads and lose much to their contention), so the joblib
    workers run with one thread each too."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=1)


def _serial(func: TaskFunc, study: str, seed: int, tasks: Sequence[Task]) -> Iterator:
    for task in tasks:
        with _blas_limit():
            rec = execute_task(func, study, seed, task.case, task.run)
        yield task, rec


def _joblib(func: TaskFunc, study: str, seed: int, tasks: Sequence[Task], jobs: int) -> Iterator:
    try:
        from joblib import Parallel, delayed
    except ImportError as exc:  # pragma: no cover - joblib is in the studies extra
        raise ImportError("jobs > 1 needs joblib: pip install 'slbasis-hdpbsid[studies]'") from exc
    par = Parallel(n_jobs=jobs, backend="loky", return_as="generator_unordered")
    # one job per record: the tasks sharing a record run in one worker, which simulates it
    # once (studies.data caches it); task by task, joblib spread them over the workers
    # and each worker simulated the record again.  The tasks travel with their records
    # so that unordered results can be matched.
    results = par(delayed(_execute_group)(func, study, seed, group) for group in _groups(tasks))
    for done in results:
        yield from done


def _groups(tasks: Sequence[Task]) -> list[list[Task]]:
    """Consecutive tasks with the same record (``data_id`` of the case and run) grouped."""
    groups: list[list[Task]] = []
    last = None
    for task in tasks:
        key = (data_id(task.case), task.run)
        if groups and key == last:
            groups[-1].append(task)
        else:
            groups.append([task])
        last = key
    return groups


def _execute_group(
    func: TaskFunc, study: str, seed: int, group: Sequence[Task]
) -> list[tuple[Task, dict]]:
    return [_execute_with_task(func, study, seed, task) for task in group]


def _execute_with_task(func: TaskFunc, study: str, seed: int, task: Task) -> tuple[Task, dict]:
    return task, execute_task(func, study, seed, task.case, task.run)


def _dask_client(scheduler: Any) -> tuple[Any, bool]:
    """A ``dask.distributed.Client`` from an address string or a client; returns
    ``(client, owned)`` (``owned``: we opened it and must close it)."""
    try:
        from dask.distributed import Client
    except ImportError as exc:  # pragma: no cover - dask is in the cluster extra
        raise ImportError(
            "scheduler needs dask.distributed: pip install 'slbasis-hdpbsid[cluster]'"
        ) from exc
    if isinstance(scheduler, Client):
        return scheduler, False
    if not isinstance(scheduler, str):
        raise TypeError(
            "scheduler must be an address string like 'tcp://127.0.0.1:8786' or a "
            f"dask.distributed.Client, got {type(scheduler).__name__}"
        )
    if "://" not in scheduler or not scheduler.split("://", 1)[1]:
        raise ValueError(
            f"scheduler must be an address like 'tcp://127.0.0.1:8786', got {scheduler!r}"
        )
    try:
        return Client(scheduler, timeout="10s", set_as_default=False), True
    except (OSError, TimeoutError, ValueError) as exc:
        raise ValueError(
            f"scheduler: could not connect to the Dask scheduler at {scheduler!r} ({exc})"
        ) from exc


def _dask(func: TaskFunc, study: str, seed: int, tasks: Sequence[Task], scheduler: Any) -> Iterator:
    from dask.distributed import as_completed

    client, owned = _dask_client(scheduler)
    try:
        futures = [
            client.submit(_execute_with_task, func, study, seed, task, pure=False) for task in tasks
        ]
        for fut in as_completed(futures, loop=client.loop):
            yield fut.result()
            fut.release()
    finally:
        if owned:
            client.close()


# -- persistence --------------------------------------------------------------------------
def load_records(path: str | Path) -> list[dict[str, Any]]:
    """The records of a ``results.jsonl`` file.

    Parameters
    ----------
    path : str or path-like
        The file; a missing file gives no records.

    Returns
    -------
    list of dict
        One record per readable line.

    Warns
    -----
    RuntimeWarning
        When lines are unreadable (an interrupted write); they are skipped.
    """
    path = Path(path)
    if not path.is_file():
        return []
    out = []
    bad = 0
    for line in path.read_text().splitlines():
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            bad += 1
    if bad:
        warnings.warn(
            f"{path}: skipped {bad} unreadable line(s) (interrupted write?)",
            RuntimeWarning,
            stacklevel=user_stacklevel(),
        )
    return out


def _progress(total: int, desc: str, enabled: bool) -> Any:
    if not enabled or total == 0:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:  # pragma: no cover - tqdm is in the studies extra
        warnings.warn(
            "tqdm is not installed: no progress bar", RuntimeWarning, stacklevel=user_stacklevel()
        )
        return None
    return tqdm(total=total, desc=desc, unit="task", dynamic_ncols=True)


def run_tasks(
    func: TaskFunc,
    cases: Sequence[dict[str, Any]],
    runs: int,
    *,
    study: str = "study",
    seed: int = 0,
    jobs: int = 1,
    scheduler: Any | None = None,
    out: str | Path | None = None,
    progress: bool = True,
    resume: bool = True,
) -> list[dict[str, Any]]:
    """Run a task function on every ``(case, run)`` and return the records in task order.

    Parameters
    ----------
    func : callable
        The study's ``task(case, rng) -> dict`` (module-level, so it pickles).
    cases : sequence of dict
        The cases, at least one.
    runs : int
        Monte Carlo runs per case.
    study : str, optional
        The study's name, stored in each record.
    seed : int, optional
        Base seed, non-negative.
    jobs : int, optional
        Local processes (joblib/loky) when above 1; -1 for every core.
    scheduler : str or dask.distributed.Client, optional
        Dask scheduler; takes precedence over ``jobs``.
    out : str or path-like, optional
        Directory for ``results.jsonl``, appended per task as it finishes.
    progress : bool, optional
        Show a tqdm progress bar.
    resume : bool, optional
        Reuse the records of matching ``(study, seed, case, run)`` already in
        ``results.jsonl``; ``False`` starts the file afresh.

    Returns
    -------
    list of dict
        The records in case order, then run, whatever the backend and the order in which
        tasks finished; records of runs beyond ``runs`` stay in the file but are not
        returned.

    Raises
    ------
    TypeError
        If ``runs`` or ``jobs`` is not an integer.
    ValueError
        If ``runs < 1``, ``jobs`` is invalid, ``seed`` is negative or there are no cases.
    """
    runs = check_runs(runs)
    jobs = check_jobs(jobs)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    cases = [dict(c) for c in cases]
    if not cases:
        raise ValueError("the study has no cases: check its settings")
    tasks = [Task(i, c, r) for i, c in enumerate(cases) for r in range(runs)]
    path = None if out is None else Path(out) / RESULTS_FILE
    done = _finished(path, study, seed, resume)
    todo = _execution_order(tasks, done)
    if scheduler is not None:
        stream: Iterable = _dask(func, study, seed, todo, scheduler)
    elif jobs > 1 and len(todo) > 1:
        stream = _joblib(func, study, seed, todo, min(jobs, len(todo)))
    else:
        stream = _serial(func, study, seed, todo)
    if todo:
        _collect(stream, done, path, _progress(len(todo), study, progress))
    return [done[t.key] for t in tasks]


def _finished(
    path: Path | None, study: str, seed: int, resume: bool
) -> dict[tuple[str, int], dict[str, Any]]:
    """The records of ``(study, seed)`` already in ``path``, by task key (none without a
    file or with ``resume=False``, which empties the file)."""
    done: dict[tuple[str, int], dict[str, Any]] = {}
    if path is None:
        return done
    path.parent.mkdir(parents=True, exist_ok=True)
    if not resume:
        path.write_text("")
        return done
    for rec in load_records(path):
        if rec.get("study") == study and rec.get("seed") == seed and "case" in rec:
            done[(case_key(rec["case"]), int(rec["run"]))] = rec
    return done


def _execution_order(tasks: list[Task], done: dict[tuple[str, int], Any]) -> list[Task]:
    """The tasks not done, the cases sharing a record (same data) back to back for each
    run index, so a process simulates each record once (:mod:`hdpbsid.studies.data`
    caches it); the returned records are in task order whatever this order."""
    group: dict[int, int] = {}
    for t in tasks:
        group.setdefault(data_id(t.case), t.index)
    todo = [t for t in tasks if t.key not in done]
    todo.sort(key=lambda t: (group[data_id(t.case)], t.run, t.index))
    return todo


def _collect(
    stream: Iterable, done: dict[tuple[str, int], Any], path: Path | None, bar: Any
) -> None:
    """Store each ``(task, record)`` of ``stream`` in ``done`` and append it to ``path``
    as it finishes (so an interrupted study resumes), updating the progress bar."""
    fh = path.open("a") if path is not None else None
    try:
        for task, rec in stream:
            done[task.key] = rec
            if fh is not None:
                fh.write(json.dumps(rec) + "\n")
                fh.flush()
            if bar is not None:
                bar.update(1)
                if not rec["ok"]:
                    bar.set_postfix_str(f"last failure: {rec['error_type']}")
    finally:
        if bar is not None:
            bar.close()
        if fh is not None:
            fh.close()
