"""``microslip bench cluster``: what a Dask cluster buys on this machine, measured.

- **Overhead per task**: ``--tasks`` empty tasks through ``tasks.Distributed`` on a local
  cluster of ``--workers`` (started once, the models pushed once), the median over
  ``--repeat`` rounds; in ms of wall time per task and in units of a fixed reference
  workload run in this process (a dense 400 x 400 LU, as ``bench core``).
- **Speed-up of studies**: each ``--study CASE:ANALYSIS`` (default: the damper-mass family
  of ``15_blisk_damper.toml``'s FRFs and the samples of ``16_blisk_uncertainty.toml``'s study,
  cut to ``--samples``) run in this process (``--workers 0``) and on a fresh local cluster
  of each ``--workers`` count, the cluster's start included (what a user waits for): the
  analysis' time, the speed-up, the peak resident memory of every worker and of this
  process, and whether the results are the serial ones to 1e-12. The reduced models come
  from ``--out``'s model cache (built by the first run, outside the analysis' time); no
  curve cache.

A study is run once per setting (minutes each): its spread between runs is a few per cent,
far below the differences measured.
"""

from __future__ import annotations

import argparse
import copy
import resource
import shutil
import sys
from pathlib import Path

import h5py

from microslip.app.run import run_case
from microslip.app.tasks import Distributed, Outcome, Serial, Task
from microslip.case import Case, CaseError, load
from microslip.laws import warm_up
from microslip.results.compare import differences

from .core import median_time, reference_unit

CASES = Path(__file__).resolve().parents[2] / "cases"
STUDIES = ("15_blisk_damper.toml:frf", "16_blisk_uncertainty.toml:spread")


def empty(models, *, progress, live=True) -> Outcome:
    """A task that computes nothing: what remains is the cluster's own cost."""
    return Outcome({}, {}, "complete")


def peak_rss_mb() -> float:
    """This process' peak resident memory [MB]: VmHWM of /proc/self/status, the high-water
    mark of its own memory (ru_maxrss, which Linux keeps across exec, would give a spawned
    worker its parent's); ru_maxrss where there is no /proc."""
    try:
        with open("/proc/self/status") as f:
            kb = next(int(line.split()[1]) for line in f if line.startswith("VmHWM:"))
    except (OSError, StopIteration):
        kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / 1024


def overhead(workers: int, tasks: int, repeat: int, unit: float) -> list[str]:
    """The wall time per empty task on a warm local cluster."""
    executor = Distributed(workers=workers)
    batch = [Task(empty)] * tasks
    try:
        t = median_time(lambda: list(executor.run(batch, None, lambda m: None)), repeat)
    finally:
        executor.close()
    return [f"Overhead per task: {tasks} empty tasks on {workers} local workers, median of "
            f"{repeat}", f"  {t / tasks * 1e3:.2f} ms per task ({t / tasks / unit:.1f} ref "
            f"units); {tasks / t:.0f} tasks per second"]


def study_case(path: Path, analysis: str, samples: int | None) -> Case:
    """The case of ``path`` with only ``analysis`` (an uncertainty study cut to ``samples``,
    its design's first ones)."""
    case = load(path)
    data = copy.deepcopy(case.data)
    data["analysis"] = [a for a in data["analysis"] if a.get("name") == analysis]
    if not data["analysis"]:
        raise CaseError(str(path), [f"no analysis named {analysis!r}"])
    if samples and data["analysis"][0]["type"] == "uncertainty":
        data["analysis"][0]["samples"] = samples
    return Case(data, case.source)


def run_once(case: Case, out: Path, workers: int) -> dict:
    """One run of ``case`` into ``out`` on ``workers`` (0: this process), its results kept
    as ``results_w<workers>.h5``: the analysis' seconds and status, the workers' peak
    resident memory [MB]."""
    executor = Serial() if workers == 0 else Distributed(workers=workers)
    try:
        path = run_case(case, out, progress=lambda m: None, cache=False, executor=executor)
        memory = (sorted(executor.client.run(peak_rss_mb).values())
                  if isinstance(executor, Distributed) and executor.client else [])
    finally:
        executor.close()
    kept = shutil.move(path, out / f"results_w{workers}.h5")
    with h5py.File(kept) as f:
        g = f[case.analysis_specs[0].name]
        return {"path": kept, "seconds": float(g.attrs["elapsed_s"]),
                "status": str(g.attrs["status"]), "memory": memory}


def study_table(spec: str, samples: int | None, counts: list[int], out: Path) -> list[str]:
    """A study run in this process and on each worker count, into one folder (one model
    cache: the first run reduces, outside the analysis' time)."""
    name, _, analysis = spec.partition(":")
    path = Path(name) if Path(name).is_file() else CASES / name
    case = study_case(path, analysis, samples)
    kind = case.analysis_specs[0]
    size = (f"{kind.samples} samples" if kind.type == "uncertainty" else
            f"{len(kind.family.values) if kind.family else 1} curves")
    lines = [f"{path.name} analysis {analysis} ({kind.type}, {size}):",
             f"  {'workers':>7} {'time s':>8} {'speed-up':>8} {'peak memory MB':>24}  "
             "same numbers"]
    warm_up(lambda m: None)  # the kernels, compiled or loaded; the first run reduces
    serial = run_once(case, out, 0)
    lines.append(f"  {0:>7} {serial['seconds']:8.1f} {1.0:8.2f} "
                 f"{f'{peak_rss_mb():.0f} (this process)':>24}  (reference) "
                 f"{serial['status']}")
    for n in counts:
        r = run_once(case, out, n)
        same = not differences(serial["path"], r["path"], rtol=1e-12)
        mem = "/".join(f"{m:.0f}" for m in r["memory"])
        lines.append(f"  {n:>7} {r['seconds']:8.1f} {serial['seconds'] / r['seconds']:8.2f} "
                     f"{mem:>24}  {'yes' if same else 'NO'} {r['status']}")
    return lines


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="microslip bench cluster", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", default="2,8",
                        help="local worker counts to compare with 0 (default 2,8)")
    parser.add_argument("--study", action="append", default=None,
                        help="CASE:ANALYSIS (a shipped case's name or a path; repeatable; "
                        f"default {', '.join(STUDIES)})")
    parser.add_argument("--samples", type=int, default=8,
                        help="samples of an uncertainty study (its first ones; default 8)")
    parser.add_argument("--tasks", type=int, default=200, help="empty tasks per round")
    parser.add_argument("--repeat", type=int, default=5, help="rounds of empty tasks")
    parser.add_argument("--out", type=Path, default=Path("out") / "bench_cluster",
                        help="folder of the runs and their model cache")
    args = parser.parse_args(argv)
    try:
        counts = [int(x) for x in args.workers.split(",") if x]
    except ValueError:
        counts = []
    if not counts or min(counts) < 1:
        print(f"microslip bench cluster: --workers {args.workers}: expected worker counts "
              ">= 1, e.g. 2,8", file=sys.stderr)
        return 2
    unit = reference_unit()
    print(f"reference unit (dense 400 x 400 LU): {unit * 1e3:.2f} ms")
    for line in overhead(counts[0], args.tasks, args.repeat, unit):
        print(line, flush=True)
    for spec in args.study or STUDIES:
        try:
            lines = study_table(spec, args.samples, counts,
                                args.out / spec.replace(":", "_").replace("/", "_"))
        except CaseError as err:
            print(f"microslip bench cluster: --study {spec}: {err.faults[0]}", file=sys.stderr)
            return 2
        for line in lines:
            print(line, flush=True)
    return 0
