"""The supervisor is reached through its command surface (service/surface.py) only.

Outside `hand_service/service/` and the wiring (`hand_service/app/daemon.py`), no module
imports the supervisor's module; none reads or writes a private attribute (`._x`, or
getattr/setattr of a `"_x"`) of the supervisor or of its hand; and none uses an attribute of
the supervisor that its surface (TickLoop) does not declare. What names a supervisor in a
module: the conventional names (`sup`, `supervisor`, and `hand` for its hand), a name or
parameter annotated with the supervisor's class or its surface, and a name assigned from one
of those.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SERVICE = "hand_service.service"
WIRING = "hand_service.app.daemon"
SUPERVISOR_MODULE = "hand_service.service.supervisor"
RECEIVERS = frozenset({"sup", "supervisor", "hand"})
HAND = "hand"
TYPES = frozenset({"Supervisor", "HandControl", "TickLoop"})


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _inside(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def _last_name(node: ast.expr) -> str | None:
    """The identifier an expression ends in: `sup` of `self.sup`, `hand` of `sup.hand`."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return None


def _annotated(annotation: ast.expr | None) -> bool:
    return annotation is not None and any(
        _last_name(n) in TYPES or (isinstance(n, ast.Constant) and n.value in TYPES)
        for n in ast.walk(annotation) if isinstance(n, (ast.Name, ast.Attribute, ast.Constant)))


def receivers(tree: ast.AST) -> set[str]:
    """The names that hold a supervisor (or its hand) in this module."""
    names = set(RECEIVERS)
    for node in ast.walk(tree):
        if isinstance(node, ast.arg) and _annotated(node.annotation):
            names.add(node.arg)
        elif isinstance(node, ast.AnnAssign) and _annotated(node.annotation):
            names.update(n for t in [node.target] if (n := _last_name(t)))
    changed = True
    while changed:  # aliases: x = sup, x = self.sup, x = Supervisor(...)
        changed = False
        for node in ast.walk(tree):
            if not isinstance(node, ast.Assign):
                continue
            value = node.value.func if isinstance(node.value, ast.Call) else node.value
            source = _last_name(value)
            if source in names or source in TYPES:
                for target in node.targets:
                    name = _last_name(target)
                    if name is not None and name not in names:
                        names.add(name)
                        changed = True
    return names


def _private(attr: str) -> bool:
    return attr.startswith("_") and not (attr.startswith("__") and attr.endswith("__"))


def _private_getattr(node: ast.Call, names: set[str]) -> bool:
    """getattr(sup, "_x"), setattr, delattr or hasattr of one."""
    return (isinstance(node.func, ast.Name) and node.func.id in ("getattr", "setattr", "delattr", "hasattr")
            and len(node.args) >= 2 and _last_name(node.args[0]) in names
            and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)
            and _private(node.args[1].value))


def private_uses(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, text) of each read or write of a private attribute of a supervisor or hand."""
    names = receivers(tree)
    return sorted((node.lineno, ast.unparse(node)) for node in ast.walk(tree)
                  if (isinstance(node, ast.Attribute) and _private(node.attr)
                      and _last_name(node.value) in names)
                  or (isinstance(node, ast.Call) and _private_getattr(node, names)))


def surface_names() -> set[str]:
    """What the surface declares: its methods, properties and attributes."""
    from hand_service.service.surface import TickLoop

    names = {name for name in dir(TickLoop) if not name.startswith("_")}
    for cls in TickLoop.__mro__:
        names.update(vars(cls).get("__annotations__", {}))
    return names


def off_surface(tree: ast.AST, surface: set[str]) -> list[tuple[int, str]]:
    """(line, text) of each use of a supervisor's attribute that its surface does not declare."""
    names = receivers(tree) - {HAND}
    return sorted((node.lineno, ast.unparse(node)) for node in ast.walk(tree)
                  if isinstance(node, ast.Attribute) and _last_name(node.value) in names
                  and not node.attr.startswith("_") and node.attr not in surface)


def supervisor_imports(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, text) of each import of the supervisor's module or class."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            hit = any(_inside(alias.name, SUPERVISOR_MODULE) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            hit = (_inside(module, SUPERVISOR_MODULE)
                   or (module == SERVICE and any(a.name == "supervisor" for a in node.names))
                   or any(a.name == "Supervisor" for a in node.names))
        else:
            continue
        if hit:
            found.append((node.lineno, ast.unparse(node)))
    return found


def outside_modules() -> dict[str, ast.AST]:
    """Every module of hand_service outside service/ and the wiring, parsed."""
    modules = {}
    for path in sorted((ROOT / "hand_service").rglob("*.py")):
        name = _module_name(path)
        if not (_inside(name, SERVICE) or _inside(name, WIRING)):
            modules[name] = ast.parse(path.read_text(), str(path))
    return modules


def test_the_checks_see_what_they_look_for() -> None:
    source = ("from hand_service.service.supervisor import Supervisor\n"
              "def f(s: 'HandControl', daemon):\n"
              "    s._ts.c = 1\n"
              "    x = daemon.sup\n"
              "    x.hand._hand\n"
              "    y = Supervisor(1, 2)\n"
              "    getattr(y, '_tick_at')\n"
              "    self.sup.hand.inputs.mode\n"
              "    other._private\n"
              "    sup.__class__\n")
    tree = ast.parse(source)
    assert [line for line, _ in supervisor_imports(tree)] == [1]
    assert [line for line, _ in private_uses(tree)] == [3, 5, 7]
    assert supervisor_imports(ast.parse("import hand_service.service.supervisor as s\n"))
    assert supervisor_imports(ast.parse("from hand_service.service import supervisor\n"))
    assert not supervisor_imports(ast.parse("from hand_service.service.surface import HandControl\n"))
    assert [line for line, _ in off_surface(tree, {"state"})] == [5, 8]  # x.hand, sup.hand


def test_the_surface_is_what_the_abstract_classes_declare() -> None:
    surface = surface_names()
    assert {"arm", "start", "hold", "set_mode", "set_target", "set_trajectory", "start_recording",
            "stop_recording", "status", "run_one", "rate_hz", "names"} <= surface
    assert not {"hand", "targets", "recorder", "faults", "stats", "transport", "fire_event"} & surface


def test_the_scan_covers_the_packages_that_use_the_supervisor() -> None:
    modules = outside_modules()
    for name in ("hand_service.api.requests", "hand_service.bench.tick", "hand_service.view.server"):
        assert name in modules
    assert not any(_inside(name, SERVICE) for name in modules)


def test_no_module_outside_the_service_imports_the_supervisor() -> None:
    found = {name: hits for name, tree in outside_modules().items() if (hits := supervisor_imports(tree))}
    assert found == {}, "only service/ and the wiring (app/) make a supervisor: " + repr(found)


def test_no_module_outside_the_service_reaches_a_private_attribute() -> None:
    found = {name: hits for name, tree in outside_modules().items() if (hits := private_uses(tree))}
    assert found == {}, "the supervisor's command surface is the way in: " + repr(found)


def test_no_module_outside_the_service_goes_around_the_surface() -> None:
    surface = surface_names()
    found = {name: hits for name, tree in outside_modules().items() if (hits := off_surface(tree, surface))}
    assert found == {}, "the supervisor's command surface is the way in: " + repr(found)
