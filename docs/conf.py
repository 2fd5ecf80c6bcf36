"""Sphinx configuration of the fecheck documentation site.

Sphinx with myst-parser (the pages are Markdown, read as they are), sphinx-gallery (the
examples in docs/examples/ run during the build and their pictures are captured),
autodoc/autosummary with napoleon (the API reference from the NumPy-style docstrings) and
the PyData theme: the stack pyvista and scikit-learn document themselves with.
Build: ``bash scripts/build_docs.sh`` (warnings are errors).
"""

from __future__ import annotations

import json
import os
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
sys.path.insert(0, str(REPO))
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("MPLBACKEND", "Agg")

from fecheck.cli import package_version  # noqa: E402

project = "fecheck"
author = "fecheck contributors"
copyright = "fecheck contributors; the lenhart2015 knee data: Apache-2.0"
release = package_version()
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_generated", "Thumbs.db", ".DS_Store", "examples/*",
                    "auto_examples/*.ipynb", "auto_examples/*.py", "auto_examples/*.zip",
                    "auto_examples/*.md5", "auto_examples/*.json"]

# --- Markdown (MyST) -----------------------------------------------------------------
myst_enable_extensions = ["colon_fence", "deflist", "substitution", "dollarmath"]
myst_heading_anchors = 3


def _verb_times() -> dict[str, str]:
    """``{{ time_VERB }}`` substitutions from docs/verb_times.json, which
    scripts/time_verbs.py writes by timing each verb on the shipped knee."""
    data = json.loads((DOCS / "verb_times.json").read_text(encoding="utf-8"))
    subs = {f"time_{verb.replace('-', '_')}": row["text"]
            for verb, row in data["verbs"].items()}
    subs["times_measured_on"] = data["machine"]
    return subs


myst_substitutions = _verb_times()

# --- API reference --------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
# a package's page documents what its modules define, not what it re-exports (__all__)
autodoc_default_options = {"members": True, "ignore-module-all": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
autodoc_mock_imports = ["fcl", "rtree", "dask", "distributed", "pydrake", "opensim"]
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
# a docstring's prose may name things in single backticks; they are not cross-references
default_role = "literal"
suppress_warnings = ["autosectionlabel.*"]

# --- gallery --------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
    "show_memory": False,
    # no sg_execution_times page: the Reference toctree globs the top-level pages
    "write_computation_times": False,
    "parallel": int(os.environ.get("FECHECK_DOCS_JOBS", "2")),
}

# --- HTML -----------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"fecheck {release}"
html_static_path = []
html_theme_options = {
    "navigation_depth": 2,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version", "theme-version"],
}
html_show_sourcelink = False

# --- docstrings -----------------------------------------------------------------------
_LITERAL = re.compile(r"(`+).+?\1")


def _escape_bars(text: str) -> str:
    """`text` with each | outside inline literals escaped: the docstrings write absolute
    values and norms as |x|, which reStructuredText would read as a substitution."""
    out, last = [], 0
    for match in _LITERAL.finditer(text):
        out += [text[last:match.start()].replace("|", "\\|"), match.group(0)]
        last = match.end()
    return "".join(out + [text[last:].replace("|", "\\|")])


_ITEM = re.compile(r"^([^\s:>*-][^:]*?) : (.+)$")


def _definition_lists(lines: list[str]) -> list[str]:
    """The docstrings' attribute lists (``name : meaning`` lines, their continuation
    indented) as reStructuredText definition lists (term line, indented meaning)."""
    out: list[str] = []
    in_list = False
    for line in lines:
        item = _ITEM.match(line)
        if item:
            if not in_list and out and out[-1].strip():
                out.append("")
            out += [item.group(1), "    " + item.group(2)]
            in_list = True
            continue
        if in_list and line.strip() and not line[0].isspace():
            out.append("")
        in_list = in_list and (not line.strip() or line[0].isspace())
        out.append(line)
    return out


def _plain_docstring(app, what, name, obj, options, lines: list[str]) -> None:
    lines[:] = _definition_lists([_escape_bars(line) for line in lines])


# --- the validation report -------------------------------------------------------------
REPORT = DOCS / "_generated" / "validation"
"""Where the gallery's validation example (plot_10) has `fecheck validate --quick` write."""
REPORT_MARK = "<!-- the report of fecheck validate --quick, inserted by conf.py -->"


def report_text(folder: Path = REPORT) -> str:
    """The report.md of `folder` as part of the validation-report page: its headings one
    level down, its pictures and CSV files (downloads) found from docs/."""
    if not (folder / "report.md").is_file():
        return "The report is written when the gallery's examples run (`plot_gallery=1`)."
    rel = folder.relative_to(DOCS).as_posix()
    text = (folder / "report.md").read_text(encoding="utf-8")
    text = re.sub(r"^#", "##", text, flags=re.MULTILINE)
    text = re.sub(r"!\[([^]]*)\]\(([^)/]+\.png)\)", rf"![\1]({rel}/\2)", text)
    return re.sub(r"(?<!!)\[([^]]*)\]\(([^)/]+\.csv)\)", rf"{{download}}`\1 <{rel}/\2>`", text)


def _insert_report(app, docname: str, source: list[str]) -> None:
    if docname == "validation-report":
        source[0] = source[0].replace(REPORT_MARK, report_text())


def setup(app) -> None:
    app.connect("source-read", _insert_report)
    app.connect("autodoc-process-docstring", _plain_docstring)
