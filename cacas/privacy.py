"""Study data are pseudonymous: free text (notes, comments, a preference in the participant's own
words) must not hold contact details. One check, used by the study database and the persona files."""

from __future__ import annotations

import re

#: Contact details a note must not hold: an e-mail address, or a phone number (7 or more digits,
#: with spaces, dots, dashes, slashes, brackets or a leading +; a date such as 2026-11-21 or 21.11.2026 is not one).
_EMAIL_RE = re.compile(r"[\w.+-]+@[\w-]+\.[\w.-]+")
_PHONE_RE = re.compile(r"(?<![\w-])\+?\(?\d[\d\s()./-]{5,}\d(?![\w-])")
_DATE_TIME_RE = re.compile(r"\b(\d{4}[./-]\d{1,2}[./-]\d{1,2}|\d{1,2}[./-]\d{1,2}[./-]\d{4}|\d{1,2}:\d{2}(:\d{2})?)\b")


#: Characters that show nothing and would split an address or a number for the check ("jo\u200b@x.org").
_INVISIBLE_RE = re.compile("[\u00ad\u200b-\u200f\u2060\ufeff]")


def contact_details(value: str) -> str | None:
    """The first e-mail address or phone number in ``value``, or None (study data hold
    pseudonymous codes, never contact details). The text is read as it shows: full-width and
    other compatibility forms as their plain letters and digits (NFKC: "anna\uff20example.com"
    is an address) and invisible characters left out."""
    import unicodedata

    value = _INVISIBLE_RE.sub("", unicodedata.normalize("NFKC", value))
    email = _EMAIL_RE.search(value)
    if email:
        return email.group(0)
    for m in _PHONE_RE.finditer(_DATE_TIME_RE.sub(";", value)):  # dates and times apart
        if _looks_like_a_phone_number(m.group(0)):
            return m.group(0).strip()
    return None


def _looks_like_a_phone_number(text: str) -> bool:
    """7 or more digits in groups of which one has 3 or more ("555-1234", "+44 20 7946 0958"), or in pairs
    after a leading 0 or + ("06 12 34 56 78", also after a code of one or two digits: "+33 6 12 34 56
    78"). Runs of small numbers are not ("6-10 16-20" hours, "rated 8 9 10 8 7 9 10", "0-2 2-4 4-6 6-8"),
    nor lists with slashes ("0/10 3/10 4/10")."""
    groups = re.findall(r"\d+", text)
    if sum(map(len, groups)) < 7:
        return False
    if text.count("/") > 1:  # "06/08 08/10", "0.91/0.85/0.73", "01/02/03": lists, not a number
        return False
    lead = text.lstrip(" (")
    if max(map(len, groups)) >= 3:
        return True
    # after a leading 0 or +: in pairs ("06 12 34 56 78"), or a country or area code of one or two
    # digits and then pairs ("+33 6 12 34 56 78", "0 30 / 12 34 56 78"); hour ranges, scores and
    # decimals have single digits among the rest ("0-2 2-4 4-6", "0.25 0.5 0.75")
    return lead[:1] in ("0", "+") and (all(len(g) == 2 for g in groups)
                                       or (len(groups) >= 5 and all(len(g) == 2 for g in groups[2:])))
