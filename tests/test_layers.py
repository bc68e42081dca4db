"""The top folders are the layers, and they depend one way, downwards: cli → bench → cases →
orchestrator → partners (yade_side, fenicsx_side) → common. Read from the source: every
`import` and `from ... import` of every module of the project, top level or inside a
function. Inside the orchestrator the coupling core sees neither the run loop nor a partner,
and the two partners never see each other."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# top first; a package's layer is its index (partners share one)
LAYERS = [("cli",), ("bench",), ("cases",), ("orchestrator",), ("yade_side", "fenicsx_side"),
          ("common",)]
PACKAGES = tuple(p for layer in LAYERS for p in layer)
# module prefix → the project modules it may import besides its own prefix and `common`
CONFINED = {"orchestrator.coupling": (), "yade_side": (), "fenicsx_side": ()}


def layer(module):
    top = module.split(".")[0]
    return next(depth for depth, names in enumerate(LAYERS) if top in names)


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


MODULES = {module_name(p): p for p in sources()}


def resolved_imports(path):
    """(line, module) for each import in the file at `path`, the name resolved to a module of
    the project: `from a import b` is module a.b when there is one, else a."""
    here = module_name(path)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    seen = set()
    for line, name in project_imports(path.read_text(), package):
        while name not in MODULES:
            name = name.rpartition(".")[0]
        if (line, name) not in seen:
            seen.add((line, name))
            yield line, name


def _within(module, prefix):
    return module == prefix or module.startswith(prefix + ".")


def test_every_top_folder_of_python_code_is_a_layer():
    tops = {p.parent.name for p in ROOT.glob("*/__init__.py")}
    assert tops == set(PACKAGES)


def test_no_package_imports_a_package_above_it():
    wrong = [f"{path.relative_to(ROOT)}:{line} imports {name}"
             for path in sources() for line, name in resolved_imports(path)
             if layer(name) < layer(module_name(path))]
    assert wrong == []


def test_the_coupling_core_and_the_partners_see_nothing_of_the_project_but_the_writer():
    wrong = []
    for path in sources():
        here = module_name(path)
        own = next((p for p in CONFINED if _within(here, p)), None)
        if own is None:
            continue
        for line, name in resolved_imports(path):
            if not (_within(name, own) or _within(name, "common")):
                wrong.append(f"{path.relative_to(ROOT)}:{line} imports {name}")
    assert wrong == []


def circles(edges):
    """The strongly connected groups of more than one node of the graph `edges`
    (node → set of nodes), each sorted, found by Tarjan's algorithm."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while not group or group[-1] != v:
                group.append(stack.pop())
                on.discard(group[-1])
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return sorted(found)


def package_graphs():
    """For each package, its members (modules and subpackages, by name) → the members they
    import, through any module inside them. A package's own __init__ is not a member: importing
    a.b runs a/__init__ first in any order."""
    graphs = {}
    for path in sources():
        here = module_name(path)
        for _, name in resolved_imports(path):
            for package in {m for m in MODULES if MODULES[m].name == "__init__.py"}:
                if not (here.startswith(package + ".") and name.startswith(package + ".")):
                    continue
                a = here[len(package) + 1:].split(".")[0]
                b = name[len(package) + 1:].split(".")[0]
                if a != b:
                    graphs.setdefault(package, {}).setdefault(a, set()).add(b)
    return graphs


def test_the_modules_of_a_package_import_each_other_in_no_circle():
    found = {package: c for package, g in sorted(package_graphs().items()) if (c := circles(g))}
    assert found == {}


def test_circles_finds_a_cycle_and_only_it():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


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
