"""The packages depend one way, downwards: CLI → cases → builder / run loop → coupling core
and partners → the file writer. Read from the source: every `import` and `from ... import`
of every module of the project, top level or inside a function."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# layers, top first; a module belongs to the first layer one of whose prefixes it starts with
LAYERS = [
    ("cli", ("orchestrator.cli", "orchestrator.commands", "orchestrator.batch",
             "orchestrator.attach", "orchestrator.render", "orchestrator.paraview_render",
             "orchestrator.slurm", "orchestrator.__main__", "orchestrator.env", "bench")),
    ("cases", ("cases",)),
    ("run", ("orchestrator.builder", "orchestrator.stepper", "orchestrator.contracts",
             "orchestrator.run", "orchestrator.casefile", "orchestrator.ensemble",
             "orchestrator.ensemble_plots", "orchestrator.verdicts")),
    ("core and partners", ("orchestrator.coupling", "yade_side", "fenicsx_side")),
    ("writer", ("common",)),
]
# within the lowest layers, these see nothing of each other
ISOLATED = ("orchestrator.coupling", "yade_side", "fenicsx_side")
PACKAGES = ("orchestrator", "cases", "yade_side", "fenicsx_side", "common", "bench")


def layer(module):
    if module == "orchestrator":      # the package itself: a docstring
        return len(LAYERS) - 1
    for depth, (_, prefixes) in enumerate(LAYERS):
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return depth
    return None


def module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def project_imports(source, package):
    """(line, imported module) of every import of a project module in `source`, the text of
    a module of `package`."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            names = [base] + [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        for name in names:
            if name.split(".")[0] in PACKAGES:
                yield node.lineno, name


def sources():
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def test_every_module_has_a_layer():
    assert [module_name(p) for p in sources() if layer(module_name(p)) is None] == []


def test_no_module_imports_a_module_above_it_or_a_sibling_partner():
    wrong = []
    for path in sources():
        here = module_name(path)
        mine = layer(here)
        if mine is None:              # reported by test_every_module_has_a_layer
            continue
        own = next((p for p in ISOLATED if here == p or here.startswith(p + ".")), None)
        package = here if path.name == "__init__.py" else here.rpartition(".")[0]
        for line, name in project_imports(path.read_text(), package):
            theirs = layer(name)
            if theirs is None:        # a name imported from a module (from a import b)
                continue
            other = next((p for p in ISOLATED if name == p or name.startswith(p + ".")), None)
            if theirs < mine or (own and other and other != own):
                wrong.append(f"{path.relative_to(ROOT)}:{line} imports {name}")
    assert wrong == []


@pytest.mark.parametrize("source, expected", [
    ("from cases.slab import SlabSpec\n", ["cases.slab", "cases.slab.SlabSpec"]),
    ("import yade_side.bulk\n", ["yade_side.bulk"]),
    ("def f():\n    from fenicsx_side.model import ElasticModel\n",
     ["fenicsx_side.model", "fenicsx_side.model.ElasticModel"]),
])
def test_the_import_reader_sees_every_kind_of_import(source, expected):
    assert [name for _, name in project_imports(source, "orchestrator")] == expected


def test_a_relative_import_is_read_as_the_module_it_names():
    assert [n for _, n in project_imports("from .bulk import BodySet\n", "yade_side")] == [
        "yade_side.bulk", "yade_side.bulk.BodySet"]
