"""The one error type for bad input: its message names what is wrong and what is valid."""

from __future__ import annotations

import difflib
import math
import re
from typing import Any, Callable, Mapping

import numpy as np


class CacasError(ValueError):
    """Bad input from a researcher (a file, a name, an argument).

    The message is one line meant for a person: it names the file / participant / preference /
    field at fault and what would be valid. The command line prints it and exits with code 2.
    """


class DamagedFile(CacasError):
    """A file's bytes are damaged; the message names the file (and the member of a zip) already, so
    it is passed on as it is, not put under the row or the file that asked for the bytes (an
    import reads a bundle's policy files as it restores the rows naming them)."""


class Problems(CacasError):
    """Several problems of one input found in one reading (a persona file's: walk3 mended three
    mistakes in three runs). ``str()`` is the one line a command prints: ``head``, their count, and
    each numbered, the first ``shown`` written out; :meth:`listed` is the same as a numbered
    Markdown list, one a line, for a page. A problem whose valid names repeat an earlier one's
    refers to it instead ("valid: as in problem 1"): the 33 activities once."""

    def __init__(self, head: str, lines: list[str], shown: int = 8):
        self.head, self.lines, self.shown = head, _said_once(lines), shown
        written = " ".join(f"[{n}] {line}" for n, line in enumerate(self.lines[:shown], 1))
        more = len(self.lines) - shown
        super().__init__(f"{head}{len(self.lines)} problems, each to mend: {written}"
                         + (f" [and {more} more]" if more > 0 else ""))

    def listed(self) -> str:
        """The problems as a numbered Markdown list under ``head`` (every one)."""
        return (f"{self.head}{len(self.lines)} problems, each to mend:\n\n"
                + "\n".join(f"{n}. {line}" for n, line in enumerate(self.lines, 1)))


def _said_once(lines: list[str]) -> list[str]:
    """``lines`` with a "; valid: ..." (or "? valid: ...") tail that an earlier line wrote already replaced by a reference to it."""
    first: dict[str, int] = {}
    out = []
    for n, line in enumerate(lines, 1):
        found = list(re.finditer(r"[;?] valid: ", line))
        valid = line[found[-1].end():] if found else None
        if valid in first:
            line = f"{line[:found[-1].end()]}as in problem {first[valid]}"
        elif valid is not None:
            first[valid] = n
        out.append(line)
    return out


def one_a_line(exc: Exception) -> str:
    """What a page shows for ``exc``: a :class:`Problems`' numbered list, else its one line."""
    return exc.listed() if isinstance(exc, Problems) else str(exc)


class AlreadyRecorded(CacasError):
    """The answer was already written (a second click, or another tab answered first): nothing
    more was written."""


class AlreadyAdapted(AlreadyRecorded):
    """The study day was adapted already (another tab or server adapted it first): nothing more
    was written (the policy that adaptation saved is a version of its own, in force unless rolled
    back since)."""


def case_twin(value: object, known) -> str | None:
    """The one name of ``known`` that equals ``value`` (surrounding spaces ignored) but for letter
    case, or None (none, or several: a restored backup may keep case twins)."""
    text = str(value).strip()
    twins = [str(k) for k in known if str(k).casefold() == text.casefold() and str(k) != text]
    return twins[0] if len(twins) == 1 else None


def did_you_mean(value: object, known) -> str:
    """``"did you mean 'P01'? "`` when :func:`case_twin` finds one, else ``""``: the start of an
    unknown-name message's hint. Participant codes and study names cannot differ only in letter
    case (new ones that would are refused), so "p01" for "P01" is a typing slip. The lookup itself
    stays exact: a stored code is never changed, nor matched without the researcher's word."""
    twin = case_twin(value, known)
    return f"did you mean {twin!r}? " if twin is not None else ""


def closest_name(value: object, known) -> str | None:
    """The one name of ``known`` close to ``value`` (letter case and repeated blanks ignored; difflib's ratio of
    at least 0.8: a letter added, dropped or changed, a missing space; else a plural for a singular name, or what
    someone is doing for the name of it, 'coughing' for 'cough'), or None: the hint of :func:`nearest`."""
    if not isinstance(value, str):
        return None
    canon = lambda text: " ".join(str(text).casefold().split())  # noqa: E731
    names = {canon(k): str(k) for k in known}
    close = difflib.get_close_matches(canon(value), list(names), n=1, cutoff=0.8)
    if not close:  # a plural for a singular name: 'activities' for the field 'activity' (walkthrough)
        word = canon(value)
        singular = word[:-3] + "y" if word.endswith("ies") else word[:-1] if word.endswith("s") else None
        close = [singular] if singular in names else []
    if not close:  # what someone is doing for the name of it: 'coughing', 'snoring', 'cutting food' (walkthrough)
        close = [name for name in _verb_forms(canon(value)) if name in names][:1]
    return names[close[0]] if close else None


def nearest(value: object, known) -> str:
    """``"did you mean 'use scissor'? "`` when one name of ``known`` is close to ``value``
    (:func:`closest_name`), else ``""``: the hint of an unknown-name message, before its list of
    valid names (walkthrough: "unknown activity 'use scissors'" was followed by 33 names to search
    for the one meant). Only a hint: the name is still refused, never replaced."""
    close = closest_name(value, known)
    return f"did you mean {close!r}? " if close is not None else ""


def _verb_forms(text: str) -> list[str]:
    """``text`` with its first word's "-ing" taken off in each way English spells it: 'coughing' -> 'cough',
    'snoring' -> 'snore', 'cutting food' -> 'cut food' (and forms no name has, which find nothing)."""
    first, _, rest = text.partition(" ")
    if not first.endswith("ing") or len(first) < 5:
        return []
    stem = first[:-3]
    stems = [stem, stem + "e"] + ([stem[:-1]] if len(stem) > 2 and stem[-1] == stem[-2] else [])
    return [" ".join(filter(None, (s, rest))) for s in stems]


def not_utf8(data: bytes) -> str:
    """Why ``data``, which does not decode as UTF-8, is not UTF-8 text, in a researcher's words, for a message
    "<file>: cannot be read as UTF-8 text (<this>); valid: ...": saved as UTF-16 (its byte order mark: a
    spreadsheet's "Unicode text", older Notepad's "Unicode"), or not text at all (a NUL byte near its start: a
    picture, a zip), or in another encoding, naming the first byte that is not UTF-8 and its line (a file saved
    as Windows-1252 in a lab in Germany: "byte 0xf6 on line 5"; it only said "cannot be read as UTF-8 text")."""
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return "it is UTF-16 text, as a spreadsheet saves 'Unicode text' and older Notepad 'Unicode'"
    if b"\x00" in data[:1024]:
        return "it is not text"
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        return (f"byte 0x{data[exc.start]:02x} on line {line} is not UTF-8: it was saved in another encoding, such as "
                "Windows-1252")
    return "it is UTF-8 text"  # not called for such data


def visible(text: str) -> str:
    """``text`` with each character that would not show as itself written as Python writes it in a
    string (a line break ``\\n``, a tab ``\\t``, a no-break space ``\\xa0``, half of a character
    ``\\ud83d``): a code or a field name in a one-line message stays on its line and shows what it
    holds (CLI audit: an id "P0<line break>1" split the message over two lines)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def shortened(text: str, limit: int) -> str:
    """``text`` whole when it has at most ``limit`` characters, else its start cut at the last
    blank that keeps it and "..." within ``limit`` (a hard cut when one word is longer): a
    participant's words quoted in a message ("tell me to be careful...", not "tell me to be
    caref..."; walkthrough). Line breaks and runs of blanks are one space, and what else would not
    show is written :func:`visible`: the quote stays on the message's one line."""
    text = visible(" ".join(str(text).split()))
    if len(text) <= limit:
        return text
    room = max(limit - 3, 1)
    head = text[:room + 1]  # one more: a blank just after the cut means the last word is whole
    cut = head.rfind(" ")
    return (head[:cut] if cut > 0 else text[:room]).rstrip(" ,;:.") + "..."


def each(*checks: Callable[[], Any]) -> list:
    """Run every check (a function of no argument, such as ``lambda: age_range(x)``): their values in
    order, or one CacasError saying every problem found, joined by "; and ". A form with two wrong
    fields is told both at one save (walkthrough: the details form said the age range, then, at the
    next save, the notes)."""
    values, problems = [], []
    for check in checks:
        try:
            values.append(check())
        except CacasError as exc:
            problems.append(str(exc))
    if problems:
        raise CacasError("; and ".join(problems))
    return values


def check_fields(owner: object, rules: Mapping[str, tuple[Callable[[Any], bool], str]], prefix: str = "") -> None:
    """Every field of ``owner`` (a configuration) that fails its rule, said at once (:func:`each`):
    ``rules`` maps a field's name to (a test of its value, what is valid), and each failing one
    reads "<prefix><field> <value> is invalid; valid: <what>", e.g. "beta 1.5 is invalid; valid:
    a number from 0 to 1 (...)"."""
    def check(name: str, test: Callable[[Any], bool], valid: str) -> Callable[[], None]:
        def run() -> None:
            value = getattr(owner, name)
            if not test(value):
                raise CacasError(f"{prefix}{name} {value!r} is invalid; valid: {valid}")
        return run
    each(*(check(name, test, valid) for name, (test, valid) in rules.items()))


# Rules for check_fields: (a test of a value, what is valid)


def is_whole(value) -> bool:
    """A whole number (Python's or numpy's; not True or False)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def is_number(value) -> bool:
    """A finite number (Python's or numpy's; not True or False, NaN or infinity)."""
    return (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
            and math.isfinite(value))


def whole_from(minimum: int, what: str) -> tuple:
    """The rule of a whole number >= ``minimum`` (:func:`check_fields`), ``what``
    saying what it counts."""
    return (lambda v: is_whole(v) and v >= minimum), f"a whole number >= {minimum} ({what})"


def number_where(test, valid: str) -> tuple:
    """The rule of a finite number that passes ``test`` (:func:`check_fields`)."""
    return (lambda v: is_number(v) and bool(test(v))), valid


def share_rule(what: str) -> tuple:
    """The rule of a number from 0 to 1, ``what`` saying what it weighs."""
    return number_where(lambda v: 0 <= v <= 1, f"a number from 0 to 1 ({what})")
