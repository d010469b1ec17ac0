"""The ``pincal`` command line: :mod:`~pincal.cli.app` builds the parser and runs a command; each command group
has a module (:mod:`~pincal.cli.view`, :mod:`~pincal.cli.report_page`, :mod:`~pincal.cli.planning`), and
:mod:`~pincal.cli.arguments` holds the options they share."""
