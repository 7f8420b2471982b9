"""scripts/results_table.py: the README's table of means per day from a daily.csv."""


import pandas as pd
import pytest

from script_module import load_script


@pytest.fixture(scope="module")
def script():
    return load_script("results_table")


def daily(nn_success, ceiling=1.0):
    rows = []
    for p, bump in (("P01", 0.0), ("P02", 0.2)):
        for day in (1, 2):
            rows.append(dict(participant=p, method="cacas", day=day, success_rate=0.2 * day + bump,
                             preference_accuracy=0.3 * day, cumulative_feedback=10 * day, interactions=15,
                             success_ceiling=ceiling))
            rows.append(dict(participant=p, method="nn", day=day, success_rate=nn_success,
                             preference_accuracy=0.1 * day, cumulative_feedback=10 * day, interactions=15,
                             success_ceiling=ceiling if nn_success == nn_success else float("nan")))
    return pd.DataFrame(rows)


def table(script, frame, tmp_path, capsys):
    path = tmp_path / "daily.csv"
    frame.to_csv(path, index=False)
    script.main(str(path))
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("|")]
    return [[cell.strip() for cell in line.strip("|").split("|")] for line in lines]


def test_the_closed_loop_methods_success_and_each_methods_accuracy(script, tmp_path, capsys):
    rows = table(script, daily(float("nan")), tmp_path, capsys)
    assert rows[0] == ["day", "success rate (cacas) mean [min-max]", "cumulative feedback", "accuracy cacas",
                       "accuracy nn"]
    assert rows[2] == ["1", "0.30 [0.20-0.40]", "10.0", "0.300", "0.100"]
    assert rows[-1][0] == "paper" and rows[-1][-1] == "0.21 (day 7)"


def test_every_closed_loop_and_the_ceiling_where_it_is_below_one(script, tmp_path, capsys):
    rows = table(script, daily(0.05, ceiling=0.8), tmp_path, capsys)
    assert rows[0][:5] == ["day", "success rate (cacas) mean [min-max]", "success rate nn", "success ceiling (cacas)",
                           "cumulative feedback (cacas)"]
    assert rows[3][:5] == ["2", "0.50 [0.40-0.60]", "0.05", "0.80", "20.0"]
    assert len(rows[-1]) == len(rows[0])


def test_cacas_leads_the_table_wherever_it_is_in_the_file(script, tmp_path, capsys):
    frame = daily(0.05)
    rows = table(script, pd.concat([frame[frame["method"] == "nn"], frame[frame["method"] == "cacas"]]), tmp_path, capsys)
    assert rows[0][1:3] == ["success rate (cacas) mean [min-max]", "success rate nn"]


def test_a_daily_csv_written_before_the_success_ceiling_existed(script, tmp_path, capsys):
    rows = table(script, daily(float("nan")).drop(columns="success_ceiling"), tmp_path, capsys)
    assert rows[0][:3] == ["day", "success rate (cacas) mean [min-max]", "cumulative feedback"]
    assert rows[2][:3] == ["1", "0.30 [0.20-0.40]", "10.0"]


@pytest.mark.parametrize("content, needle", [
    (None, "missing.csv: cannot be read as a daily.csv (FileNotFoundError: No such file or directory)"),
    ("a,b\n1,2\n", "not a daily.csv of cacas simulate or cacas export (no column 'participant')"),
])
def test_a_file_that_is_not_a_daily_csv_is_one_line_exit_2(script, tmp_path, capsys, content, needle):
    """Walkthrough: a missing file printed a traceback."""
    path = tmp_path / "missing.csv"
    if content is not None:
        path.write_text(content)
    with pytest.raises(SystemExit) as exc:
        script.main(str(path))
    err = capsys.readouterr().err
    assert exc.value.code == 2 and needle in err and len(err.strip().splitlines()) == 1


def test_a_participant_coded_na_is_counted(script, tmp_path, capsys):
    """pandas read participant "NA" (a valid code) as missing: 'participants: 1' for two."""
    path = tmp_path / "daily.csv"
    daily(float("nan")).replace({"participant": {"P01": "NA"}}).to_csv(path, index=False)
    script.main(str(path))
    assert "participants: 2, days: 2" in capsys.readouterr().out


#: The persona sets of the README's table of the issue's targets, in its columns' order (docs/results/<name>_daily.csv).
TARGET_SETS = ("example", "holdout", "independent", "independent_s", "independent_t", "independent_u", "independent_v")


@pytest.mark.parametrize("name, document", [("example", "README.md"), ("holdout", "docs/results.md")])
def test_the_documents_day_by_day_table_is_the_one_the_script_prints_from_the_shipped_results(
        script, name, document, capsys):
    """The README's table (and results.md's for the hold-out set) is what `python3 scripts/results_table.py`
    prints from the daily.csv under docs/results/ (the README's command says so): a regenerated file and a
    table left as it was disagree here, not only in a reader's run."""
    from cacas.paths import PROJECT_ROOT

    script.main(str(PROJECT_ROOT / "docs" / "results" / f"{name}_daily.csv"))
    printed = [line for line in capsys.readouterr().out.splitlines() if line.startswith("|")]
    text = (PROJECT_ROOT / document).read_text(encoding="utf-8")
    assert len(printed) == 10 and [line for line in printed if line not in text] == []


def test_the_readmes_targets_are_the_shipped_results_day_7_means():
    """The first rows of the README's table of the issue's targets, from docs/results/: CACAS's day-7
    accuracy, the day-1 and day-7 success rates, and CACAS against ORL, set by set."""
    from cacas.paths import PROJECT_ROOT
    from cacas.records import read_csv

    rows = {"CACAS preference accuracy": [], "day-1 success rate": [], "day-7 success rate": [],
            "CACAS at or above ORL": []}
    for name in TARGET_SETS:
        daily = read_csv(PROJECT_ROOT / "docs" / "results" / f"{name}_daily.csv")
        means = daily.groupby(["method", "day"])[["preference_accuracy", "success_rate"]].mean()
        cacas, orl = means.loc[("cacas", 7), "preference_accuracy"], means.loc[("orl", 7), "preference_accuracy"]
        rows["CACAS preference accuracy"].append(f"{cacas:.3f}")
        rows["day-1 success rate"].append(f"{means.loc[('cacas', 1), 'success_rate']:.2f}")
        rows["day-7 success rate"].append(f"{means.loc[('cacas', 7), 'success_rate']:.2f}")
        rows["CACAS at or above ORL"].append(f"{cacas:.3f} vs {orl:.3f}")
    readme = (PROJECT_ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    for start, cells in rows.items():
        line = next(line for line in readme if line.startswith(f"| {start}"))
        assert [cell.strip() for cell in line.strip("|").split("|")][1:] == cells, line
