"""Writes one generated section of a Markdown page in docs/, between the markers
``<!-- <name>:start -->`` and ``<!-- <name>:end -->``, leaving the rest of the page alone."""

from __future__ import annotations

from pathlib import Path

DOCS = Path(__file__).resolve().parent.parent / "docs"


def write_section(page: str, name: str, text: str, title: str = "") -> Path:
    """Replaces (or appends) section `name` of docs/`page`; returns the page's path."""
    path = DOCS / page
    path.parent.mkdir(parents=True, exist_ok=True)
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    block = f"{start}\n{text.strip()}\n{end}"
    old = path.read_text() if path.exists() else (f"# {title}\n\n" if title else "")
    if start in old and end in old:
        head, rest = old.split(start, 1)
        new = head + block + rest.split(end, 1)[1]
    else:
        new = old.rstrip() + "\n\n" + block + "\n"
    path.write_text(new)
    return path
