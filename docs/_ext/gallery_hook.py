"""MkDocs hook: run the quick gallery scripts when the site is built (mkdocs.yml ``hooks:``).

Each script of :data:`EXECUTED` runs on the coarse preset, as the gallery page shows it
(``python examples/SCRIPT.py --mesh coarse --out gallery-out``, in a fresh temporary directory, with
this build's interpreter and ``$FSISTAB_CACHE``). Its figures become files of the site at
``gallery/built/<figure>`` (the paths the gallery page links to, so ``--strict`` checks that every
figure was drawn), and its printed output and wall time replace the page's marker
``<!-- gallery:run SCRIPT -->``. A script that fails, or does not draw a figure the page expects,
fails the build with the tail of its stderr: there is no silent fallback.

``FSISTAB_DOCS_EXECUTE=0`` runs nothing and serves the stored figures of ``docs/gallery/figures``
under the same paths (quick local edits); the default, which CI builds, executes. The slow scripts
(minutes on one core) are never run here: their pages show stored outputs.

The results of one build travel from ``on_files`` to ``on_page_markdown`` as generated files of
the site (``gallery/built/SCRIPT.json``: command, wall time, printed output), not as module state.
"""

from __future__ import annotations

import json
import logging
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # mkdocs is imported only by the hooks themselves (tests read this module without it)
    from mkdocs.config.defaults import MkDocsConfig
    from mkdocs.structure.files import Files
    from mkdocs.structure.pages import Page

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
STORED = ROOT / "docs" / "gallery" / "figures"  # the stored figures (FSISTAB_DOCS_EXECUTE=0)
BUILT = "gallery/built"  # where the executed figures are in the site (docs-relative)
PAGE = "gallery/index.md"
MESH = "coarse"
LOG = logging.getLogger("mkdocs.hooks.gallery")
TIMEOUT = 600.0  # seconds per script: a hung solver fails the build instead of stalling CI
STDERR_TAIL = 40  # lines of a failing script's stderr quoted in the build error

# script stem -> the figures it draws on the coarse mesh (each also stored in docs/gallery/figures);
# quick: about 10 s of CPU each for the first two with the coarse steady state cached, under 40 s
# for the wake onset (its steady states at Re 500 from rest)
EXECUTED: dict[str, tuple[str, ...]] = {
    "plot_steady_flow": ("steady_plate_Re2900_a0.png",),
    "plot_spectrum": (
        "spectrum_plate_Re2900_a0.png",
        "flutter_plate_Re2900_a0_m1000_U4.7.png",
        "flutter_plate_Re2900_a0_m1000_U4.7_motion.png",
        "anti-flutter_plate_Re2900_a0_m1000_U4.7.png",
        "anti-flutter_plate_Re2900_a0_m1000_U4.7_motion.png",
        "wake_plate_Re2900_a0_m1000_U4.7.png",
    ),
    "plot_wake_onset": (
        "wake_onset_Re500_coarse.png",
        "wake_onset_steady_Re500_a9.77_coarse.png",
        "wake_onset_mode_Re500_a9.77_coarse.png",
    ),
}

MARKER = re.compile(r"<!--\s*gallery:run\s+(\S+)\s*-->")


class GalleryError(Exception):
    """A gallery script failed or drew less than the page shows (reported by the hooks as a
    ``PluginError``: the build stops with this message)."""


def executing(environ=os.environ) -> bool:
    """Whether this build runs the scripts: ``FSISTAB_DOCS_EXECUTE`` unset or ``1`` (default) runs
    them, ``0`` serves the stored figures; anything else is refused (a typo must not skip silently)."""
    value = environ.get("FSISTAB_DOCS_EXECUTE", "1").strip()
    if value not in ("0", "1"):
        raise ValueError(f"FSISTAB_DOCS_EXECUTE must be 0 or 1, not {value!r}")
    return value == "1"


def command(script: Path) -> list[str]:
    """The command run for ``script``: the coarse preset, a relative ``--out`` (the printed paths
    read as the page's command would print them)."""
    return [sys.executable, str(script), "--mesh", MESH, "--out", "gallery-out"]


def markers(markdown: str) -> list[str]:
    """The script stems named by the page's ``<!-- gallery:run SCRIPT -->`` markers, in order."""
    return MARKER.findall(markdown)


def record_for(stem: str, **run) -> dict:
    """What the page says of one script in this build (``run``: executed, seconds, stdout)."""
    return {
        "script": f"examples/{stem}.py",
        "command": f"python examples/{stem}.py --mesh {MESH} --out gallery-out",
        **run,
    }


def run_script(
    stem: str, figures: tuple[str, ...], *, examples: Path = EXAMPLES, timeout: float = TIMEOUT
) -> tuple[dict, dict[str, bytes]]:
    """Run ``examples/STEM.py`` in a fresh directory; its record (command, wall time, stdout) and
    the bytes of every PNG it drew. Raises :class:`GalleryError` with the tail of its stderr if it
    fails or times out, and if it did not draw one of ``figures``."""
    environ = dict(os.environ)
    if environ.get("FSISTAB_CACHE"):  # the script runs elsewhere: a relative cache path would move
        environ["FSISTAB_CACHE"] = str(Path(environ["FSISTAB_CACHE"]).resolve())
    with tempfile.TemporaryDirectory(prefix=f"fsistab-docs-{stem}-") as work:
        start = time.perf_counter()
        try:
            done = subprocess.run(
                command(examples / f"{stem}.py"),
                cwd=work,
                env=environ,
                capture_output=True,
                text=True,
                timeout=timeout,
            )
        except subprocess.TimeoutExpired as exc:
            raise GalleryError(f"gallery: examples/{stem}.py did not finish in {timeout:g} s") from exc
        seconds = time.perf_counter() - start
        if done.returncode != 0:
            tail = "\n".join(done.stderr.splitlines()[-STDERR_TAIL:])
            raise GalleryError(f"gallery: examples/{stem}.py failed (exit {done.returncode}):\n{tail}")
        out = Path(work) / "gallery-out"
        drawn = {p.name: p.read_bytes() for p in sorted(out.glob("*.png"))}
    missing = [name for name in figures if name not in drawn]
    if missing:
        raise GalleryError(f"gallery: examples/{stem}.py did not draw {', '.join(missing)}")
    record = record_for(stem, executed=True, seconds=round(seconds, 1), stdout=done.stdout)
    return record, drawn


def stored_figures(stem: str, figures: tuple[str, ...]) -> tuple[dict, dict[str, bytes]]:
    """The stored ``figures`` of ``stem`` (docs/gallery/figures) and a record saying that the
    script was not run in this build."""
    return record_for(stem, executed=False), {name: (STORED / name).read_bytes() for name in figures}


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """Run (or, with ``FSISTAB_DOCS_EXECUTE=0``, take the stored outputs of) every quick script and
    add its figures and its record to the site under ``gallery/built/``."""
    from mkdocs.exceptions import PluginError
    from mkdocs.structure.files import File

    try:
        execute = executing()
        for stem, figures in EXECUTED.items():
            if execute:
                LOG.info(f"gallery: running examples/{stem}.py --mesh {MESH}")
                record, content = run_script(stem, figures)
                LOG.info(f"gallery: examples/{stem}.py finished in {record['seconds']:.1f} s")
            else:
                record, content = stored_figures(stem, figures)
            for name, data in content.items():
                files.append(File.generated(config, f"{BUILT}/{name}", content=data))
            files.append(File.generated(config, f"{BUILT}/{stem}.json", content=json.dumps(record, indent=1)))
    except (GalleryError, ValueError) as exc:
        raise PluginError(str(exc)) from exc
    return files


def snippet(record: dict) -> str:
    """The markdown that replaces a script's marker: what ran, its wall time and printed output."""
    if not record["executed"]:
        return (
            '!!! note "Stored figures in this build"\n'
            f"    `{record['script']}` was not run: this site was built with `FSISTAB_DOCS_EXECUTE=0`, "
            "so the figures above are the stored ones of `docs/gallery/figures`.\n"
        )
    printed = record["stdout"].rstrip("\n") or "(nothing printed)"
    body = "\n".join(f"    {line}" if line else "" for line in printed.splitlines())
    return (
        f'???+ example "Run when this site was built: {record["seconds"]:.1f} s on the {MESH} mesh"\n'
        f"    `{record['command']}` printed (the figures above are from this run; the wall time includes "
        "Python's start and the imports, and depends on the machine, its load and whether "
        "`$FSISTAB_CACHE` already held the steady state):\n\n"
        f"    ```text\n{body}\n    ```\n"
    )


def on_page_markdown(markdown: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    """Replace each ``<!-- gallery:run SCRIPT -->`` of the gallery page by the script's run; a
    marker naming a script that is not executed, or an executed script without marker, is an error."""
    from mkdocs.exceptions import PluginError

    named = markers(markdown)
    if page.file.src_uri != PAGE:
        if named:
            raise PluginError(f"{page.file.src_uri}: gallery:run markers belong on {PAGE}")
        return markdown
    unknown = sorted(set(named) - set(EXECUTED))
    absent = sorted(set(EXECUTED) - set(named))
    if unknown or absent:
        raise PluginError(
            f"{PAGE}: markers of scripts not executed {unknown}, executed scripts without marker {absent}"
        )

    def replace(match: re.Match) -> str:
        record = json.loads(files.get_file_from_path(f"{BUILT}/{match.group(1)}.json").content_string)
        return snippet(record)

    return MARKER.sub(replace, markdown)
