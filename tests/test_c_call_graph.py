"""The call graph between the C units of csrc/ and board/, built from the source, has no
cycle: each unit calls down only, as the import graph of the Python packages has no loop
(tests/test_import_graph.py).

A unit is a source file. Unit A depends on unit B when A names a function that B defines
with external linkage (a call, or its address taken), or one that header B defines inline.
A name that several units define is a link-time alternative (the HAL's implementations:
host, Cortex-M, AVR, the tests' fake; the programs' `main`): a build links one of them, so a
call to it depends on the contract in the header, not on any of them. The graph is read
with a small tokenizer (comments, strings and preprocessor lines dropped, fields after `.`
and `->` ignored), so it needs neither a compiler nor the cross toolchains.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from collections import defaultdict
from pathlib import Path

import pytest

from tests.test_import_graph import find_cycle

ROOT = Path(__file__).resolve().parents[1]
DIRECTORIES = ("csrc", "board")

COMMENT_OR_LITERAL = re.compile(r'/\*.*?\*/|//[^\n]*|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'', re.S)
PREPROCESSOR = re.compile(r"^[ \t]*#(?:[^\n]*\\\n)*[^\n]*", re.M)
TOKEN = re.compile(r"[A-Za-z_]\w*|->|[{}();,.\[\]=]")
KEYWORDS = frozenset(("if", "for", "while", "switch", "return", "sizeof", "do", "else", "case", "goto",
                      "break", "continue"))


def tokens_of(text: str) -> list[str]:
    """The identifiers and the punctuation that shapes C declarations, without comments,
    string and character literals or preprocessor lines."""
    text = COMMENT_OR_LITERAL.sub(" ", text)
    return TOKEN.findall(PREPROCESSOR.sub(" ", text))


def scan(tokens: list[str], header: bool) -> tuple[dict[str, bool], set[str]]:
    """The functions a file defines (name -> external linkage) and the identifiers it
    names (fields excluded): inside function bodies, and in a source file's file-scope
    declarations and initialisers too (a table of function pointers, a prototype it relies
    on). A header's prototypes are its contract, not calls; a struct's members are names of
    its own."""
    defined: dict[str, bool] = {}
    named: set[str] = set()
    depth = 0
    counted = not header  # whether names here count: file scope, then per block
    statement: list[str] = []  # the file-scope tokens since the last ; or }
    for index, token in enumerate(tokens):
        if token == "{":
            if depth == 0:
                name = defined_function(statement)
                if name is not None:
                    defined[name] = "static" not in statement
                counted = name is not None or ("=" in statement and not header)
            depth += 1
        elif token == "}":
            depth -= 1
            if depth == 0:
                statement = []
                counted = not header
        elif token == ";" and depth == 0:
            statement = []
        elif depth == 0:
            statement.append(token)
        field = index > 0 and tokens[index - 1] in (".", "->")
        if counted and not field and (token[0].isalpha() or token[0] == "_") and token not in KEYWORDS:
            named.add(token)
    return defined, named


def defined_function(statement: list[str]) -> str | None:
    """The name of the function a file-scope statement opens with its `{` (`type name(...)`),
    or None (a struct, an initialiser, an enum)."""
    if not statement or statement[-1] != ")" or "=" in statement:
        return None
    depth = 0
    for position in range(len(statement) - 1, -1, -1):
        depth += {")": 1, "(": -1}.get(statement[position], 0)
        if depth == 0:
            name = statement[position - 1] if position > 0 else ""
            return name if re.fullmatch(r"[A-Za-z_]\w*", name) and name not in KEYWORDS else None
    return None


def c_units(directories: tuple[str, ...] = DIRECTORIES) -> dict[str, str]:
    """Path relative to the repository -> text, for every .c and .h file of the directories
    (board's build output excluded)."""
    units: dict[str, str] = {}
    for directory in directories:
        for path in sorted((ROOT / directory).rglob("*")):
            relative = path.relative_to(ROOT)
            if path.suffix in (".c", ".h", ".ino") and "build" not in relative.parts:
                units[relative.as_posix()] = path.read_text()
    return units


def call_graph(units: dict[str, str]) -> dict[str, set[str]]:
    """Unit -> the units it depends on (the module docstring says how)."""
    scanned = {unit: scan(tokens_of(text), unit.endswith(".h")) for unit, text in units.items()}
    definers: dict[str, set[str]] = defaultdict(set)
    for unit, (defined, _) in scanned.items():
        for name, external in defined.items():
            # a header's functions are inline: visible to every unit that includes it
            if external or unit.endswith(".h"):
                definers[name].add(unit)
    graph: dict[str, set[str]] = {}
    for unit, (defined, named) in scanned.items():
        graph[unit] = set()
        for name in named - set(defined):
            owners = definers.get(name, set())
            if len(owners) == 1 and unit not in owners:
                graph[unit] |= owners
    return graph


def test_graph_sees_calls_and_taken_addresses() -> None:
    units = {
        "d/a.c": "/* b_run() */ #include \"b.h\"\nint a_run(void) { return b_run(1); }\n",
        "d/b.c": "static int helper(int x) { return x; }\nint b_run(int x) { return helper(x) + c_go(); }\n",
        "d/c.c": "typedef int (*fn)(void);\nstatic const fn table[] = {a_run};\n"
                 "int c_go(void) { return 0; }\n",
        "d/d.c": "struct s { int (*b_run)(int); };\n"
                 "int d_go(struct s *p) { return p->b_run(0) + helper(1); }\n",
        "d/hal_x.c": "void hal_tick(void) { a_run(); }\n",
        "d/hal_y.c": "void hal_tick(void) { }\n",
        "d/e.c": "void e_go(void) { hal_tick(); }\n",
        "d/f.h": "int a_run(void);\nstatic inline int f_twice(int x) { return b_run(x) * 2; }\n",
        "d/g.c": "int g_go(void) { return f_twice(1); }\n",
    }
    graph = call_graph(units)
    assert graph["d/a.c"] == {"d/b.c"}  # the comment's and the include's b_run do not count
    assert graph["d/b.c"] == {"d/c.c"}
    assert graph["d/c.c"] == {"d/a.c"}  # a function's address in a table counts
    assert graph["d/d.c"] == set()  # a field named as a function, another unit's static
    assert graph["d/e.c"] == set()  # the HAL's alternatives: the contract, not an implementation
    assert graph["d/f.h"] == {"d/b.c"} and graph["d/g.c"] == {"d/f.h"}  # inline, not prototypes
    assert find_cycle(graph) == ["d/a.c", "d/b.c", "d/c.c", "d/a.c"]


def test_graph_covers_the_known_units() -> None:
    graph = call_graph(c_units())
    assert "csrc/rtcore_exact.c" in graph["csrc/rtcore_sim_etdrk4.c"]
    assert "csrc/rtcore_sim_etdrk4.c" in graph["csrc/rtcore_sim_plant.c"]
    assert "board/core/regulator.c" in graph["board/core/measure.c"]


def gcc_call_graph(sources: list[Path], include_dirs: list[Path], build: Path) -> dict[str, set[str]]:
    """The same graph between the given source files as gcc sees it: the calls in each
    translation unit (-fcallgraph-info), resolved to the unit whose object defines the
    callee (nm). Keys and targets are paths relative to the repository."""
    defined_in: dict[str, set[str]] = defaultdict(set)
    calls: dict[str, set[str]] = {}
    for source in sources:
        unit = source.relative_to(ROOT).as_posix()
        obj = build / (source.stem + ".o")
        subprocess.run(["gcc", "-std=c99", "-O0", "-fcallgraph-info", *(f"-I{d}" for d in include_dirs),
                        "-c", str(source), "-o", str(obj)], check=True, capture_output=True, cwd=build)
        info = obj.with_suffix(".ci").read_text()
        calls[unit] = set(re.findall(r'edge: \{ sourcename: "[^"]+" targetname: "([^"]+)"', info))
        symbols = subprocess.run(["nm", "--defined-only", str(obj)], check=True, capture_output=True,
                                 text=True).stdout
        for line in symbols.splitlines():
            kind, name = line.split()[-2:]
            if kind in "TD":
                defined_in[name].add(unit)
    return {unit: {owner for name in names for owner in defined_in.get(name, set())
                   if len(defined_in[name]) == 1 and owner != unit}
            for unit, names in calls.items()}


@pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("nm") is None, reason="needs gcc and nm")
def test_the_tokenizer_sees_every_call_gcc_sees_in_csrc(tmp_path: Path) -> None:
    """The graph read from the source holds every edge between csrc's units that gcc's own
    call graph has (it may hold more: a function's address taken is no call to gcc)."""
    generated = ROOT / "build" / "gen"  # rtcore_can_v1.h, made by the extension's build (rtcore/_build.py)
    sources = sorted((ROOT / "csrc").glob("*.c"))
    include_dirs = [ROOT / "csrc", ROOT / "board" / "plant", ROOT / "board" / "core", generated]
    gcc = gcc_call_graph(sources, include_dirs, tmp_path)
    ours = call_graph(c_units())
    assert sum(len(targets) for targets in gcc.values()) > 20, "gcc's graph must see the calls"
    missing = {unit: sorted(targets - ours[unit]) for unit, targets in gcc.items() if targets - ours[unit]}
    assert missing == {}


def reachable(graph: dict[str, set[str]], start: str) -> set[str]:
    seen: set[str] = set()
    todo = [start]
    while todo:
        for target in graph[todo.pop()] - seen:
            seen.add(target)
            todo.append(target)
    return seen


def cycles_through(graph: dict[str, set[str]], directory: str) -> list[list[str]]:
    """One cycle for each loop of units (a strongly connected component) that holds a unit
    of `directory`: a loop through another directory's units counts for this one too."""
    reach = {unit: reachable(graph, unit) for unit in graph}
    cycles: list[list[str]] = []
    seen: set[str] = set()
    for unit in sorted(graph):
        if unit in seen or unit not in reach[unit]:
            continue
        loop = {other for other in reach[unit] if unit in reach[other]}
        seen |= loop
        if any(member.startswith(directory + "/") for member in loop):
            cycles.append(find_cycle({member: graph[member] & loop for member in loop}) or [])
    return cycles


def test_cycles_are_found_per_directory() -> None:
    graph = {"x/a.c": {"x/b.c"}, "x/b.c": {"y/c.c"}, "y/c.c": {"x/a.c"}, "y/d.c": {"y/e.c"}, "y/e.c": set()}
    assert cycles_through(graph, "x") == [["x/a.c", "x/b.c", "y/c.c", "x/a.c"]]
    assert cycles_through(graph, "y") == cycles_through(graph, "x")
    assert cycles_through({"y/d.c": {"y/e.c"}, "y/e.c": set()}, "y") == []


@pytest.mark.parametrize("directory", ["csrc", "board"])
def test_no_call_cycle_between_c_units(directory: str) -> None:
    graph = call_graph(c_units())
    assert any(unit.startswith(directory + "/") for unit in graph), f"no C units under {directory}/"
    cycles = cycles_through(graph, directory)
    assert cycles == [], "call cycles between C units:\n" + "\n".join(" -> ".join(cycle) for cycle in cycles)


INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
SEARCH = (ROOT / "csrc", ROOT / "board" / "plant", ROOT / "board" / "core")


def included(source: Path) -> set[str]:
    """The project headers a file includes, directly or through others (by name)."""
    seen: set[str] = set()
    todo = [source]
    while todo:
        for name in INCLUDE.findall(todo.pop().read_text()):
            path = next((d / name for d in SEARCH if (d / name).exists()), None)
            if path is not None and name not in seen:
                seen.add(name)
                todo.append(path)
    return seen


@pytest.mark.parametrize("unit", ["rtcore_sim_motion.c", "rtcore_sim_plant.c", "rtcore_sim_etdrk4.c",
                                  "rtcore_sim_knee.c",
                                  "rtcore_sim_kink.c", "rtcore_sim_torque.c",
                                  "rtcore_sim_step_size.c", "rtcore_sim_span.c", "rtcore_exact.c"])
def test_the_finger_dynamics_see_nothing_of_the_hand_above_them(unit: str) -> None:
    """The finger's dynamics (rtcore_sim_plant.h) and the units below them do not depend on
    the simulated hand that calls them: not on its header's state (rtcore_sim.h: the valve's
    history, the sensors) nor on the valve's (rtcore_sim_advance.h). The board's plant links
    them without the hand."""
    seen = included(ROOT / "csrc" / unit)
    assert "rtcore_exact.h" in seen or unit == "rtcore_exact.c"
    assert seen.isdisjoint({"rtcore_sim.h", "rtcore_sim_advance.h", "rtcore_tick.h"}), sorted(seen)
