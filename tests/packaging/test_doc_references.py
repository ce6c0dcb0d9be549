"""Every reference to a doc points inside the repository, at a doc that is there.

Scanned: the files git tracks, plus new ones it does not ignore (what the next commit could
hold; a clean clone has the same set), this file excepted. Text files only.

- nothing refers to the sibling folder the project was specified in (OUTSIDE: spelt in
  parts, so that this file does not hold what it forbids);
- every `NAME.md` a file mentions (code, help text, profiles, C, docs) exists: a bare name
  in docs/, at the repository root or beside the file; a path from the repository root or
  from the file's folder; a command's output (`--markdown battery.md`, `> out.md`) is no
  mention;
- every relative link of README.md and docs/*.md resolves, and its #anchor names a heading
  (GitHub's slugs) or an <a id/name> of the target.
"""

from __future__ import annotations

import functools
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SELF = Path(__file__).resolve().relative_to(ROOT).as_posix()
SIBLING = "sha" + "red"
OUTSIDE = (f"../{SIBLING}", f"{SIBLING}/docs")
URL = re.compile(r"\b[a-z][a-z0-9+.-]*://\S+", re.I)
MENTION = re.compile(r"(?<![\w./-])((?:\.{1,2}/|[\w-]+/)*[\w-]+\.md)\b")
OUTPUT = re.compile(r"(?:--[\w-]+[ =]|>\s*)$")  # `--markdown battery.md`, `> out.md`: a file written
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)"  # [text](target "title")
                  r"|^\s*\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)", re.M)  # [label]: target
CODE_BLOCK = re.compile(r"^(```|~~~).*?^\1", re.M | re.S)
CODE_SPAN = re.compile(r"`+[^`\n]*`+")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.M)
HTML_ANCHOR = re.compile(r"<a\s+(?:[^>]*\s)?(?:id|name)\s*=\s*[\"']([^\"']+)[\"']", re.I)


@functools.cache
def repository_files() -> frozenset[str]:
    """The files of the next commit that are in the work tree."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout")
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                            cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return frozenset(name for name in listed.split("\0") if name and (ROOT / name).is_file())


def repository_texts() -> dict[str, str]:
    """path -> text, for the text files among them (this test excepted)."""
    texts = {}
    for name in sorted(repository_files() - {SELF}):
        try:
            texts[name] = (ROOT / name).read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue  # binary (png)
    return texts


def exists(path: Path, files: frozenset[str]) -> bool:
    """A file of the repository, or a folder holding one."""
    try:
        name = path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return False  # outside the repository
    return name in files or any(f.startswith(f"{name}/") for f in files) or name == "."


def test_nothing_refers_outside_the_repository() -> None:
    found = [f"{name}:{number}: {line.strip()}"
             for name, text in repository_texts().items()
             for number, line in enumerate(text.splitlines(), 1)
             if any(token in line for token in OUTSIDE)]
    assert found == [], "references outside the repository:\n" + "\n".join(found)


def test_every_mentioned_doc_exists() -> None:
    texts, files = repository_texts(), repository_files()
    dangling = []
    for name, text in texts.items():
        here = (ROOT / name).parent
        for number, line in enumerate(text.splitlines(), 1):
            line = URL.sub("", line)
            for match in MENTION.finditer(line):
                mention = match[1]
                if OUTPUT.search(line[:match.start()]):
                    continue  # a command's output file, not a doc
                if "/" in mention:
                    candidates = [ROOT / mention, here / mention]
                else:
                    candidates = [ROOT / "docs" / mention, ROOT / mention, here / mention]
                if not any(exists(c, files) for c in candidates):
                    dangling.append(f"{name}:{number}: {mention}")
    assert dangling == [], "docs mentioned but not in the repository:\n" + "\n".join(dangling)


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link: its text
    text = re.sub(r"<[^>]+>", "", text).lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(text: str) -> set[str]:
    found: set[str] = set(HTML_ANCHOR.findall(text))
    seen: dict[str, int] = {}
    for heading in HEADING.findall(CODE_BLOCK.sub("", text)):
        base = slug(heading)
        count = seen.get(base, 0)
        seen[base] = count + 1
        found.add(base if count == 0 else f"{base}-{count}")
    return found


def test_markdown_links_resolve() -> None:
    texts, files = repository_texts(), repository_files()
    pages = [n for n in texts if n == "README.md" or (n.startswith("docs/") and n.endswith(".md"))]
    broken = []
    for name in pages:
        here = (ROOT / name).parent
        for number, line in enumerate(CODE_BLOCK.sub(lambda m: "\n" * m[0].count("\n"),
                                                     texts[name]).splitlines(), 1):
            for inline, reference in LINK.findall(CODE_SPAN.sub("", line)):
                target = inline or reference
                if re.match(r"[a-z][a-z0-9+.-]*:", target, re.I):
                    continue  # https:, mailto:
                path, _, fragment = target.partition("#")
                path = path.split("?")[0]
                where = (here / path) if path else ROOT / name
                if path and not exists(where, files):
                    broken.append(f"{name}:{number}: {target} (no such file)")
                elif fragment and where.suffix == ".md":
                    key = where.resolve().relative_to(ROOT).as_posix()
                    if fragment not in anchors(texts.get(key, "")):
                        broken.append(f"{name}:{number}: {target} (no heading #{fragment} in {key})")
    assert broken == [], "links that do not resolve:\n" + "\n".join(broken)
