"""The package's layers: imports run one way, with no cycle and no hidden upward edge.

Layer order, lowest first (a layer imports only layers below it, and modules of its own layer):

    errors < settings < network < models < games < control < v2x < scenario < sim < results < report
    < experiments < cli < __main__

The package root (``intersection_cosim/__init__.py``) sets thread limits and ``__version__``
and imports nothing of the package; every layer may read it. Every import counts: module-level and
function-local ones, absolute and relative (``from . import x``) forms.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import intersection_cosim

PACKAGE = "intersection_cosim"
ROOT = Path(intersection_cosim.__file__).resolve().parent
LAYERS = ("errors", "settings", "colors", "network", "models", "games", "control", "v2x", "scenario", "sim", "results", "report",
          "experiments", "cli", "__main__")
PURE = ("models", "games")  # decision models and solvers: no simulator, no controller, no output
NOT_IN_PURE = ("control", "sim", "scenario", "results", "report", "experiments", "cli")
SIMULATOR_MODULES = ("libsumo", "traci")


@dataclass(frozen=True)
class Import:
    source: str  # importing module, e.g. "intersection_cosim.report.reporting"
    target: str  # imported module, e.g. "intersection_cosim.results.layout" or "libsumo"
    names: tuple[str, ...]  # names taken with ``from target import ...`` (empty for ``import target``)
    line: int


def module_name(path: Path, root: Path = ROOT, package: str = PACKAGE) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([package, *parts])


def is_module(name: str, root: Path = ROOT, package: str = PACKAGE) -> bool:
    if name != package and not name.startswith(package + "."):
        return False
    rel = Path(*name.split(".")[1:]) if "." in name else Path()
    return (root / rel).with_suffix(".py").is_file() or (root / rel / "__init__.py").is_file()


def imports_of(path: Path, root: Path = ROOT, package: str = PACKAGE) -> list[Import]:
    """Every import statement of ``path`` (anywhere in the file), resolved to absolute names."""
    name = module_name(path, root, package)
    this_package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [Import(name, alias.name, (), node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = this_package.split(".")[: len(this_package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            names = tuple(alias.name for alias in node.names)
            submodules = [f"{target}.{n}" for n in names if is_module(f"{target}.{n}", root, package)]
            found += [Import(name, sub, (), node.lineno) for sub in submodules]
            rest = tuple(n for n in names if f"{target}.{n}" not in submodules)
            if rest or not submodules:
                found.append(Import(name, target, rest, node.lineno))
    return found


def package_imports(root: Path = ROOT, package: str = PACKAGE) -> list[Import]:
    return [imp for path in sorted(root.rglob("*.py")) for imp in imports_of(path, root, package)]


def layer(module: str) -> str:
    """``intersection_cosim.games.nash`` -> ``games``; the package root -> ``""``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def internal(imports: list[Import]) -> list[Import]:
    return [i for i in imports if i.target == PACKAGE or i.target.startswith(PACKAGE + ".")]


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """A cycle of the directed graph ``edges`` as a list of nodes (first == last), or None."""
    state: dict[str, int] = {}  # 1 = on the current path, 2 = done

    def visit(node: str, path: list[str]) -> list[str] | None:
        state[node] = 1
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt] if nxt in path else [node, nxt]
            if nxt not in state and (cycle := visit(nxt, path + [nxt])):
                return cycle
        state[node] = 2
        return None

    for start in sorted(edges):
        if start not in state and (cycle := visit(start, [start])):
            return cycle
    return None


def layer_violations(imports: list[Import]) -> list[str]:
    out = []
    for imp in internal(imports):
        a, b = layer(imp.source), layer(imp.target)
        if b and a != b and (a not in LAYERS or b not in LAYERS or LAYERS.index(b) > LAYERS.index(a)):
            out.append(f"{imp.source}:{imp.line} imports {imp.target} ({a} may not import {b})")
    return out


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))  # dunders are public


def private_imports(imports: list[Import]) -> list[str]:
    """``from intersection_cosim.x import _name``: a module taking another module's private name."""
    return [f"{imp.source}:{imp.line} imports {', '.join(n for n in imp.names if _private(n))} from {imp.target}"
            for imp in internal(imports) if any(_private(n) for n in imp.names)]


# --- the tests -----------------------------------------------------------------------------------

def test_importing_report_loads_no_experiments_module():
    code = ("import sys, intersection_cosim.report.reporting, intersection_cosim.report.compare_figures\n"
            "print(sorted(m for m in sys.modules if m.startswith('intersection_cosim.experiments')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_walk_sees_every_module_and_import_form():
    modules = {module_name(p) for p in ROOT.rglob("*.py")}
    assert {"intersection_cosim.report.reporting", "intersection_cosim.results.layout",
            "intersection_cosim.control.registry"} <= modules
    edges = {(i.source, i.target) for i in package_imports()}
    # module-level, function-local (cli's lazy commands) and ``from package import module`` forms
    assert ("intersection_cosim.report.reporting", "intersection_cosim.results.layout") in edges
    assert ("intersection_cosim.cli", "intersection_cosim.report.reporting") in edges
    assert ("intersection_cosim.scenario.load", "intersection_cosim.control.registry") in edges


def test_no_import_cycle_between_modules():
    edges: dict[str, set[str]] = {}
    for imp in internal(package_imports()):
        if imp.target != imp.source:
            edges.setdefault(imp.source, set()).add(imp.target)
    assert find_cycle(edges) is None


def test_no_import_cycle_between_layers_and_every_import_goes_down():
    imports = package_imports()
    edges: dict[str, set[str]] = {}
    for imp in internal(imports):
        a, b = layer(imp.source), layer(imp.target)
        if b and a != b:
            edges.setdefault(a, set()).add(b)
    assert find_cycle(edges) is None
    assert layer_violations(imports) == []
    assert set(edges) - {""} <= set(LAYERS)  # a new subpackage needs a place in LAYERS


def test_pure_layers_import_no_controller_simulator_or_output():
    bad = [f"{i.source}:{i.line} imports {i.target}" for i in package_imports()
           if layer(i.source) in PURE
           and (layer(i.target) in NOT_IN_PURE and i.target.startswith(PACKAGE + ".")
                or i.target.split(".")[0] in SIMULATOR_MODULES)]
    assert bad == []


def test_only_sim_imports_the_simulator():
    users = {i.source for i in package_imports() if i.target.split(".")[0] in SIMULATOR_MODULES}
    assert users and {layer(u) for u in users} == {"sim"}


def test_no_module_imports_another_modules_private_names():
    assert private_imports(package_imports()) == []


# --- the checks can fail ---------------------------------------------------------------------------

def _fake_package(tmp_path: Path, files: dict[str, str]) -> Path:
    root = tmp_path / PACKAGE
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root


def test_checks_catch_a_bad_import(tmp_path):
    root = _fake_package(tmp_path, {
        "__init__.py": "",
        "report/__init__.py": "",
        "report/reporting.py": "def f():\n    from ..experiments import sweep\n",  # relative, local
        "experiments/__init__.py": "",
        "experiments/sweep.py": "from intersection_cosim.report.reporting import f\n",
        "games/__init__.py": "",
        "games/nash.py": "import libsumo\nfrom intersection_cosim.control.base import World\n",
        "games/stackelberg.py": "from intersection_cosim.games.nash import _Game\n",
        "control/__init__.py": "",
        "control/base.py": "",
    })
    imports = package_imports(root)
    edges: dict[str, set[str]] = {}
    for imp in internal(imports):
        edges.setdefault(imp.source, set()).add(imp.target)
    assert find_cycle(edges) == ["intersection_cosim.experiments.sweep", "intersection_cosim.report.reporting",
                                 "intersection_cosim.experiments.sweep"]
    assert layer_violations(imports) == [
        "intersection_cosim.games.nash:2 imports intersection_cosim.control.base (games may not import control)",
        "intersection_cosim.report.reporting:2 imports intersection_cosim.experiments.sweep "
        "(report may not import experiments)"]
    assert private_imports(imports) == ["intersection_cosim.games.stackelberg:1 imports _Game from "
                                        "intersection_cosim.games.nash"]
    assert [i.target for i in imports if i.target.split(".")[0] in SIMULATOR_MODULES] == ["libsumo"]
