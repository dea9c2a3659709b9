"""The package's layers: the core imports without ROS, no module imports one that imports it
back, no lower layer imports a higher one, and no module is over ``MAX_MODULE_LINES``
(docs/development.md, House style; README, Layout)."""

from __future__ import annotations

import ast
from pathlib import Path
import subprocess
import sys

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "brake_hil"

LAYERS: tuple[tuple[str, ...], ...] = (
    (
        "brake_hil",
        "brake_hil.types",
        "brake_hil.errors",
        "brake_hil.topics",
        "brake_hil.files",
        "brake_hil.words",
    ),
    ("brake_hil.physics",),
    ("brake_hil.analysis",),
    ("brake_hil.diagnosis",),
    ("brake_hil.live",),
    ("brake_hil.runtime",),
    ("brake_hil.io",),
    ("brake_hil.virtual_rig",),
    ("brake_hil.results",),
    ("brake_hil.report",),
    ("brake_hil.app",),
    ("brake_hil.cli", "brake_hil.nodes"),
)
"""Lowest first: a module may import its own layer's and lower layers' modules only."""

ROS_FREE = (
    "physics",
    "analysis",
    "diagnosis",
    "live",
    "runtime",
    "io",
    "virtual_rig",
    "results",
    "app",
)
"""Subpackages that must import with rclpy unimportable (with ``cli`` and ``report``)."""

MAX_MODULE_LINES = 600
"""A module over this many lines holds more than one concern: split it."""
MAX_FUNCTION_LINES = 80
"""A function over this many lines does more than one step: name its steps."""


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> set[str]:
    """Every brake_hil module ``path`` imports, at any depth of its code."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return {module for module in found if module.split(".")[0] == "brake_hil"}


def graph() -> dict[str, set[str]]:
    modules = {module_name(path): path for path in PACKAGE.rglob("*.py")}
    return {
        name: {target for target in imports_of(path) if target in modules and target != name}
        for name, path in modules.items()
    }


def layer(module: str) -> int:
    best, depth = -1, -1
    for index, members in enumerate(LAYERS):
        for member in members:
            nested = member != "brake_hil" and module.startswith(member + ".")
            if (module == member or nested) and len(member) > depth:
                best, depth = index, len(member)
    return best


def test_every_module_belongs_to_a_layer() -> None:
    assert [module for module in graph() if layer(module) < 0] == []


def test_no_module_imports_a_higher_layer() -> None:
    upward = [
        f"{module} (layer {layer(module)}) imports {target} (layer {layer(target)})"
        for module, targets in graph().items()
        for target in targets
        if layer(target) > layer(module)
    ]
    assert upward == []


def test_no_import_cycles() -> None:
    edges = graph()
    # a package's __init__ importing its own submodules is a re-export, not a cycle
    edges = {
        module: {t for t in targets if not t.startswith(module + ".")}
        for module, targets in edges.items()
    }
    cycles: list[list[str]] = []
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(module: str) -> None:
        state[module] = 1
        stack.append(module)
        for target in sorted(edges.get(module, ())):
            if state.get(target) == 1:
                cycles.append([*stack[stack.index(target) :], target])
            elif target not in state:
                visit(target)
        stack.pop()
        state[module] = 2

    for module in sorted(edges):
        if module not in state:
            visit(module)
    assert cycles == []


@pytest.mark.parametrize("subpackage", ROS_FREE)
def test_core_imports_without_rclpy(subpackage: str) -> None:
    modules = sorted(
        name
        for name in graph()
        if name.startswith(f"brake_hil.{subpackage}")
        or name == "brake_hil.cli"
        or name.startswith("brake_hil.cli.")
        or name.startswith("brake_hil.report")
    )
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('rclpy', 'rosidl_runtime_py', 'rcl_interfaces'):\n"
        "            raise ImportError('rclpy blocked for this test: ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        + "".join(f"import {module}\n" for module in modules)
        + "assert not any(m.startswith('rclpy') for m in sys.modules)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_every_folder_of_the_package_is_a_package_that_says_what_it_exports() -> None:
    # a folder without __init__.py is a namespace package: setup.py's find_packages (and so
    # a wheel or a colcon install) would leave it out
    folders = [p for p in PACKAGE.rglob("*") if p.is_dir() and p.name != "__pycache__"]
    assert [str(f) for f in folders if not (f / "__init__.py").is_file()] == []
    assert [str(f) for f in folders if "__all__" not in (f / "__init__.py").read_text()] == []


def test_no_module_is_over_the_line_limit() -> None:
    lengths = {
        path.relative_to(PACKAGE.parent).as_posix(): len(path.read_text().splitlines())
        for path in sorted(PACKAGE.rglob("*.py"))
    }
    too_long = [f"{name}: {n} lines" for name, n in lengths.items() if n > MAX_MODULE_LINES]
    assert too_long == [], f"over {MAX_MODULE_LINES} lines: split by concern"


def test_no_function_is_over_the_line_limit() -> None:
    too_long = [
        f"{path.relative_to(PACKAGE.parent).as_posix()}:{node.lineno} {node.name}: "
        f"{node.end_lineno - node.lineno + 1} lines"
        for path in sorted(PACKAGE.rglob("*.py"))
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        and node.end_lineno is not None
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert too_long == [], f"over {MAX_FUNCTION_LINES} lines: name the steps"
