"""The layout shows the pipeline: data flow one way between packages, no cycles, no
reaching into another module's private names.

Pipeline order (each package may import only itself and the packages before it):
scene → reference → contact → laws → statics → model → fe → io → studies → cli, with
`fecheck.errors` and the `geometry` package below all of them; `geometry` imports nothing
of `fecheck`.
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
