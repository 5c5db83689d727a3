"""examples/python/sphere_grace.py runs: render under Grace, project, compare with eq. 15 (plot if
Matplotlib is importable)."""

import importlib.util
import os
import subprocess
import sys

from conftest import ROOT


def test_sphere_grace_example_runs(data_dir, tmp_path):
    out = tmp_path / "plot.png"
    r = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "python" / "sphere_grace.py"), "--lmax", "2", "--spp", "4",
         "--height", "16", "--out", str(out)],
        capture_output=True, text=True, cwd=tmp_path, env={**os.environ, "REFLECT_DATA": str(data_dir), "MPLBACKEND": "Agg"},
    )
    assert r.returncode == 0, r.stderr
    assert "largest difference over l ≤ 2" in r.stdout
    # Nine B_lm rows (l ≤ 2) of measured against predicted.
    rows = [line for line in r.stdout.splitlines() if line.split()[:1] and line.split()[0].isdigit()]
    assert len(rows) == 9
    if importlib.util.find_spec("matplotlib") is not None:
        assert out.is_file() and out.stat().st_size > 0
    else:
        assert "no plot" in r.stdout
