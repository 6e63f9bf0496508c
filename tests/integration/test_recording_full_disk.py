"""`carav record` on a disk that fills up: the run fails in one line naming the file and what happened, without the
recorder's traceback. Needs a small tmpfs: skipped where mounting one is not allowed."""
import subprocess

import pytest

from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs, unmounted afterwards; the test is skipped where mounting is not allowed."""
    where = tmp_path / "small"
    where.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(where)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip() or done.returncode}")
    yield where
    subprocess.run(["umount", "-l", str(where)], check=False)


def test_carav_record_on_a_full_disk_fails_in_one_line_naming_the_file(carav, small_disk):
    out = small_disk / "rec"
    done = carav.cli("record", str(ROOT / "graphs" / "demo.toml"), "--out", str(out), "--cycles", "64",
                     "--no-progress")
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr and "Traceback" not in done.stdout, done.stderr
    line = (f"carav: node 'recorder' (sigmf_sink) failed: exited with status 1: BlockError: "
            f"{out}/recording.sigmf-data: cannot write: No space left on device")
    assert done.stderr.strip().splitlines() == [line], done.stderr
