"""Every tutorial runs as plain Python (Agg backend) and prints sane numbers."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

TUTORIALS = sorted((Path(__file__).parent.parent / "tutorials").glob("*.py"))


def _run(path: Path, tmp_path: Path) -> str:
    env = dict(os.environ, MPLBACKEND="Agg", REFSYNTH_TUTORIAL_OUT=str(tmp_path))
    env.pop("DISPLAY", None)
    proc = subprocess.run([sys.executable, str(path)], capture_output=True, text=True,
                          env=env, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def test_there_are_tutorials():
    assert TUTORIALS


@pytest.mark.parametrize("path", TUTORIALS, ids=lambda p: p.name)
def test_tutorial_runs(path, tmp_path):
    out = _run(path, tmp_path)
    assert list(tmp_path.glob("*.png")), "the tutorial wrote no figure"
    if path.name.startswith("01_"):
        assert "identical 0.0000" in out
        a_b = re.search(r"a-b ([\d.]+), b-a ([\d.]+)", out)
        assert a_b and a_b.group(1) == a_b.group(2)
        mar_np, mar_nn = map(float, re.search(
            r"NP: MAR ([\d.]+) m .* MAR ([\d.]+) m", out).groups())
        assert 0 < mar_np < 3 and 0 < mar_nn < 3
        c_lo, c_hi = map(float, re.search(r"C in \[([\d.]+), ([\d.]+)\]", out).groups())
        assert 0 <= c_lo <= c_hi <= 1
        d_lo, d_hi = map(float, re.search(r"D in \[([\d.]+), ([\d.]+)\]", out).groups())
        assert 0 <= d_lo <= d_hi <= 1
        for label in ("priority order", "onion order", "no edges", "no isophotes"):
            assert re.search(rf"{label}: MAR [\d.]+ ± [\d.]+ m", out)
        return
    if path.name.startswith("02_"):
        assert "agreeing candidate 0.0000" in out
        sweeps = re.findall(r"after \d sweep\(s\): P\(2 m\) per pixel = \[([\d., ]+)\]", out)
        assert len(sweeps) == 3
        for probs in sweeps:
            assert all(0.0 <= float(p) <= 1.0 for p in probs.split(","))
        bp_mar, ceiling, np_mar = map(float, re.search(
            r"BP: MAR ([\d.]+) m .* candidate ceiling ([\d.]+) m; NP: MAR ([\d.]+) m",
            out).groups())
        assert ceiling <= bp_mar and 0 < np_mar < 3
