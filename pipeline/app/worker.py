"""What runs on a Dask worker (``tasks.Distributed``): the case's models pushed once per
worker, the task that reads them, and the start-up hook of local workers.

The models reach the workers as a worker plugin (:class:`Models`), not as scattered data:
the scheduler keeps a plugin and hands it to every worker that joins later, a worker
restarted after a loss included, while its memory manager keeps only as many copies of
scattered data as tasks wait for (one, between analyses), so a lost worker could take the
only copy with it and each task could fetch the models again.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from distributed import get_worker
from distributed.diagnostics.plugin import WorkerPlugin


class Models(WorkerPlugin):
    """A case's models (``LumpedModels`` or ``AssemblyModels``) on a worker, under ``name``;
    a worker's assembly models, built from them by its tasks, stay for the next ones."""

    def __init__(self, models: Any, name: str):
        self.models = models
        self.name = name
        self.blas = None  # the worker's ThreadpoolController, made by its first task

    def setup(self, worker) -> None:
        """The worker process keeps the memory it frees for reuse, as the command does
        (fe.linalg.retain_freed_memory): without it a worker spent 30 % of its time in the
        kernel, faulting in fresh pages for each large array."""
        from microslip.fe.linalg import retain_freed_memory

        retain_freed_memory()


def remote(task, name: str, threads: int = 1):
    """Run ``task`` (a ``tasks.Task``) on this worker with the models pushed as ``name`` and
    ``threads`` BLAS threads (the run's ``--threads``);
    its outcome, carrying every line the task gave (the client prints them). The contact
    kernels' numba threads are the worker's threads (one by default): numba's own default,
    every core, made N workers on N cores run 2N threads (the blisk's damper-mass family
    on two workers: 78 s with them, 63 s without)."""
    import numba
    from threadpoolctl import ThreadpoolController

    lines: list[str] = []
    worker = get_worker()
    plugin = worker.plugins[name]
    numba.set_num_threads(min(worker.state.nthreads, numba.config.NUMBA_NUM_THREADS))
    if plugin.blas is None:  # the libraries a task's imports load are loaded by now
        plugin.blas = ThreadpoolController()
    outcome = task.run(plugin.models, lines.append, live=False, blas=plugin.blas,
                       threads=threads)
    return replace(outcome, lines=(*lines, *outcome.lines))


def dask_setup(worker) -> None:
    """Dask's preload hook, run in each local worker process as it starts (and restarts):
    the worker ignores SIGINT. Ctrl-C in a terminal reaches the whole process group; the
    client alone handles it (cancels the outstanding tasks, saves what finished, closes the
    cluster), where a worker taking it would die mid-task with a traceback."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
