"""Write docs/warnings.md from the catalogue of warnings (``evtribo.warning``).

    .venv/bin/python scripts/warnings_doc.py          # rewrite docs/warnings.md
    .venv/bin/python scripts/warnings_doc.py --check  # exit 1 when docs/warnings.md is out of date

``tests/warning/test_docs.py`` runs the check, so the page never disagrees with the catalogue.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from evtribo.warning.docs import page

PAGE = Path(__file__).parents[1] / "docs" / "warnings.md"


def main(argv: list[str] | None = None) -> int:
    """Write the page, or check it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only check the page is current")
    args = parser.parse_args(argv)
    text = page()
    if args.check:
        current = PAGE.read_text(encoding="utf-8") if PAGE.is_file() else ""
        if current != text:
            print(f"{PAGE} is out of date: python scripts/warnings_doc.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
