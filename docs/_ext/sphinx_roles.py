"""Griffe extension of the documentation build: Sphinx cross-reference roles in docstrings as links.

The docstrings of fsistab cite other objects with Sphinx roles (``:func:`name```, ``:class:`~a.b.C```,
``:mod:``, ``:meth:``, ``:attr:``, ``:data:``, ``:exc:``, ``:obj:``), which Markdown would show
literally. Once the whole package is loaded (static analysis, nothing imported), each role becomes an
*optional* mkdocs-autorefs reference: a link when the target has a page in the API reference, plain
code otherwise, so that a reference to a module without a page, or to another package, never fails
the strict build. A relative name (``recording``) is looked up in the object's class, then in its
module; ``~`` shows the last component only, as in Sphinx. reST's literal-block marker ``::`` at
the end of a paragraph becomes ``:`` (the indented block after it is a code block in Markdown too).
"""

from __future__ import annotations

import html
import re

import griffe

ROLE = re.compile(r":(?:py:)?(?:func|class|mod|meth|attr|data|exc|obj|const):`(?P<target>[^`]+)`")
# reST's literal-block marker: ``text::`` reads ``text:`` before the (indented) block, a lone ``::``
# nothing; the indented block itself is already a code block in Markdown
LITERAL_MARKER = re.compile(r"(?<=\S)::$", flags=re.MULTILINE)
LONE_MARKER = re.compile(r"^[ \t]*::[ \t]*\n", flags=re.MULTILINE)


def _candidates(obj: griffe.Object, name: str) -> list[str]:
    """Full paths that ``name`` may mean, seen from ``obj``: as written, then from its class and
    module (innermost first)."""
    scopes = []
    parent: griffe.Object | None = obj if obj.is_class or obj.is_module else obj.parent
    while parent is not None:
        scopes.append(parent.path)
        parent = parent.parent
    return [name] + [f"{scope}.{name}" for scope in scopes]


def _resolve(obj: griffe.Object, name: str) -> str:
    """The first candidate path that exists in the loaded package (an imported name followed to its
    definition), else ``name`` as written."""
    package = obj.package
    for path in _candidates(obj, name):
        if not path.startswith(package.path):
            continue
        try:
            member = package.modules_collection.get_member(path)
        except (KeyError, ValueError, AttributeError):
            continue
        if member.is_alias:  # an imported name: link to where it is defined
            try:
                return member.final_target.path
            except (griffe.AliasResolutionError, griffe.CyclicAliasError):
                return path
        return path
    return name


def _link(obj: griffe.Object, match: re.Match) -> str:
    target = match["target"].strip()
    short = target.startswith("~")
    target = target.lstrip("~.")
    if "<" in target and target.endswith(">"):  # :func:`title <target>`
        title, target = target[:-1].split("<", 1)
        title = title.strip()
    else:
        title = target.rsplit(".", 1)[-1] if short else target
    path = _resolve(obj, target)
    return (
        f'<autoref identifier="{html.escape(path, quote=True)}" optional>'
        f"<code>{html.escape(title)}</code></autoref>"
    )


class SphinxRoles(griffe.Extension):
    """Rewrites the Sphinx roles of every docstring of a package once it is loaded."""

    def on_package(self, *, pkg: griffe.Module, **kwargs) -> None:
        self._rewrite(pkg, set())

    # the same event in griffe 1 (mkdocstrings-python 2.0 accepts griffe >= 1.13); rewriting is
    # idempotent, so a griffe that calls both does no harm
    on_package_loaded = on_package

    def _rewrite(self, obj: griffe.Object, seen: set[str]) -> None:
        if obj.path in seen:
            return
        seen.add(obj.path)
        if obj.docstring is not None:
            text = ROLE.sub(lambda m: _link(obj, m), obj.docstring.value)
            text = LONE_MARKER.sub("", LITERAL_MARKER.sub(":", text))
            obj.docstring.value = text
        for member in obj.members.values():
            if not member.is_alias:
                self._rewrite(member, seen)
