"""Independent curves as tasks: in this process one after another, or on a Dask cluster.

A study is many curves that share nothing but the model: the members of a family, the
values of a peak curve found by sweeps, the samples of an uncertainty study. Each is a
:class:`Task`, a module-level function of the case's models and its own arguments that
returns an :class:`Outcome` (the datasets and attributes of its results.h5 group, its status
and the lines it reported). Continuation along one branch stays inside one task.

Two executors run them with the same interface (:meth:`Serial.run`,
:meth:`Distributed.run`: ``(task index, outcome)`` as each finishes):

- :class:`Serial` calls each task in this process, in order, its progress printed live (as
  every run did before there were clusters);
- :class:`Distributed` submits them to a Dask cluster: a local one of worker processes,
  started on first need, or an existing scheduler by address (a dask-jobqueue cluster is
  one). Before a local cluster exists, an analysis with one task to compute, or (by
  default) with less work than starting the cluster saves (``worth_s``), runs here. The
  models reach every worker once, as a worker plugin (``worker.Models``: a worker that
  joins or restarts later gets them too) and stay there for the run (a worker's assembly
  models, built from them, are kept between its tasks); numba's kernels load from its
  on-disk cache once per worker process. Workers write nothing: the client gathers each
  outcome as it finishes, prints its lines and is the only writer of results.h5.

A worker lost mid-task (killed, out of memory) has its task re-run on another by the
scheduler (up to ``distributed.scheduler.allowed-failures`` times, 3 by default, then the
curve fails, naming the loss). A task that raises is a bug, not bad luck: it is reported as
that curve's failure, not retried. Ctrl-C (or SIGTERM) while the client waits cancels every
outstanding task and leaves what finished.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from .progress import time_left

Progress = Callable[[str], None]

#: Seconds to wait for a scheduler given by address before saying it is unreachable.
CONNECT_S = 10.0
#: A quiet wait longer than this prints a line (tasks done, running, time so far).
HEARTBEAT_S = 30.0
#: How often the client looks for finished tasks while it waits [s] (Dask's own
#: as_completed polls as often).
POLL_S = 0.1
#: BLAS threads of every stage of a run by default (``--threads``), wherever it runs. One:
#: the same numbers serially and on any worker (OpenBLAS' LU rounds differently with its
#: thread count: 1e-10 on blisk_quick's curves, a point's dissipation at a stick/slip kink
#: apart), and faster at these sizes (blisk_quick's three-curve family serially: 12.2 s at
#: one thread, 22.9 s at two on two cores; a loaded machine's factorization 0.05 s at one,
#: 22 s at the default); the parallelism is the tasks'.
BLAS_THREADS = 1
#: Starting a local cluster of two workers and loading microslip and the compiled kernels
#: into each takes ~5 s here (1.3 s for the processes, 3.6 s for the imports). By default
#: (``run`` without ``--workers``) an analysis whose tasks are estimated to take less than
#: this in one process runs in it: two workers would save at most half of it.
WORTH_S = 10.0
#: Local workers per core at most: past that each worker gets too little of a core and of the
#: memory to be worth its process.
MAX_WORKERS_PER_CORE = 8


@dataclass(frozen=True)
class Outcome:
    """What one task computed: ``data`` and ``attrs`` of its results.h5 group (the layout of
    ``ResultsWriter.write_group``), its ``status`` and ``message`` (as a curve's), the
    ``lines`` its consumer prints once the outcome is written (its summary; on a worker
    every line it gave) and the seconds it took."""

    data: dict[str, Any]
    attrs: dict[str, Any]
    status: str
    message: str = ""
    lines: tuple[str, ...] = ()
    seconds: float = 0.0


@dataclass(frozen=True)
class Task:
    """``function(models, *args, progress=..., live=...) -> Outcome``, a module-level
    function (a worker imports it by name); ``label`` names it in progress lines;
    ``estimate``: its rough seconds in one process (``case.task_seconds``). ``live``
    False: the task runs on a worker, its progress lines are kept for the client and
    per-point ticks are left out."""

    function: Callable[..., Outcome]
    args: tuple = ()
    label: str = ""
    estimate: float = 0.0

    def run(self, models: Any, progress: Progress, live: bool, blas: Any = None,
            threads: int = BLAS_THREADS) -> Outcome:
        """The outcome, computed with ``threads`` BLAS threads and timed. ``blas``: this
        process' ``threadpoolctl.ThreadpoolController`` (its scan of the loaded libraries
        takes 3 ms, half a cluster's cost per task: made once by the caller), or None."""
        from threadpoolctl import ThreadpoolController

        t = time.perf_counter()
        with (blas or ThreadpoolController()).limit(limits=threads, user_api="blas"):
            outcome = self.function(models, *self.args, progress=progress, live=live)
        return replace(outcome, seconds=time.perf_counter() - t)


@dataclass
class Serial:
    """Every task in this process, in order (``--workers 0``), with ``threads`` BLAS
    threads."""

    threads: int = BLAS_THREADS
    workers = 0

    def run(self, tasks: Sequence[Task], models: Any, progress: Progress, what: str = "",
            count: bool = True) -> Iterator[tuple[int, Outcome]]:
        from threadpoolctl import ThreadpoolController

        blas = ThreadpoolController()
        for i, task in enumerate(tasks):
            yield i, task.run(models, progress, live=True, blas=blas, threads=self.threads)

    def close(self) -> None:
        pass


@dataclass
class Distributed:
    """Tasks on a Dask cluster: a local one of ``workers`` processes started on first need,
    or the scheduler at ``address`` (connected at once: :func:`connect`). Until a local
    cluster runs, tasks whose estimates sum to less than ``worth_s`` seconds run here."""

    workers: int = 0
    address: str = ""
    worth_s: float = 0.0
    heartbeat_s: float = HEARTBEAT_S
    threads: int = BLAS_THREADS  # BLAS threads of each task, on every worker
    client: Any = None
    _cluster: Any = None
    _announced: bool = False
    _pushed: dict[int, tuple[Any, str]] = field(default_factory=dict)

    def run(self, tasks: Sequence[Task], models: Any, progress: Progress, what: str = "",
            count: bool = True) -> Iterator[tuple[int, Outcome]]:
        """(task index, outcome) as each finishes (``what`` prefixes the client's own lines;
        ``count``: a line per finished task with the time left); without a cluster yet, a
        single task, or less work than ``worth_s``, runs here. Ctrl-C cancels the
        outstanding tasks and is raised again."""
        if self.client is None and (len(tasks) < 2 or
                                    sum(t.estimate for t in tasks) < self.worth_s):
            yield from Serial(self.threads).run(tasks, models, progress)
            return
        from distributed import as_completed

        from .worker import remote

        client = self._client(progress)
        name = self._push(models)
        futures = [client.submit(remote, t, name, self.threads, pure=False, retries=0)
                   for t in tasks]
        index = {f.key: i for i, f in enumerate(futures)}
        # results gathered in the background as tasks finish (one callback per future, not
        # a wait over every pending one per finished task: 10,000 samples stay linear)
        finished = as_completed(futures, with_results=True, raise_errors=False)
        pending, t0, quiet = set(futures), time.perf_counter(), time.perf_counter()
        try:
            while pending:
                if not finished.has_ready():
                    time.sleep(POLL_S)
                    if time.perf_counter() - quiet > self.heartbeat_s:
                        quiet = time.perf_counter()  # a quiet while: the cluster works
                        progress(f"{what}{len(tasks) - len(pending)} of {len(tasks)} tasks "
                                 f"finished, {len(pending)} running or queued "
                                 f"({quiet - t0:.0f} s so far)")
                    continue
                for f, result in sorted(finished.next_batch(block=False),
                                        key=lambda fr: index[fr[0].key]):
                    pending.discard(f)
                    yield index[f.key], _result(f, result, tasks[index[f.key]])
                    # said once the consumer has written it: a Ctrl-C now keeps it
                    done = len(tasks) - len(pending)
                    left = time_left(time.perf_counter() - t0, done / len(tasks))
                    if count and len(tasks) > 1:
                        progress(f"{what}{done} of {len(tasks)} tasks finished on the "
                                 f"cluster{', ' + left if left else ''}")
                quiet = time.perf_counter()
        finally:  # interrupted, or the consumer stopped early: nothing left running
            if pending:
                client.cancel(list(pending))

    def _client(self, progress: Progress):
        """The client, a local cluster started first if there is none; said once."""
        if self.client is None:
            self._cluster, self.client = local_cluster(self.workers)
            progress(f"[cluster] local Dask cluster: {self.workers} worker processes, one "
                     "thread each")
            self._announced = True
        if not self._announced:
            n = len(self.client.scheduler_info().get("workers", {}))
            progress(f"[cluster] the Dask cluster at {self.address}: {n} workers")
            self._announced = True
        return self.client

    def _push(self, models: Any) -> str:
        """The name under which ``models`` are on every worker (worker.Models), pushed once
        per models object (kept here, so that its id stays its own)."""
        import uuid

        from .worker import Models

        key = id(models)
        if key not in self._pushed:
            name = f"microslip-models-{uuid.uuid4().hex}"
            self.client.register_plugin(Models(models, name), name=name)
            self._pushed[key] = (models, name)
        return self._pushed[key][1]

    def close(self) -> None:
        """Take the models off the workers (a remote cluster outlives the run) and shut a
        local cluster down."""
        if self.client is not None:
            for _, name in self._pushed.values():
                with contextlib.suppress(Exception):  # a cluster already gone
                    self.client.unregister_worker_plugin(name)
            self._pushed.clear()
            self.client.close()
        if self._cluster is not None:
            self._cluster.close()
        self.client = self._cluster = None


def _result(future, result: Any, task: Task) -> Outcome:
    """A finished future's outcome (``result``: its value, or (type, error, traceback)); a
    task that raised, or whose workers kept dying, as a failed curve that says so."""
    if future.status == "finished":
        return result
    err = result[1]
    name = type(err).__name__
    if name == "KilledWorker":
        why = ("its worker was lost each time it ran (out of memory? give the workers more "
               "memory, or run fewer of them)")
    else:
        why = f"error on a worker: {name}: {err}"
    return Outcome({}, {}, "failed", f"{task.label}: {why}".lstrip(": "))


def local_cluster(workers: int):
    """(cluster, client) of ``workers`` local worker processes, one thread each (the
    kernels are single-threaded; so is each worker's BLAS, by Dask's default), no dashboard
    (the scheduler's HTTP routes on a free port: two runs at once do not collide on 8787)
    and Dask's own log lines silenced: a task's fault reaches the run through its future
    (:func:`_result`), and what Dask logs besides is nothing a user acts on (a worker's
    heartbeat that finds the scheduler closed first, on a loaded machine, printed a
    traceback after a complete run)."""
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.CRITICAL,
                           scheduler_kwargs={"dashboard_address": ":0"},
                           preload=["microslip.app.worker"])  # its dask_setup
    return cluster, Client(cluster)


def workers_fault(workers: int, cores: int | None = None) -> str:
    """"" if ``--workers`` is allowed on this machine, else what is (one line)."""
    cores = cores or machine_cores()
    top = MAX_WORKERS_PER_CORE * cores
    if 0 <= workers <= top:
        return ""
    return (f"--workers = {workers}: expected 0 (in this process) to {top} "
            f"({MAX_WORKERS_PER_CORE} per core of this machine's {cores})")


def machine_cores() -> int:
    """The cores this process may use (the default number of local workers)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def connect(address: str, timeout: float = CONNECT_S) -> tuple[Any, str]:
    """(client, "") of the scheduler at ``address`` whose every worker can run microslip's
    tasks, else (None, one line saying why): unreachable, no workers, or a worker without
    microslip (or with other sources than this machine's)."""
    from distributed import Client

    unreachable = (f"--scheduler {address}: cannot reach a Dask scheduler there in "
                   f"{timeout:g} s ({{}}); start one (dask scheduler) or give its address as "
                   "tcp://host:port")
    kind, why = _probe(address, timeout)
    if kind == "unreachable":  # said at once: Dask's own connect would retry until the timeout
        return None, unreachable.format(why)
    if kind:  # Dask's client would wait for ever, or read a reply as a frame size
        return None, (f"--scheduler {address}: {why}; give the address of a Dask "
                      "scheduler (dask scheduler prints it: tcp://host:8786)")
    try:
        client = Client(address, timeout=f"{timeout}s")
    except (OSError, TimeoutError, ValueError) as err:
        return None, unreachable.format(type(err).__name__)
    fault = workers_ready(client)
    if fault:
        client.close()
        return None, f"--scheduler {address}: {fault}"
    return client, ""


#: A Dask message's first 8 bytes are its size; a handshake is far below this [bytes].
HANDSHAKE_BYTES = 1 << 26


def _probe(address: str, timeout: float) -> tuple[str, str]:
    """(what is wrong with the TCP scheduler address, one phrase why): ("unreachable", ...)
    when it cannot be connected to, ("not dask", ...) when the service there is not a Dask
    scheduler, ("", "") when it greets as one (or the protocol is not TCP: Dask checks those
    itself).

    A scheduler greets each connection with its handshake at once: a message whose first 8
    bytes are its size. A service that says nothing until asked (an HTTP server, a proxy
    that accepts any address) would keep Dask's client waiting past any timeout, and one
    that answers what Dask sends is read as a frame of exabytes; so connect once and listen,
    sending nothing, for ``timeout`` seconds."""
    import socket
    import struct
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme != "tcp":
        return "", ""
    try:
        host, port = parts.hostname, parts.port
    except ValueError:  # a port out of range or not a number
        return "unreachable", "no valid port"
    if not host or port is None:
        return "unreachable", "no host:port"
    try:
        sock = socket.create_connection((host, port), timeout=timeout)
    except OSError as err:
        return "unreachable", err.strerror or type(err).__name__
    head = b""
    deadline = time.monotonic() + timeout
    with sock:
        try:
            while len(head) < 8 and time.monotonic() < deadline:
                sock.settimeout(max(deadline - time.monotonic(), 1e-3))
                chunk = sock.recv(8 - len(head))
                if not chunk:
                    break
                head += chunk
        except TimeoutError:
            pass
        except OSError as err:
            return "not dask", f"the connection failed ({err.strerror or type(err).__name__})"
    if not head:
        return "not dask", (f"a service listens there but said nothing in {timeout:g} s, as "
                            "a Dask scheduler would at once (an HTTP server or a proxy?)")
    if len(head) < 8 or struct.unpack("Q", head)[0] > HANDSHAKE_BYTES:
        return "not dask", f"the service there is not a Dask scheduler (it began with {head!r})"
    return "", ""


def workers_ready(client) -> str:
    """"" when the cluster has workers that all import microslip with this machine's
    sources (the same code gives the same numbers), else what is wrong (one line)."""
    from importlib.metadata import version

    from .store import code_digest

    # a function of the standard library: a worker without microslip can still run it
    found = client.run(version, "microslip", on_error="return")
    if not found:
        return "the scheduler has no workers (start some: dask worker <address>)"
    missing = sorted(w for w, v in found.items() if isinstance(v, BaseException))
    if missing:
        return (f"worker {missing[0]} cannot import microslip ({len(missing)} of {len(found)}"
                " workers); install it there as on this machine (pip install -e <repo>)")
    digests = client.run(code_digest, on_error="return")
    failed = sorted(w for w, d in digests.items() if isinstance(d, BaseException))
    if failed:
        return (f"worker {failed[0]} cannot read its microslip sources "
                f"({digests[failed[0]]}); install microslip there from its sources")
    mine = code_digest()
    other = sorted(w for w, d in digests.items() if d != mine)
    if other:
        return (f"worker {other[0]} runs other microslip sources than this machine "
                f"({len(other)} of {len(digests)} workers); install the same version there")
    return ""
