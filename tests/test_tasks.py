"""Independent curves on a real Dask cluster (local worker processes): the same numbers as in
one process, a lost worker's task re-run elsewhere, Ctrl-C keeping every finished curve, and
a cluster that cannot serve refused in one line before any work."""

import contextlib
import copy
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
import tomllib

import h5py
import pytest

from microslip import case as cases
from microslip.app import tasks
from microslip.app.run import run_case
from microslip.app.tasks import Distributed, Outcome, Serial, Task
from microslip.cli import main
from microslip.fe.linalg import available_backends
from microslip.results.compare import differences

CLI = [sys.executable, "-m", "microslip.cli"]

#: The Jenkins oscillator of 01_sdof_wall.toml with a family of FRFs, a peak curve found by a
#: sweep per value and an uncertainty study: every kind of independent curve, 4 + 3 + 8 tasks.
STUDY_TOML = textwrap.dedent("""\
    title = "Jenkins oscillator: every kind of independent curve"
    [model]
    dofs = ["x"]
    mass = [1.0]
    stiffness = [1.0]
    damping = [0.02]
    [[contacts]]
    name = "wall"
    law = "A"
    kt = 3.0
    mu = 1.0
    n0 = 1.0
    u = { x = 1.0 }
    [[loads]]
    dof = "x"
    amplitude = 0.1
    harmonic = 1
    [harmonics]
    max = 3
    samples = 128
    [[analysis]]
    name = "family"
    type = "frf"
    start = 0.5
    stop = 2.5
    family = { key = "contacts.wall.n0", values = [0.0, 0.02, 0.05, 0.2] }
    [[analysis]]
    name = "swept"
    type = "peak"
    parameter = "excitation"
    start = 0.5
    stop = 2.0
    points = 3
    tracking = "sweep"
    window = [0.5, 2.5]
    output = "x"
    [[analysis]]
    name = "spread"
    type = "uncertainty"
    window = [0.8, 2.2]
    output = "x"
    samples = 8
    limit = 0.8
    parameters = { mu = { uniform = [0.01, 0.06] } }
    """)
STUDY = tomllib.loads(STUDY_TOML)


def run(folder, executor, progress=lambda m: None):
    return run_case(cases.Case(copy.deepcopy(STUDY), "study.toml"), folder, progress=progress,
                    cache=False, executor=executor)


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    return run(tmp_path_factory.mktemp("serial"), Serial())


@pytest.fixture(scope="module")
def cluster():
    """A local cluster of two worker processes, one thread each, started now."""
    executor = Distributed(workers=2)
    lines = []
    executor._client(lines.append)
    assert lines == ["[cluster] local Dask cluster: 2 worker processes, one thread each"]
    yield executor
    executor.close()


def scheduled(client) -> dict[str, int]:
    """How many times the scheduler has moved the study's tasks into each state so far."""
    def counts(dask_scheduler):
        prefix = dask_scheduler.task_prefixes.get("remote")  # the tasks' function, _remote
        return {} if prefix is None else dict(prefix.state_counts)
    return client.run_on_scheduler(counts)


def test_a_cluster_gives_the_serial_numbers(serial, cluster, tmp_path):
    before = scheduled(cluster.client)
    path = run(tmp_path, cluster)
    # every task went to the workers, once: 4 + 3 + 8
    done = {k: v - before.get(k, 0) for k, v in scheduled(cluster.client).items()}
    assert done["memory"] == done["processing"] == 15
    with h5py.File(path) as f:
        assert f.attrs["status"] == "complete"
    # same curves in the same order, every number to 1e-12 of its dataset (one BLAS thread
    # per task, here and there: the same operations in the same order)
    assert differences(serial, path, rtol=1e-12) == []


@pytest.mark.slow
def test_an_assembly_study_on_a_cluster_gives_the_serial_numbers(cluster, tmp_path):
    """The coarse blisk + damper (30 s): a damper-mass family with its maps and linear
    limits, and an uncertainty study with its free and stuck levels."""
    from test_assembly_case import CASE

    data = copy.deepcopy(CASE)
    frf = data["analysis"][0] | {"maps": ["peak"], "map_types": ["status"],
                                 "family": {"key": "assembly.mass_multiplier",
                                            "values": [1.0, 4.0]}}
    spread = {"name": "spread", "type": "uncertainty", "window": [3200.0, 3300.0],
              "output": "tip", "samples": 4, "levels": True,
              "parameters": {"mu": {"uniform": [0.3, 0.8]}}}
    data["analysis"] = [frf, spread]
    before = scheduled(cluster.client)
    paths = [run_case(cases.Case(copy.deepcopy(data), "coarse.toml"), tmp_path / where,
                      cache=False, progress=lambda m: None, executor=executor)
             for where, executor in (("serial", Serial()), ("cluster", cluster))]
    assert scheduled(cluster.client)["memory"] - before.get("memory", 0) == 2 + 4
    with h5py.File(paths[1]) as f:
        assert f.attrs["status"] == "complete"
        assert "linear_free" in f["frf"] and "free_peak" in f["spread/statistics"].attrs
    assert differences(paths[0], paths[1], rtol=1e-12) == []


def test_a_lost_worker_s_task_runs_again_elsewhere(serial, cluster, tmp_path):
    killed = []

    def kill_a_busy_worker(line):
        if killed or "tasks finished on the cluster" not in line:
            return
        busy = [w for w, keys in cluster.client.processing().items() if keys]
        if busy:  # the first finished task's line: others are on the workers
            pid = cluster.client.run(os.getpid, workers=busy[:1])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    before = scheduled(cluster.client)
    path = run(tmp_path, cluster, kill_a_busy_worker)
    assert killed, "no worker was busy when the first task finished"
    after = scheduled(cluster.client)
    # 15 tasks finished, one or more of them assigned again after the loss: the one the
    # killed worker ran, and any finished result it still held before the client took it
    # (then that task finishes twice)
    finished = after["memory"] - before.get("memory", 0)
    assert finished >= 15
    assert after["processing"] - before.get("processing", 0) > 15
    with h5py.File(path) as f:
        assert f.attrs["status"] == "complete"
    assert differences(serial, path, rtol=1e-12) == []


def sleepy(models, seconds, *, progress, live=True):
    """A task that only waits."""
    time.sleep(seconds)
    return Outcome({"slept": seconds}, {}, "complete")


def test_a_quiet_cluster_says_it_is_working(cluster, monkeypatch):
    monkeypatch.setattr(cluster, "heartbeat_s", 0.25)
    lines = []
    found = dict(cluster.run([Task(sleepy, (1.0,)), Task(sleepy, (1.5,))], None, lines.append))
    assert [found[i].data["slept"] for i in (0, 1)] == [1.0, 1.5]
    assert found[0].seconds >= 1.0  # timed on the worker
    # quiet lines while both sleep, then a line per finished task
    assert "0 of 2 tasks finished, 2 running or queued (0 s so far)" in lines
    assert lines[-1] == "2 of 2 tasks finished on the cluster"


def threads(models, *, progress, live=True):
    """A task that reports the threads its kernels and linear algebra may use."""
    import numba
    from threadpoolctl import threadpool_info

    blas = {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}
    return Outcome({"numba": numba.get_num_threads(), "blas": max(blas)}, {}, "complete")


def test_a_worker_runs_each_task_on_one_thread(cluster):
    # N one-thread workers on N cores: numba's default (every core) per worker made 2N
    # threads; a task must also see the one BLAS thread that keeps the numbers identical
    found = dict(cluster.run([Task(threads, ()), Task(threads, ())], None, lambda m: None))
    assert [found[i].data for i in (0, 1)] == [{"numba": 1, "blas": 1}] * 2


def broken(models, *, progress, live=True):
    """A task with a bug."""
    raise ValueError("a bug, not bad luck")


def test_a_task_that_raises_is_a_failed_curve_not_retried(cluster):
    before = scheduled(cluster.client)
    found = dict(cluster.run([Task(broken, (), "[a] curve 1"), Task(sleepy, (0.1,))], None,
                             lambda m: None))
    assert found[0].status == "failed"
    assert found[0].message == ("[a] curve 1: error on a worker: ValueError: a bug, not bad "
                                "luck")
    assert found[1].status == "complete"
    after = scheduled(cluster.client)
    assert after["processing"] - before.get("processing", 0) == 2  # each ran once
    assert after["erred"] - before.get("erred", 0) == 1


@pytest.mark.slow  # (the local cluster's test gives the same numbers through the same code)
def test_a_cluster_by_address_gives_the_serial_numbers(serial, cluster, tmp_path, capsys):
    address = cluster._cluster.scheduler_address  # as if started by `dask scheduler`
    before = scheduled(cluster.client)
    code = main(["run", str(case_file(tmp_path)), "--out", str(tmp_path / "o"), "--no-cache",
                 "--scheduler", address])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert f"[cluster] the Dask cluster at {address}: 2 workers" in out.out
    assert scheduled(cluster.client)["memory"] - before.get("memory", 0) == 15
    found = differences(serial, tmp_path / "o" / "results.h5", rtol=1e-12)
    assert [d.path for d in found] == ["@source"]  # the case file's path, not the numbers


def case_file(folder):
    path = folder / "study.toml"
    path.write_text(STUDY_TOML)
    return path


# ------------------------------------------------------------------ faults, before any work
def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


#: The study's oscillator with one FRF.
TINY = STUDY_TOML.split("[[analysis]]")[0] + textwrap.dedent("""\
    [[analysis]]
    name = "a"
    type = "frf"
    start = 0.5
    stop = 2.5
    """)


def test_an_unreachable_scheduler_is_one_line_at_once(tiny, tmp_path, capsys):
    t = time.perf_counter()
    address = f"tcp://127.0.0.1:{free_port()}"
    assert main(["run", str(tiny), "--out", str(tmp_path / "o"), "--scheduler", address]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert f"--scheduler {address}: cannot reach a Dask scheduler there" in err
    assert "refused" in err.lower()
    assert time.perf_counter() - t < 5.0  # refused at once, not after Dask's retries
    assert not (tmp_path / "o" / "results.h5").exists()


@contextlib.contextmanager
def service(reply: bytes | None):
    """A TCP service on a free local port that is not a Dask scheduler: ``reply`` None is an
    HTTP server (it waits for a request: silent on connect); bytes are sent on connect (a
    banner, as SSH's). Yields its address."""
    import http.server
    import socketserver

    if reply is None:
        server = http.server.HTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
    else:
        class Banner(socketserver.BaseRequestHandler):
            def handle(self):
                self.request.sendall(reply)
                time.sleep(0.5)

        server = socketserver.TCPServer(("127.0.0.1", 0), Banner)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


@pytest.mark.parametrize("reply, expected", [
    (None, "a service listens there but said nothing in 1 s, as a Dask scheduler would at "
     "once (an HTTP server or a proxy?)"),
    (b"SSH-2.0-OpenSSH_9.2\r\n", "the service there is not a Dask scheduler (it began with "
     "b'SSH-2.0-'"),
])
def test_a_service_that_is_not_a_scheduler_is_named_within_the_timeout(reply, expected):
    """An HTTP server kept Dask's client waiting for over 300 s; a proxy answering Dask's
    handshake with 'HTTP/1.1 400' was read as a frame of 3 EiB."""
    with service(reply) as address:
        t = time.perf_counter()
        client, fault = tasks.connect(address, timeout=1.0)
        assert client is None and expected in fault, fault
        assert time.perf_counter() - t < 3.0  # the timeout, not Dask's


def test_run_at_a_banner_service_is_one_line(tiny, tmp_path, capsys):
    with service(b"HTTP/1.1 400 Bad Request\r\n\r\n") as address:
        assert main(["run", str(tiny), "--out", str(tmp_path / "o"), "--scheduler",
                     address]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert f"--scheduler {address}: the service there is not a Dask scheduler" in err


@pytest.mark.parametrize("argv,expected", [
    (["--workers", "-1"], "--workers = -1: expected 0 (in this process) to "),
    (["--workers", "100000"], "--workers = 100000: expected 0 (in this process) to "),
    (["--workers", "2", "--scheduler", "tcp://h:1"], "give one"),
    (["--scheduler", " "], "expected an address such as tcp://host:8786"),
])
def test_bad_cluster_options_are_one_line(tiny, tmp_path, capsys, argv, expected):
    assert main(["run", str(tiny), "--out", str(tmp_path / "o"), *argv]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and expected in err


class FakeClient:
    """What workers_ready asks of a client: run a function on every worker."""

    def __init__(self, versions, digests):
        self.answers = {"version": versions, "code_digest": digests}

    def run(self, function, *args, on_error="raise"):
        return self.answers[function.__name__]


def test_workers_that_cannot_run_microslip_are_named():
    from microslip.app.store import code_digest

    mine = code_digest()
    ok = {"tcp://a:1": "0.1.0", "tcp://b:1": "0.1.0"}
    assert tasks.workers_ready(FakeClient(ok, dict.fromkeys(ok, mine))) == ""
    assert "no workers" in tasks.workers_ready(FakeClient({}, {}))
    missing = ok | {"tcp://b:1": ModuleNotFoundError("microslip")}
    fault = tasks.workers_ready(FakeClient(missing, {}))
    assert "worker tcp://b:1 cannot import microslip (1 of 2 workers)" in fault
    other = tasks.workers_ready(FakeClient(ok, {"tcp://a:1": mine, "tcp://b:1": "x"}))
    assert "worker tcp://b:1 runs other microslip sources" in other


# ------------------------------------------------------------------ Ctrl-C
#: Six FRFs of small steps, ~1.5 s each: a Ctrl-C after the first lands while others run.
FAMILY_TOML = STUDY_TOML.split("[[analysis]]")[0].replace("samples = 128", """samples = 128
    [solver]
    step = 5e-3
    max_step = 5e-3
    max_points = 100000""") + textwrap.dedent("""\
    [[analysis]]
    name = "slow"
    type = "frf"
    start = 0.5
    stop = 2.5
    stability = false
    family = { key = "contacts.wall.n0", values = [0.0, 0.02, 0.05, 0.1, 0.2, 0.5] }
    """)


@pytest.mark.slow  # (7 s: a cluster of two started and stopped; Ctrl-C and a lost worker
# keep what finished in the fast tests of the serial run and of the lost worker)
def test_ctrl_c_on_a_cluster_keeps_every_finished_curve(tmp_path):
    (tmp_path / "family.toml").write_text(FAMILY_TOML)
    out = tmp_path / "o"
    # its own session: the signal goes to the whole process group, as a terminal's Ctrl-C
    # does (the workers ignore it: the client cancels them and saves)
    p = subprocess.Popen([*CLI, "run", "family.toml", "--workers", "2", "--out", str(out)],
                         cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, start_new_session=True)
    seen = []
    for line in p.stdout:  # said once that curve is written
        seen.append(line)
        if "[slow] 1 of 6 tasks finished on the cluster" in line:
            os.killpg(p.pid, signal.SIGINT)
            break
    rest, err = p.communicate(timeout=120)
    assert p.returncode == 130, "".join(seen) + rest + err
    assert "Traceback" not in err and "interrupted" in err, err
    with h5py.File(out / "results.h5") as f:
        assert f.attrs["status"] == "partial"
        g = f["slow"]
        assert g.attrs["status"] == "interrupted"
        finished = sorted(g)
        assert 1 <= len(finished) < 6
        for name in finished:  # whole curves only, each complete
            assert g[name].attrs["status"] == "complete" and g[name]["parameter"].size > 100


@pytest.mark.skipif("pardiso" not in available_backends(), reason="PARDISO not installed")
def test_the_runs_thread_limit_holds_for_pardiso(tmp_path):
    """PARDISO's MKL loads on the first large factorization, inside the run's thread limit:
    the limit must hold for it as for NumPy's BLAS (it did not: MKL factorized on every core
    whatever --threads said, and two runs' reduced models differed at round-off). In a fresh
    process, where nothing has loaded MKL yet."""
    code = ("from threadpoolctl import threadpool_info\n"
            "from microslip.app.run import run_threads\n"
            "with run_threads(1):\n"
            "    import pypardiso\n"
            "    print(sorted({i['internal_api']: i['num_threads'] for i in threadpool_info()"
            " if i['user_api'] == 'blas'}.items()))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=tmp_path).stdout.strip()
    assert out == "[('mkl', 1), ('openblas', 1)]"
