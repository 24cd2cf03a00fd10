"""The gallery scripts (examples/*.py) cannot rot silently: each imports, documents itself, parses its
options and answers ``--help`` as a script without computing anything (docs/gallery/index.md)."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("plot_*.py"))
EXPECTED = {
    "plot_steady_flow.py",
    "plot_spectrum.py",
    "plot_eigenvalue_branches.py",
    "plot_stability_map.py",
    "plot_theodorsen.py",
    "plot_heaving_cylinder.py",
    "plot_reynolds_study.py",
    "plot_alpha0_study.py",
    "plot_wake_onset.py",
    "plot_limit_cycles.py",
    "plot_typical_section.py",
}


def load(path: Path):
    spec = importlib.util.spec_from_file_location(f"gallery_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_result_has_its_script():
    assert {p.name for p in EXAMPLES} == EXPECTED


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_documents_itself(path):
    """The module docstring names what it shows, the command, the mesh and the reference values."""
    doc = load(path).__doc__
    assert doc and doc.strip()
    for needed in ("Command-line equivalent", "fsistab ", "Mesh:", "Reference"):
        assert needed in doc, f"{path.name}: docstring lacks {needed!r}"


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_options(path, tmp_path):
    """``--mesh`` defaults to coarse, ``--out`` is taken, and a bad preset is refused by argparse."""
    module = load(path)
    args = module.parse_args([])
    assert args.mesh == "coarse"
    assert module.parse_args(["--out", str(tmp_path), "--mesh", "medium"]).out == tmp_path
    with pytest.raises(SystemExit) as exc:
        module.parse_args(["--mesh", "huge"])
    assert exc.value.code == 2


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_help_runs_as_a_script(path, tmp_path):
    """``python examples/X.py --help`` exits 0, lists --mesh and --out, imports no solver and
    writes nothing (the heavy imports are inside ``run``)."""
    probe = (
        "import runpy, sys; sys.argv = [sys.argv[1], '--help']\n"
        "try:\n    runpy.run_path(sys.argv[0], run_name='__main__')\n"
        "except SystemExit as exc:\n    code = exc.code\n"
        "else:\n    code = 'no exit'\n"
        "print('NGSOLVE' if 'ngsolve' in sys.modules else 'LIGHT', code)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe, str(path)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "--mesh" in done.stdout and "--out" in done.stdout
    assert done.stdout.strip().splitlines()[-1] == "LIGHT 0"
    assert not any(tmp_path.iterdir())


def test_gallery_page_lists_every_script():
    page = (ROOT / "docs" / "gallery" / "index.md").read_text()
    for path in EXAMPLES:
        assert f"examples/{path.name}" in page, f"docs/gallery/index.md does not show {path.name}"


# --- the docs build runs the quick scripts (docs/_ext/gallery_hook.py); cheap checks, no NGSolve, no mkdocs

HOOK_PATH = ROOT / "docs" / "_ext" / "gallery_hook.py"
PAGE = ROOT / "docs" / "gallery" / "index.md"


@pytest.fixture(scope="module")
def hook():
    return load(HOOK_PATH)


def test_docs_hook_is_registered():
    assert "  - docs/_ext/gallery_hook.py" in (ROOT / "mkdocs.yml").read_text().split("hooks:")[1]


def test_executed_scripts_exist_and_their_figures_are_stored(hook):
    """Every executed script is a gallery script, its figures are stored (FSISTAB_DOCS_EXECUTE=0)
    and the gallery page links them where the build puts them."""
    assert hook.EXECUTED, "no gallery script is executed when the docs build"
    page = PAGE.read_text()
    for stem, figures in hook.EXECUTED.items():
        assert ROOT / "examples" / f"{stem}.py" in EXAMPLES
        assert figures
        for name in figures:
            assert (ROOT / "docs" / "gallery" / "figures" / name).is_file(), f"{name} not stored"
            assert f"](built/{name})" in page, f"the gallery page does not show built/{name}"


def test_gallery_markers_name_the_executed_scripts(hook):
    """Each ``<!-- gallery:run SCRIPT -->`` names a real, executed script, once; each executed
    script has its marker."""
    page = PAGE.read_text()
    named = hook.markers(page)
    assert sorted(named) == sorted(set(named)), "a script is run twice on the page"
    assert set(named) == set(hook.EXECUTED)
    for stem in named:
        assert (ROOT / "examples" / f"{stem}.py").is_file()
        assert f"<!-- gallery:run {stem} -->" in page
    assert hook.markers("<!--gallery:run  plot_x -->\n<!-- gallery:run plot_y-->") == ["plot_x", "plot_y"]


def test_executed_command_is_the_pages_and_parses(hook):
    for stem in hook.EXECUTED:
        script = ROOT / "examples" / f"{stem}.py"
        cmd = hook.command(script)
        assert cmd[0] == sys.executable and cmd[1] == str(script)
        args = load(script).parse_args(cmd[2:])
        assert args.mesh == "coarse" and args.out == Path("gallery-out")
        assert f"python examples/{stem}.py --mesh coarse --out gallery-out" in PAGE.read_text()


@pytest.mark.parametrize(
    ("value", "expected"), [(None, True), ("1", True), ("0", False), (" 0 ", False), ("no", None), ("", None)]
)
def test_execution_switch(hook, value, expected):
    environ = {} if value is None else {"FSISTAB_DOCS_EXECUTE": value}
    if expected is None:
        with pytest.raises(ValueError, match="FSISTAB_DOCS_EXECUTE must be 0 or 1"):
            hook.executing(environ)
    else:
        assert hook.executing(environ) is expected


FAKE = """import argparse, sys
from pathlib import Path
p = argparse.ArgumentParser(); p.add_argument("--mesh"); p.add_argument("--out", type=Path)
a = p.parse_args()
print("mesh", a.mesh, "out", a.out)
{body}
"""


def fake_script(tmp_path: Path, body: str) -> Path:
    examples = tmp_path / "examples"
    examples.mkdir()
    (examples / "plot_fake.py").write_text(FAKE.format(body=body))
    return examples


def test_run_script_returns_output_and_figures(hook, tmp_path):
    body = 'a.out.mkdir(); (a.out / "fake.png").write_bytes(b"PNG"); print("drawn")'
    record, drawn = hook.run_script("plot_fake", ("fake.png",), examples=fake_script(tmp_path, body))
    assert record["executed"] is True and record["seconds"] >= 0
    assert record["stdout"] == "mesh coarse out gallery-out\ndrawn\n"
    assert record["command"] == "python examples/plot_fake.py --mesh coarse --out gallery-out"
    assert drawn == {"fake.png": b"PNG"}
    text = hook.snippet(record)
    assert "    mesh coarse out gallery-out\n    drawn\n" in text and f"{record['seconds']:.1f} s" in text


def test_run_script_failure_raises_with_stderr_tail(hook, tmp_path):
    body = 'print("first line of stderr", file=sys.stderr); sys.exit("solver diverged")'
    with pytest.raises(hook.GalleryError, match=r"(?s)failed \(exit 1\).*first line.*solver diverged"):
        hook.run_script("plot_fake", (), examples=fake_script(tmp_path, body))


def test_run_script_missing_figure_raises(hook, tmp_path):
    body = 'a.out.mkdir(); (a.out / "other.png").write_bytes(b"PNG")'
    with pytest.raises(hook.GalleryError, match="did not draw fake.png"):
        hook.run_script("plot_fake", ("fake.png",), examples=fake_script(tmp_path, body))


def test_run_script_timeout_raises(hook, tmp_path):
    body = "import time; time.sleep(30)"
    with pytest.raises(hook.GalleryError, match="did not finish in 1 s"):
        hook.run_script("plot_fake", (), examples=fake_script(tmp_path, body), timeout=1.0)


def test_stored_figures_are_the_files(hook):
    stem, figures = next(iter(hook.EXECUTED.items()))
    record, content = hook.stored_figures(stem, figures)
    assert record["executed"] is False and "FSISTAB_DOCS_EXECUTE=0" in hook.snippet(record)
    assert content == {n: (ROOT / "docs" / "gallery" / "figures" / n).read_bytes() for n in figures}
