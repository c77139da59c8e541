"""The package's layout holds: at most three modules at its top, each package importing only from
the layers below it (docs/architecture.md), and nothing in the library importing the command line.
Imports are read from the source (``ast``), not run; imports under ``if TYPE_CHECKING:`` are types
only and not counted."""

import ast
from pathlib import Path

import pytest
from conftest import PROJECT_ROOT

PACKAGE = PROJECT_ROOT / "mazeslam"

#: What each package may import at run time besides itself (docs/architecture.md, "Layers").
ALLOWED = {
    "core": set(),
    "data": {"core"},
    "sim": {"core", "data"},
    "robot": {"core", "data", "sim"},
    "features": {"core", "data"},
    "registration": {"core", "data"},
    "fastslam": {"core", "data", "registration"},
    "gridslam": {"core", "data", "registration"},
    "posegraph": {"core", "data", "registration", "gridslam"},
    "pipeline": {"core", "data", "features", "registration", "fastslam", "gridslam", "posegraph", "evaluation"},
    "evaluation": {"core", "data", "features", "sim"},
    "smoothing": {
        "core",
        "data",
        "features",
        "registration",
        "fastslam",
        "gridslam",
        "posegraph",
        "evaluation",
        "pipeline",
    },
    "calibration": {"core", "data", "features", "registration", "fastslam", "evaluation", "pipeline"},
    "envs": {"core", "data", "sim", "robot", "features", "fastslam"},
    "viz": {"core", "data", "sim", "features", "fastslam", "gridslam", "pipeline", "evaluation", "smoothing"},
    "sweeps": {"core", "data", "sim", "features", "fastslam", "gridslam", "pipeline", "evaluation", "smoothing", "viz"},
}


def runtime_imports(path: Path) -> set[str]:
    """The mazeslam packages a module imports when it runs (not under ``if TYPE_CHECKING:``)."""
    tree = ast.parse(path.read_text())
    typing_only = {
        id(node)
        for block in ast.walk(tree)
        if isinstance(block, ast.If) and "TYPE_CHECKING" in ast.unparse(block.test)
        for statement in block.body
        for node in ast.walk(statement)
    }
    names = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("mazeslam."):
            names.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            names.update(a.name.split(".")[1] for a in node.names if a.name.startswith("mazeslam."))
    return names


def test_at_most_three_modules_at_the_top():
    assert len(list(PACKAGE.glob("*.py"))) <= 3


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_a_package_imports_only_the_layers_below_it(package):
    for path in sorted((PACKAGE / package).glob("*.py")):
        imported = runtime_imports(path) - {package}
        assert imported <= ALLOWED[package], (
            f"{path.relative_to(PACKAGE)} imports {sorted(imported - ALLOWED[package])}"
        )


def test_nothing_in_the_library_imports_the_command_line():
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.parent.name != "cli":
            tree = ast.parse(path.read_text())
            modules = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module]
            modules += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
            assert not any(m == "mazeslam.cli" or m.startswith("mazeslam.cli.") for m in modules), path


def test_every_package_is_in_the_layers():
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}
    assert packages - {"cli"} == set(ALLOWED)
