#!/usr/bin/env python3
"""Checks the layout of Rust crates: no import circles between modules, and
no file over 800 lines without a reason at its top.

Usage: python3 scripts/layout_check.py CRATE_DIR [...]

Long files: a `.rs` file over 800 lines must say why near its top, in a
comment line containing "Long file:" (within its first 40 lines).

Import circles: under CRATE_DIR/src,

Every `.rs` file under the directory is a module (`a/b.rs` and
`a/b/mod.rs` are `a::b`). A module depends on another when its code
(comments and strings aside) names a path into it: `use crate::…`,
`use super::…`, `use self::…`, a child `use name::…`, or an inline
`crate::…`/`super::…` path. A module and its own descendants are one
concept split into files (a parent re-exports its children, a child uses
its parent's types), so those edges are not counted; any other circle is
printed, one line per circle, and the exit status is 1. The tour of the
crates, and why circles matter, is in the README ("Where things live").
"""
import os
import re
import sys


def module_of(root, path):
    rel = os.path.relpath(path, root)[: -len(".rs")].split(os.sep)
    if rel[-1] in ("mod", "lib", "main"):
        rel = rel[:-1]
    return tuple(rel)


def strip(text):
    """Code only: no comments, no string or char literals."""
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r'r#*"(?:.|\n)*?"#*', '""', text)
    text = re.sub(r'"(?:\\.|[^"\\])*"', '""', text)
    return text


def use_paths(tree):
    """Expands a use tree `a::{b, c::{d}}` into paths."""
    tree = tree.strip()
    m = re.match(r"^(.*?)::\s*\{(.*)\}$", tree, re.S)
    if not m:
        return [[p for p in re.split(r"\s*::\s*", tree.split(" as ")[0]) if p]]
    head = [p for p in re.split(r"\s*::\s*", m.group(1)) if p]
    parts, depth, cur = [], 0, ""
    for ch in m.group(2):
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    return [head + sub for part in parts if part.strip() for sub in use_paths(part)]


def resolve(mod, path, modules):
    """The module a path from `mod` points into (None: outside the crate)."""
    if not path:
        return None
    if path[0] == "crate":
        base, rest = (), path[1:]
    elif path[0] in ("super", "self"):
        base, rest = mod, path
        while rest and rest[0] in ("super", "self"):
            if rest[0] == "super":
                base = base[:-1]
            rest = rest[1:]
    elif mod + (path[0],) in modules:
        base, rest = mod, path
    else:
        return None
    target = base
    for seg in rest:
        if target + (seg,) in modules:
            target = target + (seg,)
        else:
            break
    return target


def related(a, b):
    return a[: len(b)] == b or b[: len(a)] == a


def cycles(root):
    files = {}
    for d, _, names in os.walk(root):
        for n in names:
            if n.endswith(".rs"):
                p = os.path.join(d, n)
                files[module_of(root, p)] = p
    modules = set(files)
    graph = {m: set() for m in modules}
    for mod, path in files.items():
        code = strip(open(path, encoding="utf-8").read())
        found = []
        for m in re.finditer(r"\buse\s+([^;]+);", code):
            found += use_paths(m.group(1))
        for m in re.finditer(r"\b((?:crate|super)(?:::\w+)+)", code):
            found.append(m.group(1).split("::"))
        for p in found:
            t = resolve(mod, [s.strip() for s in p], modules)
            if t is not None and t != mod and not related(mod, t):
                graph[mod].add(t)
    # Tarjan's strongly connected components.
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(modules):
        if v not in index:
            visit(v)
    return out, len(modules)


MAX_LINES = 800


def long_files(crate):
    """Files over MAX_LINES lines whose top gives no reason."""
    out = []
    for d, _, names in os.walk(crate):
        if "target" in d.split(os.sep):
            continue
        for n in sorted(names):
            if not n.endswith(".rs"):
                continue
            p = os.path.join(d, n)
            lines = open(p, encoding="utf-8").read().split("\n")
            if len(lines) > MAX_LINES and not any("Long file:" in l for l in lines[:40]):
                out.append((p, len(lines)))
    return out


def main():
    bad = 0
    for crate in sys.argv[1:]:
        for p, n in long_files(crate):
            print(f"{p}: {n} lines, over {MAX_LINES} with no \"Long file:\" reason at its top")
            bad += 1
        root = os.path.join(crate, "src")
        found, n = cycles(root)
        for comp in found:
            names = ["::".join(m) or "crate" for m in comp]
            print(f"{root}: import circle between {', '.join(names)}")
        bad += len(found)
        if not found:
            print(f"{root}: {n} modules, no import circle")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
