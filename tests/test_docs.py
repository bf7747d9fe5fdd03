"""The documentation: the Sphinx site builds with every warning an error (numpydoc's validation
of the public API included); every public name is on an API page and has an Examples section
whose examples run; every "§" a docstring, test or benchmark cites is a section of a method
page; and no page, docstring or message points at a file outside the repository."""

import doctest
import importlib.util
import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest

import kalmanfield as kf
from kalmanfield import experiments, trajectory

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
#: the files users and contributors read: sources, tests, benchmarks, pages
READ_FILES = sorted(
    [
        *(ROOT / "python" / "kalmanfield").rglob("*.py"),
        *(ROOT / "python" / "kalmanfield").rglob("*.pyi"),
        *(ROOT / "tests").rglob("*.py"),
        *(ROOT / "benches").glob("*.py"),
        *(ROOT / "benches").glob("*.rs"),
        *DOCS.rglob("*.md"),
        ROOT / "README.md",
        ROOT / "CHANGELOG.md",
    ]
)
#: the names the API pages document: every name of kalmanfield.__all__, and the functions and
#: classes of the subpackages that users import by their own path ("experiments.type_confusion",
#: the trajectory domain's result types and plots: "trajectory.plot_gains")
PUBLIC = {name: getattr(kf, name) for name in kf.__all__} | {
    f"{sub.__name__.rpartition('.')[2]}.{name}": getattr(sub, name)
    for sub in (experiments, trajectory)
    for name in sub.__all__
    if callable(getattr(sub, name)) and name not in kf.__all__
}
SECTION = re.compile(r"§(\d+(?:\.\d+)?)(?:[–-](\d+(?:\.\d+)?))?")
SOURCE_CITATION = re.compile(r"\[(?:P|K93|K95|F|I)\b[^\]]*\]")


def api_page_names() -> list[str]:
    """The names listed in the autosummary blocks of docs/api/*.md, relative to kalmanfield
    (a block under ``.. currentmodule:: kalmanfield.experiments`` lists
    "experiments.<name>")."""
    directive = re.compile(r"\.\. currentmodule:: (\S+)\n|\.\. autosummary::\n((?:   .*\n|\n)+)")
    names = []
    for page in sorted((DOCS / "api").glob("*.md")):
        prefix = ""
        for module, block in directive.findall(page.read_text()):
            if module:
                prefix = module[len("kalmanfield") :].lstrip(".")
                continue
            for line in block.splitlines():
                if line.strip() and not line.strip().startswith(":"):
                    names.append(f"{prefix}.{line.strip()}" if prefix else line.strip())
    return names


def test_api_pages_list_every_public_name_once():
    names = api_page_names()
    assert sorted(names) == sorted(PUBLIC)


@pytest.mark.parametrize("name", PUBLIC)
def test_public_name_has_an_examples_section(name):
    doc = inspect.getdoc(PUBLIC[name]) or ""
    assert re.search(r"^Examples\n-{8}", doc, re.M), f"{name} has no Examples section"


def public_members(obj):
    """`obj` and, for a class, its public methods (static and class methods included) and
    properties defined in kalmanfield (in the class or a kalmanfield base class)."""
    yield obj
    if inspect.isclass(obj):
        members = {}
        for cls in reversed(obj.__mro__):
            if cls.__module__.startswith("kalmanfield"):
                members |= vars(cls)
        for attr, member in members.items():
            if isinstance(member, (staticmethod, classmethod)):
                member = member.__func__
            if not attr.startswith("_") and (
                inspect.isfunction(member) or isinstance(member, property)
            ):
                yield member.fget if isinstance(member, property) else member


@pytest.mark.parametrize("name", PUBLIC)
def test_examples_run(name):
    finder = doctest.DocTestFinder(recurse=False)
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    runner = doctest.DocTestRunner(optionflags=flags)
    for member in public_members(PUBLIC[name]):
        for test in finder.find(member, f"kalmanfield.{name}", module=False, globs={}):
            runner.run(test)
    assert runner.failures == 0, f"{runner.failures} failing example(s) in {name} (output above)"


def method_sections() -> set[str]:
    """The section numbers of the method pages' headings ("## §1.3 …" → "1.3")."""
    found = set()
    for page in (DOCS / "methods").glob("*.md"):
        found |= set(re.findall(r"^#+ §(\d+(?:\.\d+)?)\b", page.read_text(), re.M))
    return found


def test_every_cited_section_is_on_a_method_page():
    sections = method_sections()
    missing = set()
    for path in READ_FILES:
        if path.suffix == ".md" and DOCS / "methods" in path.parents:
            continue
        text = SOURCE_CITATION.sub("", path.read_text(encoding="utf-8"))
        for match in SECTION.finditer(text):
            for number in filter(None, match.groups()):
                if number not in sections:
                    missing.add(f"§{number} ({path.relative_to(ROOT)})")
    assert not missing, f"cited sections without a method-page heading: {sorted(missing)}"


def test_nothing_points_outside_the_repository():
    outside = ["SPEC" + ".md", "SPEC" + " §", "../" + "shared", "/work" + "/", "seeds" + "/0"]
    hits = [
        f"{path.relative_to(ROOT)}: {word}"
        for path in READ_FILES
        if path.name != "test_docs.py"
        for word in outside
        if word in path.read_text(encoding="utf-8")
    ]
    assert not hits


def test_pictures_exist_and_are_small():
    linked = re.findall(r"\((docs/images/[^)\s]+\.png)\)", (ROOT / "README.md").read_text())
    assert linked, "the README shows no picture"
    for path in linked:
        assert (ROOT / path).is_file(), path
    for png in (DOCS / "images").glob("*.png"):
        assert png.stat().st_size < 200_000, f"{png.name} is {png.stat().st_size} bytes"


#: pages whose ```python blocks must run, each page's blocks in order in one namespace
CODE_PAGES = [ROOT / "README.md", DOCS / "getting_started.md", *sorted(DOCS.glob("guide/*.md"))]


@pytest.mark.parametrize("page", CODE_PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_code_blocks_run(page, monkeypatch, tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.S)
    if not blocks:
        pytest.skip("no Python block")
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    exec(compile("\n".join(blocks), str(page), "exec"), {"__name__": "__page__"})
    plt = pytest.importorskip("matplotlib.pyplot")
    plt.close("all")


SPHINX = ("sphinx", "myst_parser", "numpydoc", "pydata_sphinx_theme")


@pytest.mark.skipif(
    any(importlib.util.find_spec(m) is None for m in SPHINX),
    reason="the docs extra (sphinx, myst-parser, numpydoc, pydata-sphinx-theme) is not installed",
)
def test_site_builds_with_warnings_as_errors(tmp_path):
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
    command += ["-d", str(tmp_path / "doctrees"), str(DOCS), str(tmp_path / "html")]
    run = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    assert (tmp_path / "html" / "api" / "generated" / "kalmanfield.denoise.html").is_file()
