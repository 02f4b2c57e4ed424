"""Where a build's tasks run: in this process, in local worker processes, or on Ray.

Each runner calls ``on_result(TaskResult)`` in this process as tasks finish, in any order;
the build writes cache entries and outputs from there, so a worker never writes a file.

- :func:`run_local`: ``jobs`` worker processes (spawned, one torch thread each); with one
  worker, or one task, in this process (no start-up cost).
- :func:`run_ray`: the same tasks as Ray tasks (``num_cpus=1``, retried by Ray when a worker
  dies). The weights go to Ray's object store once and each worker process writes them to
  a local file once. ``address`` None starts a Ray instance on this machine (what the tests
  use); ``auto`` or ``ray://HOST:10001`` joins a cluster, whose nodes need this Python
  environment and the scripts' folder (recordings, gesture folders) at the same path.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

from core.fileio import atomic_write
from core.interrupts import import_optional
from core.reading import read_bytes
from core.workers import spawn_context, stop
from model.engines import NETWORK_ENGINES
from sgt_tui.build.keys import database_hash, weights_hash
from sgt_tui.build.work import Task, TaskResult, run_task, warm_up

OnResult = Callable[[TaskResult], None]


class RunnerError(Exception):
    """The runner itself failed (a worker process died, Ray could not start); one line for users."""


class LocalPool:
    """``jobs`` spawned worker processes (no inherited state: threads, torch), started on
    demand; :meth:`warm` starts one now, to load torch and the weights while the build is
    still reading the scripts (the "one line changed" build waits for nothing else)."""

    def __init__(self, jobs: int, settings) -> None:
        from concurrent.futures import ProcessPoolExecutor

        self.jobs = jobs
        self.started: list = []  # every worker process started, recorded before the executor does
        self.pool = ProcessPoolExecutor(max_workers=jobs, mp_context=spawn_context(self.started),
                                        initializer=warm_up, initargs=(settings,))
        self.warming = None  # the warm-up's future, while :meth:`warm` has started one worker

    def warm(self) -> None:
        self.warming = self.pool.submit(int)

    def submit_when_warm(self, tasks: Sequence[Task], idle: Callable[[], None] | None) -> dict:
        """Hand ``tasks`` (fewer than the workers) to the warm worker once it is ready, calling
        ``idle`` meanwhile: submitted earlier, they would make the pool start a second worker
        (nothing is idle yet), whose imports take a core from this process and the first one
        (an edit's rebuild waits for them). Returns {future: task}."""

        futures: dict = {}
        failed: list[BaseException] = []

        def hand_over() -> None:
            try:
                self.warming.result()
            except BaseException as exc:  # noqa: BLE001 - re-raised below, in the build's thread
                failed.append(exc)
                return
            futures.update({self.pool.submit(run_task, task): task for task in tasks})

        thread = threading.Thread(target=hand_over, name="sgt-hand-over", daemon=True)
        thread.start()
        if idle:
            idle()
        thread.join()
        if failed:
            raise failed[0]
        return futures

    def close(self, wait: bool = True) -> None:
        """Stop the workers; without ``wait``, at once (a warm-up that turned out useless)."""
        stop(self.pool, self.started, wait)


def run_local(tasks: Sequence[Task], jobs: int, on_result: OnResult, pool: LocalPool | None = None,
              idle: Callable[[], None] | None = None) -> None:
    """Run ``tasks`` on ``pool`` (closed after), or on a new one; one task or one job without a
    pool runs in this process. ``idle`` is called once the tasks are handed to the workers,
    before waiting for them."""
    workers = min(jobs, len(tasks))
    if pool is None and workers <= 1:
        for task in tasks:
            on_result(run_task(task))
        return
    from concurrent.futures import as_completed
    from concurrent.futures.process import BrokenProcessPool

    pool = pool or LocalPool(workers, tasks[0].settings)
    finished = False
    try:
        if pool.warming is not None and len(tasks) < pool.jobs:
            futures = pool.submit_when_warm(tasks, idle)
        else:
            futures = {pool.pool.submit(run_task, task): task for task in tasks}
            if idle:
                idle()
        for future in as_completed(futures):
            try:
                result = future.result()
            except BrokenProcessPool:
                raise
            except Exception as exc:  # noqa: BLE001 - a bug in a worker fails its utterances, not the build
                result = TaskResult(futures[future].number, error=f"internal error: {exc.__class__.__name__}: {exc}")
            on_result(result)
        finished = True
    except BrokenProcessPool:
        raise RunnerError("a worker process died (killed, or out of memory); run the build again to finish it") from None
    finally:
        # interrupted (ctrl+c) or failed: stop the workers now; they do not get SIGINT themselves
        pool.close(wait=finished)


# -- Ray --------------------------------------------------------------------------------------

#: Per Ray worker process: weights (or matching database) sha256 -> the local file holding
#: them (and the weights' ONNX export beside it, when they have one).
_WEIGHTS_FILES: dict[str, str] = {}


def _local_weights(digest: str, holder: list, suffix: str = ".pt") -> str:
    """The weights (``suffix`` ``.npz``: the matching database) as a file on this worker,
    fetched from the object store once per process."""
    path = _WEIGHTS_FILES.get(digest)
    if path is None:
        import tempfile

        import ray  # lazy: ray

        path = os.path.join(tempfile.gettempdir(), f"sgt-{'weights' if suffix == '.pt' else 'matching'}-{digest}{suffix}")
        if not os.path.isfile(path):
            atomic_write(path, ray.get(holder[0]))
        if len(holder) > 1:  # the ONNX export beside it, so workers run what local ones run
            onnx = path[: -len(".pt")] + ".onnx"
            if not os.path.isfile(onnx):
                atomic_write(onnx, ray.get(holder[1]))
        _WEIGHTS_FILES[digest] = path
    return path


def _ray_task(task: Task, weights: tuple | None, database: tuple | None = None) -> TaskResult:
    local = _local_weights(*weights) if weights is not None else None
    return run_task(task, weights=local, database=_local_weights(*database, ".npz") if database is not None else None)


def run_ray(tasks: Sequence[Task], address: str | None, on_result: OnResult, *, jobs: int | None = None) -> None:
    try:
        ray = import_optional("ray")  # lazy: ray
    except ImportError:
        raise RunnerError("--ray needs Ray: pip install -e '.[ray]' (or pip install 'ray>=2.40')") from None
    started = not ray.is_initialized()
    if started:
        import logging

        # Ray's own warnings (its token-authentication notice on every local start, among them)
        # are not the build's: --quiet prints errors only, and Ray's errors come as exceptions
        logging.getLogger("ray").setLevel(logging.ERROR)
        kwargs: dict = {"include_dashboard": False, "log_to_driver": False, "configure_logging": False}
        if address:
            kwargs["address"] = address
        elif jobs:
            kwargs["num_cpus"] = jobs
        # workers import sgt from the same place as this process (a checkout on PYTHONPATH or an install)
        root = str(Path(__file__).resolve().parents[2])
        kwargs["runtime_env"] = {"env_vars": {"PYTHONPATH": os.pathsep.join(
            p for p in (root, os.environ.get("PYTHONPATH", "")) if p)}}
        try:
            ray.init(**kwargs)
        except Exception as exc:  # noqa: BLE001 - ray.init raises ConnectionError, RuntimeError, ValueError...: all mean "no cluster"
            raise RunnerError(f"cannot start or reach Ray{' at ' + address if address else ''}: {exc}") from None
    try:
        weights = None
        settings = tasks[0].settings if tasks else None
        if settings is not None and settings.engine in NETWORK_ENGINES:
            from model.weights import default_weights  # lazy: numpy

            source = Path(settings.weights) if settings.weights else default_weights(settings.engine)
            holder = [ray.put(read_bytes(source, "weights"))]
            export = source.with_suffix(".onnx")  # model.runtime.onnx_path: inference uses it when fresh
            if export.is_file():
                holder.append(ray.put(read_bytes(export, "weights")))
            weights = (weights_hash(settings.weights, settings.engine), holder)
        database = None
        if settings is not None and settings.engine == "matching" and settings.database:  # (the shipped one is in the checkout)
            database = (database_hash(settings.database), [ray.put(read_bytes(settings.database, "matching database"))])
        remote = ray.remote(num_cpus=1, max_retries=3)(_ray_task)
        pending = [remote.remote(task, weights, database) for task in tasks]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            try:
                on_result(ray.get(done[0]))
            except ray.exceptions.RayError as exc:
                raise RunnerError(f"a Ray task failed: {str(exc).splitlines()[0]}") from None
    finally:
        if started:
            ray.shutdown()
