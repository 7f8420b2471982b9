"""docs/tables.md names every column of every CSV the export and `cacas simulate` write, in the
files' order, each with its type, unit and what an empty cell means (an analyst's walkthrough found
daily.csv's successes, user_initiated and feedback, adaptations.csv's columns and the meaning of an
empty policy_version named nowhere)."""

import re

import numpy as np
import pandas as pd

from cacas import export, records
from cacas.paths import PROJECT_ROOT
from cacas.store import StudyStore

DOC = PROJECT_ROOT / "docs" / "tables.md"


def documented() -> dict[str, list[list[str]]]:
    """File name -> the rows of its table in docs/tables.md (cells, the column's name unquoted)."""
    tables, current = {}, None
    for line in DOC.read_text(encoding="utf-8").splitlines():
        heading = re.fullmatch(r"## `(\w+\.csv)`", line)
        if heading:
            current = tables.setdefault(heading.group(1), [])
        elif current is not None and line.startswith("| `"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            current.append([cells[0].strip("`"), *cells[1:]])
    return tables


def test_the_parser_reads_a_table():
    rows = documented()["daily.csv"]
    assert rows[0] == ["participant", "text", "the participant's code", "never empty"]


def test_every_column_of_every_exported_table_is_documented_in_order(tmp_path):
    with StudyStore(tmp_path / "a" / "study.sqlite") as s:
        s.add_participant("P01")
        s.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
        day = s.open_day("P01")
        s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=3,
                             robot_action="pain check", response="accept", probabilities=np.full(14, 1 / 14))
        s.close_day("P01", day)
        s.record_adaptation("P01", day, "nn", {}, 0.5, {"preference_accuracy": 0.5})
        s.record_questionnaire("P01", 8, "fine")
        written = export.export_study(s, tmp_path / "out", bundle=False).tables
    docs = documented()
    assert set(docs) == {f"{t}.csv" for t in export.TABLES} | {"summary.csv"}
    for table, path in written.items():
        columns = list(pd.read_csv(path, nrows=0).columns)
        assert [row[0] for row in docs[f"{table}.csv"]] == columns, table
        assert all(len(row) == 4 and all(row) for row in docs[f"{table}.csv"]), table  # type, unit, empty


def test_the_simulations_columns_are_the_documented_ones_it_writes():
    docs = documented()
    for name, columns in (("daily.csv", records.DAILY_COLUMNS), ("interactions.csv", records.INTERACTION_COLUMNS),
                          ("by_preference.csv", records.BY_PREFERENCE_COLUMNS)):
        assert [row[0] for row in docs[name]][:len(columns)] == columns, name
    text = DOC.read_text(encoding="utf-8")
    assert f"writes the columns\nup to `{records.DAILY_COLUMNS[-1]}`" in text
    assert f"writes the columns up to\n`{records.INTERACTION_COLUMNS[-1]}`" in text


def test_every_event_the_store_writes_is_named_in_events_csv():
    """events.csv's `what` lists the writes the log holds: each name the store passes to its `_event` (an event
    added without the docs would leave an analyst to guess it; a docs walkthrough checked them by hand)."""
    written = set()
    for source in (PROJECT_ROOT / "cacas").rglob("*.py"):
        written |= set(re.findall(r'_event\(\w+, "(\w+)"', source.read_text(encoding="utf-8")))
    row = next(row for row in documented()["events.csv"] if row[0] == "what")
    named = re.findall(r"\b[a-z]+(?:_[a-z]+)+\b", row[2].split(":", 1)[1])
    assert len(written) >= 15 and sorted(named) == sorted(written)


def test_the_labs_summary_columns_are_the_documented_ones():
    """The Simulation lab's summary.csv (a walkthrough found it downloadable and named nowhere in tables.md): its
    columns are summary_table's of a daily.csv, in order."""
    from cacas.experiment import summary_table

    daily = pd.DataFrame({c: [1] for c in records.DAILY_COLUMNS}).assign(participant="P01", method="cacas")
    assert [row[0] for row in documented()["summary.csv"]] == list(summary_table(daily).columns)
    assert all(len(row) == 4 and all(row) for row in documented()["summary.csv"])
