"""PNG previews and the meshing benchmark entry point."""

import matplotlib.image as mpimg
import numpy as np

from microslip.bench.meshing import main as bench_main
from microslip.draw.previews import render_previews
from microslip.geometry.root_joint import root_joint


def test_previews_are_written_and_not_blank(tmp_path):
    mesh = root_joint(size=0.015, blade_size=0.008, sectors=6, r_bore=0.08)
    paths = render_previews(mesh, tmp_path)
    assert [p.name for p in paths] == [
        "root_joint_sector.png", "root_joint_contacts.png", "root_joint_full_disk.png"]
    for p in paths:
        img = mpimg.imread(p)[..., :3]
        assert img.shape[0] >= 600 and img.shape[1] >= 800
        # a drawn model covers a good part of the white background
        non_white = np.mean(np.any(img < 0.95, axis=-1))
        assert non_white > 0.03, (p.name, non_white)


def test_bench_prints_one_row_per_model_and_factor(capsys):
    assert bench_main(["--factors", "2", "--repeats", "1", "--models", "root_joint"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].split()[:5] == ["model", "factor", "grid", "nodes", "tets"]
    row = lines[2].split()
    assert row[0] == "root_joint" and float(row[1]) == 2.0 and int(row[3]) > 0
