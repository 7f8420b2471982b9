"""argparse types of the ``cacas`` command's options: a value argparse refuses is said in one line
naming the option and what is valid (``cacas: error: argument --seed: '-1' is not ...``), exit
code 2, before any work begins."""

from __future__ import annotations

import argparse
from pathlib import Path


def integer(text: str) -> int:
    """Any whole number (a range the command checks itself, with its own message)."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number; valid: e.g. 7") from None


def number(example: str):
    """A number (its range the command checks itself); ``example`` says what a valid one looks like."""
    def parse(text: str) -> float:
        try:
            return float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number; valid: {example}") from None
    parse.__name__ = "number"
    return parse


share = number("a share such as 0.1")


def between(minimum: float, maximum: float):
    """A number from ``minimum`` to ``maximum`` (both valid); its ``valid`` says so, for the
    option's help and its messages (the library's own range, e.g. a synthetic clip's seconds)."""
    valid = f"a number from {minimum:g} to {maximum:g}"

    def parse(text: str) -> float:
        value = number(valid)(text)
        if not minimum <= value <= maximum:  # NaN too
            problem = "not a number" if value != value else f"too {'small' if value < minimum else 'large'}"
            raise argparse.ArgumentTypeError(f"{text!r} is {problem}; valid: {valid}")
        return value
    parse.__name__ = parse.valid = valid
    return parse


def at_least(minimum: int, maximum: int | None = None):
    """A whole number >= ``minimum`` (and <= ``maximum``): a count of epochs, clips, copies: 1 and up;
    a seed: 0 to 2**32 - 1, what the random generators take. Its ``valid`` says so, for the
    option's help (:func:`described`) and its messages."""
    valid = f"a whole number >= {minimum}" if maximum is None else f"a whole number from {minimum} to {maximum}"

    def parse(text: str) -> int:
        value = integer(text)
        if value < minimum or (maximum is not None and value > maximum):
            raise argparse.ArgumentTypeError(f"{text!r} is too {'small' if value < minimum else 'large'}; "
                                             f"valid: {valid}")
        return value
    parse.__name__ = parse.valid = valid
    return parse


seed = at_least(0, 2**32 - 1)
count = at_least(1)


def described(what: str, kind, default) -> str:
    """An option's help naming its valid values as its type checks them: ``described("clips per
    activity", count, 24)`` -> "clips per activity; valid: a whole number >= 1 (default 24)"."""
    return f"{what}; valid: {kind.valid} (default {default})"


def path(text: str) -> Path:
    """A file or folder path, not empty (an empty one was read as the current folder, or as not
    given at all)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; valid: a file or folder path")
    return Path(text)


def database_file(text: str) -> Path:
    """A study database file to write, its path not ending in a separator: "newdir/" reads as a folder, and it
    made a file named "newdir" (review)."""
    p, given = path(text), text.rstrip()
    folder = given.rstrip("/\\")
    if folder != given:
        raise argparse.ArgumentTypeError(f"{text!r} ends in {given[-1]!r}, a folder; valid: a file path, "
                                         f"e.g. {folder or 'results'}/study.sqlite")
    return p


def png(text: str) -> Path:
    """A file path ending in .png (the confusion matrix is drawn as PNG)."""
    p = path(text)
    if p.suffix.lower() != ".png":
        raise argparse.ArgumentTypeError(f"{text!r} does not end in .png; valid: a PNG file path, e.g. "
                                         "confusion.png")
    return p
