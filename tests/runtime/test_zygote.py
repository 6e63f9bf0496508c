"""The zygote (runtime/zygote.py, runtime/launcher.py) forks processes that hold what a fresh interpreter would
hold and nothing more: random streams of their own (the activation source reading the OS's generator after the
fork), their log and their data plane's descriptors at the numbers the spec names and no other descriptor, the
command line and environment they were given, the supervisor as their parent. Each test forks tests/runtime/
zygote_probe.py, which the zygote imported first, from a real zygote process; the test process stands in for the
supervisor (a child subreaper while its zygote lives)."""
import json
import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import pytest

from carav_stream.runtime import launcher
from carav_stream.runtime.launcher import NODE_ARGV, Forked, Launcher, Zygote, node_env

ROOT = Path(__file__).resolve().parents[2]
PROBE = "tests.runtime.zygote_probe"
TIMEOUT_S = 120.0          # the zygote's imports, on a loaded machine


def probe_env(**more: str) -> dict[str, str]:
    return {**node_env(), "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
            **more}


@contextmanager
def probe_zygote():
    z = Zygote(probe_env(), preload=[PROBE])
    try:
        yield z
    finally:
        z.close()


def fork_probe(z: Zygote, tmp_path: Path, name: str, fds=(), block: str | None = None) -> tuple[dict, Forked]:
    """Fork the probe as node `name` (of type `block`), with the descriptors `fds` at their numbers; what it found in
    its process, and the process (ended)."""
    out, log = tmp_path / f"{name}.json", tmp_path / f"{name}.log"
    argv = [*NODE_ARGV, str(out)]
    with open(log, "ab") as logf:
        proc = Forked(z.fork(argv, logf.fileno(), list(fds), probe_env(PROBE_VALUE=name), TIMEOUT_S, PROBE, block),
                      argv)
    assert proc.wait(TIMEOUT_S) == 0, log.read_text()
    return json.loads(out.read_text()), proc


def test_two_forked_nodes_draw_different_random_streams_and_the_activation_reads_the_os_after_the_fork(tmp_path):
    with probe_zygote() as z:
        a, _ = fork_probe(z, tmp_path, "a")
        b, _ = fork_probe(z, tmp_path, "b")
    # numpy's legacy global generator and Python's were seeded in the zygote; a fork copies them
    for stream in ("numpy_legacy", "python_random", "numpy_default_rng"):
        assert a[stream] != b[stream], stream
    # the secure activation source was made in the zygote, before the forks: each draw reads the OS's generator
    # in the forked process itself (8 bytes per chirp), so the two draw different sequences
    assert a["activation"] != b["activation"]
    assert a["urandom_bytes_read"] == b["urandom_bytes_read"] == 8 * 4 * 16


def test_a_forked_node_holds_its_log_and_descriptors_at_their_numbers_and_no_other(tmp_path):
    seg = [os.memfd_create("carav-test-a"), os.memfd_create("carav-test-b")]   # as a plane's segments
    high = os.dup2(seg[1], 77)                                               # numbers far apart
    try:
        with probe_zygote() as z:
            found, _ = fork_probe(z, tmp_path, "a", [seg[0], high])
        ours = {fd: os.fstat(fd).st_ino for fd in (seg[0], high)}
    finally:
        for fd in (*seg, high):
            os.close(fd)
    assert found["fds"] == sorted({0, 1, 2, seg[0], high})   # the zygote's link and held file: not inherited
    inode = {int(k): v for k, v in found["fd_inodes"].items()}
    assert inode[1] == inode[2] == (tmp_path / "a.log").stat().st_ino
    assert inode[0] == os.stat(os.devnull).st_ino
    assert {fd: inode[fd] for fd in ours} == ours             # the supervisor's segments, at their numbers
    assert found["threads"] == 1


def test_a_forked_node_has_its_own_command_line_environment_and_the_supervisor_as_parent(tmp_path):
    with probe_zygote() as z:
        found, proc = fork_probe(z, tmp_path, "a")
    argv = [*NODE_ARGV, str(tmp_path / "a.json")]
    assert found["cmdline"][:len(argv)] == argv and set(found["cmdline"][len(argv):]) == {""}
    assert found["argv"][1:] == [str(tmp_path / "a.json")]
    assert found["env"] == "a"
    assert found["ppid"] == os.getpid() and found["pid"] == proc.pid


def test_the_zygote_holds_no_descriptor_but_its_link_and_runs_one_thread(tmp_path):
    """What the zygote imports for its nodes (runtime.node, the planes, the built-in blocks) opens no descriptor,
    starts no thread and makes no ZeroMQ context (whose sockets and threads a fork would copy)."""
    z = Zygote(node_env())
    try:
        argv = [*NODE_ARGV, str(tmp_path / "none.spec")]     # answered once its imports are done; exits at once
        with open(tmp_path / "n.log", "ab") as logf:
            node = Forked(z.fork(argv, logf.fileno(), [], node_env(), TIMEOUT_S), argv)
        assert node.wait(TIMEOUT_S) == 1 and "none.spec" in (tmp_path / "n.log").read_text()
        fds = {fd: os.readlink(f"/proc/{z.proc.pid}/fd/{fd}") for fd in os.listdir(f"/proc/{z.proc.pid}/fd")}
        threads = os.listdir(f"/proc/{z.proc.pid}/task")
    finally:
        z.close()
    held = {fd: target for fd, target in fds.items() if fd not in ("0", "1", "2")}
    assert len(held) == 1 and next(iter(held.values())).startswith("socket:"), held      # its link
    assert len(threads) == 1


def test_the_zygote_loads_no_module_level_generator_but_the_two_each_fork_reseeds():
    """zygote.reseed draws numpy's legacy global generator and Python's afresh; a generator any other module kept
    at its top level would be copied into every node: none of the modules the zygote imports (every built-in block
    among them: it imports those a run names) may keep one."""
    scan = ("import random, sys\nimport numpy as np\nfrom carav_stream.runtime import zygote\n"
            "from carav_stream.runtime.registry import builtin_dir\n"
            "assert not zygote.preload()\n"
            "assert not zygote.import_blocks(sorted(p.stem for p in builtin_dir().glob('[!_]*.py')))\n"
            "kinds = (random.Random, np.random.RandomState, np.random.Generator, np.random.BitGenerator)\n"
            "print(sorted(f'{n}.{a}' for n, m in list(sys.modules.items()) if m for a, v in vars(m).items()\n"
            "             if isinstance(v, kinds) and not isinstance(v, random.SystemRandom)))")
    out = subprocess.run([sys.executable, "-c", scan], env=node_env(), capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["['numpy.random.mtrand._rand',", "'random._inst']"]


def test_the_zygote_imports_the_blocks_it_is_told_of_and_a_nodes_own_before_its_fork_and_no_other(tmp_path):
    with probe_zygote() as z:
        assert fork_probe(z, tmp_path, "bare")[0]["blocks"] == []        # its start imports no block
        z.import_blocks(["gate", "no_such_block", "../gate"])            # a run's types; not a built-in: left alone
        assert fork_probe(z, tmp_path, "told")[0]["blocks"] == ["carav_blocks.gate"]
        found = fork_probe(z, tmp_path, "own", block="tracker")[0]
        assert found["blocks"] == ["carav_blocks.gate", "carav_blocks.tracker"]
        assert found["threads"] == 1


def test_a_zygote_left_with_a_thread_by_its_imports_forks_nothing_and_says_why(tmp_path):
    """A fork copies the calling thread only: a zygote whose imports started one exits, and the launcher names it."""
    module = tmp_path / "threaded_import.py"
    module.write_text("import threading, time\nthreading.Thread(target=time.sleep, args=(600,), daemon=True).start()\n")
    z = Zygote(probe_env(PYTHONPATH=os.pathsep.join([str(tmp_path), probe_env()["PYTHONPATH"]])),
               preload=["threaded_import"])
    try:
        with pytest.raises(launcher.ZygoteGone, match="2 threads after its imports"):
            fork_probe(z, tmp_path, "never")
    finally:
        z.close()


def test_a_dead_zygote_is_named_once_and_nodes_start_fresh(tmp_path):
    lines = []
    start = Launcher(log=lines.append)
    assert start.zygote is not None
    start.zygote.proc.kill()
    spec = tmp_path / "n.spec"              # no such spec: the fresh node exits at once, and says why in its log
    try:
        first = start.launch(spec, tmp_path / "n.log", [], node_env(), TIMEOUT_S)
        second = start.launch(spec, tmp_path / "n.log", [], node_env(), TIMEOUT_S)
    finally:
        start.close()
    assert isinstance(first, subprocess.Popen) and isinstance(second, subprocess.Popen)
    assert first.wait(TIMEOUT_S) == second.wait(TIMEOUT_S) == 1
    assert len(lines) == 1 and "the zygote" in lines[0] and "signal SIGKILL" in lines[0] \
        and "fresh interpreter" in lines[0], lines
    assert start.counts() == {"forked": 0, "fresh": 2}


@pytest.mark.parametrize("how", ["environment", "changed environment"])
def test_without_a_zygote_nodes_start_as_fresh_interpreters(tmp_path, monkeypatch, how):
    if how == "environment":
        monkeypatch.setenv(launcher.ZYGOTE_ENV, "0")
    start = Launcher()
    try:
        assert (start.zygote is None) == (how == "environment")
        env = {**node_env(), "CARAV_SOMETHING_NEW": "1"} if how == "changed environment" else node_env()
        proc = start.launch(tmp_path / "n.spec", tmp_path / "n.log", [], env, TIMEOUT_S)
    finally:
        start.close()
    assert isinstance(proc, subprocess.Popen) and proc.wait(TIMEOUT_S) == 1
    assert start.counts() == {"forked": 0, "fresh": 1}
