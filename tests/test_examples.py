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
    for needed in ("Command-line equivalent", "fsistab ", "Mesh:", "REFERENCE.md §"):
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
