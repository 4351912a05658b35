"""The examples run (quick settings) and write their figures."""

import os
import subprocess
import sys

import pytest

if os.environ.get("VIBROBAR_REQUIRE_EXTRAS"):
    import matplotlib  # noqa: F401  (scripts/test.sh installs it: a skip would hide the examples)
else:
    pytest.importorskip("matplotlib", reason="the examples draw with matplotlib")


@pytest.mark.parametrize("name, files", [("fig3", ["fig3.png", "fig3.csv"]), ("design_map", ["design_map.png", "design_map.csv"])])
def test_example_runs(root, tmp_path, name, files):
    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.run(
        [sys.executable, str(root / "python" / "examples" / f"{name}.py"), "--quick", "--out", str(tmp_path)],
        capture_output=True, text=True, env=env, timeout=300,
    )
    assert p.returncode == 0, p.stderr
    for f in files:
        path = tmp_path / f
        assert path.is_file() and path.stat().st_size > 1000, f
    assert (tmp_path / files[0]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "wrote" in p.stdout
