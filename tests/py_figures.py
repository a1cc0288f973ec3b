"""The figures README.md states (scripts/figures.py's generated blocks: the methods table and the
command transcripts) measured again with this build: the test fails when one has drifted from
what the README says (times aside), naming the block and showing the difference."""
import os
import subprocess
import sys

import pytest

ENVLIGHT = os.environ.get("ENVLIGHT", "")
SOURCE = os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__), ".."))
DATA = os.environ.get("ENVL_SHARED_DATA", os.path.join(SOURCE, "..", "shared", "data"))
TMP = os.environ.get("ENVL_TEST_TMP", "/tmp/envl_py_figures")

pytestmark = pytest.mark.skipif(not ENVLIGHT, reason="needs ENVLIGHT (the built CLI)")


def test_readme_figures_hold():
    os.makedirs(TMP, exist_ok=True)
    r = subprocess.run([sys.executable, os.path.join(SOURCE, "scripts", "figures.py"), "--check",
                        "--envlight", ENVLIGHT, "--data", DATA, "--tmp", TMP,
                        "--readme", os.path.join(SOURCE, "README.md")],
                       capture_output=True, text=True)
    print(r.stdout)
    print(r.stderr)
    assert r.returncode == 0, "README.md's figures drifted (above)"
    assert "ok: methods" in r.stdout or "SKIP: methods" in r.stdout


def test_check_fails_on_a_changed_figure(tmp_path):
    """The check can fail: with a README whose fit range is 0.00-0.00, the built-in sky alone
    (an empty data folder: the range check of a partial data set) is refused."""
    import re
    with open(os.path.join(SOURCE, "README.md")) as f:
        text = f.read()
    bad, n = re.subn(r"(\| `lights --method fit -n 4` \| )[0-9.]+-[0-9.]+", r"\g<1>0.00-0.00",
                     text)
    assert n == 1, "README.md's methods block has no fit row"
    readme = tmp_path / "README.md"
    readme.write_text(bad)
    (tmp_path / "empty").mkdir()
    r = subprocess.run([sys.executable, os.path.join(SOURCE, "scripts", "figures.py"), "--check",
                        "--envlight", ENVLIGHT, "--data", str(tmp_path / "empty"),
                        "--tmp", str(tmp_path / "w"), "--readme", str(readme)],
                       capture_output=True, text=True)
    print(r.stdout)
    assert r.returncode == 1 and "FAIL: fit4 on built-in sky" in r.stdout
