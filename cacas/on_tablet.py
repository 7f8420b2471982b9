"""What each participant's tablet shows now: the robot's proposal awaiting the participant's
answer (Section V-B.1: the participant sets the context on a tablet and answers the robot there).

The researcher's own view of the session reads it, so that it shows the proposal the participant
is answering and does not offer a second context form for the same interaction: two screens
proposing for one interaction recorded the researcher's answer in the participant's place, and
the participant's answer was then refused. One board lives in the server process and is shared by
its sessions (the app keeps it in a cached resource); nothing of it is written to the study
database, which records answers only.

The board also holds a request the participant typed that awaits their confirmation ("You would
like me to ... Is that right?"): a tablet's session lives in the browser's page, so a reload began
a new session and the request was gone, with the proposal's buttons back in its place. Held here
(in the server's memory only, until it is answered, withdrawn, or another proposal is shown), the
reloaded tablet asks it again.

The board also holds which policy version each participant's interaction at hand is proposed
with (:meth:`TabletBoard.policy_for`): a policy put in force on the Adaptation page while a proposal
awaits its answer is "in force from the next interaction", so the page drawn again (a request typed,
a reload) keeps the robot's line the participant is answering.

The board names a participant by code and by when they were added (:func:`board_name`): a
participant removed while their tablet showed a proposal left it here, and a new participant given
the same code opened their tablet on it.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field, replace


def board_name(store, code: str) -> str:
    """The participant ``code`` as the board names them: their code and when they were added
    (``created_at``, strictly increasing). A study day with several tablets (lan): P04 was removed
    while their tablet showed a proposal, and the next participant given the code P04 opened their
    tablet on it, the removed participant's context and the robot's line, to be answered as theirs
    (and the researcher's view and the Adaptation page spoke of it). A participant that is gone
    raises CacasError (:meth:`StudyStore.get_participant`)."""
    return f"{code} (added {store.get_participant(code).created_at})"


@dataclass(frozen=True)
class Shown:
    """A proposal on a participant's tablet: for interaction ``index`` of ``day``, in the context
    the participant set (activity, room, time of day; ``interval``: the time since their last
    activity, S4, as the tablet says it), the robot's ``action`` and ``line``; ``since`` is when
    it was first shown (seconds since the epoch; not part of equality, so a tablet drawing the
    same proposal again changes nothing). ``context`` is the context's address token: a tablet
    reopened at its plain address (the browser closed, or the address typed again) returns to
    this proposal instead of dropping it for an empty form."""

    day: int
    index: int
    activity: str
    scene: str
    time_slot: str
    action: str
    line: str
    interval: str = ""
    context: str = ""
    since: float = field(default=0.0, compare=False)

    @property
    def shown_at(self) -> str:
        """When it was first shown, in UTC as the app says every time ("2026-11-27 22:00 UTC",
        :func:`cacas.app_support.short_time`): the server's local clock, its zone unsaid, read
        "23:00" in Berlin beside the Overview's "22:00 UTC" for the same moment."""
        from cacas.app_support import short_time

        return short_time(self.since)


@dataclass(frozen=True)
class Asked:
    """A request typed on the tablet for the proposal of interaction ``index`` of ``day`` in the
    context ``context`` (its address token), matched to ``action``, in the participant's words
    ``said``, awaiting the participant's confirmation."""

    day: int
    index: int
    context: str
    action: str
    said: str


class TabletBoard:
    """Per (study database, participant): the proposal their tablet shows, or nothing. The pages
    name the participant by :func:`board_name`, not by code alone."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._shown: dict[tuple[str, str], Shown] = {}
        self._heard: set[tuple[str, str]] = set()  # tablets drawn (a proposal or a form) since this board began
        self._asked: dict[tuple[str, str], Asked] = {}
        # (day, index, context token) of the interaction at hand -> the policy (version, sha256) it is proposed with
        self._policies: dict[tuple[str, str], tuple[tuple[int, int, str], tuple]] = {}
        self.started = time.time()  # when this board (this server process) began

    def heard(self, db: str, participant: str) -> bool:
        """Whether the participant's tablet has been drawn since this board began: a server started
        afresh knows nothing of a proposal its predecessor showed until the tablet is used again (a
        page left open reconnects without being drawn), so its "nothing shown" means "not known"."""
        with self._lock:
            return (str(db), participant) in self._heard

    def show(self, db: str, participant: str, shown: Shown) -> None:
        """The tablet draws ``shown``: kept with the time it was first shown."""
        key = (str(db), participant)
        with self._lock:
            self._heard.add(key)
            held = self._shown.get(key)
            since = held.since if held == shown else time.time()
            self._shown[key] = replace(shown, since=since)
            asked = self._asked.get(key)
            if asked is not None and (asked.day, asked.index) != (shown.day, shown.index):
                del self._asked[key]  # of an interaction answered meanwhile

    def clear(self, db: str, participant: str) -> None:
        """The tablet shows no proposal (it was answered, or the participant went back to the form)."""
        with self._lock:
            self._heard.add((str(db), participant))
            self._shown.pop((str(db), participant), None)
            self._asked.pop((str(db), participant), None)

    def ask(self, db: str, participant: str, asked: Asked) -> None:
        """The participant typed a request the robot matched: it awaits their confirmation."""
        with self._lock:
            self._asked[(str(db), participant)] = asked

    def withdraw(self, db: str, participant: str) -> None:
        """No request awaits confirmation (answered, said "No" to, or the proposal left)."""
        with self._lock:
            self._asked.pop((str(db), participant), None)

    def asked(self, db: str, participant: str, day: int, index: int, context: str) -> Asked | None:
        """The request awaiting confirmation on the participant's tablet for this proposal (the
        interaction ``index`` of ``day`` in the context token ``context``), or None."""
        with self._lock:
            held = self._asked.get((str(db), participant))
        if held is None or (held.day, held.index, held.context) != (day, index, context):
            return None
        return held

    def pending(self, db: str, participant: str) -> Asked | None:
        """The request awaiting the participant's confirmation on their tablet, whatever its
        proposal: what the researcher's view says beside the proposal it follows."""
        with self._lock:
            return self._asked.get((str(db), participant))

    def shown(self, db: str, participant: str, day: int | None = None, index: int | None = None) -> Shown | None:
        """The proposal the participant's tablet shows; with ``day`` and ``index``, only if it is
        for that interaction (one already answered elsewhere, or of a closed day, is not)."""
        with self._lock:
            held = self._shown.get((str(db), participant))
        if held is None or (day is not None and held.day != day) or (index is not None and held.index != index):
            return None
        return held

    def policy_for(self, db: str, participant: str, day: int, index: int, context: str, in_force: tuple) -> tuple:
        """The policy (version, sha256) that proposes for interaction ``index`` of ``day`` in the
        context token ``context``: the one in force when it was first drawn (``in_force`` now, held
        until another interaction or context is drawn), so that a policy put in force meanwhile
        ("Put in force" on the Adaptation page: "in force from the next interaction") does not change
        the robot's line under the participant's eyes. One interaction is held per participant."""
        key, at = (str(db), participant), (day, index, context)
        with self._lock:
            held = self._policies.get(key)
            if held is not None and held[0] == at:
                return held[1]
            self._policies[key] = (at, tuple(in_force))
            return tuple(in_force)
