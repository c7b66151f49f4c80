"""Small tools the other packages share: docstring parts, an exact fast median, running counts,
numbers printed for people."""
