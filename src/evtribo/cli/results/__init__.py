"""Commands on a study's results: ``analyze``, ``compare``, ``report``, ``plot``, ``model``."""
