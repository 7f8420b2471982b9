"""cacas.table_layouts' measure of a text (the pages' tables and photo grid are measured by the page tests)."""

import pytest

from cacas import table_layouts

#: widths (px) in Streamlit's 14-px Source Sans, measured in headless Chromium (canvas measureText): participant
#: codes as the data grid draws them, file names as a photo's caption
MEASURED = {"mmmmmmmmmmmmmmmm": 185.7, "WWWWWWWWWWWWWWWW": 176.1, "participant_0001": 99.3, "PARTICIPANT-0001": 108.1,
            "P-2026-HOSP-0001": 109.6, "0000000000000000": 111.3, "P01": 21.8, "synthetic_0_000.jpg": 117.7,
            "IMG_20260301_101500.jpg": 156.0, "PXL_20260301_101500123.jpg": 176.0, "kitchen photo (2).jpeg": 128.4}


@pytest.mark.parametrize("text, px", MEASURED.items())
def test_a_text_s_width_is_never_less_than_chromium_draws_it_and_not_much_more(text, px):
    """Never less, so that a column or a photo fitted to it keeps the text on one line; not much more, so that a
    short code's column takes no room from the others."""
    assert px <= table_layouts.text_width(text) <= px * 1.1 + 1


def test_an_accented_letter_counts_as_its_letter_and_another_character_as_the_widest():
    assert table_layouts.text_width("é") == table_layouts.text_width("e") == 7.0
    assert table_layouts.text_width("@") >= 11.86


def test_a_japanese_character_is_an_em_wide_and_an_emoji_wider():
    """A CJK font draws a kanji or kana one em wide, 14 px in the 14-px font: "台所の写真" was counted 12 px a
    character, so a photo fitted to its name broke its caption (the library keeps such names since they are
    letters). An emoji (a file copied in by `cacas scene import`) is up to 1.25 em."""
    assert table_layouts.text_width("台所の写真") >= 5 * 14 and table_layouts.text_width("ｐ０１") >= 3 * 14
    assert table_layouts.text_width("☀") >= 17.5 and table_layouts.text_width("🍳") >= 17.5
    assert table_layouts.photo_width(["台所の写真とても長い名前の一枚.png"]) >= 15 * 14 + table_layouts.text_width(".png")


def test_recent_activity_fits_the_page_and_wraps_only_a_line_too_long():
    """It was 895 px wide in 818 (a sideways scroll at 1280 px, a comparison's long line cut at the page's edge)."""
    short = ["day 1 closed", "questionnaire: satisfaction 8"]
    widths, row = table_layouts.recent_activity_layout(["P01", "2 participants"], short)
    assert widths == {"when": 145, "participant": 110, "what": 818 - 145 - 110} and row is None
    long = short + ["comparison runs (CACAS w/o PR, ORL, NN, Bandit (TS)) for P01, P02, participant_0003 on day 1, "
                    "no policy saved"]
    widths, row = table_layouts.recent_activity_layout(["P01", "participant_0003"], long)
    assert sum(widths.values()) == table_layouts.OVERVIEW_TABLE_ROOM and row == table_layouts.WRAPPING_ROW
    assert widths["participant"] > 110  # the code whole, "what" narrower by as much


def test_a_table_of_wrapping_rows_is_as_tall_as_ten_of_them():
    """Scale walk: the Overview's 60 participants showed 5 at a time (rows of two lines in Streamlit's height for
    ten of one line). Ten wrapping rows whole, a shorter table no taller than its rows, one-line rows as before."""
    rows = table_layouts.WRAPPING_ROW
    assert table_layouts.table_height(60, rows) == table_layouts.GRID_FRAME + 10 * rows
    assert table_layouts.table_height(2, rows) == table_layouts.GRID_FRAME + 2 * rows
    assert table_layouts.table_height(0, rows) == table_layouts.GRID_FRAME + rows  # "no participants" has its row
    assert table_layouts.table_height(60, None) == "auto"
