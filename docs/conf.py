"""Sphinx configuration of the sassi_bench documentation site.

Build: ``pip install -e ".[docs]"`` then ``sphinx-build -W docs docs/_build/html``. Pages
are MyST Markdown; the API reference is generated from the numpydoc docstrings; the
notebooks of ``notebooks/`` are copied in, with the outputs of their run on the virtual
bench (``docs/_data/notebooks/``, written by ``benchmarks/render_notebooks.py``) while
their code is what ran; nothing is executed while building.
"""

from __future__ import annotations

import json
from pathlib import Path

from sphinx.util import logging

import sassi_bench

logger = logging.getLogger(__name__)

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

project = "sassi_bench"
author = "sassi_bench developers"
copyright = "sassi_bench developers"
release = sassi_bench.__version__ if hasattr(sassi_bench, "__version__") else ""

extensions = [
    "myst_nb",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.viewcode",
]

# .rst first: autosummary writes its generated API pages with the first suffix.
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "_data", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
templates_path = ["_templates"]

# Notebooks: shown with the outputs of benchmarks/render_notebooks.py, never run here.
nb_execution_mode = "off"
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# API reference: one page per module, generated from the docstrings.
autosummary_generate = True
autosummary_imported_members = False
# Each object on the page of the module that defines it: a package's face re-exports
# names in its __all__, which would describe them twice.
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
autodoc_mock_imports = ["torch", "fast_slic", "cupy"]
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

intersphinx_mapping: dict[str, tuple[str, None]] = {}

html_theme = "pydata_sphinx_theme"
html_title = "sassi_bench"
html_static_path = ["_static"]
html_css_files = ["tables.css"]
html_theme_options = {
    "header_links_before_dropdown": 5,
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"index": []}
html_show_sourcelink = False


RENDERED = DOCS / "_data" / "notebooks"


def _ran_this_code(ran: dict, book: dict) -> bool:
    """Whether the executed notebook ``ran`` has the code cells of ``book``: the same
    sources, the parameters cell's followed only by the settings the run added."""
    ran_code = [cell for cell in ran["cells"] if cell["cell_type"] == "code"]
    code = [cell for cell in book["cells"] if cell["cell_type"] == "code"]
    if len(ran_code) != len(code):
        return False
    for executed, cell in zip(ran_code, code, strict=True):
        source, executed_source = "".join(cell["source"]), "".join(executed["source"])
        if "parameters" in cell["metadata"].get("tags", []):
            if not executed_source.startswith(source):
                return False
        elif executed_source != source:
            return False
    return True


def with_outputs(notebook: Path, rendered: Path = RENDERED) -> tuple[str, bool]:
    """The notebook to show for ``notebook``: its text and code with the outputs of its
    executed copy in ``rendered`` (and the settings that run added to its parameters
    cell), when that copy ran exactly this code; else the notebook as it is. Returns the
    notebook's JSON and whether it has the outputs.
    """
    book = json.loads(notebook.read_text(encoding="utf-8"))
    copy = rendered / notebook.name
    if not copy.is_file():
        return json.dumps(book, indent=1, ensure_ascii=False) + "\n", False
    ran = json.loads(copy.read_text(encoding="utf-8"))
    if not _ran_this_code(ran, book):
        return json.dumps(book, indent=1, ensure_ascii=False) + "\n", False
    ran_code = [cell for cell in ran["cells"] if cell["cell_type"] == "code"]
    code = [cell for cell in book["cells"] if cell["cell_type"] == "code"]
    for cell, executed in zip(code, ran_code, strict=True):
        cell["outputs"] = executed["outputs"]
        cell["execution_count"] = executed["execution_count"]
        if "parameters" in cell["metadata"].get("tags", []):
            cell["source"] = executed["source"]
    return json.dumps(book, indent=1, ensure_ascii=False) + "\n", True


def _copy_notebooks() -> None:
    """Copy the guided notebooks into the source tree (they live in ``notebooks/``), each
    with its outputs when its executed copy ran its present code (:func:`with_outputs`)."""
    target = DOCS / "_notebooks"
    target.mkdir(exist_ok=True)
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        text, rendered = with_outputs(notebook)
        if not rendered:
            logger.info(f"{notebook.name}: shown without outputs (no executed copy of this code)")
        copy = target / notebook.name
        if not copy.exists() or copy.read_text(encoding="utf-8") != text:
            copy.write_text(text, encoding="utf-8")


def _unlisted_pages_glob(app, docname: str, source: list[str]) -> None:
    """Keep a table of contents' closing ``*`` glob only while it has pages to pick up.

    The indexes list their pages in order and end with ``*``, so a page added to their
    folder later appears with no index edit; with no such page, the glob would match
    nothing, which Sphinx reports as a warning (and ``-W`` as an error).
    """
    if "```{toctree}" not in source[0] or "\n*\n" not in source[0]:
        return
    folder = docname.rpartition("/")[0]
    prefix = f"{folder}/" if folder else ""
    body = source[0].split("```{toctree}", 1)[1].split("```", 1)[0]
    listed = {prefix + line.strip() for line in body.splitlines() if line.strip()}
    siblings = {
        name
        for name in app.env.found_docs
        if name.startswith(prefix) and "/" not in name[len(prefix) :] and name != docname
    }
    if not siblings - listed:
        source[0] = source[0].replace("\n*\n", "\n", 1)


def _skip_foreign_members(app, what, name, obj, skip, options):
    """Leave out what a module imports from other packages (scipy's cKDTree, say)."""
    module = getattr(obj, "__module__", None)
    if what == "module" and isinstance(module, str) and not module.startswith("sassi_bench"):
        return True
    return None


def setup(app):
    _copy_notebooks()
    app.connect("source-read", _unlisted_pages_glob)
    app.connect("autodoc-skip-member", _skip_foreign_members)
