"""The layout shows the pipeline: data flow one way between packages, no cycles, no
reaching into another module's private names.

Pipeline order (each package may import only itself and the packages before it):
scene → reference → contact → laws → statics → model → fe → io → studies → cli, with
`fecheck.errors` and the `geometry` package below all of them; `geometry` imports nothing
of `fecheck`. The `validation` package (the scripts) sits above the pipeline: it imports
`fecheck`, `geometry` and its own modules by their package name, and nothing imports it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ORDER = ("scene", "reference", "contact", "laws", "statics", "model", "fe", "io", "studies",
         "cli")
RANK = {name: i for i, name in enumerate(ORDER)}
BASE = ("fecheck.errors", "fecheck.__main__", "fecheck")


def _modules(package: str) -> dict[str, Path]:
    out = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(path: Path, module: str) -> list[tuple[str, tuple[str, ...], bool, int]]:
    """(imported module, names, at module level, line) for every import in `path`."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top = {id(node) for node in tree.body}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, (), id(node) in top, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = module.split(".")[:-node.level] if not path.name == "__init__.py" \
                    else module.split(".")[:len(module.split(".")) - node.level + 1]
                base = ".".join(pkg + ([base] if base else []))
            out.append((base, tuple(a.name for a in node.names), id(node) in top, node.lineno))
    return out


def _stage(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "fecheck" or module in BASE or len(parts) < 2:
        return None
    return parts[1]


MODULES = _modules("fecheck") | _modules("geometry")
SCRIPTS = _modules("validation")
SIBLINGS = {m.rsplit(".", 1)[-1] for m in SCRIPTS if "." in m} | {"tests", "conftest", "scripts"}
"""Names a validation module may reach only through a `sys.path` edit: its siblings' bare
names (``import report`` for ``validation.report``), the tests and the repository scripts."""


def _validation_violations(module: str, path: Path) -> list[str]:
    """The imports of `path` that break the validation package's rules: a pipeline module
    (fecheck, geometry) importing validation, or a validation module importing a sibling by
    its bare name or the tests."""
    top = [(t.split(".")[0], line) for t, _, _, line in _imports(path, module)]
    if module.split(".")[0] == "validation":
        return [f"{module}:{line} imports {t} by its bare name" for t, line in top
                if t in SIBLINGS]
    return [f"{module}:{line} imports validation" for t, line in top if t == "validation"]


def _resolve(target: str, names: tuple[str, ...]) -> list[str]:
    """The modules an import statement loads: `from fecheck.model import run` names the
    submodule fecheck.model.run."""
    subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in MODULES]
    return subs or [target]


def test_geometry_knows_nothing_of_fecheck():
    bad = [f"{m}:{line} imports {t}" for m, p in _modules("geometry").items()
           for t, _, _, line in _imports(p, m) if t.split(".")[0] == "fecheck"]
    assert not bad, bad


def test_every_fecheck_module_belongs_to_a_stage_of_the_pipeline():
    stray = [m for m in _modules("fecheck") if m not in BASE and _stage(m) not in RANK]
    assert not stray, f"modules outside the pipeline packages {ORDER}: {stray}"


@pytest.mark.parametrize("module", sorted(m for m in _modules("fecheck") if _stage(m)))
def test_imports_flow_one_way(module):
    stage = _stage(module)
    bad = []
    for target, names, _, line in _imports(MODULES[module], module):
        for t in _resolve(target, names):
            other = _stage(t)
            if other is not None and RANK.get(other, -1) > RANK[stage]:
                bad.append(f"line {line}: {stage} → {other} ({t})")
    assert not bad, f"{module} imports a later stage: {bad}"


def test_no_private_names_imported_from_another_module():
    bad = []
    for module, path in MODULES.items():
        for target, names, _, line in _imports(path, module):
            if target.split(".")[0] not in ("fecheck", "geometry"):
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private and target != module:
                bad.append(f"{module}:{line} from {target} import {private}")
    assert not bad, bad


def test_module_level_imports_have_no_cycle():
    graph = {m: {t for target, names, at_top, _ in _imports(p, m) if at_top
                 for t in _resolve(target, names) if t in MODULES and t != m}
             for m, p in MODULES.items()}
    done: set[str] = set()

    def visit(node: str, path: list[str]) -> None:
        if node in path:
            cycle = path[path.index(node):] + [node]
            raise AssertionError(f"import cycle: {' → '.join(cycle)}")
        if node in done:
            return
        for nxt in graph[node]:
            visit(nxt, path + [node])
        done.add(node)

    for m in graph:
        visit(m, [])


def test_the_checker_sees_a_backward_import(tmp_path):
    # the rule itself bites: a model module importing the CLI is reported
    fake = tmp_path / "fake.py"
    fake.write_text("def f():\n    from fecheck.cli import main\n")
    targets = [t for t, *_ in _imports(fake, "fecheck.model.fake")]
    assert targets == ["fecheck.cli"]
    assert RANK[_stage(targets[0])] > RANK[_stage("fecheck.model.fake")]


def test_nothing_of_the_pipeline_imports_validation():
    bad = [v for m, p in MODULES.items() for v in _validation_violations(m, p)]
    assert not bad, bad


def test_validation_imports_its_siblings_through_the_package():
    assert {"validation", "validation.report", "validation.row_rigid"} <= set(SCRIPTS)
    bad = [v for m, p in SCRIPTS.items() for v in _validation_violations(m, p)]
    assert not bad, bad


@pytest.mark.parametrize("module, line, expected", [
    ("fecheck.model.fake", "def f():\n    from validation import report\n",
     ["fecheck.model.fake:2 imports validation"]),
    ("geometry.fake", "import validation.lenhart\n", ["geometry.fake:1 imports validation"]),
    ("validation.fake", "import thesis_values as tv\n",
     ["validation.fake:1 imports thesis_values by its bare name"]),
    ("validation.fake", "from knee_synthetic import write_mesh\n",
     ["validation.fake:1 imports knee_synthetic by its bare name"]),
    ("validation.fake", "from validation.report import Row\nfrom fecheck import laws\n", []),
])
def test_the_checker_sees_a_forbidden_validation_import(tmp_path, module, line, expected):
    fake = tmp_path / "fake.py"
    fake.write_text(line)
    assert _validation_violations(module, fake) == expected
