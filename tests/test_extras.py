"""
Each command's extra brings what its modules import: ``pip install ".[compare]"`` alone runs ``sb3-reinforce compare``.

Read from the source, not from this environment (which has every extra): every module-level import of a third-party
package, in the modules a command reaches through this package's own imports, must be installed by the package's
dependencies and the command's extra, directly or as their dependencies (read from the installed metadata). Imports
inside functions are left out (a feature of another extra, imported when used), as are those under ``TYPE_CHECKING``
or in a ``try`` that catches ``ImportError``.
"""

import ast
import re
import sys
from importlib import metadata
from pathlib import Path

import pytest
import tomllib
from packaging.requirements import Requirement

REPO = Path(__file__).resolve().parents[1]
#: The modules each extra's commands start from (their entry points and the sub-commands they import when run).
COMMANDS = {
    "compare": (
        "sb3_reinforce.lab.cli",
        "sb3_reinforce.lab.compare.command",
        "sb3_reinforce.lab.report",
        "sb3_reinforce.lab.seed.reproduction",
    ),
    "zoo": ("sb3_reinforce.lab.zoo.cli",),
}


def _name(distribution: str) -> str:
    return re.sub(r"[-_.]+", "-", distribution).lower()


def _guards(node: ast.AST) -> bool:
    if isinstance(node, ast.If):
        return "TYPE_CHECKING" in ast.unparse(node.test)
    if isinstance(node, ast.Try):
        return any(h.type is not None and "ImportError" in ast.unparse(h.type) for h in node.handlers)
    return False


def module_level_imports(path: Path) -> list[tuple[str, bool]]:
    """Each import outside functions in ``path``: (module, whether guarded by ``TYPE_CHECKING`` or ``ImportError``)."""
    found: list[tuple[str, bool]] = []

    def visit(node: ast.AST, guarded: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            if isinstance(child, ast.Import):
                found.extend((alias.name, guarded) for alias in child.names)
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                found.append((child.module, guarded))
            visit(child, guarded or _guards(child))

    visit(ast.parse(path.read_text()), False)
    return found


def third_party_imports(start: tuple[str, ...]) -> dict[str, set[str]]:
    """Top-level third-party packages imported by the package's modules reachable from ``start`` -> who imports them."""
    seen: set[str] = set()
    todo, imported = list(start), {}
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        base = REPO / module.replace(".", "/")
        path = base.with_suffix(".py") if base.with_suffix(".py").exists() else base / "__init__.py"
        if not path.exists():  # a name imported from a module, not a module
            continue
        for name, guarded in module_level_imports(path):
            top = name.split(".")[0]
            if top == "sb3_reinforce":
                todo.append(name)
            elif not guarded and top not in sys.stdlib_module_names:
                imported.setdefault(top, set()).add(module)
    return imported


def installed_by(extra: str) -> set[str]:
    """The distributions the package's dependencies and ``extra`` install, with theirs (installed metadata)."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    todo = [Requirement(text) for text in [*project["dependencies"], *project["optional-dependencies"][extra]]]
    done: set[tuple[str, frozenset[str]]] = set()
    while todo:
        requirement = todo.pop()
        key = (_name(requirement.name), frozenset(requirement.extras))
        if key in done:
            continue
        done.add(key)
        try:
            requires = metadata.requires(requirement.name) or []
        except metadata.PackageNotFoundError:
            continue
        for text in requires:
            dependency = Requirement(text)
            markers = [{"extra": name} for name in ("", *requirement.extras)]
            if dependency.marker is None or any(dependency.marker.evaluate(marker) for marker in markers):
                todo.append(dependency)
    return {name for name, _ in done}


@pytest.mark.parametrize("extra", sorted(COMMANDS))
def test_the_extra_installs_what_its_commands_import(extra: str) -> None:
    installed = installed_by(extra)
    distributions = metadata.packages_distributions()
    missing = {
        package: sorted(modules)
        for package, modules in third_party_imports(COMMANDS[extra]).items()
        if not any(_name(distribution) in installed for distribution in distributions.get(package, [package]))
    }
    assert not missing, f"imported by these modules, not installed by the {extra!r} extra: {missing}"
