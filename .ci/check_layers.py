#!/usr/bin/env python3
"""Layering check of the Rust crate (rust/src): fails (exit 1) when a module uses a higher
layer, when two domain folders use each other, or when the modules of one folder import
each other in a cycle.

Every `use` path and every `crate::` / `super::` / `self::` path in the code (comments and
string literals left out, tests included) is resolved to the file that defines the item,
following `pub use` re-exports, so that `crate::rowfilter::ScalarRowFilter` counts as a use
of rust/src/rowfilter/scalar/mod.rs. Then:

1. Layers. Each domain folder under rust/src has a rank (LAYERS, lowest first); a file may
   use its own domain and domains of a lower rank. Domains of equal rank may use each other
   one way only. A root file (error.rs) is the lowest layer; lib.rs, which declares the
   domains, is not checked.
2. No two domain folders use each other.
3. No cycle among the children of any folder (its files and its sub-folders, each
   sub-folder as one node; the folder's own mod.rs, which declares and re-exports them, is
   not a node): a module split into files is a tree of layers too.

Plain Python, no dependencies. Run: python3 .ci/check_layers.py [path/to/rust/src]
"""

from __future__ import annotations

import re
import sys
from collections import defaultdict
from pathlib import Path

# Domain folders and root files, lowest layer first; equal ranks are siblings.
LAYERS = {
    "error": 0,
    "simd": 1,
    "linalg": 2,
    "field": 3,
    "identification": 3,
    "kalman": 3,
    "rowfilter": 4,
    "filterbank": 4,
    "trajectory": 4,
    "denoising": 5,
    "tracking": 6,
    "python": 7,
}

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
RAW_STRING = re.compile(r'b?r(#*)"')
CHAR = re.compile(r"'(\\.[^']*|[^\\'])'")


def strip_code(text: str) -> str:
    """The code without comments, string and char literals (each replaced by spaces, so that
    line numbers and braces stay put)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif (m := RAW_STRING.match(text, i)) and (i == 0 or not text[i - 1].isalnum()):
            end = text.find('"' + m.group(1), m.end())
            j = n if end < 0 else end + 1 + len(m.group(1))
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(re.sub(r"[^\n]", " ", text[i : j + 1]))
            i = j + 1
        elif c == "'" and (m := CHAR.match(text, i)):
            out.append(" " * (m.end() - i))
            i = m.end()
        else:
            out.append(c)
            i += 1
    return "".join(out)


def expand_use(tree: str) -> list[tuple[str, str]]:
    """The (path, name) pairs of a `use` tree: `a::{b, c::{d as e, self}}` -> (a::b, b),
    (a::c::d, e), (a::c, c)."""
    tree = re.sub(r"\s+", " ", tree).strip()
    if "{" not in tree:
        path, _, alias = (part.strip() for part in tree.partition(" as "))
        path = path.replace(" ", "")
        return [(path, alias or path.split("::")[-1])]
    start = tree.index("{")
    prefix, inner = tree[:start].replace(" ", ""), tree[start + 1 : tree.rindex("}")]
    parts, level, begin = [], 0, 0
    for k, ch in enumerate(inner):
        level += (ch == "{") - (ch == "}")
        if ch == "," and level == 0:
            parts.append(inner[begin:k])
            begin = k + 1
    parts.append(inner[begin:])
    out = []
    for part in filter(str.strip, parts):
        for path, name in expand_use(part):
            if path == "self":
                module = prefix.rstrip(":")
                out.append((module, module.split("::")[-1] if name == "self" else name))
            else:
                out.append((prefix + path, name))
    return out


class Crate:
    def __init__(self, src: Path):
        self.src = src
        self.files = sorted(src.rglob("*.rs"))
        self.code = {f: strip_code(f.read_text()) for f in self.files}
        self.exports = {f: self.reexports(f) for f in self.files}

    # -- modules and files ------------------------------------------------------------------
    def module_of(self, f: Path) -> tuple[str, ...]:
        parts = f.relative_to(self.src).with_suffix("").parts
        if parts[-1] in ("mod", "lib"):
            parts = parts[:-1]
        return tuple(parts)

    def file_of(self, module: tuple[str, ...]) -> Path | None:
        if not module:
            return self.src / "lib.rs"
        base = self.src.joinpath(*module)
        for f in (base.with_suffix(".rs"), base / "mod.rs"):
            if f.exists():
                return f
        return None

    def reexports(self, f: Path) -> dict[str, str]:
        """name -> path of the `pub use` / `pub(...) use` items of a file."""
        out = {}
        for m in re.finditer(r"\bpub(?:\([^)]*\))?\s+use\s+([^;]+);", self.code[f]):
            for path, name in expand_use(m.group(1)):
                out[name] = path
        return out

    # -- resolution -------------------------------------------------------------------------
    def resolve(self, module: tuple[str, ...], path: str, seen=0) -> Path | None:
        """The file defining what `path`, written in `module`, names."""
        segs = [s for s in path.split("::") if s]
        if not segs or seen > 8:
            return None
        head = segs[0]
        if head in ("crate", "$crate"):
            here, segs = (), segs[1:]
        elif head == "super":
            here = module
            while segs and segs[0] == "super":
                here, segs = here[:-1], segs[1:]
        elif head == "self":
            here, segs = module, segs[1:]
        elif self.file_of(module + (head,)) is not None:
            here = module
        else:
            return None  # an external crate, std, or a local item
        while segs:
            child = here + (segs[0],)
            if self.file_of(child) is not None:
                here, segs = child, segs[1:]
                continue
            f = self.file_of(here)
            target = self.exports.get(f, {}).get(segs[0])
            if target is not None:
                return self.resolve(here, target, seen + 1) or f
            return f
        return self.file_of(here)

    def uses(self, f: Path) -> set[Path]:
        """The files whose items `f` uses."""
        code = self.code[f]
        base = self.module_of(f)
        # inline modules (`mod tests { … }`): their paths start one module further down
        spans = []
        for m in re.finditer(r"\bmod\s+(" + IDENT + r")\s*\{", code):
            depth, j = 1, m.end()
            while j < len(code) and depth:
                depth += code[j] == "{"
                depth -= code[j] == "}"
                j += 1
            spans.append((m.start(), j, m.group(1)))

        def module_at(pos: int) -> tuple[str, ...]:
            inner = tuple(name for start, end, name in spans if start <= pos < end)
            return base + inner

        paths = []
        use_spans = []
        for m in re.finditer(r"\buse\s+([^;]+);", code):
            use_spans.append((m.start(), m.end()))
            if self.is_reexport(code, m.start()):
                continue  # `pub use` declares the module's facade: not a use
            paths += [(m.start(), path) for path, _ in expand_use(m.group(1))]
        roots = r"(?<![\w:])(\$?crate|super|self|" + IDENT + r")((?:::" + IDENT + ")+)"
        for m in re.finditer(roots, code):
            if not any(s <= m.start() < e for s, e in use_spans):
                paths.append((m.start(), m.group(1) + m.group(2)))
        out = set()
        for pos, p in paths:
            target = self.resolve(module_at(pos), p)
            if target is not None and target != f and target.name != "lib.rs":
                out.add(target)
        return out

    @staticmethod
    def is_reexport(code: str, pos: int) -> bool:
        """Whether the `use` at `pos` is a `pub use` / `pub(...) use`."""
        start = code.rfind("\n", 0, pos) + 1
        return re.match(r"\s*pub(?:\([^)]*\))?\s+use\b", code[start : pos + 3]) is not None


def domain(crate: Crate, f: Path) -> str:
    parts = f.relative_to(crate.src).parts
    return parts[0] if len(parts) > 1 else f.stem


def cycles(nodes: set[str], edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one node (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return out


def folder_node(folder: Path, f: Path) -> str | None:
    """The child of `folder` that holds `f` (a file or a sub-folder), None outside it or
    for the folder's own mod.rs / lib.rs."""
    try:
        parts = f.relative_to(folder).parts
    except ValueError:
        return None
    if parts in (("mod.rs",), ("lib.rs",)):
        return None
    return parts[0].removesuffix(".rs")


def check(src: Path) -> list[str]:
    crate = Crate(src)
    errors = []
    graph = {f: crate.uses(f) for f in crate.files if f.name != "lib.rs"}

    def rel(f: Path) -> str:
        return str(f.relative_to(src.parent.parent))

    for f in graph:
        if domain(crate, f) not in LAYERS:
            errors.append(f"{rel(f)}: domain '{domain(crate, f)}' has no layer in LAYERS")
    # 1, 2: layers and mutual use of domains
    domain_edges = defaultdict(set)
    for f, targets in graph.items():
        a = domain(crate, f)
        for t in sorted(targets):
            b = domain(crate, t)
            if a == b or a not in LAYERS or b not in LAYERS:
                continue
            domain_edges[a].add(b)
            if LAYERS[b] > LAYERS[a]:
                errors.append(f"{rel(f)} uses {rel(t)}: '{a}' may not use the higher '{b}'")
    for a in sorted(domain_edges):
        for b in sorted(domain_edges[a]):
            if a < b and a in domain_edges.get(b, ()):
                errors.append(f"domains '{a}' and '{b}' use each other")
    # 3: cycles among the children of every folder
    for folder in sorted({f.parent for f in crate.files}):
        edges = defaultdict(set)
        for f, targets in graph.items():
            a = folder_node(folder, f)
            for t in targets:
                b = folder_node(folder, t)
                if a and b and a != b:
                    edges[a].add(b)
        nodes = set(edges) | {b for targets in edges.values() for b in targets}
        for component in cycles(nodes, edges):
            errors.append(f"{rel(folder)}/: import cycle among {', '.join(component)}")
    return errors


def main() -> int:
    default = Path(__file__).resolve().parent.parent / "rust" / "src"
    src = Path(sys.argv[1]) if len(sys.argv) > 1 else default
    errors = check(src)
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        print(f"check_layers: {len(errors)} layering error(s) in {src}", file=sys.stderr)
        return 1
    print(f"check_layers: {src}: layers, domains and folders free of cycles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
