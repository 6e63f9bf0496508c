"""Code states no measured run time: a docstring or comment in carav_stream/ or blocks/ says why the code has its
shape in words, and names the docs/bench page where the measurement is regenerated; a figure such as "2.4 ns per
sample", "0.42 ms against 2.8 ms" or "about 4 x faster" goes stale with every machine and numpy release.

A physical duration is not a run time: `t_adc_start_s`, "a 1 ms chirp", "latency 100 ns", "64 x 7.33 us per cycle",
"slept in steps of 1 ms" pass."""
import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCANNED = ("carav_stream", "blocks")

_NUM = r"\d+(?:\.\d+)?(?:e[-+]?\d+)?"
_UNIT = r"(?:ns|us|µs|ms|s|seconds?|milliseconds?|microseconds?|nanoseconds?)"
_SPAN = rf"{_NUM}\s*(?:(?:-|to)\s*{_NUM}\s*)?{_UNIT}\b"          # "0.4 ns", "2 to 5 us", "0.3-1 s"
_PHYSICAL = r"(?<![\w.])(?<!of )(?<!= )(?<!x )"       # a whole number, not "frames of 40 ms each", "64 x 7 us per"
PATTERNS = {
    # a time per unit of work: "10 ns per sample", "1.3 us a cycle", "40 ms each", "200 us of kernel time per"
    "rate": rf"{_PHYSICAL}{_NUM}\s*{_UNIT}\s+(?:of\s+[\w-]+(?:\s+time)?\s+)?(?:a|an|per|each)\b",
    # two times compared: "0.42 ms against 2.8 ms", "208 -> 184 us", "1.7 against 2.5 ns"
    "comparison": rf"\b{_NUM}\s*(?:{_UNIT}\s*)?(?:\w+\s+)?(?:against|->|→|vs\.?|versus)\s+{_NUM}\s*{_UNIT}\b"
                  rf"|\b{_NUM}\s*{_UNIT}\b[^.;:]{{0,40}}?\b(?:against|vs\.?|versus)\s+{_NUM}\b",
    # a speed ratio: "3x faster", "about 4 x slower", "twice as fast"
    "ratio": rf"(?:\b{_NUM}\s*[x×]|\btwice|\b\d+\s+times)\s+(?:as\s+)?(?:faster|slower|quicker|fast|slow)\b",
    # a share of the time: "in half the time", "a sixth of the time"
    "share": r"\b(?:half|(?:a|one)\s+(?:third|quarter|fifth|sixth|tenth))\s+(?:of\s+)?the\s+(?:time|cpu)\b",
    # a cost: "costs about 10 ns", "would add about 0.8 s", "saves 2 ms"
    "cost": rf"\b(?:costs?|costing|spends?|adds?|saves?)\b[^.;]{{0,30}}?\b{_SPAN}",
    # CPU or kernel time: "1.89 s of kernel time", "2 to 5 us of Python"
    "cpu": rf"\b{_SPAN}\s+of\s+(?:cpu|kernel|user|wall|python)\b",
    # a start-up time in brackets: "still importing numpy (0.3-1 s)"
    "startup": rf"\b(?:import|imports|importing|start-up|startup|first call)\b[^.;]{{0,60}}?\(\s*~?{_SPAN}\s*\)",
}
TIMING = re.compile("|".join(f"(?P<{name}>{rx})" for name, rx in PATTERNS.items()), re.IGNORECASE)


def prose(source: str) -> list[tuple[int, str]]:
    """(line, text) of every docstring and every run of consecutive comment lines (one text, so that a figure
    broken over two comment lines is read whole), whitespace collapsed."""
    found, run, first, last = [], [], 0, -1
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type != tokenize.COMMENT:
            continue
        if run and tok.start[0] != last + 1:
            found.append((first, " ".join(run)))
            run = []
        if not run:
            first = tok.start[0]
        run.append(tok.string.lstrip("#"))
        last = tok.start[0]
    if run:
        found.append((first, " ".join(run)))
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                found.append((node.body[0].lineno if node.body else 1, doc))
    return [(line, " ".join(text.split())) for line, text in found]


def timing_figures(source: str) -> list[str]:
    """Every timing figure stated in the docstrings and comments of a module's source: 'line: [kind] excerpt'."""
    return [f"{line}: [{m.lastgroup}] ...{text[max(0, m.start() - 30): m.end() + 10]}..."
            for line, text in prose(source) for m in TIMING.finditer(text)]


def _modules() -> dict[str, Path]:
    return {p.relative_to(ROOT).as_posix(): p for top in SCANNED for p in sorted((ROOT / top).rglob("*.py"))}


def test_no_docstring_or_comment_states_a_timing_figure():
    found = [f"{name}:{hit}" for name, path in _modules().items() for hit in timing_figures(path.read_text())]
    assert found == [], ("measured run times belong in a benchmark record and its docs/bench page; say the reason "
                         "in words and name the page:\n" + "\n".join(found))


@pytest.mark.parametrize("text", [
    '"""Box-Muller costs about 2.4 ns on an AVX-512 machine."""',
    "# 480 runs: codes of RMS 40 0.19 ns a\n# code against 0.30\n",
    '"""table1 (64 x 1080): 1.8 us a cycle without attack."""',
    '"""table1\'s grid: 0.42 ms against 2.8 ms for np.mod."""',
    '"""into an output array in cache (64 x 1080 samples: 208 -> 184 us)."""',
    "# lam_a * rho + lam_s * (1 - rho) is exact, and 3x faster than a masked copy\n",
    "# A compiled one-pass loop with int64 sums is about 4 x\n# faster on AVX-512\n",
    '"""single precision (about twice as fast)."""',
    '"""a search asks the same moments at every eta, 40 ms each by quadrature."""',
    '"""scipy would add about 0.8 s of CPU to every start of the node."""',
    '"""kernel time: 1.89 s of kernel time against 0.48 s with them."""',
    '"""a few integer checks, about 2 to 5 us of Python."""',
    '"""while the node is still importing numpy, ZeroMQ and its block (0.3-1 s)."""',
    "import scipy.signal  # lazily: it costs ~1 s per process\n",
    '"""the same bits (a new array), a sixth of the time."""',
])
def test_a_measured_run_time_is_found(text):
    assert timing_figures(text), text


@pytest.mark.parametrize("text", [
    '"""t_adc_start_s: the ADC starts 7 us after the ramp (1.1e-3 on AWR1642 with a 7 us start)."""',
    '"""a 1 ms chirp; a reactive repeater at 30 m, latency 100 ns, and 5 us."""',
    '"""t_m = 5.5 * 2 * 200 / c = 7.34 us, bandwidth c / 2."""',
    '"""the radar cycle: 64 x 7.33 us per cycle; awr1642 frames of 40 ms each."""',
    '"""checked every packet, slept in steps of at least 1 ms; redrawn at most every 0.2 s."""',
    '"""uses far less than `min_step` (0.5 CPU-s) in `stall_s` (60 s)."""',
    '"""numpy\'s complex exp is slower; cheaper than a stable argsort (tests check both pick alike)."""',
    '"""SMART_CHUNK_CYCLES cycles per pass; C(N, N/2) / 2^N (0.099 for N = 64): about 10 raw words a cycle."""',
])
def test_a_physical_duration_or_a_reason_in_words_is_not_a_run_time(text):
    assert timing_figures(text) == [], text
