"""
The package's layers, read from the code with ``ast``: the algorithm (``sb3_reinforce.reinforce``) imports
nothing of the opt-in safeguards (``sb3_reinforce.safeguards``) or the tooling (``sb3_reinforce.lab``), the
safeguards nothing of the tooling, the top level exports the algorithm, and no module takes part in an import
circle. Every import counts, also one inside a function.
"""

import ast
from pathlib import Path

import pytest

import sb3_reinforce

PACKAGE_DIR = Path(sb3_reinforce.__file__).parent
ALGORITHM = "sb3_reinforce.reinforce"
SAFEGUARDS = "sb3_reinforce.safeguards"
LAB = "sb3_reinforce.lab"
#: Each layer, and the layers above it that it must not import
LAYERS = {ALGORITHM: (SAFEGUARDS, LAB), SAFEGUARDS: (LAB,)}


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(path): path for path in sorted(PACKAGE_DIR.rglob("*.py"))}


def _resolve(name: str) -> str | None:
    """The package's module that an import of ``name`` runs (its longest prefix that is a module), or None."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        candidate = ".".join(parts[:end])
        if candidate in MODULES:
            return candidate
    return None


def imports_of(module: str) -> set[str]:
    """The package's modules that ``module`` imports, anywhere in its file."""
    found = set()
    for node in ast.walk(ast.parse(MODULES[module].read_text())):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
        else:
            continue
        found |= {target for target in map(_resolve, names) if target is not None and target != module}
    return found


GRAPH = {module: imports_of(module) for module in MODULES}


def _circles() -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in GRAPH[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
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

    for node in GRAPH:
        if node not in index:
            visit(node)
    return components


def test_the_graph_is_read() -> None:
    # the control: the reader finds imports that are known to be there
    assert "sb3_reinforce.reinforce.buffers" in GRAPH["sb3_reinforce.reinforce.reinforce"]
    assert ALGORITHM in GRAPH["sb3_reinforce"]
    assert any(module.startswith(LAB) for module in GRAPH), "the tooling layer is missing"


def test_no_import_circle() -> None:
    assert _circles() == []


@pytest.mark.parametrize("module", sorted(m for m in MODULES if m.startswith((ALGORITHM, SAFEGUARDS))))
def test_nothing_imports_a_layer_above(module: str) -> None:
    layer = ALGORITHM if module.startswith(ALGORITHM) else SAFEGUARDS
    upward = sorted(target for target in GRAPH[module] if target.startswith(LAYERS[layer]))
    assert upward == [], f"{module} imports a layer above it: {upward}"


#: sb3-contrib 2.9.2's algorithms in lines (``wc -l``), each with the ``sb3_contrib.common`` subpackage that is its own:
#: MaskablePPO (``ppo_mask/`` + ``common/maskable/``, 9 files) 1795, RecurrentPPO (``ppo_recurrent/`` +
#: ``common/recurrent/``, 7 files) 1504, TQC 901, CrossQ 873, QR-DQN 615, ARS 485, TRPO 432.
CONTRIB_LARGEST_ALGORITHM_LINES = 1795
#: Its longest module: ``common/recurrent/policies.py`` (RecurrentPPO's policy), 611 lines.
CONTRIB_LONGEST_MODULE_LINES = 611


def test_the_algorithm_is_contrib_sized() -> None:
    # sb3-contrib's shape (issue 46): the algorithm, its policy, its buffer and the return math, in a few files, no
    # more code than sb3-contrib's largest algorithm and no module longer than its longest. Measured at 6 files,
    # 1396 lines, the longest reinforce.py (538).
    lines = {
        str(path.relative_to(PACKAGE_DIR)): len(path.read_text().splitlines())
        for path in sorted((PACKAGE_DIR / "reinforce").rglob("*.py"))
    }
    assert lines["reinforce/reinforce.py"] > 0  # the control: the files are read
    assert len(lines) <= 6, sorted(lines)
    assert max(lines.values()) <= CONTRIB_LONGEST_MODULE_LINES, lines
    assert sum(lines.values()) <= CONTRIB_LARGEST_ALGORITHM_LINES, lines


def test_the_top_level_exports_the_algorithm() -> None:
    assert GRAPH["sb3_reinforce"] <= {ALGORITHM, "sb3_reinforce.version"}
    assert {"REINFORCE", "ReinforcePolicy", "MlpPolicy", "EpisodeRolloutBuffer"} <= set(sb3_reinforce.__all__)
    assert not {"save_weights", "load_weights", "NonFiniteError"} & set(sb3_reinforce.__all__)  # the safeguards' own
