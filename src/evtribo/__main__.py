from evtribo.cli import entry

entry()
