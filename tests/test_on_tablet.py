"""What each participant's tablet shows now (cacas.on_tablet)."""

from cacas.on_tablet import Asked, Shown, TabletBoard


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



def test_a_request_awaiting_confirmation_is_read_back_for_its_proposal_only():
    """A reloaded tablet asks again the request typed before the reload; not for another proposal."""
    board = TabletBoard()
    asked = Asked(1, 2, "3.6.20.2", "remind to turn off", "turn off the stove please")
    board.show("a.sqlite", "P01", _shown(2))
    board.ask("a.sqlite", "P01", asked)
    assert board.asked("a.sqlite", "P01", 1, 2, "3.6.20.2") == asked
    for other in ((1, 2, "3.6.20.3"), (1, 3, "3.6.20.2"), (2, 2, "3.6.20.2")):  # another context, interaction, day
        assert board.asked("a.sqlite", "P01", *other) is None
    assert board.asked("b.sqlite", "P01", 1, 2, "3.6.20.2") is None and board.asked("a.sqlite", "P02", 1, 2,
                                                                                    "3.6.20.2") is None
    board.show("a.sqlite", "P01", _shown(2))  # the same proposal drawn again (the reload) keeps it
    assert board.asked("a.sqlite", "P01", 1, 2, "3.6.20.2") == asked
    board.withdraw("a.sqlite", "P01")  # "No"
    assert board.asked("a.sqlite", "P01", 1, 2, "3.6.20.2") is None
    board.ask("a.sqlite", "P01", asked)
    board.show("a.sqlite", "P01", _shown(3))  # the next interaction: answered meanwhile
    assert board.asked("a.sqlite", "P01", 1, 2, "3.6.20.2") is None
    board.ask("a.sqlite", "P01", asked)
    assert board.pending("a.sqlite", "P01") == asked and board.pending("a.sqlite", "P02") is None  # any proposal's
    board.clear("a.sqlite", "P01")  # the tablet shows its form
    assert board.asked("a.sqlite", "P01", 1, 2, "3.6.20.2") is None and board.pending("a.sqlite", "P01") is None


def test_when_a_proposal_was_shown_is_said_in_utc_as_the_apps_other_times(monkeypatch):
    """On a server in Berlin, the researcher's view said "shown at 23:00" beside the Overview's "2026-11-27 22:00
    UTC" for the same moment (the server's local clock, its zone unsaid): every time the app shows is UTC and says so
    (app_support.short_time). Here the moment is 00:30 UTC on the day Berlin's clocks go forward (02:30 there)."""
    import calendar
    import time

    monkeypatch.setenv("TZ", "Europe/Berlin")
    time.tzset()
    try:
        since = calendar.timegm((2026, 3, 29, 0, 30, 0))
        assert Shown(1, 1, "cough", "bedroom", "00:00-02:00", "pain check", "line", since=since).shown_at == \
            "2026-03-29 00:30 UTC"
    finally:
        monkeypatch.undo()
        time.tzset()


def test_the_interaction_at_hand_keeps_the_policy_it_was_first_proposed_with():
    """lan's left-alone item: a policy put in force on the Adaptation page while a proposal awaited its
    answer ("in force from the next interaction") proposed again at the page's next draw, and the robot's
    line could change under the participant's eyes. The board holds the first (version, sha256) drawn
    for the interaction and its context until another is drawn; per participant and database."""
    board = TabletBoard()
    assert board.policy_for("a.sqlite", "P01", 1, 3, "ctx-a", (2, "sha-2")) == (2, "sha-2")
    assert board.policy_for("a.sqlite", "P01", 1, 3, "ctx-a", (1, "sha-1")) == (2, "sha-2")  # rolled back meanwhile
    assert board.policy_for("a.sqlite", "P02", 1, 3, "ctx-a", (1, "sha-1")) == (1, "sha-1")  # another participant
    assert board.policy_for("b.sqlite", "P01", 1, 3, "ctx-a", (1, "sha-1")) == (1, "sha-1")  # another database
    assert board.policy_for("a.sqlite", "P01", 1, 3, "ctx-b", (1, "sha-1")) == (1, "sha-1")  # another context
    assert board.policy_for("a.sqlite", "P01", 1, 4, "ctx-b", (None, None)) == (None, None)  # the next interaction
    assert board.policy_for("a.sqlite", "P01", 1, 4, "ctx-b", (1, "sha-1")) == (None, None)
    assert board.policy_for("a.sqlite", "P01", 2, 4, "ctx-b", (1, "sha-1")) == (1, "sha-1")  # the next day
