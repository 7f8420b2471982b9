"""What each participant's tablet shows now (cacas.on_tablet)."""

from cacas.on_tablet import Shown, TabletBoard


def _shown(index=1, line="Shall I remind you to turn the stove off?"):
    return Shown(1, index, "use stove", "kitchen", "08:00-10:00", "remind to turn off", line)


def test_a_proposal_shown_is_read_back_for_its_interaction_only():
    board = TabletBoard()
    assert board.shown("a.sqlite", "P01") is None
    board.show("a.sqlite", "P01", _shown(2))
    assert board.shown("a.sqlite", "P01") == _shown(2)
    assert board.shown("a.sqlite", "P01", day=1, index=2) == _shown(2)
    assert board.shown("a.sqlite", "P01", day=1, index=3) is None  # interaction 2 was answered elsewhere
    assert board.shown("a.sqlite", "P01", day=2, index=2) is None
    assert board.shown("a.sqlite", "P02") is None and board.shown("b.sqlite", "P01") is None  # per database
    board.clear("a.sqlite", "P01")
    assert board.shown("a.sqlite", "P01") is None
    board.clear("a.sqlite", "P01")  # clearing nothing is fine


def test_a_board_knows_which_tablets_it_has_heard_from():
    """A server started afresh has heard from no tablet: its "nothing shown" is "not known" until the
    tablet draws a proposal or its form."""
    board = TabletBoard()
    assert not board.heard("a.sqlite", "P01") and board.started > 0
    board.show("a.sqlite", "P01", _shown())
    board.clear("a.sqlite", "P02")  # P02's tablet drew its form
    assert board.heard("a.sqlite", "P01") and board.heard("a.sqlite", "P02")
    assert not board.heard("b.sqlite", "P01")
    board.clear("a.sqlite", "P01")
    assert board.heard("a.sqlite", "P01")  # answered: still heard from


def test_drawing_the_same_proposal_again_keeps_when_it_was_first_shown():
    board = TabletBoard()
    board.show("a.sqlite", "P01", _shown())
    first = board.shown("a.sqlite", "P01").since
    assert first > 0
    board.show("a.sqlite", "P01", _shown())  # the tablet reruns (a choice in the request list)
    assert board.shown("a.sqlite", "P01").since == first
    board.show("a.sqlite", "P01", _shown(line="Shall I set a timer?"))  # another proposal
    assert board.shown("a.sqlite", "P01").line == "Shall I set a timer?"
    assert board.shown("a.sqlite", "P01").since >= first

