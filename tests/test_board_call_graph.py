"""The C units of board/ call down only: the graph of which .c file calls a function
another defines, built from the source, has no loop (as tests/test_import_graph.py holds
the Python packages to).

A function several files define (the HAL of core/hal.h, which each port writes; `main`)
is a seam, not an edge: the core calls the contract, not a port. A call through a
function pointer (core/board_internal.h's struct board_rx, which hands the wires'
decoded messages up to board.c) is no edge either: that is how a lower unit reaches
an upper one without depending on it.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TREES = ("board",)
SKIP_DIRS = ("build",)
KEYWORDS = {"if", "for", "while", "switch", "return", "sizeof", "defined"}
COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)
STRING = re.compile(r'"(?:\\.|[^"\\])*"|\'(?:\\.|[^\'\\])*\'')
DIRECTIVE = re.compile(r"^\s*#.*?(?<!\\)$", re.M | re.S)
TOKEN = re.compile(r"[A-Za-z_]\w*|[{}();]")


def c_files(tree: Path) -> list[Path]:
    return sorted(p for p in tree.rglob("*.c") if not set(p.relative_to(tree).parts) & set(SKIP_DIRS))


def functions(text: str) -> tuple[dict[str, bool], set[str]]:
    """The functions a C source defines (name -> static?) and the names it calls."""
    text = DIRECTIVE.sub("", STRING.sub('""', COMMENT.sub(" ", text)))
    defined: dict[str, bool] = {}
    called: set[str] = set()
    tokens = TOKEN.findall(text)
    depth = 0
    statement: list[str] = []  # the tokens at file scope since the last ; or }
    for i, token in enumerate(tokens):
        if token == "{":
            if depth == 0 and statement[-1:] == [")"]:
                name = _declared_name(statement)
                if name is not None:
                    defined[name] = "static" in statement
            depth += 1
            statement = []
        elif token == "}":
            depth -= 1
            statement = []
        elif token == ";" and depth == 0:
            statement = []
        elif depth == 0:
            statement.append(token)
        elif i + 1 < len(tokens) and tokens[i + 1] == "(" and token not in KEYWORDS:
            called.add(token)
    return defined, called


def _declared_name(statement: list[str]) -> str | None:
    """`int f(int x)`: f, the identifier before the first ( at file scope."""
    if "(" not in statement:
        return None
    at = statement.index("(")
    return statement[at - 1] if at > 0 and statement[at - 1] not in KEYWORDS else None


def call_graph(sources: dict[str, str]) -> dict[str, set[str]]:
    """File -> the files whose functions it calls (seams and static functions left out)."""
    parsed = {name: functions(text) for name, text in sources.items()}
    owners: dict[str, list[str]] = {}
    for name, (defined, _) in parsed.items():
        for function, static in defined.items():
            if not static:
                owners.setdefault(function, []).append(name)
    graph: dict[str, set[str]] = {name: set() for name in sources}
    for name, (defined, called) in parsed.items():
        for function in called - set(defined):
            where = owners.get(function, [])
            if len(where) == 1:
                graph[name].add(where[0])
    return graph


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one file (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in graph[node]:
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_the_checker_finds_a_loop_and_passes_a_seam() -> None:
    sources = {"a.c": "static int h(void) { return 1; }\nvoid a(void) { b(); h(); }",
               "b.c": "#include \"x.h\"\nint b(int x)\n{\n    if (x) { c(); }\n    return 0;\n}",
               "c.c": "void c(void) { a(); hal_x(); }",
               "port1.c": "void hal_x(void) { a(); }", "port2.c": "void hal_x(void) {}"}
    graph = call_graph(sources)
    assert graph["a.c"] == {"b.c"} and graph["c.c"] == {"a.c"} and graph["port1.c"] == {"a.c"}
    assert loops(graph) == [["a.c", "b.c", "c.c"]]


def test_no_c_unit_calls_up() -> None:
    for tree in TREES:
        root = ROOT / tree
        sources = {str(p.relative_to(ROOT)): p.read_text() for p in c_files(root)}
        graph = call_graph(sources)
        assert sum(map(len, graph.values())) > len(sources) // 2, "the checker sees no calls"
        assert loops(graph) == [], f"C units of {tree}/ that call each other: {loops(graph)}"
