"""The import contract (issue 12 item 3): layers from errors up to cli, no circles, typer/rich only in cli/."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = ROOT / "pyproject.toml"

grimp = pytest.importorskip("grimp")
importlinter_cli = pytest.importorskip("importlinter.cli")

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def _contracts() -> list[dict]:
    return tomllib.loads(PYPROJECT.read_text())["tool"]["importlinter"]["contracts"]


@pytest.fixture(scope="module")
def graph():
    return grimp.build_graph("forcecontrol", include_external_packages=True, exclude_type_checking_imports=True)


def test_import_contract_holds():
    """`lint-imports` with the contracts in pyproject.toml exits 0 (every contract kept)."""
    assert importlinter_cli.lint_imports(config_filename=str(PYPROJECT), no_cache=True) == 0


def test_every_top_level_module_has_a_layer(graph):
    """Each module and package directly under forcecontrol is placed in the layers contract (a new one must be placed)."""
    (layers,) = [c for c in _contracts() if c["type"] == "layers"]
    placed = {name.strip() for layer in layers["layers"] for name in layer.replace(":", "|").split("|")}
    top = {m.split(".")[1] for m in graph.modules if m.startswith("forcecontrol.")} - {"__main__"}
    assert top - placed == set(), f"modules missing from the layers contract in pyproject.toml: {sorted(top - placed)}"


def test_only_cli_imports_typer_and_rich(graph):
    """grimp's graph (a second check next to the protected contract): every importer of typer or rich is in cli/."""
    for lib in ("typer", "rich"):
        importers = {m for m in graph.find_modules_that_directly_import(lib) if m.startswith("forcecontrol")}
        assert importers, f"expected the CLI to import {lib}"
        outside = sorted(m for m in importers if not m.startswith("forcecontrol.cli"))
        assert outside == [], f"{lib} imported outside cli/: {outside}"


def test_the_contract_catches_an_upward_import(graph):
    """The layers contract really checks direction: adding errors -> cli to the graph breaks it."""
    (layers,) = [c for c in _contracts() if c["type"] == "layers"]
    order = [[n.strip() for n in layer.replace(":", "|").split("|")] for layer in layers["layers"]]
    assert "errors" in order[-1] and order[0] == ["cli"]
    assert not graph.find_illegal_dependencies_for_layers(layers=("forcecontrol.cli", "forcecontrol.errors"))
    graph.add_import(importer="forcecontrol.errors", imported="forcecontrol.cli.app")
    try:
        assert graph.find_illegal_dependencies_for_layers(layers=("forcecontrol.cli", "forcecontrol.errors"))
    finally:
        graph.remove_import(importer="forcecontrol.errors", imported="forcecontrol.cli.app")


def test_the_root_holds_only_rooms():
    """Issue 29: the package root holds __init__, __main__, errors and the sub-packages (the rooms), nothing else."""
    root = ROOT / "src" / "forcecontrol"
    loose = sorted(p.name for p in root.glob("*.py") if p.name not in {"__init__.py", "__main__.py", "errors.py"})
    assert loose == [], f"modules loose in the package root (put them in a room): {loose}"


def test_the_contract_is_short_and_has_no_exceptions():
    """Issue 29: about a dozen layers a person can hold in mind, and no ignored imports in any contract."""
    contracts = _contracts()
    (layers,) = [c for c in contracts if c["type"] == "layers"]
    assert len(layers["layers"]) <= 12
    assert all("ignore_imports" not in c for c in contracts)


def test_the_architecture_page_matches_the_contract():
    """docs/architecture.md lists exactly the contract's rooms, and its layer table is the contract's layers in order."""
    import re

    page = (ROOT / "docs" / "architecture.md").read_text()
    (layers,) = [c for c in _contracts() if c["type"] == "layers"]
    want = [[n.strip() for n in re.split(r"[:|]", layer)] for layer in layers["layers"]]
    rooms_section = page.split("## The rooms", 1)[1].split("## The layers", 1)[0]
    rooms = re.findall(r"^\| `([a-z_]+)` \|", rooms_section, flags=re.M)
    assert sorted(rooms) == sorted(n for layer in want for n in layer)
    layers_section = page.split("## The layers", 1)[1].split("##", 1)[0]
    rows = re.findall(r"^\| (\d+) \| (.+?) \|", layers_section, flags=re.M)
    got = [re.findall(r"`([a-z_]+)`", cells) for _, cells in rows]
    assert got == want
