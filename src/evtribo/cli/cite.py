"""``evtribo cite [--bibtex]``: how to cite evtribo and the model it implements.

A paper whose numbers evtribo computed cites two works: the software, at the version that
computed them (``evtribo --version``; the report's provenance section names the versions
of the analysis, the fit and the report), and the seed paper whose model the fit uses.
Printed as text, or as BibTeX entries with ``--bibtex``; ``CITATION.cff`` in the source
repository holds the same.
"""

from __future__ import annotations

import argparse
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``cite``."""
    p = subparsers.add_parser("cite", help="how to cite evtribo and the model (text, BibTeX)",
                              description=__doc__.split("\n\n")[1].replace("\n", " "))
    p.add_argument("--bibtex", action="store_true",
                   help="BibTeX entries of both works instead of text")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Print the citations; return the exit code."""
    from evtribo.citation import PAPER, SOFTWARE, bibtex, text

    if args.bibtex:
        print(bibtex(SOFTWARE) + "\n" + bibtex(PAPER), end="")
        return 0
    print(f"If you publish results evtribo computed, please cite the software:\n\n"
          f"  {text(SOFTWARE)}\n\nand the model it fits:\n\n  {text(PAPER)}\n\n"
          "BibTeX: evtribo cite --bibtex")
    return 0
