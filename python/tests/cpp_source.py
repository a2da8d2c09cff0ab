"""The executable's source as tests read it: tables kept in C++ that the analysis must match."""
import os

REPOSITORY = os.path.join(os.path.dirname(__file__), "..", "..")


def source_part(path, start, end, after=None):
    """The text of REPOSITORY/`path` from the first `start` (or from the first `after` that
    follows `start`) up to the first `end` after it, `end` left out. Raises ValueError naming the
    file when a mark is missing, so that a renamed function fails the test that reads it."""
    with open(os.path.join(REPOSITORY, path), encoding="utf-8") as f:
        text = f.read()
    try:
        part = text[text.index(start):]
        if after is not None:
            part = part[part.index(after):]
        return part[:part.index(end)]
    except ValueError:
        raise ValueError(f"{path}: no {start!r} ... {end!r} (after {after!r}) in the source") \
            from None
