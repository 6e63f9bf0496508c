"""The run root is this user's own folder, mode 0700, or nothing runs: another user could plant runs in it."""
import os
import pwd

import pytest

from carav_stream.runtime.rundir import RunRootError, run_root


@pytest.fixture
def base(tmp_path, monkeypatch):
    monkeypatch.setenv("CARAV_RUN_DIR", str(tmp_path))
    return tmp_path


def test_a_missing_run_root_is_made_private_whatever_the_umask(base):
    old = os.umask(0o022)
    try:
        root = run_root()
    finally:
        os.umask(old)
    assert root == base / f"carav-{os.getuid()}" and (root.stat().st_mode & 0o777) == 0o700


@pytest.mark.parametrize("mode", [0o777, 0o755, 0o750, 0o701])
def test_a_run_root_open_to_others_is_refused_naming_it_and_what_to_do(base, mode):
    root = base / f"carav-{os.getuid()}"
    root.mkdir()
    root.chmod(mode)
    with pytest.raises(RunRootError) as info:
        run_root()
    text = str(info.value)
    assert str(root) in text and f"mode {mode:04o}" in text and "remove it" in text and "\n" not in text


def test_a_run_root_that_is_a_link_is_refused(base, tmp_path_factory):
    elsewhere = tmp_path_factory.mktemp("elsewhere")
    elsewhere.chmod(0o700)
    (base / f"carav-{os.getuid()}").symlink_to(elsewhere)
    with pytest.raises(RunRootError, match="is not a folder"):
        run_root()


@pytest.mark.skipif(os.getuid() != 0, reason="only root can give a folder to another user")
def test_a_run_root_planted_by_another_user_is_refused(base):
    root = base / f"carav-{os.getuid()}"
    root.mkdir(mode=0o700)
    nobody = pwd.getpwnam("nobody").pw_uid
    os.chown(root, nobody, -1)
    with pytest.raises(RunRootError) as info:
        run_root()
    assert str(root) in str(info.value) and f"belongs to uid {nobody}" in str(info.value)
