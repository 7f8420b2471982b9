"""How wide the pages draw their tables and grids (Streamlit's data grid, the photo grid): each column's
width in px from its longest heading or cell, fitted to the room a page has beside the sidebar at
1280 x 800 (measured in headless Chromium), and rows tall enough to wrap where a column cannot fit.
A participant column or a photo is as wide as keeps the longest code or file name on one line (:func:`text_width`).
No streamlit: the pages pass these to ``st.dataframe``'s column_config and ``st.image``.
"""

from __future__ import annotations

import math
import unicodedata

from cacas.store.validate import CODE_RE


#: The width (px) the researcher's table of today's interactions has on the Study session page at 1280 x 800,
#: beside the sidebar (measured in headless Chromium).
TODAY_TABLE_ROOM = 784

#: The padding (px) of a data grid's cell, 8 px a side: a column shows its width less this of text.
CELL_PADDING = 16

#: The width (px) of each character in Streamlit's 14-px Source Sans (the data grid's cells, a photo's caption), rounded
#: up by group (measured in headless Chromium, ten of each with canvas measureText: "m" 11.61, "W" 11.004, "O" 9.30,
#: "d" 7.77, digits and "_" 6.96-7.00, "r" 4.86, "(" 4.24, "i" 3.44, "." 3.49, " " 2.80); an accented letter
#: counts as its letter ("é" 6.94, "e" 6.94), another character as the widest ("@" 11.86).
_CHARACTERS = ((3.7, "Iijl.,;' !"), (4.9, "frt-()[]{}"), (7.0, "0123456789_FJLYceksvxyz+=#~$^"),
               (8.0, "ACEPRSTVXZabdghnopqu`"), (9.3, "BDGHKNOQU&"), (11.1, "MWw"), (11.7, "m%"))
_CHARACTER_WIDTH = {c: w for w, chars in _CHARACTERS for c in chars}
_WIDEST_CHARACTER = 12.0
#: A wide or full-width character (Japanese, Chinese, Korean: east_asian_width W or F) is one em, 14 px, in every font
#: that has it (their glyphs are drawn on the em square; this machine's Chromium has no such font to measure), and
#: an emoji or other symbol up to 1.25 em (Noto Color Emoji's advance), 18 px: a photo named "台所の写真.jpg" (kept
#: so since its letters are) was counted 12 px a character, and its caption broke under a photo fitted to it.
_EM, _SYMBOL = 14.0, 18.0


def _character_width(c: str) -> float:
    if unicodedata.category(c) == "So":
        return _SYMBOL
    if unicodedata.east_asian_width(c) in "WF":
        return _EM
    return _CHARACTER_WIDTH.get(c) or _CHARACTER_WIDTH.get(unicodedata.normalize("NFKD", c)[:1], _WIDEST_CHARACTER)


def text_width(text: str) -> float:
    """A text's width (px) in Streamlit's 14-px Source Sans (a participant code in the data grid, a photo's file name
    under it), never less than Chromium draws it, each character rounded up within its group: the widest
    16-character code, "mmmmmmmmmmmmmmmm", 185.7 px measured, 187.2 estimated; "participant_0001" 99.3, 104.1;
    "P01" 21.8, 22.0; "synthetic_0_000.jpg" 117.7, 122.9; "IMG_20260301_101500.jpg" 156.0, 159.5."""
    return sum(_character_width(c) for c in str(text))


def code_column(codes, least: int) -> int:
    """The width (px) of a participant column that keeps each of ``codes`` whole on one line, ``least`` at least
    (what the column's heading and other values need)."""
    return max([least] + [math.ceil(text_width(c)) + CELL_PADDING for c in codes])


#: The widths (px) of the Overview's recent activity (:func:`cacas.recent_activity.recent_events`): a time ("2026-11-27 10:55 UTC", 125 px
#: in the data grid's 14-px Source Sans, measured in Chromium) and "999 participants" (94 px; a method comparison's
#: line) each whole, with the grid's 8 px of padding a side: "participant" had 85 px and showed "2 participants"
#: cut at its "s" (the ui helper), "when" 165 with 30 to spare. "what" takes the rest of the page's width.
RECENT_ACTIVITY_WIDTHS = {"when": 145, "participant": 110}


def recent_activity_layout(participants, what=()) -> tuple[dict[str, int], int | None]:
    """How the Overview draws its recent activity, whose participant column holds ``participants`` (codes, or
    "2 participants" for a line of several) and whose "what" holds ``what``: each column's width (px) and the row
    height (px; None: one line). :data:`RECENT_ACTIVITY_WIDTHS`, the participant column widened to keep a longer
    code whole (:func:`code_column`; 16 characters: up to 204 px), and "what" the rest of
    :data:`OVERVIEW_TABLE_ROOM`: it had 640 px, so the table (895 px) scrolled sideways at 1280 px, "what" cut at the
    page's edge. A line longer than its column wraps (rows of :data:`WRAPPING_ROW`, only then)."""
    widths = dict(RECENT_ACTIVITY_WIDTHS)
    widths["participant"] = code_column([p for p in participants if CODE_RE.fullmatch(str(p))], widths["participant"])
    widths["what"] = OVERVIEW_TABLE_ROOM - widths["when"] - widths["participant"]
    longest = max((text_width(w) for w in what), default=0)
    return widths, (WRAPPING_ROW if longest + CELL_PADDING > widths["what"] else None)


#: The width (px) of the Overview page's table of participants at 1280 x 800, beside the sidebar (measured in
#: headless Chromium: 820 px, its 1-px borders included).
OVERVIEW_TABLE_ROOM = 818

#: The width (px) of the Participants page's table of saved preferences at 1280 x 800, beside the sidebar, and of
#: an earlier version's inside its expander (measured in headless Chromium: 820 and 786 px, borders included).
PREFERENCES_TABLE_ROOM = 818
EARLIER_PREFERENCES_ROOM = 784

#: The row height (px) at which Streamlit's data grid lets a cell's text wrap (only in rows over 4rem, 64 px):
#: three lines, so that what is longer than its column wraps instead of being cut.
WRAPPING_ROW = 66


#: The data grid's height (px) above and around its rows: the header row (35 px) and its borders.
GRID_FRAME = 38


def table_height(rows: int, row_height: int | None, most: int = 10) -> int | str:
    """The height (px) of a data grid that shows up to ``most`` of its ``rows`` whole, rows of ``row_height`` px
    (None: Streamlit's 35, and its own height, "auto": it shows 10 of them). Wrapping rows of :data:`WRAPPING_ROW`
    left Streamlit's height showing 5 (scale walk: 5 of 60 participants on the Overview)."""
    if row_height is None:
        return "auto"
    return GRID_FRAME + row_height * max(1, min(rows, most))


def fitted_layout(widths: dict[str, int], columns, room: int) -> tuple[dict[str, int], int]:
    """A data grid's layout in which every column is in view: the pixel widths of the ``columns``
    shown (``widths``: each column's, chosen so that a name stays whole on one line), which together
    fit ``room`` (the table stretches them on a wider page), and rows of :data:`WRAPPING_ROW`, so
    that a longer value wraps instead of being cut. Raises ValueError when they do not fit."""
    chosen = {c: w for c, w in widths.items() if c in columns}
    if sum(chosen.values()) > room:
        raise ValueError(f"columns of {sum(chosen.values())} px in all do not fit {room} px")
    return chosen, WRAPPING_ROW


def today_table_layout(columns) -> tuple[dict[str, int | str], int | None]:
    """How the Study session page draws the researcher's table of today's interactions
    (:func:`cacas.app_support.interactions_view` of one day, its columns ``columns``): each column's width (px, or
    Streamlit's "medium") and the row height (px; None: one line). Without what the robot heard and
    saw, every value fits on one line beside narrow "#", time and interval columns, the answer
    given room ("asked for remind to take medicine" whole). With them, nine columns need about
    1,000 px on one line, more than the page has at 1280 px: the walkthrough saw "robot saw" off the
    right edge at 1280 px and "use hair dryer", "living room" cut at 1440 px (the data grid's own
    widths), while the answer had room to spare. Then every column has a width of its own, the
    widths together fit :data:`TODAY_TABLE_ROOM` (:func:`fitted_layout`): a name on one line ("use
    hair dryer", "living room"), a proposal or an answer on two or three."""
    if "robot heard" not in columns and "robot saw" not in columns:
        return {"#": 40, "time of day": 90, "since last activity": 80, "answer": "medium"}, None
    widths = {"#": 32, "activity": 100, "robot proposed": 106, "answer": 106, "time of day": 88,
              "since last activity": 74, "room": 88, "robot heard": 100, "robot saw": 88}
    return fitted_layout(widths, columns, TODAY_TABLE_ROOM)


def overview_table_layout(columns, codes=()) -> tuple[dict[str, int], int]:
    """How the Overview page draws its table of participants (:func:`overview_frame`'s ``columns``
    that it shows, its participants' ``codes``): each column's width (px) and the row height (px). On one
    line the six columns need about 870 px ("Start day 1 on the tablet (Study session)", "version 1 (newest: 2)",
    "2026-11-21 09:47 UTC", the "success rate so far" bar), more than the table has at 1280 px: the
    ui helper saw "last recorded" cut at the right edge. The widths fit :data:`OVERVIEW_TABLE_ROOM`
    (:func:`fitted_layout`): a code, a day, a next step and a header on one line, the policy's
    "(newest: 2)" and the time of "last recorded" on a second. A code longer than the 85 px of "P01"'s column
    hold ("participant_0001" was cut, 16 characters "m" wrapped mid-code) widens its column (:func:`code_column`),
    and the next step gives the room: it wraps on two lines."""
    widths = {"participant": 85, "next step": 250, "day": 100, "success rate so far": 140, "policy": 110,
              "last recorded": 110}
    wider = code_column(codes, widths["participant"])
    spare = OVERVIEW_TABLE_ROOM - sum(w for c, w in widths.items() if c in columns)
    widths["next step"] -= max(0, wider - widths["participant"] - spare)
    widths["participant"] = wider
    return fitted_layout(widths, columns, OVERVIEW_TABLE_ROOM)


#: The headings of :func:`cacas.preference_form.preferences_table`'s columns as the page shows them: short where the column is narrow.
PREFERENCES_HEADINGS = {"since last activity": "since last", "covered states": "states"}


def preferences_table_layout(columns, room: int = PREFERENCES_TABLE_ROOM) -> tuple[dict[str, int], int]:
    """How the Participants page draws :func:`cacas.preference_form.preferences_table` (its ``columns``) in ``room`` px: each
    column's width (px) and the row height (px). On one line its eight columns need about 1,100 px
    (three activities, "bathroom, living room", the participant's words), more than the page has at
    1280 px: the table scrolled sideways, "covered states" and the participant's words off its right
    edge. Each column has a width of its own (:func:`fitted_layout`): a heading ("since last", "states":
    :data:`PREFERENCES_HEADINGS`), an action, hours and a room on one line, the activities and the
    rooms on two or three, the participant's words taking what is left (wrapping to three lines)."""
    widths = {"#": 32, "activities": 130, "action": 125, "rooms": 105, "hours": 96, "since last activity": 80,
              "covered states": 70}
    shown = [c for c in widths if c in columns]
    widths["in their words"] = room - sum(widths[c] for c in shown)
    return fitted_layout(widths, columns, room)


#: The width (px) of the Adaptation page's table of described preferences at 1280 x 800, beside the sidebar
#: (measured in headless Chromium: as the Overview's table).
LEARNT_TABLE_ROOM = 818


def learnt_table_layout(columns) -> tuple[dict[str, int], int]:
    """How the Adaptation page draws each described preference before and after
    (:func:`cacas.adaptation.preferences_learnt` with the states each covers; its ``columns``): each
    column's width (px) and the row height (px). The participant's words wrap on up to three lines (at
    1280 px they were cut: "When I drink water in the morning, remind me to take m", walkthrough); the two
    counts of states, "states covered" and "Fig. 4 draws", keep their names whole."""
    widths = {"label": 250, "action": 125, "covers": 115, "states": 110, "before": 105, "after": 105}
    return fitted_layout(widths, columns, LEARNT_TABLE_ROOM)


#: The least width (px) of a photo in the Sounds and scenes page's "Every photo of one room" grid: as the grid's five
#: columns drew the shipped 128-px photos at 1280 x 800 (measured in headless Chromium).
PHOTO_WIDTH = 144
#: What a photo's caption has less than its photo (px): 2 px of padding a side (Chromium: a caption of 117.7 px broke
#: under a photo of 118).
CAPTION_PADDING = 4


def photo_width(names) -> int:
    """The width (px) of each photo of the grid of every photo of a room, whose file ``names`` are their captions:
    :data:`PHOTO_WIDTH`, or wider where the longest name needs it to stay on one line (:func:`text_width`).
    The page puts the photos in a row that wraps (st.container(horizontal=True)), so that as many stand side by
    side as the window has room for: it cannot know the window's width. In columns fitted to 1280 px the shipped
    "synthetic_0_000.jpg" broke mid-name at 1024 px ("synthetic_0_00" / "0.jpg", five columns of 93 px; the ui
    helper), and in six at 1280 ("synthetic_0_000.jp" / "g"). A name wider than the page still wraps."""
    widest = max((text_width(n) for n in names), default=0.0)
    return max(PHOTO_WIDTH, math.ceil(widest) + CAPTION_PADDING)
