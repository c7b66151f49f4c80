"""``python -m evtribo``: the command line (importing this module runs nothing)."""

from evtribo.cli import entry

if __name__ == "__main__":
    entry()
