"""The layout's rules, checked on the source: imports run one way, and only the task layer
branches on config strings (everything else gets objects, enums and plain values)."""

import ast
import enum
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from grace import CONF_DIR
from grace.cli.schemas import heavy_schemas

PACKAGE = Path(__file__).resolve().parents[1] / "grace"

LAYERS = (
    "domain",
    "simulation",
    "data",
    "graphs",
    "model",
    "planning",
    "evaluation",
    "visualisation",
    "cli",
    "tasks",
)
"""Bottom to top (docs/contributing.md, Layout): a module may import its own layer and the ones
below. `cli` is the command line's machinery (schemas, checks, the runner, folds, the fit built
from the config); `tasks` holds the entry points only."""

LEAVES = ("grace", "grace.errors", "grace.roles")
"""Modules every layer may import; they import nothing of grace themselves (grace.roles: what a
config key changes, declared by schemas of every layer)."""


def modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def layer(module: str) -> int:
    """Index in LAYERS; the entry point (grace.__main__) sits with the tasks on top."""
    if module == "grace.__main__":
        return len(LAYERS) - 1
    return LAYERS.index(module.split(".")[1])


def grace_imports(module: str, path: Path) -> list[tuple[int, str]]:
    """(line, imported module) of every import of grace code in `path`, nested ones included."""
    found = []
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            found.append((node.lineno, base))
    return [(line, name) for line, name in found if name == "grace" or name.startswith("grace.")]


def test_the_rule_sees_both_kinds_of_import(tmp_path):
    source = tmp_path / "mod.py"
    source.write_text("import grace.cli.runner\nfrom ..evaluation import metrics\nimport numpy\n")
    imports = grace_imports("grace.model.mod", source)
    assert imports == [(1, "grace.cli.runner"), (2, "grace.evaluation")]
    assert [layer(name) > layer("grace.model.mod") for _, name in imports] == [True, True]


def test_no_layer_imports_one_above_it():
    wrong = []
    for module, path in modules().items():
        for line, name in grace_imports(module, path):
            if module in LEAVES:
                wrong.append(f"{path}:{line}: the leaf {module} imports {name}")
            elif name not in LEAVES and layer(name) > layer(module):
                wrong.append(f"{path}:{line}: {module} imports {name} from a higher layer")
    assert not wrong, "\n".join(wrong)


def config_strings() -> set[str]:
    """Every string a config can hold: the shipped configs' values and option names (a group's
    file names) and the values of the enums that type config keys; no targets, no paths."""
    values: set[str] = set()

    def walk(node: object, key: str = "") -> None:
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, str(k))
        elif isinstance(node, list):
            for item in node:
                walk(item, key)
        elif isinstance(node, str) and "${" not in node and not key.startswith("_"):
            values.add(node)

    for path in CONF_DIR.rglob("*.yaml"):
        walk(OmegaConf.to_container(OmegaConf.load(path), resolve=False))
        values.add(path.stem)
    for kind in enum.StrEnum.__subclasses__():
        if kind.__module__.startswith("grace."):
            values |= {member.value for member in kind}
    return values


heavy_schemas()  # imports every module whose enums type a config key
CHOICES = config_strings()


def branch_tests(tree: ast.AST) -> list[ast.expr]:
    """The conditions of every if, conditional expression, while, assert and comprehension."""
    tests: list[ast.expr] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.If, ast.IfExp, ast.While, ast.Assert)):
            tests.append(node.test)
        elif isinstance(node, ast.comprehension):
            tests += node.ifs
        elif isinstance(node, ast.match_case) and isinstance(node.pattern, ast.MatchValue):
            tests.append(node.pattern.value)
    return tests


def config_string_branches(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, string) of every branch on a string that a config can hold. A string that only
    looks a key up (`row["val_step_auc"]`, `row.get("val_step_auc")`) is no branch on it: metric
    names are config strings too (`monitor.metric`, `tune.metric`), nor is one asked for
    membership (`"brute_force" in runs`)."""
    found = []
    for test in branch_tests(tree):
        keys = set()
        for node in ast.walk(test):
            if isinstance(node, ast.Subscript):
                keys.add(id(node.slice))
            elif isinstance(node, ast.Compare) and isinstance(node.ops[0], (ast.In, ast.NotIn)):
                keys.add(id(node.left))
            elif (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == "get"
                and node.args
            ):
                keys.add(id(node.args[0]))
        for node in ast.walk(test):
            if isinstance(node, ast.Constant) and node.value in CHOICES and id(node) not in keys:
                found.append((node.lineno, node.value))
    return sorted(found)


def test_the_rule_sees_a_branch_on_a_config_string():
    assert {"fast", "pyg", "orders", "reachable", "sinusoidal", "csv", "generated"} <= CHOICES
    code = (
        "if impl == 'fast':\n    pass\n"
        "x = [a for a in b if a in ('pyg',)]\n"
        "y = 1 if 'orders' else 2\n"
    )
    assert config_string_branches(ast.parse(code)) == [(1, "fast"), (3, "pyg"), (4, "orders")]
    assert config_string_branches(ast.parse("if line == 'begin Pieces':\n    pass\n")) == []
    lookups = "x = [r for r in rows if r.get('orders')]\ny = 1 if r['fast'] == 'pyg' else 2\n"
    assert config_string_branches(ast.parse(lookups)) == [(2, "pyg")]
    member = "if 'orders' in runs:\n    pass\nif impl in ('pyg',):\n    pass\n"
    assert config_string_branches(ast.parse(member)) == [(3, "pyg")]


@pytest.mark.parametrize(
    "module", [m for m in modules() if m not in LEAVES and layer(m) < len(LAYERS) - 1]
)
def test_below_the_task_layer_nothing_branches_on_a_config_string(module):
    path = modules()[module]
    found = config_string_branches(ast.parse(path.read_text(), str(path)))
    assert not found, "\n".join(f"{path}:{line}: branches on {value!r}" for line, value in found)


TESTS = PACKAGE.parent / "tests"


def test_every_task_module_is_a_short_entry_point():
    """grace/tasks/ holds entry points only: each task config's `run` target, within 200 lines,
    and the modules of a task package (code of the command line that one task alone uses,
    docs/contributing.md, Layout); library logic lives in the layers below."""
    targets = {OmegaConf.load(p).run._target_ for p in (CONF_DIR / "task").glob("*.yaml")}
    entry_points = {target.rpartition(".")[0] for target in targets}
    found = {m for m in modules() if m.startswith("grace.tasks.")}
    beside = {m for m in found if m.rpartition(".")[0] in entry_points}
    assert found - beside == entry_points, "grace/tasks/ holds a module that no task config runs"
    long = [f"{modules()[m]}: {n} lines" for m in found if (n := lines(modules()[m])) > 200]
    assert not long, "\n".join(long)


def lines(path: Path) -> int:
    return len(path.read_text().splitlines())


def test_no_other_layer_nor_its_tests_imports_a_task_module():
    wrong = []
    sources = {m: p for m, p in modules().items() if not m.startswith("grace.tasks")}
    tests = {f"tests.{p.stem}": p for p in TESTS.rglob("*.py") if "tasks" not in p.parts}
    for module, path in {**sources, **tests}.items():
        for line, name in grace_imports(module, path):
            if name.startswith("grace.tasks") and module != "grace.__main__":
                wrong.append(f"{path}:{line}: imports {name}")
    assert not wrong, "\n".join(wrong)


CONFIG_READERS = {
    "grace.simulation.cell_config": "the simulator's own typed config (cell, generator), its "
    "schemas registered with Hydra and checked by OmegaConf",
    "grace.simulation.world_timing": "`python -m grace.simulation.world_timing`: composes the "
    "simulator config it times (the world's benchmark, run without a task)",
    "grace.simulation.reference": "`python -m grace.simulation.reference`: composes the "
    "simulator config it checks against the uncached MuJoCo reference",
    "grace.data.store": "rebuilds the simulator in each worker process from its config node "
    "(a MuJoCo model does not cross processes)",
    "grace.model.kept": "reads the config a training run kept beside its checkpoint",
    "grace.model.checkpoints": "rebuilds a kept model from that config",
    "grace.evaluation.book": "reads run folders' Hydra records (overrides, config sources) "
    "to print the commands that made them",
}
"""Modules below cli/ that read a config (docs/contributing.md, Layout), each with its reason.
Below cli/ code otherwise gets objects, enums and plain values."""

CONFIG_LIBRARIES = ("omegaconf", "hydra")


def config_reads(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import of a config library in `path`, nested ones included;
    `from omegaconf import MISSING` (a schema's marker of a required field) reads nothing."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            if node.module == "omegaconf" and [a.name for a in node.names] == ["MISSING"]:
                continue
            names = [node.module or ""]
        else:
            continue
        found += [(node.lineno, n) for n in names if n.split(".")[0] in CONFIG_LIBRARIES]
    return found


def test_the_config_rule_sees_every_kind_of_import(tmp_path):
    source = tmp_path / "mod.py"
    source.write_text(
        "from omegaconf import MISSING\nimport hydra.utils\n"
        "def f():\n    from omegaconf import OmegaConf\n"
    )
    assert config_reads(source) == [(2, "hydra.utils"), (4, "omegaconf")]


def test_only_the_command_line_reads_the_config():
    """Only cli/, tasks/ and the listed CONFIG_READERS import a config library; a listed module
    that no longer does is struck off the list."""
    readers = {
        module
        for module, path in modules().items()
        if module not in LEAVES and layer(module) < LAYERS.index("cli") and config_reads(path)
    }
    unlisted = sorted(readers - CONFIG_READERS.keys())
    wrong = [f"{modules()[m]}:{line}: imports {name}" for m in unlisted for line, name in
             config_reads(modules()[m])]  # fmt: skip
    assert not wrong, "a layer below cli/ reads the config:\n" + "\n".join(wrong)
    assert not CONFIG_READERS.keys() - readers, "listed readers that read no config"


DYNAMIC_IMPORTERS = {
    "grace.cli.schemas": "a task's schema class, found through its config's `run._target_` "
    "(as Hydra finds every target), so cli/ names no task module",
}
"""Modules that import by name at run time (importlib), each with its reason: the import rule
above cannot see such imports, so each is listed here."""


def dynamic_imports(path: Path) -> list[int]:
    """Lines of every call of importlib.import_module, __import__ or Hydra's locators."""
    names = {"import_module", "__import__", "_locate", "get_class", "get_method", "get_object"}
    lines_found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Call):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in names:
                lines_found.append(node.lineno)
    return lines_found


def test_every_dynamic_import_is_listed():
    found = {m for m, path in modules().items() if dynamic_imports(path)}
    assert found == DYNAMIC_IMPORTERS.keys(), (
        f"dynamic imports outside the list: {sorted(found - DYNAMIC_IMPORTERS.keys())}; "
        f"listed but gone: {sorted(DYNAMIC_IMPORTERS.keys() - found)}"
    )
