"""The import graph of rtcore and hand_service, built from the source, has no cycle.

Every import counts, at module level or inside a function: an import deferred into a
function still ties the two modules together, it only hides the loop until run time.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rtcore", "hand_service")
BINDING = "rtcore._rtcore"  # the cffi extension: a leaf of the graph


def module_files() -> dict[str, Path]:
    """Dotted module name -> source file, for every module of the project's packages."""
    modules: dict[str, Path] = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            modules[".".join(parts)] = path
    modules[BINDING] = ROOT / "rtcore" / "_build.py"  # compiled at install; _build.py makes it
    return modules


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules that `name` imports, anywhere in its source."""
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = name.split(".") if is_package else name.split(".")[:-1]
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                       for alias in node.names]
        else:
            continue
        found.update(target for target in targets if target in modules and target != name)
    return found


def import_graph() -> dict[str, set[str]]:
    modules = module_files()
    return {name: imports_of(name, path, modules) if name != BINDING else set()
            for name, path in modules.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle as a path that starts and ends at the same module, or None."""
    colour = dict.fromkeys(graph, 0)  # 0 unseen, 1 on the stack, 2 done
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        colour[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if colour[nxt] == 1:
                return [*stack[stack.index(nxt):], nxt]
            if colour[nxt] == 0 and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        colour[node] = 2
        return None

    for node in sorted(graph):
        if colour[node] == 0 and (cycle := visit(node)):
            return cycle
    return None


def test_graph_sees_imports_inside_functions() -> None:
    modules = {"p": Path("p/__init__.py"), "p.a": Path("p/a.py"), "p.b": Path("p/b.py")}
    source = "def f():\n    from p import b\n    import p.a\n"
    tree_path = ROOT / "tests" / "_graph_probe.py"
    try:
        tree_path.write_text(source)
        assert imports_of("p.a", tree_path, modules) == {"p.b"}
    finally:
        tree_path.unlink()
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycle() -> None:
    graph = import_graph()
    assert len(graph) > 50, "the graph must cover the packages"
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def test_hand_service_goes_through_rtcore_facade() -> None:
    """Only rtcore touches the raw cffi binding (rtcore._rtcore): hand_service uses its
    Python facade (Hand, Simulator, SimLink, Gate, Tick, Ring, clock)."""
    graph = import_graph()
    raw = sorted(name for name, targets in graph.items()
                 if name.startswith("hand_service") and "rtcore._rtcore" in targets)
    assert "rtcore._rtcore" in graph["rtcore.tick"], "the graph must see the binding's users"
    assert raw == []


def test_the_command_line_loads_no_bus_library_before_a_command_runs() -> None:
    """Every `hand-service` call builds the parser of every command; python-can and cantools
    (0.4 s of a 0.8 s start, each CLI call of the test suite and each battery case paying
    it) load only when a command that talks to a bus runs."""
    import subprocess
    import sys

    probe = ("import sys; from hand_service.cli import build_parser; build_parser(); "
             "print(sorted(m for m in ('can', 'cantools', 'serial') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]", out.stdout


def test_the_wiring_sits_above_the_service_the_api_and_the_view() -> None:
    """app/ wires the supervisor, the control API and the view together: it imports them,
    and none of them imports it; the service imports neither the API nor the view."""
    graph = import_graph()
    below = ("hand_service.service", "hand_service.api", "hand_service.view")
    up = sorted((name, target) for name, targets in graph.items() if name.startswith(below)
                for target in targets if target.startswith("hand_service.app"))
    assert up == []
    service_up = sorted((name, target) for name, targets in graph.items()
                        if name.startswith("hand_service.service.") for target in targets
                        if target.startswith(("hand_service.api", "hand_service.view")))
    assert service_up == []
    assert "hand_service.api.requests" in graph["hand_service.app.daemon"], "the graph must see the wiring"
