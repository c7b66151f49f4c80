"""Sphinx configuration of evtribo's documentation site: ``make docs``.

The pages are the Markdown of ``docs/`` as GitHub shows them, read by MyST-Parser; the front
page is the README; the API reference comes from the numpydoc docstrings (autodoc +
numpydoc); ``examples/quickstart.ipynb`` is executed and rendered by MyST-NB. ``make docs``
builds with warnings as errors, so a broken link between pages, a missing anchor, a page
left out of the navigation, a docstring Sphinx cannot read or a notebook cell that fails
stops the build.
"""

from __future__ import annotations

import json
import logging
import os
import re
import sys
from pathlib import Path
from typing import Any

import evtribo

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

# the build says only what needs saying: a module the theme imports (a11y_pygments, through
# pygments' styles) sets the root logger up at INFO when nothing has, which printed every
# library's INFO (NumExpr's threads, the notebook client's kernel)
logging.basicConfig(level=logging.WARNING)

project = "evtribo"
author = "The evtribo developers"
copyright = "2026, the evtribo developers"
release = evtribo.__version__
version = release

extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc"]

# the pages: GitHub-flavoured Markdown; links to headings as GitHub writes them (#the-title)
myst_heading_anchors = 4
exclude_patterns = ["_build", "**.ipynb_checkpoints"]
templates_path = ["_templates"]

# the API reference: numpydoc's sections; types are in the docstrings, not repeated from
# the signature; members in the order of the source; a page per module, every submodule
# listed (autosummary), each page with the names of the module's __all__ (automodule)
autodoc_typehints = "none"
autodoc_member_order = "bysource"
autodoc_preserve_defaults = True
autosummary_generate = True
autosummary_ignore_module_all = True
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# the notebook: executed at every build, in this interpreter, a failing cell an error
nb_execution_mode = "force"
nb_execution_raise_on_error = True
nb_execution_timeout = 600
nb_merge_streams = True

html_theme = "furo"
html_title = f"evtribo {release}"
html_static_path: list[str] = []
html_show_sourcelink = False


#: A link in Markdown: [text](target), the target without a title.
_LINK = re.compile(r"(\]\()([^)\s]+)(\))")
#: Files of the repository's root that are pages of the site.
_PAGES = {"README.md": "index.md", "CHANGELOG.md": "changelog.md",
          "CONTRIBUTING.md": "contributing.md"}


def _outside_links(app: Any, relative_path: Path, parent_docname: str,
                   content: list[str]) -> None:
    """Links of a page included from outside docs/ (the README, the changelog, the guide to
    contributing) as they resolve from docs/: ``docs/x.md`` is the page ``x.md``, the
    README the front page, any other relative link a file of the repository (a download
    when it exists; a warning, as for any broken link, when it does not)."""
    source = (DOCS / relative_path).resolve()
    if source.parent == DOCS:
        return

    def resolved(match: re.Match[str]) -> str:
        target, _, anchor = match[2].partition("#")
        if not target or re.match(r"[a-z][a-z0-9+.-]*:|/", target):
            return match[0]
        path = (source.parent / target).resolve()
        page = _PAGES.get(path.name) if path.parent == ROOT else None
        link = page or os.path.relpath(path, DOCS)
        return f"{match[1]}{link}{'#' + anchor if anchor else ''}{match[3]}"

    content[0] = _LINK.sub(resolved, content[0])


def setup(app: Any) -> dict[str, Any]:
    """Register the rewriting of links in pages included from outside docs/."""
    app.connect("include-read", _outside_links)
    return {"parallel_read_safe": True}


def _kernel() -> None:
    """A Jupyter kernel named as the notebook asks (python3) that runs this interpreter,
    found before any other (the user's may run another Python, without evtribo), with
    inline figures and evtribo's cache under build/docs; its own log at errors only (it
    warned that it talks to the build over local TCP, which is how a notebook is run)."""
    folder = ROOT / "build" / "docs" / "jupyter"
    spec = folder / "kernels" / "python3"
    spec.mkdir(parents=True, exist_ok=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}",
                 "--IPKernelApp.log_level=ERROR"],
        "display_name": "Python 3 (evtribo docs)", "language": "python",
        "env": {"MPLBACKEND": "module://matplotlib_inline.backend_inline",
                # decoded trials kept with the build, not in the user's cache
                "EVTRIBO_CACHE_DIR": str(ROOT / "build" / "docs" / "cache")}}),
        encoding="utf-8")
    os.environ["JUPYTER_PATH"] = os.pathsep.join(
        [str(folder), *filter(None, [os.environ.get("JUPYTER_PATH")])])


_kernel()
