"""errors: message helpers (a participant's words quoted shortened at a word's end)."""

import pytest

from cacas.errors import CacasError, shortened, visible
from cacas.preferences import check_private_words, parse_personas


@pytest.mark.parametrize("text, limit, expected", [
    ("When I dry my hair, tell me to be careful with the plug", 43, "When I dry my hair, tell me to be..."),
    ("When I cough, check whether I am in pain.", 43, "When I cough, check whether I am in pain."),  # fits: whole
    ("  padded  ", 43, "padded"),
    ("x" * 80, 43, "x" * 40 + "..."),  # one word longer than the room: cut where it must be
    ("call for help, now please", 18, "call for help..."),  # no comma left before the dots
    ("one two", 6, "one..."),  # a blank just after the cut: the word before it is whole
])
def test_shortened_cuts_at_the_end_of_a_word_within_the_limit(text, limit, expected):
    out = shortened(text, limit)
    assert out == expected and len(out) <= limit


@pytest.mark.parametrize("text, expected", [
    ("line one\nline two", "line one line two"),  # a description's line break: one space, on the message's line
    ("  two\t\tblanks \u00a0 here ", "two blanks here"),
    ("half \ud83d of a smile", "half \\ud83d of a smile"),  # half of a character, as it is written in JSON
])
def test_shortened_keeps_a_quote_on_one_line(text, expected):
    assert shortened(text, 43) == expected


@pytest.mark.parametrize("text, expected", [
    ("P0\n1", "P0\\n1"),
    ("act\tion", "act\\tion"),
    ("P\u00a001", "P\\xa001"),  # a no-break space, which looks like a blank and is not one
    ("P\ud800", "P\\ud800"),
    ("Küche, café 😀 'x'", "Küche, café 😀 'x'"),  # what shows as itself is kept
])
def test_visible_writes_what_would_not_show_as_its_escape(text, expected):
    assert visible(text) == expected


def test_a_preference_quoted_in_a_message_is_cut_at_a_word_end():
    """Walkthrough: 'preference 3 ("When I dry my hair, tell me to be caref...")'."""
    doc = {"participants": [{"id": "P01", "preferences": [
        {"description": "When I dry my hair, tell me to be careful, my number is +44 20 7946 0958",
         "activity": ["use hair dryer"], "action": "remind to unplug"}]}]}
    with pytest.raises(CacasError) as err:
        check_private_words(parse_personas(doc, "f.json")[0], "f.json")
    assert 'preference 1 ("When I dry my hair, tell me to be..."), field' in str(err.value)
