"""The compiled contact kernels: serial and threaded marches agree, the dispatch by work
size, one compiled type per argument, and the first-run compile message."""

import os
import subprocess
import sys

import numba
import numpy as np
import pytest

from microslip.fourier import Harmonics
from microslip.laws import kernels_cached, returnmap, warm_up
from microslip.laws.coulomb import ContactElements
from microslip.laws.returnmap import cycle, kinks, point, steps


def contact_state(law: str, P: int, seed: int = 0):
    """P points of ``law`` whose motion mixes stick, slip, lift-off and re-contact."""
    rng = np.random.default_rng(seed)
    h = Harmonics.up_to(3, 64)
    kw = dict(kt=rng.uniform(1.0, 3.0, P), mu=rng.uniform(0.2, 0.6, P))
    if law in "BD":
        kw.update(kn=rng.uniform(1.0, 2.0, P), interference=rng.uniform(0.05, 0.3, P),
                  coupled=True)
    else:
        kw["n0"] = rng.uniform(0.1, 0.5, P)
    el = ContactElements.create(law, **kw)
    g = 0.15 * rng.normal(size=(P, el.n_components, h.n_coeffs))
    g[:, : el.dim, h.cos_index[0]] += 0.6
    if el.variable_normal:
        g[:, -1, h.cos_index[0]] += 0.5 * el.n0 / el.kn + 0.3
    return el, g * np.geomspace(0.01, 3.0, P)[:, None, None], h  # stuck to gross slip


def evaluate_with(monkeypatch, parallel: bool, el, g, h):
    monkeypatch.setattr(returnmap, "parallel_pays", lambda *work: parallel)
    return el.evaluate(g, h, histories=True)


# slow: its first call compiles the threaded kernel (11 s of a cold fast suite), which no
# other fast test uses; every other kernel test runs the serial one
@pytest.mark.slow
@pytest.mark.parametrize("law", ["A", "B", "C", "D"])
def test_serial_and_threaded_marches_agree(monkeypatch, law):
    el, g, h = contact_state(law, 24)
    serial = evaluate_with(monkeypatch, False, el, g, h)
    threaded = evaluate_with(monkeypatch, True, el, g, h)
    assert len(set(serial.state.tolist())) > 1  # a multi-point state, not one regime
    for field in ("forces", "jacobian", "d_n0", "state", "periods", "T", "N", "flags"):
        np.testing.assert_array_equal(getattr(serial, field), getattr(threaded, field),
                                      err_msg=field)


def test_dispatch_runs_small_work_serially(monkeypatch):
    least = returnmap.PARALLEL_MIN_WORK
    assert not returnmap.parallel_pays(1, 4096, least)  # one point: never threads
    assert not returnmap.parallel_pays(2, 64, least // 128 - 1)
    assert returnmap.parallel_pays(2, 64, least // 128) == (numba.get_num_threads() > 1)
    called = []
    for name in ("march_serial", "march_parallel"):
        kernel = getattr(returnmap, name)
        monkeypatch.setattr(returnmap, name, lambda *a, k=kernel, n=name: (called.append(n), k(*a)))
    el, g, h = contact_state("A", 4)  # 4 x 64 samples: below the threshold
    el.evaluate(g, h)
    assert called == ["march_serial"]


def test_one_compiled_type_per_argument():
    """Strided, read-only or int inputs are cast at the boundary: no new specialisation
    (each compiles the whole kernel again), and no helper compiled twice (literals)."""
    el, g, h = contact_state("D", 3)
    el.evaluate(g, h)
    el.evaluate(g, h, jacobian=False, corrections=False)
    args = list(_march_args(el, g, h))
    args[0] = np.asfortranarray(args[0])
    args[3] = np.broadcast_to(args[3][:1], args[3].shape)  # read-only, zero strides
    args[10] = args[10].astype(np.int64)
    kernel_args = returnmap._bundled(returnmap._cast(tuple(args)))  # as march calls them
    assert tuple(numba.typeof(a) for a in kernel_args) == returnmap.SIGNATURE
    for module in (returnmap, point, cycle, steps, kinks):  # every kernel of the package
        for name in dir(module):
            dispatcher = getattr(module, name)
            if isinstance(dispatcher, numba.core.registry.CPUDispatcher):
                assert len(dispatcher.signatures) <= 1, (name, dispatcher.signatures)


def _march_args(el, g, h):
    P, c, nc, ns, d = el.size, el.n_components, h.n_coeffs, h.n_samples, el.dim
    return (g, np.empty((P, d, ns)), np.empty((P, ns)), el.kt, el.kn, el.mu, el.n0,
            h.synthesis, h.analysis, h.coeff_order.astype(float), h.coeff_kind,
            el.variable_normal, True, 200, 1e-13, True, np.empty((P, d, ns)),
            np.empty((P, ns)), np.empty((P, ns), np.int8), np.empty((P, d + 1, nc)),
            np.empty((P, c, nc, c * nc)), np.empty((P, c, nc)), np.empty(P, np.int64),
            np.empty((P, 3), np.int64))


def test_outputs_are_never_copied():
    el, g, h = contact_state("A", 2)
    args = list(_march_args(el, g, h))
    args[16] = np.empty((2, 1, h.n_samples), order="F")[:, :, ::2]  # strided T_out
    with pytest.raises(ValueError, match="output 16"):
        returnmap._cast(tuple(args))


def test_empty_cache_is_not_cached(tmp_path):
    """A fresh NUMBA_CACHE_DIR holds no kernel (checked without compiling)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run(
        [sys.executable, "-c", "from microslip.laws import kernels_cached; "
         "print(kernels_cached())"], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_compile_message_only_when_compiling(monkeypatch):
    el, g, h = contact_state("A", 1)
    el.evaluate(g, h)  # compiled (or loaded) in this process: nothing to tell
    assert kernels_cached()
    told: list[str] = []
    warm_up(told.append)
    assert told == []
    monkeypatch.setattr(returnmap, "kernels_cached", lambda: False)  # as on a first run
    warm_up(told.append)
    assert told[0].startswith("compiling the contact kernels (first run only, ~")
    assert told[1].startswith("compiled the contact kernels in")
