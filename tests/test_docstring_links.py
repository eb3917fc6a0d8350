"""Cross-references in the packages' docstrings are links that name importable objects.

The API pages render docstrings with mkdocstrings (Google style), whose cross-references are
mkdocs-autorefs links: ``[`name`][package.module.Object]``. The strict docs build fails on a link
autorefs cannot resolve, but only in the docstrings the API pages render; this test checks every
docstring of the library packages (rendered or not): each link's identifier is a fully qualified
path that imports (a module, then attributes; a class's annotated fields count), and no Sphinx
role (``:func:`...```, ``:class:`...```, ...) is left, in docstrings or comments.
"""

from __future__ import annotations

import ast
import importlib
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = [name for name in ("track_envs", "predictors", "agents", "track_apps") if (ROOT / name).is_dir()]
FILES = sorted(p for name in PACKAGES for p in (ROOT / name).rglob("*.py"))

#: A Sphinx cross-reference role.
ROLE = re.compile(r":(?:py:)?(?:func|class|mod|meth|attr|data|exc|obj|const):`")
#: A reference link: ``[text][identifier]`` (``[text][]``: the text is the identifier).
LINK = re.compile(r"\[((?:`[^`\n]+`|[^\[\]`\n])+)\]\[([^\[\]\s]*)\]")
#: A double-backtick code span (may hold brackets that are not links).
CODE = re.compile(r"``.+?``", re.S)


def docstrings(source: str) -> list[tuple[int, str]]:
    """(line, text) of every docstring: module, class, function and attribute docstrings (every
    string statement)."""
    nodes = [n for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Expr)]
    return [
        (n.lineno, n.value.value)
        for n in nodes
        if isinstance(n.value, ast.Constant) and isinstance(n.value.value, str)
    ]


def comments(source: str) -> list[tuple[int, str]]:
    return [
        (tok.start[0], tok.string)
        for tok in tokenize.generate_tokens(io.StringIO(source).readline)
        if tok.type == tokenize.COMMENT
    ]


def links(text: str) -> list[str]:
    """The identifiers of the reference links in ``text`` (outside double-backtick code)."""
    found = []
    for m in LINK.finditer(CODE.sub("", text)):
        identifier = m.group(2) or m.group(1).strip("`")
        found.append(identifier)
    return found


_MISSING = object()


def member(owner: object, name: str) -> object:
    value = getattr(owner, name, _MISSING)
    if value is not _MISSING:
        return value
    if isinstance(owner, type):  # an attribute declared by annotation only (dataclass, protocol)
        if any(name in getattr(k, "__annotations__", {}) for k in owner.__mro__):
            return name
        return _MISSING
    module_name = getattr(owner, "__name__", None)
    if isinstance(module_name, str) and hasattr(owner, "__path__"):  # a package's submodule
        try:
            return importlib.import_module(f"{module_name}.{name}")
        except ImportError:
            return _MISSING
    return _MISSING


def importable(identifier: str) -> bool:
    """Whether ``identifier`` names a module of the packages or an attribute path below one."""
    parts = identifier.split(".")
    if parts[0] not in PACKAGES:
        return False
    for i in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            obj = member(obj, name)
            if obj is _MISSING:
                return False
        return True
    return False


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_docstring_links_name_importable_objects(path):
    source = path.read_text(encoding="utf-8")
    bad = []
    for line, text in docstrings(source):
        bad += [f"{line}: [{identifier}]" for identifier in links(text) if not importable(identifier)]
    assert not bad, f"{path.relative_to(ROOT)}: links that name no importable object: {bad}"


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_sphinx_role_is_left(path):
    source = path.read_text(encoding="utf-8")
    found = [
        f"{line}: {m.group(0)}"
        for line, text in [*docstrings(source), *comments(source)]
        for m in ROLE.finditer(text)
    ]
    assert not found, f"{path.relative_to(ROOT)}: Sphinx roles (write [`name`][dotted.path]): {found}"


def test_the_link_syntax_is_read():
    """The parser of this test: a titled link, a bare one, code that looks like indexing."""
    text = "See [`Tracks`][track_envs.Tracks] and [track_envs.io][] but not ``x[i][j]``."
    assert links(text) == ["track_envs.Tracks", "track_envs.io"]
    assert importable("track_envs.Tracks") and importable("track_envs.io")
    assert not importable("track_envs.NoSuchThing") and not importable("numpy.ndarray")
