"""The one error type for bad input: its message names what is wrong and what is valid."""


class CacasError(ValueError):
    """Bad input from a researcher (a file, a name, an argument).

    The message is one line meant for a person: it names the file / participant / preference /
    field at fault and what would be valid. The command line prints it and exits with code 2.
    """


class AlreadyRecorded(CacasError):
    """The answer was already written (a second click, or another tab answered first): nothing
    more was written."""


class AlreadyAdapted(AlreadyRecorded):
    """The study day was adapted already (another tab or server adapted it first): nothing more
    was written (the policy that adaptation saved is a version of its own, in force unless rolled
    back since)."""
