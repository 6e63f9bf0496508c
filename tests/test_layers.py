"""The house keeps its floors: the import-linter contracts of pyproject.toml hold (no import from a lower floor to a
higher one, no circle of imports inside a package, the runtime knows nothing of radar), every package of
carav_stream sits on a floor of the layer contract, and the package's own modules are imported at the top of a
module, not hidden inside functions, where a reader of the imports would not see them."""
import ast
import tomllib
from pathlib import Path

from importlinter.cli import lint_imports

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "carav_stream"


def _contracts() -> list[dict]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]


def test_the_import_contracts_hold(monkeypatch):
    monkeypatch.chdir(ROOT)
    assert lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True) == 0


def test_every_package_of_carav_stream_is_on_a_floor_of_the_layer_contract():
    layers = next(c for c in _contracts() if c["type"] == "layers")["layers"]
    on_a_floor = {name.strip() for layer in layers for name in layer.split("|")}
    packages = {f"carav_stream.{p.parent.name}" for p in PACKAGE.glob("*/__init__.py")}
    assert packages - on_a_floor == set(), "a package outside the layer contract is not checked by it"
    assert on_a_floor - packages == set(), "the layer contract names a package that does not exist"


def test_console_is_forbidden_to_every_package_but_the_commands():
    forbidding = [c for c in _contracts()
                  if c["type"] == "forbidden" and c["forbidden_modules"] == ["carav_stream.console"]]
    assert len(forbidding) == 1, "no contract keeps console (exit codes, progress bar) to the commands"
    packages = {f"carav_stream.{p.parent.name}" for p in PACKAGE.glob("*/__init__.py")}
    assert set(forbidding[0]["source_modules"]) == packages - {"carav_stream.cli", "carav_stream.console"}


def _hidden_imports(path: Path, root: Path = ROOT) -> list[str]:
    """Imports of carav_stream's own modules inside functions, without a comment on the line above saying why."""
    lines = path.read_text().splitlines()
    found = []
    for fn in ast.walk(ast.parse("\n".join(lines))):
        if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for node in ast.walk(fn):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            if not any(n.startswith("carav_stream") for n in names):
                continue
            above = lines[node.lineno - 2].strip() if node.lineno > 1 else ""
            if not (above.startswith("#") or above.startswith("from carav_stream") or above.startswith("import ")):
                found.append(f"{path.relative_to(root)}:{node.lineno}")
    return found


def test_the_package_imports_its_own_modules_at_the_top_of_each_module():
    hidden = [hit for path in sorted(PACKAGE.rglob("*.py")) for hit in _hidden_imports(path)]
    assert hidden == []


def test_a_hidden_import_without_its_reason_is_found(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def f():\n    x = 1\n    from carav_stream.core import units\n    return units\n")
    assert len(_hidden_imports(f, tmp_path)) == 1
    f.write_text("def f():\n    # start-up time: units is heavy\n    from carav_stream.core import units\n")
    assert _hidden_imports(f, tmp_path) == []



def _imported_roots(path: Path) -> set[str]:
    roots = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            roots |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            roots.add(node.module.split(".")[0])
    return roots


def test_the_installed_package_and_the_blocks_import_neither_the_benchmarks_nor_the_tests():
    files = sorted(PACKAGE.rglob("*.py")) + sorted((ROOT / "blocks").glob("*.py"))
    offenders = [str(f.relative_to(ROOT)) for f in files if _imported_roots(f) & {"bench", "tests"}]
    assert offenders == []
