"""The cache every run shares (meshes and reduced models): a mesh kept there is the mesh,
bit for bit; a copied case reuses what it holds; its size is bounded; `microslip cache`
shows and clears it."""

import os
import time
from pathlib import Path

import numpy as np
import pytest

from microslip import geometry
from microslip.app.cache import (
    CacheSettingError,
    SharedCache,
    built_mesh,
    size_bytes,
)
from microslip.case import GeometryTable
from microslip.cli import main
from microslip.geometry.stored import load_mesh, save_mesh

CASES = Path(__file__).parents[1] / "cases"

#: Every parametric model, coarse; and an imported deck with contacts declared between its
#: surfaces (SurfaceContact) and its material cards in the parameters.
MESHES = {
    "blisk_sector": lambda: geometry.blisk_sector(sectors=6, size=0.03, blade_size=0.012,
                                                  contact_n_axial=3, contact_n_flank=2),
    "blisk_sector_averaged": lambda: geometry.blisk_sector(
        sectors=6, size=0.03, blade_size=0.012, contact_n_axial=3, contact_n_flank=2,
        contact_size=0.004),
    "root_joint": lambda: geometry.root_joint(size=0.02, blade_size=0.01),
    "shrouded_blisk": lambda: geometry.shrouded_blisk(size=0.02, blade_size=0.01),
    "beam": lambda: geometry.beam(size=0.02),
    "imported": lambda: GeometryTable.of(
        {"model": "import", "file": str(CASES / "imported_blade.inp"), "units": "mm-t-s",
         "contacts": {"flank": {"surfaces": ["FLANK_L"], "ground": True}}}).build(),
}


@pytest.mark.parametrize("name", MESHES)
def test_a_kept_mesh_is_the_mesh(name, tmp_path):
    """Saved and loaded: the same content hash (every array, name, face, contact and
    parameter: what the reduced models are keyed by) and the same fields."""
    mesh = MESHES[name]()
    save_mesh(mesh, tmp_path / "m.h5")
    back = load_mesh(tmp_path / "m.h5")
    assert back.content_hash == mesh.content_hash
    assert back.parameters == mesh.parameters and back.contacts.keys() == mesh.contacts.keys()
    for key, c in mesh.contacts.items():
        for field, value in vars(c).items():
            np.testing.assert_array_equal(getattr(back.contacts[key], field), value)


def test_a_parametric_mesh_is_built_once_for_every_run(tmp_path, monkeypatch):
    cache = SharedCache(tmp_path / "cache")
    table = GeometryTable.of({"model": "beam", "parameters": {"size": 0.02}})
    first, kept = built_mesh(table, cache)
    assert kept is None and len(cache.files()) == 1
    monkeypatch.setitem(geometry.MODELS, "beam", lambda **k: pytest.fail("meshed again"))
    again, kept = built_mesh(table, cache)
    assert kept == cache.files()[0] and again.content_hash == first.content_hash
    other = GeometryTable.of({"model": "beam", "parameters": {"size": 0.025}})
    with pytest.raises(pytest.fail.Exception):  # another parameter: another mesh
        built_mesh(other, cache)


def _files(folder: Path, sizes: dict[str, int], start: float) -> dict[str, Path]:
    """Files of the given sizes, each a second more recently used than the one before."""
    out = {}
    for k, (name, size) in enumerate(sizes.items()):
        path = folder / "models" / f"{name}.h5"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"x" * size)
        os.utime(path, (start + k, start + k))
        out[name] = path
    return out


def test_the_least_recently_used_go_first_never_those_in_use(tmp_path):
    cache = SharedCache(tmp_path, limit=250)
    files = _files(tmp_path, {"old": 100, "kept": 100, "mid": 100, "new": 100},
                   time.time() - 100)
    removed = cache.prune(keep=[files["kept"]])
    # 400 > 250: the oldest not in use (old), then the next (mid); 'kept' is older but in use
    assert removed == (2, 200)
    assert sorted(p.stem for p in cache.files()) == ["kept", "new"]
    cache.used([files["kept"]])
    assert cache.prune() == (0, 0)  # 200 <= 250


def test_sizes_read_as_people_write_them():
    assert size_bytes("10GB") == 10**10 and size_bytes("500 MB") == 5 * 10**8
    assert size_bytes("2GiB") == 2 * 2**30 and size_bytes("1234") == 1234
    for bad in ("ten", "-1GB", "5XB"):
        with pytest.raises(CacheSettingError, match="MICROSLIP_CACHE_SIZE"):
            size_bytes(bad)


def test_the_cache_command_shows_and_clears(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MICROSLIP_CACHE", str(tmp_path))
    monkeypatch.setenv("MICROSLIP_CACHE_SIZE", "1GB")
    _files(tmp_path, {"a": 1000, "b": 2000}, time.time())
    assert main(["cache"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{tmp_path}: 3 kB of at most 1.0 GB") and "models: 2 files" in out
    assert main(["cache", "--clear"]) == 0
    assert capsys.readouterr().out == f"removed 2 files (3 kB) from {tmp_path}\n"
    assert SharedCache(tmp_path).files() == []


def test_a_bad_cache_setting_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("MICROSLIP_CACHE_SIZE", "lots")
    # (a meshed case: only those keep anything in the shared cache)
    assert main(["run", str(CASES / "09_blisk_mesh.toml"), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == ("microslip run: MICROSLIP_CACHE_SIZE = 'lots': expected a size such as "
                   "10GB, 500MB or a number of bytes\n")
    monkeypatch.delenv("MICROSLIP_CACHE_SIZE")
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("MICROSLIP_CACHE", str(blocker))  # a file, not a folder
    assert main(["cache"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"microslip cache: the shared cache of meshes and reduced models: "
                          f"MICROSLIP_CACHE = {blocker}: cannot write there") and \
        err.count("\n") == 1
