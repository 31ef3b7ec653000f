"""One parser per command, light to import: the handler each names is imported only when it
runs (``grouptron.cli.app``)."""
