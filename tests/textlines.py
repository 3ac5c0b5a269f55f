"""Lines of a command's output that must fit a terminal's width.

A line naming output files, ``label: /a/path[, /another]``, is printed whole (a path broken
over two lines cannot be copied: ``roverimpact.cli._app.print_paths``) and left to the
terminal's own soft wrap; every other line must fit.
"""

from __future__ import annotations

import re

#: ``label: /absolute/path ...``
PATH_LINE = re.compile(r"^[\w .^-]+: /")


def fitted_lines(out: str) -> list[str]:
    """The lines of ``out`` that must fit the width: all but the path lines."""
    return [ln for ln in out.splitlines() if not PATH_LINE.match(ln)]
