"""The README tells the truth: its Python examples run and print what their comments say,
and its key tables document exactly the keys the case reader accepts."""

import contextlib
import io
import re
from pathlib import Path

import pytest

from microslip.case import (
    analysis_rules,
    assembly_table,
    faults,
    mistuning_table,
    reduction_table,
    specs,
)
from microslip.case.kinds import shipped

README = (Path(__file__).parents[1] / "README.md").read_text(encoding="utf-8")


def _section(heading: str) -> str:
    """The README's text from the heading starting with ``heading`` to the next heading."""
    m = re.search(rf"^#+ {re.escape(heading)}.*?$(.*?)(?=^#+ |\Z)", README, re.M | re.S)
    assert m, heading
    return m.group(1)


def _python_blocks() -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", README, re.M | re.S)


def test_the_library_example_prints_what_its_comments_say():
    (code,) = [b for b in _python_blocks() if "sweep(" in b]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {})
    peak = out.getvalue().splitlines()[0]
    # the comment quotes the peak to the 4 digits it shows: (1.0019, 1.8414)
    w, a = (float(v) for v in peak.strip("()").split(","))
    expected = re.search(r"# \(w at the peak, max\|x\(t\)\|\): \(([\d.]+), ([\d.]+)\)", code)
    assert w == pytest.approx(float(expected[1]), abs=1e-4)
    assert a == pytest.approx(float(expected[2]), abs=1e-4)


def test_the_slurm_example_writes_one_core_worker_jobs(monkeypatch):
    """The dask-jobqueue example, run as written but for the SLURM jobs it would submit:
    its job script asks one core and the memory per worker, and starts a one-thread worker
    with the numba cache on the node."""
    from dask_jobqueue import SLURMCluster

    (code,) = [b for b in _python_blocks() if "SLURMCluster" in b]
    monkeypatch.setattr(SLURMCluster, "scale", lambda self, jobs=0, **kw: None)
    names: dict = {}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), names)
    cluster = names["cluster"]
    try:
        script = cluster.job_script()
        assert out.getvalue().strip() == cluster.scheduler_address
    finally:
        cluster.close()
    assert "#SBATCH --cpus-per-task=1" in script and "#SBATCH --mem=4G" in script
    assert "export NUMBA_CACHE_DIR=/tmp/$USER-numba" in script
    assert "--nthreads 1" in script and cluster.scheduler_address in script


def _strip_parentheses(text: str) -> str:
    """``text`` without its (possibly nested) parenthesised asides: they hold values and
    units, not keys."""
    out, depth = [], 0
    for ch in text:
        depth += ch == "("
        if depth == 0:
            out.append(ch)
        depth -= ch == ")" and depth > 0
    return "".join(out)


def _cells(row: str) -> list[str]:
    return [c.strip() for c in re.split(r"(?<!\\)\|", row.strip())[1:-1]]


def _tables(text: str, first: str) -> list[list[list[str]]]:
    """The markdown tables of ``text`` whose header's first cell is ``first``: rows of cells
    (header and rule dropped)."""
    tables, rows = [], None
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            if rows is None:
                rows = [_cells(line)]
            else:
                rows.append(_cells(line))
        elif rows is not None:
            if rows[0][0] == first:
                tables.append(rows[2:])
            rows = None
    return tables


def _documented_keys(text: str, section: str) -> set[str]:
    """Dotted key paths of the key tables in ``text``: a first cell lists backticked keys
    (asides in parentheses are not keys); ``[table] key`` or ``[[array]] key`` gives the
    table for this key and the rows after it; other keys belong to the last table named
    (``section`` at first). ``[table]`` alone documents the table itself."""
    keys, current = set(), section
    for table in _tables(text, "key"):
        for row in table:
            for token in re.findall(r"`([^`]+)`", _strip_parentheses(row[0])):
                head = re.match(r"\[\[?([\w.<>]+)\]\]?\s*(.*)", token)
                if head:
                    current, token = head[1], head[2]
                    if not token:
                        keys.add(current)
                        continue
                for key in token.split(","):
                    keys.add(".".join(p for p in (current, key.strip()) if p))
    return keys


def _analysis_keys() -> set[str]:
    """analysis.<type>.<key> from the Analyses table (its keys column) and the sentence
    that gives every analysis a ``name``, a ``type`` and optionally a ``figure``."""
    text = _section("Case files")
    assert "(`[[analysis]]`, each with a `name` and a `type`; `figure` names" in text
    keys = set()
    for row in _tables(text, "type")[0]:
        kind = row[0].strip("`")
        found = re.findall(r"`(\w+)`", _strip_parentheses(row[1]))
        keys |= {f"analysis.{kind}.{k}" for k in found + ["name", "type", "figure"]}
    return keys


def _documented() -> set[str]:
    return (_documented_keys(_section("Case files"), "") | _analysis_keys()
            | _documented_keys(_section("The `[reduction]` table"), "reduction")
            | _documented_keys(_section("The `[assembly]` table"), "assembly"))


def _accepted() -> set[str]:
    """Every key path the case reader accepts (its key sets; tables given by their keys)."""
    def under(prefix, names):
        return {f"{prefix}.{k}" for k in names}

    from microslip.laws.registry import LAWS

    springs = {k for law in LAWS.values() for k in (*law.parameters, *getattr(law, "keys", ()))}
    tables = {"model": faults.MODEL_KEYS,
              "contacts": faults.CONTACT_KEYS | springs | {"coef", "lag"},
              "loads": faults.LOAD_KEYS, "harmonics": faults.HARMONIC_KEYS,
              "solver": faults.SOLVER_KEYS, "geometry": {"model", "parameters"},
              "analysis.family": analysis_rules.FAMILY_KEYS,
              "reduction": reduction_table.KEYS - {"material", "damping", "bodies",
                                             "contact_stiffness"},
              "reduction.material": reduction_table.MATERIAL_KEYS,
              "reduction.damping": reduction_table.DAMPING_KEYS,
              "reduction.bodies.<body>": reduction_table.BODY_KEYS,
              "reduction.contact_stiffness.<patch>": reduction_table.STIFFNESS_KEYS,
              "assembly": assembly_table.KEYS - {"contacts", "loads", "outputs",
                                                 "mistuning"},
              "assembly.mistuning": mistuning_table.KEYS,
              "assembly.contacts": assembly_table.CONTACT_KEYS,
              "assembly.loads": assembly_table.LOAD_KEYS,
              "assembly.outputs": assembly_table.OUTPUT_KEYS}
    tables |= {f"analysis.{name}": specs.keys(kind.spec) for name, kind in shipped().items()}
    # every top-level key is a table above (or text): no table of the reader is left out
    assert faults.TOP_KEYS == {"title", "description"} | {p.split(".")[0] for p in tables}
    out = {"title", "description"}
    for prefix, names in tables.items():
        out |= under(prefix, names)
    return out


def test_every_accepted_case_key_is_documented():
    missing = _accepted() - _documented()
    assert not missing, f"keys the reader accepts but the README does not document: {missing}"


def test_every_documented_case_key_is_accepted():
    extra = _documented() - _accepted()
    assert not extra, f"keys the README documents but the reader refuses: {extra}"


def test_the_commands_table_lists_every_command():
    from microslip.cli import BENCHES, COMMANDS

    text = _section("Commands")
    listed = set(re.findall(r"^\| `microslip (\w+)", text, re.M))
    assert listed == set(COMMANDS)
    assert set(re.findall(r"^\| `microslip bench (\w+)", text, re.M)) == set(BENCHES)


def test_the_results_layout_section_is_the_schema():
    from microslip.results import schema

    block = re.search(r"^### Results \(`results.h5`\).*?^```\n(.*?)^```", README,
                      re.M | re.S).group(1)
    assert block == schema.layout_text()


def test_the_analyses_table_gives_each_number_and_switch_default_of_the_specs():
    """A key's default in the Analyses table ("`points` (25)") is the spec's, and every
    analysis key whose default is a number or a switch says it there."""
    rows = {row[0].strip("`"): row[1] for row in _tables(_section("Case files"), "type")[0]}
    for kind, cls in ((name, k.spec) for name, k in shipped().items()):
        said = {k: v for k, v in re.findall(r"`(\w+)` \((-?[\d.]+|true|false)[;:)]",
                                            rows[kind])}
        scalar = {k: v for k, v in specs.defaults(cls).items()
                  if isinstance(v, (bool, int, float))}
        assert said.keys() == scalar.keys(), kind
        for key, text in said.items():
            value = {"true": True, "false": False}.get(text)
            assert scalar[key] == (value if value is not None else float(text)), (kind, key)


def test_the_walk_through_of_a_case_of_ones_own_runs_and_writes_its_page(tmp_path):
    """The bash lines of "Writing your own case", run as written in a folder holding a copy
    of the shipped cases: the case checks, runs complete and its page shows the new
    analysis and the changed contact."""
    import shutil
    import subprocess
    import sys

    # (the block's own comment lines start with "#": not read as headings here)
    block = re.search(r"^### Writing your own case.*?^```bash\n(.*?)^```", README,
                      re.M | re.S).group(1)
    shutil.copytree(Path(__file__).parents[1] / "cases", tmp_path / "cases")
    import os

    # this environment (its numba cache: the compiled kernels), microslip first on the PATH
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}:{os.environ['PATH']}"}
    done = subprocess.run(["bash", "-e", "-c", block], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "kt = 6.0 " in (tmp_path / "my_wall.toml").read_text()
    page = (tmp_path / "out" / "my_wall" / "report.html").read_text()
    assert "my_mode" in page and "complete" in page
