"""MkDocs hook: the command-line reference generated from the typer app (mkdocs.yml ``hooks:``).

The page ``cli.md`` holds the marker ``<!-- cli:reference -->``; at build time it is replaced by the
Markdown that typer's own documentation generator (``typer.cli.get_docs_for_click``, the code behind
``typer fsistab.cli utils docs``) writes for :data:`fsistab.cli.app`: every command with its usage,
help text, options and defaults, read from the same objects as ``fsistab COMMAND --help``, so the
page cannot drift from the commands. Options shared by every command (those of ``fsistab mesh``) are
listed once, under "Shared options", and left out of each command's list.

Importing ``fsistab.cli`` imports no solver (NGSolve, SciPy's sparse solvers): the build stays
light and offline. Nothing but typer, which fsistab depends on, is needed.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from mkdocs.structure.pages import Page

PAGE = "cli.md"
MARKER = "<!-- cli:reference -->"
SHARED_MARKER = "<!-- cli:shared-options -->"
SHARED_SOURCE = "mesh"  # the command whose options are exactly the shared ones
OPTION = re.compile(r"^\* `--")


def command_docs() -> str:
    """typer's Markdown for the whole app, headings starting at level 2."""
    import click
    import typer.cli
    from typer.main import get_command

    from fsistab.cli import app

    command = get_command(app)
    ctx = click.Context(command, info_name="fsistab")
    return typer.cli.get_docs_for_click(obj=command, ctx=ctx, name="fsistab", title="fsistab", indent=1)


def split_sections(text: str) -> list[tuple[str, list[str]]]:
    """``(heading, lines)`` per ``## `fsistab X` `` section; the app's own section first."""
    sections: list[tuple[str, list[str]]] = [("", [])]
    for line in text.splitlines():
        if line.startswith("### `fsistab ") or line.startswith("## `fsistab "):
            sections.append((line, []))
        else:
            sections[-1][1].append(line)
    return sections


def shared_options(sections) -> list[str]:
    """The option lines of ``fsistab mesh``, but ``--help``."""
    for heading, lines in sections:
        if heading.endswith(f"`fsistab {SHARED_SOURCE}`"):
            return [line for line in lines if OPTION.match(line) and not line.startswith("* `--help`")]
    raise ValueError(f"no section for `fsistab {SHARED_SOURCE}` in typer's output")


def render(text: str) -> tuple[str, str]:
    """(the shared options as a list, the commands with their own options only)."""
    sections = split_sections(text)
    shared = shared_options(sections)
    common = set(shared)
    out: list[str] = []
    for heading, lines in sections[1:]:
        out.append("## " + heading.lstrip("#").strip())
        own = [line for line in lines if line not in common]
        if own != lines:
            index = next(i for i, line in enumerate(own) if line.startswith("* `--help`"))
            own.insert(index, "* the [shared options](#shared-options)")
        out.extend(own)
    return "\n".join(shared), "\n".join(out)


def on_page_markdown(markdown: str, page: Page, **kwargs) -> str:
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown or SHARED_MARKER not in markdown:
        raise ValueError(f"{PAGE} must hold {MARKER} and {SHARED_MARKER}")
    shared, commands = render(command_docs())
    return markdown.replace(SHARED_MARKER, shared).replace(MARKER, commands)
