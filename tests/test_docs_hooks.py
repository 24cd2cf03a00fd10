"""The documentation's build hooks (docs/_ext): the CLI reference generated from the typer app and
the tutorial notebook rendered as a page. Cheap: no NGSolve, no mkdocs, nothing executed."""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def load(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / "_ext" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cli_reference_lists_every_command_once_with_its_own_options():
    hook = load("cli_hook")
    shared, commands = hook.render(hook.command_docs())
    from typer.main import get_command

    from fsistab.cli import app

    names = sorted(get_command(app).commands)
    for name in names:
        assert commands.count(f"## `fsistab {name}`") == 1, name
    assert "* `--body <str>`" in shared and "* `--mesh <str>`" in shared
    assert "* `--body <str>`" not in commands  # shared options listed once
    assert "* `--mass-ratio-range" in commands  # a command's own option kept


def test_cli_page_has_the_markers():
    page = (ROOT / "docs" / "cli.md").read_text()
    hook = load("cli_hook")
    assert hook.MARKER in page and hook.SHARED_MARKER in page


def test_tutorial_notebook_is_stored_without_outputs():
    notebook = json.loads((ROOT / "notebooks" / "tutorial.ipynb").read_text())
    code = [c for c in notebook["cells"] if c["cell_type"] == "code"]
    assert code
    assert all(not c.get("outputs") and c.get("execution_count") is None for c in code)


def test_notebook_render_shows_text_and_figures_and_refuses_errors():
    hook = load("notebook_hook")
    png = "iVBORw0KGgo="  # base64 of a PNG signature
    notebook = {
        "cells": [
            {"cell_type": "markdown", "source": ["# Title\n"]},
            {
                "cell_type": "code",
                "source": ["print(1)\n", "fig"],
                "outputs": [
                    {"output_type": "stream", "name": "stdout", "text": ["1\n"]},
                    {"output_type": "display_data", "data": {"image/png": png, "text/plain": ["<Figure>"]}},
                ],
            },
        ]
    }
    markdown, figures = hook.render(notebook, note="NOTE\n")
    assert markdown.startswith("# Title") and "NOTE" in markdown
    assert "```python\nprint(1)\nfig\n```" in markdown and "```text\n1\n```" in markdown
    assert list(figures) == ["figure-1.png"] and figures["figure-1.png"].startswith(b"\x89PNG")
    assert "(tutorial/figure-1.png)" in markdown
    notebook["cells"][1]["outputs"] = [{"output_type": "error", "ename": "ValueError", "evalue": "x"}]
    with pytest.raises(hook.NotebookError):
        hook.render(notebook, note="")


def test_docs_execute_switch_refuses_a_typo():
    hook = load("notebook_hook")
    assert hook.executing({}) and not hook.executing({"FSISTAB_DOCS_EXECUTE": "0"})
    with pytest.raises(ValueError):
        hook.executing({"FSISTAB_DOCS_EXECUTE": "no"})


def test_every_module_has_a_reference_page_a_row_and_a_place_in_the_nav():
    """A new module is documented: its page under docs/reference, its row in the reference index
    and its entry in mkdocs.yml's nav (the site build would not notice a page left out)."""
    modules = sorted(p.stem for p in (ROOT / "src" / "fsistab").glob("*.py") if p.stem != "__init__")
    index = (ROOT / "docs" / "reference" / "index.md").read_text()
    nav = (ROOT / "mkdocs.yml").read_text()
    missing = [
        m
        for m in modules
        if not (ROOT / "docs" / "reference" / f"{m}.md").is_file()
        or f"[`fsistab.{m}`]({m}.md)" not in index
        or f"reference/{m}.md" not in nav
    ]
    assert missing == []
