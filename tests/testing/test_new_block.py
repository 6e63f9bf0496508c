"""`carav new block`: the three files it writes pass their own tests outside this repository (pytest with only the
installed package and its plugin), and those tests fail once the block is broken."""
import subprocess
import sys

import pytest

from carav_stream.cli import main as carav
from carav_stream.cli.new import files_for
from carav_stream.console.errors import Exit

pytestmark = pytest.mark.integration

BREAK = {"filter": ("        x = inp.payload", "        raise RuntimeError('broken')\n        x = inp.payload"),
         "source": ("        n = min(self.batch", "        raise RuntimeError('broken')\n        n = min(self.batch"),
         "sink": ("        self.cycles += n_cycles(inp)", "        raise RuntimeError('broken')")}


def pytest_in(folder) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(folder)],
                          cwd=folder, capture_output=True, text=True)


@pytest.mark.parametrize("kind", ["filter", "source", "sink"])
def test_a_new_block_passes_its_generated_tests_and_they_fail_when_it_breaks(tmp_path, kind):
    folder = tmp_path / "mine"
    assert carav(["new", "block", f"my_{kind}", "--kind", kind, "--dir", str(folder)]) == 0
    assert sorted(p.name for p in folder.iterdir()) == sorted(files_for(f"my_{kind}", kind))
    done = pytest_in(folder)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    block = folder / f"my_{kind}.py"
    old, new = BREAK[kind]
    assert old in block.read_text()
    block.write_text(block.read_text().replace(old, new))
    broken = pytest_in(folder)
    assert broken.returncode == 1 and "failed" in broken.stdout, broken.stdout[-3000:]


def test_new_block_refuses_a_bad_name_a_built_in_name_and_overwriting(tmp_path, capsys):
    assert carav(["new", "block", "My-Gain", "--dir", str(tmp_path)]) == Exit.USAGE
    assert "expected a lower-case Python name" in capsys.readouterr().err
    assert carav(["new", "block", "gate", "--dir", str(tmp_path)]) == Exit.USAGE
    assert "a built-in block" in capsys.readouterr().err
    assert carav(["new", "block", "my_gain", "--dir", str(tmp_path)]) == 0
    assert carav(["new", "block", "my_gain", "--dir", str(tmp_path)]) == Exit.USAGE
    assert "exist already; nothing written" in capsys.readouterr().err
