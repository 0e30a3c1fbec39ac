"""The package's floors (docs/architecture.md) as import-linter contracts and an import graph.

`lint-imports` runs on the tree with the contracts of pyproject.toml; each contract is
then shown to catch what it forbids by planting a violating import in a copy of the
package (module level and inside a function: the linter's graph, grimp, sees both).
The graph checks (cycles, imports of the package root, the top level's size) are plain
Tarjan on grimp's direct imports, independent of import-linter.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "vcavity"
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")

CONTRACT_NAMES = {
    "floors": "Floors: each room imports only the floors below it",
    "reading-compiles-nothing": "Reading and evaluating a table compiles nothing",
    "consumers-need-no-walk": "Consumers read tables and evaluate models",
    "acyclic-rooms": "No cycles between the rooms of a floor or the modules of a room",
}


def _lint(tree: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(tree))  # the copy shadows the installed package
    return subprocess.run([str(LINT_IMPORTS), "--no-cache", "--config", str(tree / "pyproject.toml")],
                          cwd=tree, env=env, capture_output=True, text=True, timeout=300)


def _verdicts(output: str) -> dict:
    """Contract id -> "KEPT" or "BROKEN", from lint-imports' summary lines (names may wrap)."""
    flat = " ".join(output.split())
    verdicts = {}
    for contract, name in CONTRACT_NAMES.items():
        start = flat.find(name)
        assert start >= 0, f"contract {contract!r} not in the output:\n{output}"
        rest = flat[start:]
        kept, broken = rest.find(" KEPT"), rest.find(" BROKEN")
        candidates = [(pos, word) for pos, word in ((kept, "KEPT"), (broken, "BROKEN")) if pos >= 0]
        verdicts[contract] = min(candidates)[1]
    return verdicts


@pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="import-linter is in the dev extra")
def test_contracts_are_kept():
    result = _lint(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert set(_verdicts(result.stdout).values()) == {"KEPT"}


# (module, planted code, contract that must break)
PLANTED = [
    ("vcavity/parameters.py", "import vcavity._version\n", "floors"),           # a sibling on its floor
    ("vcavity/microfacet/common.py", "import vcavity.config\n", "floors"),      # a floor above
    ("vcavity/io/table.py", "import numba\n", "reading-compiles-nothing"),
    ("vcavity/brdf/table_brdf.py", "import vcavity.sensor.binning\n",           # allowed floor, but
     "reading-compiles-nothing"),                                                # binning imports Numba
    ("vcavity/io/writer.py", "def _planted():\n    import numba\n", "reading-compiles-nothing"),
    ("vcavity/plots/data.py", "def _planted():\n    import vcavity.simulate.pipeline\n",
     "consumers-need-no-walk"),
    ("vcavity/export/rgl.py", "import vcavity.kernels.trace\n", "consumers-need-no-walk"),
    ("vcavity/analytic/quadrature.py", "def _planted():\n    import vcavity.analytic.cells\n", "acyclic-rooms"),
]


@pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="import-linter is in the dev extra")
@pytest.mark.parametrize("module, code, contract", PLANTED, ids=[f"{c}:{m}" for m, _, c in PLANTED])
def test_planted_violation_breaks_its_contract(tmp_path, module, code, contract):
    shutil.copytree(PACKAGE, tmp_path / "vcavity", ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    target = tmp_path / module
    target.write_text(target.read_text() + "\n\n" + code)
    result = _lint(tmp_path)
    assert result.returncode != 0, result.stdout
    assert _verdicts(result.stdout)[contract] == "BROKEN", result.stdout


def _graph():
    return grimp.build_graph("vcavity", cache_dir=None)


def _cycles(graph) -> list:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, on_stack, stack, components = {}, {}, set(), [], []
    counter = 0
    for start in sorted(graph.modules):
        if start in index:
            continue
        work = [(start, iter(sorted(graph.find_modules_directly_imported_by(start))))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.find_modules_directly_imported_by(child)))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    components.append(sorted(component))
    return components


def test_cycle_finder_finds_a_planted_cycle():
    graph = _graph()
    graph.add_import(importer="vcavity.sensor.grid", imported="vcavity.config")  # config -> ... -> sensor.grid
    assert any({"vcavity.sensor.grid", "vcavity.config"} <= set(c) for c in _cycles(graph))


def test_no_import_cycles_function_level_imports_included():
    assert _cycles(_graph()) == []


def test_no_module_imports_the_package_root():
    graph = _graph()
    importers = sorted(graph.find_modules_that_directly_import("vcavity"))
    assert importers == []


def test_top_level_of_the_package_is_small():
    modules = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(modules) <= 10, modules


def test_every_room_says_what_it_is_for():
    for init in sorted(PACKAGE.glob("*/__init__.py")):
        text = init.read_text().lstrip()
        assert text.startswith('"""') and len(text) > 10, f"{init.relative_to(ROOT)} has no docstring"
