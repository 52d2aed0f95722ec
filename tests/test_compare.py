"""`microslip compare`: two results files agree dataset by dataset, to a tolerance relative
to each dataset's largest entry; structural and textual differences are named."""

import h5py
import numpy as np
import pytest

from microslip.cli import main
from microslip.results.compare import differences


def _results(path, *, scale=1.0, extra=False, label="a", created="2026-01-01"):
    with h5py.File(path, "w") as f:
        f.attrs["created"] = created  # volatile: never compared
        f.attrs["status"] = "complete"
        for key in ("title", "source", "case_hash", "message", "versions"):
            f.attrs[key] = ""
        g = f.create_group("frf/curve_000")
        g.attrs["label"] = label
        g.attrs["elapsed_s"] = 3.0 * scale  # volatile
        g.create_dataset("amplitude", data=np.array([1.0, 2.0, 1e-20]) * scale)
        g.create_dataset("state", data=np.array([0, 1, 2], dtype=np.int8))
        if extra:
            g.create_dataset("jumps", data=np.zeros((0, 2)))
    return path


def test_the_same_numbers_agree_whatever_the_run_records(tmp_path):
    a = _results(tmp_path / "a.h5")
    b = _results(tmp_path / "b.h5", created="2026-02-02")
    assert differences(a, b) == []
    assert main(["compare", str(a), str(b)]) == 0


def test_a_difference_is_measured_against_the_datasets_largest_entry(tmp_path):
    a = _results(tmp_path / "a.h5")
    # 1e-13 of 2.0 moves the tiny third entry by 1e7 of itself: still 1e-13 of the dataset
    b = _results(tmp_path / "b.h5", scale=1 + 1e-13)
    assert differences(a, b, rtol=1e-12) == []
    c = _results(tmp_path / "c.h5", scale=1 + 1e-9)
    (d,) = differences(a, c, rtol=1e-12)
    assert d.path == "/frf/curve_000/amplitude"
    assert d.relative == pytest.approx(1e-9, rel=1e-3)
    assert main(["compare", str(a), str(c)]) == 1


def test_missing_datasets_and_changed_text_are_named(tmp_path, capsys):
    a = _results(tmp_path / "a.h5")
    b = _results(tmp_path / "b.h5", extra=True, label="b")
    found = {d.path: (d.what, d.added) for d in differences(a, b)}
    assert found == {"/frf/curve_000@label": ("'a' against 'b'", False),
                     "/frf/curve_000/jumps": ("only in the new file", True)}
    assert main(["compare", str(b), str(a)]) == 1  # a dataset lost, a label changed
    assert main(["compare", str(tmp_path), str(b)]) == 2  # a folder without results.h5
    assert "no results file at" in capsys.readouterr().err
    assert main(["compare", str(a), str(b), "--rtol", "-1"]) == 2


def test_additions_leave_every_old_number_in_place(tmp_path, capsys):
    a = _results(tmp_path / "a.h5")
    b = _results(tmp_path / "b.h5", extra=True)
    assert main(["compare", str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert "the same numbers, 1 addition(s)" in out and "jumps: only in the new file" in out


def test_a_file_that_is_not_a_results_file_is_bad_input(tmp_path, capsys):
    """An HDF5 file of another program said 'only in the old file' and exit 1; it is bad
    input: one line, exit 2, on either side."""
    a = _results(tmp_path / "a.h5")
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("x", data=[1.0])
    text = tmp_path / "notes.txt"
    text.write_text("not HDF5")
    for old, new in ((a, other), (other, a), (a, text)):
        assert main(["compare", str(old), str(new)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("microslip compare: "), err
    assert main(["compare", str(a), str(other)]) == 2
    assert "an HDF5 file but not a microslip results file" in capsys.readouterr().err
    assert main(["compare", str(a), str(text)]) == 2
    assert "not an HDF5 file" in capsys.readouterr().err


def test_render_of_an_analysis_the_file_lacks_is_bad_input(tmp_path, capsys):
    a = _results(tmp_path / "a.h5")
    assert main(["render", str(a), "--analysis", "nope"]) == 2
    err = capsys.readouterr().err
    assert err == (f"microslip render: --analysis nope: {a} has no analysis of that name; "
                   "its analyses: ['frf']\n")
