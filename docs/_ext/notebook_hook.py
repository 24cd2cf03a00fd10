"""MkDocs hook: the tutorial notebook executed and shown as a page of the site (mkdocs.yml ``hooks:``).

``notebooks/tutorial.ipynb`` is stored without outputs. When the site is built it is executed with
nbclient (a Jupyter kernel of this build's interpreter, in a fresh temporary directory, with
``$FSISTAB_CACHE``), and rendered as the generated page ``tutorial.md``: markdown cells as they are,
code cells as Python blocks, their printed and returned values as text blocks and their figures as
PNG files of the site (``tutorial/figure-N.png``). A cell that raises fails the build with the
error: the notebook cannot go stale unnoticed.

``FSISTAB_DOCS_EXECUTE=0`` (as for the gallery) runs nothing and renders the cells without outputs,
with a note saying so; then only the standard library is needed. Executing needs ``nbclient``,
``nbformat`` and ``ipykernel``.
"""

from __future__ import annotations

import base64
import json
import logging
import os
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from mkdocs.config.defaults import MkDocsConfig
    from mkdocs.structure.files import Files

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "notebooks" / "tutorial.ipynb"
PAGE = "tutorial.md"
FIGURES = "tutorial"  # docs-relative folder of the generated figures
TIMEOUT = 600  # seconds per cell
LOG = logging.getLogger("mkdocs.hooks.notebook")


class NotebookError(Exception):
    """The notebook failed to execute (reported by the hook as a ``PluginError``)."""


def executing(environ=os.environ) -> bool:
    """``FSISTAB_DOCS_EXECUTE`` unset or ``1`` executes, ``0`` renders the stored cells."""
    value = environ.get("FSISTAB_DOCS_EXECUTE", "1").strip()
    if value not in ("0", "1"):
        raise ValueError(f"FSISTAB_DOCS_EXECUTE must be 0 or 1, not {value!r}")
    return value == "1"


def execute(path: Path = NOTEBOOK, timeout: int = TIMEOUT) -> tuple[dict, float]:
    """The notebook as a dict after running every cell in a fresh directory, and the wall time."""
    try:
        import nbclient
        import nbformat
    except ImportError as exc:
        raise NotebookError(
            "notebook: executing notebooks/tutorial.ipynb needs nbclient, nbformat and ipykernel "
            "(or build with FSISTAB_DOCS_EXECUTE=0)"
        ) from exc
    notebook = nbformat.read(path, as_version=4)
    cache = os.environ.get("FSISTAB_CACHE")
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="fsistab-docs-notebook-") as work:
        client = nbclient.NotebookClient(
            notebook, timeout=timeout, kernel_name="python3", resources={"metadata": {"path": work}}
        )
        try:
            if cache:  # the kernel runs in `work`: a relative cache path would move
                os.environ["FSISTAB_CACHE"] = str(Path(cache).resolve())
            client.execute()
        except nbclient.exceptions.CellExecutionError as exc:
            raise NotebookError(f"notebook: notebooks/tutorial.ipynb failed:\n{exc}") from exc
        finally:
            if cache:
                os.environ["FSISTAB_CACHE"] = cache
    return json.loads(nbformat.writes(notebook)), time.perf_counter() - start


def stored(path: Path = NOTEBOOK) -> dict:
    """The notebook as stored (no outputs), read with the standard library."""
    return json.loads(path.read_text(encoding="utf-8"))


def _text(value) -> str:
    return "".join(value) if isinstance(value, list) else str(value)


def _fence(text: str, language: str) -> str:
    return f"```{language}\n{text.rstrip()}\n```\n"


def render(notebook: dict, note: str) -> tuple[str, dict[str, bytes]]:
    """The page's markdown and its figures (name → PNG bytes) from a notebook dict."""
    parts, figures = [], {}
    for index, cell in enumerate(notebook["cells"]):
        source = _text(cell.get("source", ""))
        if cell["cell_type"] == "markdown":
            parts.append(source.rstrip() + "\n")
            if index == 0 and note:
                parts.append(note)
            continue
        if cell["cell_type"] != "code":
            continue
        parts.append(_fence(source, "python"))
        for output in cell.get("outputs", []):
            if output["output_type"] == "stream" and output.get("name") == "stdout":
                parts.append(_fence(_text(output["text"]), "text"))
            elif output["output_type"] in ("execute_result", "display_data"):
                data = output.get("data", {})
                if "image/png" in data:
                    name = f"figure-{len(figures) + 1}.png"
                    figures[name] = base64.b64decode(_text(data["image/png"]))
                    parts.append(f"![figure {len(figures)} of the tutorial]({FIGURES}/{name})\n")
                elif "text/plain" in data:
                    parts.append(_fence(_text(data["text/plain"]), "text"))
            elif output["output_type"] == "error":
                raise NotebookError(f"notebook: a cell raised {output.get('ename')}: {output.get('evalue')}")
    return "\n".join(parts), figures


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """Execute (or read) the notebook and add its page and figures to the site."""
    from mkdocs.exceptions import PluginError
    from mkdocs.structure.files import File

    try:
        if executing():
            LOG.info("notebook: executing notebooks/tutorial.ipynb")
            notebook, seconds = execute()
            LOG.info(f"notebook: notebooks/tutorial.ipynb executed in {seconds:.1f} s")
            note = (
                '!!! info "Executed when this site was built"\n'
                f"    This page is `notebooks/tutorial.ipynb`, run from top to bottom in {seconds:.0f} s "
                "when the site was built (the time depends on the machine and on whether "
                "`$FSISTAB_CACHE` already held the coarse steady state).\n"
            )
        else:
            notebook = stored()
            note = (
                '!!! note "Not executed in this build"\n'
                "    This page is `notebooks/tutorial.ipynb` without its outputs: the site was built "
                "with `FSISTAB_DOCS_EXECUTE=0`.\n"
            )
        markdown, figures = render(notebook, note)
    except (NotebookError, ValueError, OSError) as exc:
        raise PluginError(str(exc)) from exc
    files.append(File.generated(config, PAGE, content=markdown))
    for name, data in figures.items():
        files.append(File.generated(config, f"{FIGURES}/{name}", content=data))
    return files
