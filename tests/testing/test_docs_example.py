"""docs/TESTING.md's example of a detector of one's own in place of rms_detector runs as written: its files, taken
from the document, pass with pytest outside this repository, and its test stays under 20 lines."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration

DOC = Path(__file__).resolve().parents[2] / "docs" / "TESTING.md"


def example_files() -> dict[str, str]:
    """{file name: text} of the document's python blocks that start with `# file: NAME`."""
    blocks = re.findall(r"```python\n# file: (\S+)\n(.*?)```", DOC.read_text(), re.S)
    return dict(blocks)


def test_the_documented_detector_example_runs_and_its_test_is_under_20_lines(tmp_path):
    files = example_files()
    assert sorted(files) == ["d0_detector.py", "test_d0_detector.py"]
    assert len(files["test_d0_detector.py"].strip().splitlines()) < 20
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
                          cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0 and "2 passed" in done.stdout, done.stdout[-3000:] + done.stderr[-2000:]
