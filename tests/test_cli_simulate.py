import json
import subprocess
import sys
from pathlib import Path

import pytest

from cacas.cli import main

GOOD = {"participants": [{"id": "P01", "preferences": [
    {"description": "Stove: set a timer", "activity": ["use stove"], "scene": ["kitchen"], "action": "set a timer"}]}]}


def write(tmp_path, data, name="personas.json"):
    p = tmp_path / name
    p.write_text(data if isinstance(data, str) else json.dumps(data))
    return p


def bad_pref(**change):
    pref = dict(GOOD["participants"][0]["preferences"][0], **change)
    return {"participants": [{"id": "P01", "preferences": [pref]}]}


@pytest.mark.parametrize("content,args,needles", [
    (None, [], ["missing.json", "no such persona file"]),
    ("{not json", [], ["personas.json", "not valid JSON"]),
    (bad_pref(activity=["stove"]), [], ["personas.json", "participant P01", "preference 1", "field 'activity'", "'stove'"]),
    (bad_pref(action="dance"), [], ["personas.json", "participant P01", "field 'action'", "'dance'"]),
    ({"participants": [{"id": "P01", "preferences": [
        {"activity": ["cough"], "action": "pain check"},
        {"activity": ["cough"], "scene": ["bedroom"], "action": "show compassion"}]}]}, [],
     ["personas.json", "participant P01", "preferences 1 and 2", "different actions"]),
    # every problem of the file in its one line (walk3: three mistakes, three runs)
    ({"participants": [{"id": "P01", "preferences": [dict(GOOD["participants"][0]["preferences"][0], action="dance"),
                                                     {"activity": ["coughing"], "action": "pain check"}]},
                       {"id": "P02", "preferences": [{"activity": ["cough"], "action": "pain check", "hours": [[7, 9]]}]}]},
     [], ["personas.json: 3 problems, each to mend: [1] participant P01, preference 1 (\"Stove: set a timer\"), "
          "field 'action': unknown action 'dance'", "[2] participant P01, preference 2, field 'activity'",
          "did you mean 'cough'?", "[3] participant P02, preference 1, field 'hours': [7, 9] is invalid"]),
    (dict(GOOD, studdy="typo"), [], ["personas.json", "field 'studdy': unknown field; valid fields: participants"]),
    ('{"participants": [{"id": "P01", "id": "P02", "preferences": []}]}', [],
     ["personas.json", "field 'id' appears twice in one object"]),
    # a comma in a code: --participants (comma-separated codes) could not pick that participant (CLI audit)
    ({"participants": [dict(GOOD["participants"][0], id="Smith, Anna")]}, [],
     ["personas.json: participant 1, field 'id': 'Smith, Anna' holds a comma, which separates the codes of "
      "`cacas simulate --participants`; valid: a pseudonymous code"]),
    # CLI audit: a number too long for int() and half of a character were tracebacks (the second after the whole
    # run); line breaks in a description or a code split the line
    pytest.param('{"participants": [{"id": "P01", "preferences": [{"activity": ["cough"], "action": "pain check", '
                 '"hours": [[0, ' + "9" * 5000 + ']]}]}]}', [],
                 ["personas.json: the number on line 1 has 5000 digits, more than can be read", "valid: the format of"],
                 id="a 5000-digit number"),
    pytest.param('{"participants": [{"id": "P01", "preferences": [{"description": "I like \\ud83d tea", '
                 '"activity": ["cough"], "action": "pain check"}]}]}', [],
                 ["personas.json, participant P01, preference 1, field 'description': holds half of a character "
                  "('\\ud83d' without the other half of its pair)", "valid: whole characters"],
                 id="half of a character"),
    ({"participants": [{"id": "P01", "preferences": [
        {"description": "line one\nline two", "activity": ["cough"], "action": "pain check"},
        {"description": "second\n\n  line", "activity": ["cough"], "action": "chitchat"}]}]}, [],
     ['personas.json, participant P01: preferences 1 ("line one line two") and 2 ("second line") both cover']),
    ({"participants": [dict(GOOD["participants"][0], id="P0\n1\t")]}, ["--participants", "P09"],
     ["--participants: P09 is not in", "personas.json: P0\\n1"]),
    ({"participants": [{"id": "P0\n1", "preferences": bad_pref(action="dance")["participants"][0]["preferences"]}]}, [],
     ["personas.json, participant P0\\n1, preference 1 (\"Stove: set a timer\"), field 'action': unknown action"]),
    (GOOD, ["--days", "0"], ["--days 0"]),
    (GOOD, ["--methods", "cacas,dqn"], ["--methods cacas,dqn: unknown method 'dqn'", "valid: cacas, cacas-no-pr"]),
    (GOOD, ["--no-response-rate", "1"], ["--no-response-rate 1.0", "0 <= rate < 1"]),
    (GOOD, ["--ask-after-reject", "2"], ["--ask-after-reject 2.0", "0 <= rate <= 1"]),
    (GOOD, ["--loop", "both"], ["--loop 'both' is invalid", "valid: first", "or each"]),
    (GOOD, ["--days", "two"], ["--days", "'two' is not a whole number; valid"]),
    (GOOD, ["--no-response-rate", "some"], ["--no-response-rate", "'some' is not a number; valid: a share"]),
    (GOOD, ["--days", "366"], ["--days 366", "from 1 to 365"]),
    (GOOD, ["--interactions", "10000000000"], ["--interactions 10000000000", "from 1 to 1440"]),
    (GOOD, ["--seed", "-1"], ["--seed -1", "from 0 to 4294967295"]),
    (GOOD, ["--methods", "cacas,nn,cacas"], ["--methods cacas,nn,cacas: method 'cacas' is listed twice",
                                              "valid: each of cacas, cacas-no-pr"]),
    (GOOD, ["--d4a", ""], ["argument --d4a: an empty path; valid: a file or folder path"]),
    (GOOD, ["--plot", " "], ["argument --plot: an empty path"]),
    (GOOD, ["--jobs", "0"], ["--jobs 0 is invalid; valid: a whole number >= 1"]),
    (GOOD, ["--participants", "P01,P09"], ["--participants: P09 is not in", "personas.json",
                                           "valid: comma-separated codes of", "P01"]),
    (GOOD, ["--participants", "p01"], ["--participants: p01 is not in", "; did you mean P01? valid: comma-separated"]),
    (GOOD, ["--participants", " , "], ["--participants ' , ' names no participant", "valid:", "P01"]),
    (GOOD, ["--participants", "P01,P01"], ["--participants: P01 given twice", "valid:"]),
])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, content, args, needles):
    path = tmp_path / "missing.json" if content is None else write(tmp_path, content)
    code = main(["simulate", "--personas", str(path), "--out", str(tmp_path / "out"), "--quiet", *args]) \
        if args[1:2] not in (["two"], ["some"], [""], [" "]) else None
    if code is None:  # argparse's own type errors exit through SystemExit
        with pytest.raises(SystemExit) as exc:
            main(["simulate", "--personas", str(path), "--out", str(tmp_path / "out"), *args])
        code = exc.value.code
    err = capsys.readouterr().err
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err
    for n in needles:
        assert n in lines[0]
    assert not (tmp_path / "out").exists()  # nothing written


def test_a_d4a_file_answering_do_nothing_exits_2_naming_the_cell(tmp_path, capsys):
    """design.md: a bad file is exit code 2 and one line naming it; the robot doing nothing gets no
    response, so a D4A file answering its column is refused before any work."""
    from cacas.d4a import default_d4a_path

    lines = default_d4a_path().read_text().splitlines()
    cells = lines[6].split(",")  # fall down; column 2 is "do nothing"
    assert cells[0] == "fall down" and cells[1] == "others"
    cells[1] = "Accept"
    lines[6] = ",".join(cells)
    (tmp_path / "mine.csv").write_text("\n".join(lines) + "\n")
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--d4a", str(tmp_path / "mine.csv"),
                 "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err
    assert "mine.csv, line 7, column 2 (fall down / do nothing): 'Accept'; valid: 'others' only" in lines[0]
    assert not (tmp_path / "out").exists()


def test_without_a_terminal_the_training_of_a_new_d4a_s_initial_policy_is_said(tmp_path, capsys, monkeypatch):
    """walk3: `cacas simulate --d4a FILE` with stderr not a terminal (a log, a pipe) printed nothing during the
    30-45 s of training the new table's initial policy: the progress bar is drawn only on a terminal. One line
    says it, before the training; none once the policy is kept, and none with --quiet."""
    import cacas.adaptation
    import cacas.experiment
    from cacas.d4a import default_d4a_path
    from cacas.errors import CacasError

    lines = default_d4a_path().read_text().splitlines()
    cells = lines[1].split(",")
    assert cells[0] == "cough" and "reject" in cells
    cells[cells.index("reject")] = "accept"
    lines[1] = ",".join(cells)
    (tmp_path / "ours.csv").write_text("\n".join(lines) + "\n")
    kept = tmp_path / "models" / "initial_policy-d4a-ours.pt"  # not trained yet
    monkeypatch.setattr(cacas.adaptation, "initial_policy_path", lambda d4a=None, config=None: kept)
    said = []

    def started(*args, **kwargs):  # what was said before the simulation (and its training) started
        said.append(capsys.readouterr().err)
        raise CacasError("stopped here")
    monkeypatch.setattr(cacas.experiment, "simulate_study", started)
    argv = ["simulate", "--personas", str(write(tmp_path, GOOD)), "--d4a", str(tmp_path / "ours.csv"),
            "--out", str(tmp_path / "out")]
    assert not sys.stderr.isatty() and main(argv) == 2
    assert said[0] == (f"cacas simulate: training the initial policy for {tmp_path / 'ours.csv'} first (CACAA step 1, "
                       f"about half a minute; once: it is kept as {kept})\n")
    assert capsys.readouterr().err == "cacas: error: stopped here\n"
    assert main(argv + ["--quiet"]) == 2 and said[1] == ""
    capsys.readouterr()
    kept.parent.mkdir()
    kept.write_bytes(b"trained before")
    assert main(argv) == 2 and said[2] == ""


def test_no_traceback_from_the_installed_command(tmp_path):
    bad = write(tmp_path, bad_pref(scene=["garage"]))
    proc = subprocess.run([sys.executable, "-m", "cacas", "simulate", "--personas", str(bad), "--out",
                           str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1
    assert "field 'scene'" in proc.stderr and "'garage'" in proc.stderr and "Traceback" not in proc.stderr


def test_same_seed_writes_the_same_daily_csv_byte_for_byte(tmp_path, capsys):
    personas = write(tmp_path, GOOD)
    args = ["simulate", "--personas", str(personas), "--days", "2", "--interactions", "4",
            "--methods", "cacas,nn", "--seed", "7", "--quiet"]
    assert main(args + ["--out", str(tmp_path / "a"), "--plot", str(tmp_path / "plots")]) == 0
    assert main(args + ["--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "accuracy" in out and "cacas" in out  # the printed table of means
    a, b = (tmp_path / "a" / "daily.csv").read_bytes(), (tmp_path / "b" / "daily.csv").read_bytes()
    assert a == b and a.startswith(b"participant,method,day,success_rate,preference_accuracy,cumulative_feedback,"
                                   b"interactions")
    for name in ("interactions.csv", "by_preference.csv"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    assert (tmp_path / "a" / "by_preference.csv").read_text().startswith(
        "participant,method,day,preference,label,activity,action,states,correct,accuracy\n")
    assert (tmp_path / "plots" / "fig3_success.html").stat().st_size > 1000
    assert (tmp_path / "plots" / "fig4_methods.html").exists()
    assert "Accuracy by described preference" in (tmp_path / "plots" / "fig4_by_preference.html").read_text()


def test_loop_each_gives_every_method_its_success_rate_and_fig3(tmp_path, capsys):
    import pandas as pd

    personas = write(tmp_path, GOOD)
    assert main(["simulate", "--personas", str(personas), "--days", "2", "--interactions", "4", "--methods",
                 "cacas,nn", "--loop", "each", "--quiet", "--out", str(tmp_path / "o"),
                 "--plot", str(tmp_path / "p")]) == 0
    daily = pd.read_csv(tmp_path / "o" / "daily.csv")
    assert set(daily["method"]) == {"cacas", "nn"} and daily["success_rate"].notna().all()
    assert set(pd.read_csv(tmp_path / "o" / "interactions.csv")["method"]) == {"cacas", "nn"}
    assert "Success rate by method" in (tmp_path / "p" / "fig3_methods.html").read_text()
    # the paper's protocol (default) has one closed loop and no such figure
    assert main(["simulate", "--personas", str(personas), "--days", "2", "--interactions", "4", "--methods",
                 "cacas,nn", "--quiet", "--out", str(tmp_path / "o2"), "--plot", str(tmp_path / "p2")]) == 0
    assert pd.read_csv(tmp_path / "o2" / "daily.csv").query("method == 'nn'")["success_rate"].isna().all()
    assert not (tmp_path / "p2" / "fig3_methods.html").exists()


def test_each_figure_page_has_the_apps_caption_under_its_figure(tmp_path, capsys):
    """walk2: the app's figures say under them what the band, the dashed line and the hollow points are, and what
    Fig. 4 and its heatmap show; ``cacas simulate --plot``'s pages said nothing. Each holds its caption now, in the
    app's words (cacas.plots), under the figure (tests/browser/test_browser_figures.py: in view, not overlapped)."""
    import html

    import pandas as pd

    from cacas import plots

    personas = write(tmp_path, GOOD)
    assert main(["simulate", "--personas", str(personas), "--days", "2", "--interactions", "3", "--methods",
                 "cacas,nn", "--loop", "each", "--quiet", "--out", str(tmp_path / "o"),
                 "--plot", str(tmp_path / "o")]) == 0
    daily = pd.read_csv(tmp_path / "o" / "daily.csv")
    captions = {"fig3_success.html": plots.success_caption(daily, "cacas"),
                "fig3_methods.html": plots.success_methods_caption(daily),
                "fig4_methods.html": plots.METHODS_CAPTION, "fig4_by_preference.html": plots.preferences_caption(2)}
    assert "A hollow point" in captions["fig3_success.html"]  # 3 interactions a day: some day rests on few
    assert "A hollow point" in captions["fig3_methods.html"] and "by day 2." in captions["fig4_by_preference.html"]
    for name, caption in captions.items():
        page = (tmp_path / "o" / name).read_text()
        assert f'<p class="caption">{html.escape(caption)}</p>' in page, name
        assert page.index('class="caption"') < page.index("Plotly.newPlot"), name  # laid out when the figure is sized


@pytest.mark.parametrize("flag", ["--out", "--plot"])
def test_an_output_folder_that_cannot_be_written_is_refused_before_the_simulation(tmp_path, capsys, monkeypatch,
                                                                                    flag):
    import cacas.experiment

    def never(*a, **k):
        raise AssertionError("the simulation ran before the output folder was checked")

    monkeypatch.setattr(cacas.experiment, "simulate_study", never)
    (tmp_path / "a_file").write_text("not a folder")
    folders = {"--out": str(tmp_path / "out"), "--plot": str(tmp_path / "plots")}
    folders[flag] = str(tmp_path / "a_file" / "sub")
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet",
                 *[a for k, v in folders.items() for a in (k, v)]])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert f"{flag} {folders[flag]}: cannot write in this folder" in err
    assert not (tmp_path / "out").exists()  # a refused --plot leaves no empty --out behind


@pytest.mark.parametrize("option", ["--out", "--personas"])
def test_an_empty_path_is_refused_not_read_as_the_current_folder(tmp_path, capsys, monkeypatch, option):
    """Review: --out "" wrote the tables into the current folder (exit 0); --personas "" said
    '.: cannot be read'."""
    monkeypatch.chdir(tmp_path)
    args = {"--personas": str(write(tmp_path, GOOD)), "--out": "out"}
    args[option] = ""
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--quiet", *[a for k, v in args.items() for a in (k, v)]])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.strip() == f"cacas: error: argument {option}: an empty path; valid: a file or folder path"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["personas.json"]


def test_a_refused_plot_leaves_none_of_the_folders_out_created(tmp_path, capsys):
    """Review: --out n1/n2/n3 with a refused --plot removed n3 but left n1/n2."""
    (tmp_path / "a_file").write_text("not a folder")
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--out",
                 str(tmp_path / "n1" / "n2" / "n3"), "--plot", str(tmp_path / "a_file")])
    assert code == 2 and "--plot" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "personas.json"]


def test_an_interrupted_run_leaves_no_empty_folder_behind(tmp_path, capsys, monkeypatch):
    import cacas.experiment

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(cacas.experiment, "simulate_study", interrupted)
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "daily.csv").write_text("an earlier run's")
    for out in ("new", "old"):
        assert main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / out),
                     "--plot", str(tmp_path / f"{out}-plots")]) == 130
    assert "cacas: interrupted" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old", "personas.json"]
    assert (tmp_path / "old" / "daily.csv").read_text() == "an earlier run's"


def test_an_earlier_runs_figures_do_not_stay_beside_new_tables(tmp_path, capsys):
    """Walkthrough: a --loop each run's fig3_methods.html stayed beside a later run's tables (and
    without --plot, every earlier figure did)."""
    personas = write(tmp_path, GOOD)
    run = ["simulate", "--personas", str(personas), "--days", "1", "--interactions", "3", "--methods", "cacas,nn",
           "--quiet", "--out", str(tmp_path / "o")]
    assert main(run + ["--loop", "each", "--plot", str(tmp_path / "o")]) == 0
    figures = {"fig3_success.html", "fig4_methods.html", "fig4_by_preference.html", "fig3_methods.html"}
    assert figures <= {p.name for p in (tmp_path / "o").iterdir()}
    capsys.readouterr()
    assert main(run + ["--plot", str(tmp_path / "o")]) == 0  # one closed loop: no fig3_methods.html
    assert not (tmp_path / "o" / "fig3_methods.html").exists() and (tmp_path / "o" / "fig3_success.html").exists()
    # one file is 'it', not 'they' (README audit: "removed an earlier run's .../fig3_methods.html (they no longer
    # match these tables)")
    assert (f"removed an earlier run's {tmp_path / 'o' / 'fig3_methods.html'} (it no longer matches these tables)"
            in capsys.readouterr().out)
    (tmp_path / "o" / "notes.html").write_text("mine")
    assert main(run) == 0  # no figures asked for: none of an earlier run's stays
    assert not figures & {p.name for p in (tmp_path / "o").iterdir()}
    assert "(they no longer match these tables)" in capsys.readouterr().out  # three of them
    assert (tmp_path / "o" / "notes.html").read_text() == "mine"  # only the command's own figures go


def test_a_failed_write_leaves_the_earlier_run_whole(tmp_path, capsys, monkeypatch, fail_on_call):
    """The disk fills while the tables are written: the earlier run's three files stay as they
    were (not a mix of two runs), no temporary file is left, one line, exit 2."""
    from cacas.store import files

    out = tmp_path / "out"
    out.mkdir()
    earlier = {name: f"earlier {name}\n" for name in ("daily.csv", "interactions.csv", "by_preference.csv")}
    for name, text in earlier.items():
        (out / name).write_text(text)
    monkeypatch.setattr(files.os, "fsync", fail_on_call(files.os.fsync, 3))  # checksums.sha256, daily.csv, then this
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--days", "1", "--interactions", "2",
                 "--methods", "nn", "--jobs", "1", "--quiet", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "interactions.csv: cannot be written (No space left on device)" in err
    assert {p.name: p.read_text() for p in out.iterdir()} == earlier


def test_a_simulation_into_a_study_exports_folder_is_refused_before_it_runs(tmp_path, capsys):
    """Its three tables would replace the study's and leave participants.csv, questionnaire.csv
    and the zip beside them: one folder mixing two studies (data-analyst review)."""
    personas = write(tmp_path, GOOD)
    out = tmp_path / "export"
    out.mkdir()
    for name in ("daily.csv", "participants.csv", "questionnaire.csv", "cacas-study.zip"):
        (out / name).write_text(f"the study's {name}")
    code = main(["simulate", "--personas", str(personas), "--days", "1", "--interactions", "3", "--quiet",
                 "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert f"--out {out}: holds an export of a study database (participants.csv, questionnaire.csv, " \
           "cacas-study.zip)" in err and "valid: an empty folder, a new one, or an earlier simulation's" in err
    assert (out / "daily.csv").read_text() == "the study's daily.csv"


def test_a_terminated_run_leaves_no_empty_folder_behind(tmp_path, capsys, monkeypatch):
    """SIGTERM (kill, a scheduler's stop) left the new --out folder behind, empty (Ctrl-C did not)."""
    import os
    import signal

    import cacas.experiment

    def terminated(*a, **k):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM did not stop the run")

    monkeypatch.setattr(cacas.experiment, "simulate_study", terminated)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / "new"),
                 "--plot", str(tmp_path / "plots")]) == 143
    assert "cacas: terminated" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["personas.json"]
    assert signal.getsignal(signal.SIGTERM) == before  # the caller's handler is back


def test_an_error_after_sigterm_is_said_as_the_termination(tmp_path, capsys, monkeypatch):
    """SIGTERM to the process group also ends the workers' manager process: the run then failed
    with 'cacas: error: Connection reset by peer' (exit 2) instead of saying it was terminated."""
    import os
    import signal

    import cacas.experiment

    def terminated_then_reset(*a, **k):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
        finally:  # the cleanup talks to the manager process, which the same signal ended
            raise ConnectionResetError(104, "Connection reset by peer")

    monkeypatch.setattr(cacas.experiment, "simulate_study", terminated_then_reset)
    assert main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / "new")]) \
        == 143
    assert capsys.readouterr().err == "cacas: terminated\n"
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("after", [BrokenPipeError(32, "Broken pipe"), EOFError()])
def test_a_broken_pipe_or_eof_after_sigterm_is_the_termination(tmp_path, capsys, monkeypatch, after):
    """CLI review: SIGTERM as the workers start: the stop handler's call to the ended manager raised
    BrokenPipeError, taken for a reader of stdout that left (exit 0, nothing said, no tables: a script
    took it for a success), or EOFError (a traceback, exit 1)."""
    import os
    import signal

    import cacas.experiment

    def terminated_then(*a, **k):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
        finally:
            raise after

    monkeypatch.setattr(cacas.experiment, "simulate_study", terminated_then)
    assert main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / "new")]) \
        == 143
    assert capsys.readouterr().err == "cacas: terminated\n"
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("name, said", [("Anna Smith", "participant code 'Anna Smith' is invalid"),
                                        ("0612345678", "participant code '0612345678' looks like a phone number")])
def test_a_name_for_a_participant_code_is_noted_and_run(tmp_path, capsys, name, said):
    """Walkthrough: "Anna Smith" ran without a word, though the study database refuses names as
    codes (design.md: pseudonymous codes only), and phone numbers too. The file is the
    researcher's: it runs, with a note."""
    people = {"participants": [dict(GOOD["participants"][0], id=name)]}
    code = main(["simulate", "--personas", str(write(tmp_path, people)), "--out", str(tmp_path / "out"),
                 "--days", "1", "--interactions", "2", "--methods", "nn", "--quiet"])
    err = capsys.readouterr().err
    assert code == 0 and (tmp_path / "out" / "daily.csv").exists()
    assert "note: " in err and said in err and "valid: a pseudonymous code" in err and "never a name" in err


def test_an_interrupted_runs_progress_line_is_ended_before_cacas_interrupted(tmp_path, monkeypatch):
    """Review: on Ctrl-C the progress line was left open, so "cacas: interrupted" (and the shell's
    next prompt) began on the same line as the bar."""
    import io

    import cacas.experiment

    class Tty(io.StringIO):
        def isatty(self):
            return True

    def interrupted(*a, progress=None, **k):
        progress(0.4, "simulating P01, day 1 of 2")
        raise KeyboardInterrupt

    monkeypatch.setattr(cacas.experiment, "simulate_study", interrupted)
    monkeypatch.setattr(sys, "stderr", Tty())
    assert main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--out", str(tmp_path / "o")]) == 130
    err = sys.stderr.getvalue()
    assert "simulate [" in err and "simulating P01, day 1 of 2" in err
    assert err.endswith("simulating P01, day 1 of 2\ncacas: interrupted\n"), repr(err)


@pytest.mark.parametrize("held,names,says", [
    ("export", ("daily.csv", "participants.csv", "questionnaire.csv", "cacas-study.zip"),
     "holds an export of a study database (participants.csv, questionnaire.csv, cacas-study.zip)"),
    ("earlier-run", ("daily.csv", "interactions.csv", "by_preference.csv", "fig3_success.html"),
     "holds another simulation's tables (daily.csv, interactions.csv, by_preference.csv)")])
def test_figures_into_a_folder_of_other_tables_are_refused_before_the_run(tmp_path, capsys, monkeypatch, held,
                                                                          names, says):
    """Review: --plot <a study's export folder> was taken: the run's figures and plotly.min.js went
    in beside the study's tables (nothing overwritten, but the folder then mixed a real study with a
    simulation, and a later export into it kept the figures); so did --plot <another run's --out>,
    its tables beside this run's figures."""
    import cacas.experiment

    def never(*a, **k):
        raise AssertionError("the simulation ran before --plot was checked")

    monkeypatch.setattr(cacas.experiment, "simulate_study", never)
    folder = tmp_path / held
    folder.mkdir()
    for name in names:
        (folder / name).write_text(f"the {held}'s {name}")
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / "new"),
                 "--plot", str(folder)])
    err = capsys.readouterr().err
    assert code == 2 and err == (f"cacas: error: --plot {folder}: {says}; this run's figures would sit beside "
                                 "results they do not show; valid: the --out folder, an empty folder, a new one, or "
                                 "one holding figures only\n")
    assert {p.name: p.read_text() for p in folder.iterdir()} == {n: f"the {held}'s {n}" for n in names}
    assert not (tmp_path / "new").exists()


def test_figures_beside_their_own_tables_and_in_a_figures_folder_are_written(tmp_path, capsys):
    """--plot as --out (the README's example; written another way) and a folder of figures only."""
    personas = write(tmp_path, GOOD)
    run = ["simulate", "--personas", str(personas), "--days", "1", "--interactions", "3", "--methods", "nn",
           "--jobs", "1", "--quiet"]
    assert main(run + ["--out", str(tmp_path / "o"), "--plot", str(tmp_path / "o")]) == 0
    assert main(run + ["--out", str(tmp_path / "o"), "--plot", str(tmp_path / "x" / ".." / "o")]) == 0
    assert main(run + ["--out", str(tmp_path / "o2"), "--plot", str(tmp_path / "figures")]) == 0
    assert main(run + ["--out", str(tmp_path / "o3"), "--plot", str(tmp_path / "figures")]) == 0
    assert (tmp_path / "figures" / "fig4_methods.html").is_file()


def test_the_plotly_js_the_figures_load_is_written_said_and_a_leftover_one_replaced(tmp_path, capsys):
    """Review: a plotly.min.js left in the --plot folder (an older plotly's, a truncated copy) was
    kept, and the new figures loaded it; the message named the figures only, not the file they need."""
    from plotly.offline import get_plotlyjs

    plots = tmp_path / "plots"
    plots.mkdir()
    (plots / "plotly.min.js").write_text("/* plotly.js of another version */")
    run = ["simulate", "--personas", str(write(tmp_path, GOOD)), "--days", "1", "--interactions", "3", "--methods",
           "nn", "--jobs", "1", "--quiet", "--out", str(tmp_path / "o"), "--plot", str(plots)]
    assert main(run) == 0
    out = capsys.readouterr().out
    assert (plots / "plotly.min.js").read_text() == get_plotlyjs()
    assert '<script charset="utf-8" src="plotly.min.js">' in (plots / "fig4_methods.html").read_text()
    assert (f"{plots / 'fig4_by_preference.html'} and {plots / 'plotly.min.js'}, the plotly.js they load (keep it "
            "beside them)\n") in out
    assert f"replaced an earlier {plots / 'plotly.min.js'}: it was not the plotly.js these figures need\n" in out
    assert main(run) == 0  # the same one again: written, not said to be replaced
    out = capsys.readouterr().out
    assert "the plotly.js they load" in out and "replaced an earlier" not in out


def test_participants_of_a_file_get_the_rows_the_whole_files_run_gives_them(tmp_path, capsys):
    """--participants runs some of a file's participants, each with its random streams of the
    whole file's run (seeded by its place in the file, not in the choice), whatever the order given."""
    import pandas as pd

    from cacas.paths import study_data_dir

    people = json.loads((study_data_dir() / "personas" / "example.json").read_text())["participants"][:3]
    personas = write(tmp_path, {"participants": people})
    codes = [p["id"] for p in people]
    run = ["simulate", "--personas", str(personas), "--days", "2", "--interactions", "4", "--methods", "cacas,nn",
           "--seed", "3", "--quiet"]
    assert main(run + ["--out", str(tmp_path / "all")]) == 0
    assert main(run + ["--out", str(tmp_path / "some"), "--participants", f"{codes[2]}, {codes[0]}",
                       "--jobs", "2"]) == 0
    for name in ("daily.csv", "interactions.csv", "by_preference.csv"):
        whole, some = (pd.read_csv(tmp_path / d / name) for d in ("all", "some"))
        assert sorted(set(some["participant"])) == sorted([codes[0], codes[2]])
        mine = whole[whole["participant"] != codes[1]].reset_index(drop=True)
        pd.testing.assert_frame_equal(some, mine)
    assert len(pd.read_csv(tmp_path / "some" / "interactions.csv")) > 0


@pytest.mark.parametrize("plot", ["absolute", "dotdot", "symlink"])
def test_figures_into_the_out_folder_named_another_way_are_kept(tmp_path, capsys, monkeypatch, plot):
    """CLI audit: --plot naming the --out folder another way (an absolute path beside a relative
    one, x/../out, a link to it) deleted the figures just written there as 'an earlier run's'."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "x").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "out", target_is_directory=True)
    plot_dir = {"absolute": str(tmp_path / "out"), "dotdot": "x/../out", "symlink": "link"}[plot]
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--days", "1", "--interactions", "2",
                 "--methods", "nn", "--jobs", "1", "--quiet", "--out", "out", "--plot", plot_dir])
    out = capsys.readouterr().out
    assert code == 0 and "removed an earlier run's" not in out
    assert {"daily.csv", "fig3_success.html", "fig4_methods.html", "fig4_by_preference.html", "plotly.min.js"} <= \
        {p.name for p in (tmp_path / "out").iterdir()}



def _earlier_run(folder):
    """An earlier run's tables and figures in ``folder``: name -> text."""
    folder.mkdir(parents=True, exist_ok=True)
    earlier = {name: f"the earlier run's {name}\n" for name in
               ("daily.csv", "interactions.csv", "by_preference.csv", "fig3_success.html", "fig4_methods.html",
                "fig4_by_preference.html", "fig3_methods.html")}
    for name, text in earlier.items():
        (folder / name).write_text(text)
    return earlier


def _texts(folder):
    return {p.name: p.read_text() for p in folder.iterdir() if p.is_file()}


def test_ctrl_c_while_the_figures_are_drawn_leaves_the_earlier_run_whole(tmp_path, capsys, monkeypatch):
    """CLI audit: the tables were written before the figures were drawn, so Ctrl-C (or a failure)
    while drawing them left the new tables beside the earlier run's figures, and exit 130 said
    'interrupted' over a folder that was no longer as it was (README: 'leaves the folder as it was')."""
    import cacas.plots

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(cacas.plots, "methods_figure", interrupted)
    out = tmp_path / "out"
    earlier = _earlier_run(out)
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--days", "1", "--interactions", "2",
                 "--methods", "nn", "--jobs", "1", "--quiet", "--out", str(out), "--plot", str(out)])
    captured = capsys.readouterr()
    assert code == 130 and "cacas: interrupted" in captured.err
    assert "wrote" not in captured.out
    assert _texts(out) == earlier


def _refused_rename_onto(monkeypatch, name):
    """Every rename onto a file called ``name`` refused, as Windows refuses to replace a file another
    program holds open (plotly.min.js in a browser); the others done."""
    from cacas.store import files

    real = files.os.replace

    def replace(src, dst, *args, **kwargs):
        if Path(dst).name == name:
            raise PermissionError(13, "Permission denied", str(dst))
        return real(src, dst, *args, **kwargs)

    monkeypatch.setattr(files.os, "replace", replace)


def test_figures_that_cannot_be_written_leave_the_tables_beside_them_as_they_were(tmp_path, capsys, monkeypatch):
    """CLI audit: a figure that could not be written failed with 'the folder's files are unchanged'
    after the new tables had replaced the earlier run's there."""
    out = tmp_path / "out"
    earlier = _earlier_run(out)
    _refused_rename_onto(monkeypatch, "plotly.min.js")
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--days", "1", "--interactions", "2",
                 "--methods", "nn", "--jobs", "1", "--quiet", "--out", str(out), "--plot", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "plotly.min.js: cannot be written (Permission denied)" in err
    assert _texts(out) == earlier


@pytest.mark.parametrize("folder, plot, options", [
    ("out/daily.csv", None, []),
    ("out/checksums.sha256", None, []),
    ("plots/fig4_methods.html", "plots", []),
    ("plots/plotly.min.js", "plots", []),
    ("out/fig3_success.html", "out", []),  # figures beside their tables
    ("out/fig3_methods.html", "out", ["--loop", "each", "--methods", "cacas,nn"]),
])
def test_a_folder_where_a_result_file_goes_is_refused_before_the_simulation(tmp_path, capsys, monkeypatch, folder,
                                                                             plot, options):
    """CLI audit: a folder named daily.csv (or checksums.sha256) in --out was refused only when the
    tables were written, after the whole simulation."""
    import cacas.experiment

    def never(*a, **k):
        raise AssertionError("the simulation ran before the output folder was checked")

    monkeypatch.setattr(cacas.experiment, "simulate_study", never)
    (tmp_path / folder).mkdir(parents=True)
    (tmp_path / "out").mkdir(exist_ok=True)
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / "out"),
                 *(["--plot", str(tmp_path / plot)] if plot else []), *options])
    err = capsys.readouterr().err
    name = Path(folder).name
    flag = "--plot" if plot and plot != "out" else "--out"
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert (f"{flag} {tmp_path / Path(folder).parent}: holds a folder named {name}, where this run writes its {name}; "
            "valid: a folder without it (move or rename that folder), or another folder") in err
    assert [p.name for p in (tmp_path / "out").iterdir()] == ([name] if folder.startswith("out/") else [])  # as it was


@pytest.mark.parametrize("signum, code, said", [("SIGINT", 130, "cacas: interrupted"),
                                                ("SIGTERM", 143, "cacas: terminated")])
def test_a_signal_while_the_results_are_put_in_place_waits_for_them(tmp_path, capsys, monkeypatch, signum, code,
                                                                     said):
    """CLI audit: Ctrl-C or SIGTERM between the tables' write and the figures' left the new tables
    beside the earlier run's figures. Once the results are being put in place, the signal waits
    until they all are (under a second), then stops the command as usual."""
    import os
    import signal

    from cacas.store import files

    real = files.write_all
    sent = []

    def signalled(folder, contents, **kwargs):
        written = real(folder, contents, **kwargs)
        if not sent:
            sent.append(signum)
            os.kill(os.getpid(), getattr(signal, signum))
        return written

    monkeypatch.setattr(files, "write_all", signalled)
    out = tmp_path / "out"
    _earlier_run(out)
    plots = tmp_path / "plots"
    before = signal.getsignal(signal.SIGINT)
    result = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--days", "1", "--interactions", "2",
                   "--methods", "nn", "--jobs", "1", "--quiet", "--out", str(out), "--plot", str(plots)])
    captured = capsys.readouterr()
    assert sent and result == code and captured.err.endswith(f"{said}\n")
    assert f"wrote {out / 'daily.csv'}" in captured.out and "removed an earlier run's" in captured.out
    assert signal.getsignal(signal.SIGINT) == before
    texts = _texts(out)
    assert sorted(texts) == ["by_preference.csv", "checksums.sha256", "daily.csv", "interactions.csv"]  # the earlier figures went
    assert texts["daily.csv"].startswith("participant,method,day,")
    assert {"fig3_success.html", "fig4_methods.html", "fig4_by_preference.html", "plotly.min.js"} <= \
        {p.name for p in plots.iterdir()}


def test_figures_that_cannot_be_written_in_their_own_folder_say_the_tables_were(tmp_path, capsys, monkeypatch):
    """--plot another folder: the tables are put in place first; a figure that then cannot be
    written is one line that says where the tables were written."""
    plots = tmp_path / "plots"
    plots.mkdir()
    _refused_rename_onto(monkeypatch, "plotly.min.js")
    code = main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--days", "1", "--interactions", "2",
                 "--methods", "nn", "--jobs", "1", "--quiet", "--out", str(tmp_path / "out"), "--plot", str(plots)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "plotly.min.js: cannot be written (Permission denied)" in err
    assert f"; the tables were written in {tmp_path / 'out'}" in err
    assert (tmp_path / "out" / "daily.csv").read_text().startswith("participant,method,day,")
    assert not (plots / "fig3_success.html").exists()


def _option_help(command, option):
    """The --help text of ``option`` of ``cacas <command>``, on one line."""
    from cacas.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command").choices[command]
    action = next(a for a in sub._actions if option in a.option_strings)
    return " ".join(action.help.split())


from cacas.experiment import MAX_DAYS, MAX_INTERACTIONS, MAX_SEED  # noqa: E402


@pytest.mark.parametrize("option, says", [
    ("--days", [f"valid: a whole number from 1 to {MAX_DAYS}", "(default 7)"]),
    ("--interactions", [f"valid: a whole number from 1 to {MAX_INTERACTIONS}", "(default 15)"]),
    ("--seed", [f"valid: a whole number from 0 to {MAX_SEED}", "(default 0)"]),
    ("--no-response-rate", ["valid: 0 <= rate < 1", "(default 0.1)"]),
    ("--ask-after-reject", ["valid: 0 <= rate <= 1", "default 0"]),
    ("--jobs", ["valid: a whole number >= 1", "default: one per core"]),
    ("--methods", ["cacas, cacas-no-pr, orl, nn, bandit, sac-user-data", "default cacas,cacas-no-pr,orl,nn"]),
])
def test_simulate_help_says_what_is_valid_and_the_default(option, says):
    """CLI audit: --days, --interactions, --seed and the two rates said neither what the command
    accepts (it refuses the rest) nor, for --seed, the default; --methods said 'the paper's four'."""
    text = _option_help("simulate", option)
    for s in says:
        assert s in text, text


def _study_of_every_method(days):
    """A StudyResult as simulate_study returns it: every method, the given days, two participants
    (the first method in closed loop, a day with no interaction), the other tables empty."""
    import pandas as pd

    from cacas import records
    from cacas.experiment import StudyResult

    rows = []
    for person in ("P01", "P02"):
        for m_i, method in enumerate(records.METHOD_ORDER):
            for day in days:
                acts = m_i == 0 and day != days[0]
                rows.append(dict(participant=person, method=method, day=day,
                                 success_rate=0.123456 if acts else float("nan"), preference_accuracy=0.98765,
                                 cumulative_feedback=1234.5 + day, interactions=15,
                                 success_ceiling=1.0 if acts else float("nan"), unanswered=1))
    daily = pd.DataFrame(rows).reindex(columns=records.DAILY_COLUMNS)
    return StudyResult(daily=daily, interactions=pd.DataFrame(columns=records.INTERACTION_COLUMNS),
                       by_preference=pd.DataFrame(columns=records.BY_PREFERENCE_COLUMNS))


def test_the_printed_table_fits_an_80_column_terminal(tmp_path, capsys, monkeypatch):
    """CLI audit: the per-method, per-day table printed daily.csv's column names on one line, 91
    columns wide: it wrapped in an 80-column terminal (and in a log read in one). Every method,
    a day of three digits: the table's lines fit, its headings name daily.csv's columns, an
    empty mean is '-', and a piped run (capsys is no terminal) gets the same."""
    import cacas.experiment
    from cacas import records

    monkeypatch.setattr(cacas.experiment, "simulate_study", lambda *a, **k: _study_of_every_method([1, 365]))
    assert main(["simulate", "--personas", str(write(tmp_path, GOOD)), "--quiet", "--days", "365",
                 "--methods", ",".join(records.METHOD_ORDER), "--out", str(tmp_path / "o")]) == 0
    table = capsys.readouterr().out.split("\nwrote ")[0].splitlines()
    assert max(len(line) for line in table) <= 80, "\n".join(table)
    assert len(table) == 2 + 2 * len(records.METHOD_ORDER)
    assert table[0].split() == ["success", "success", "preference", "cumulative"]
    assert table[1].split() == ["method", "day", "rate", "ceiling", "accuracy", "feedback"]
    assert table[2].split() == ["cacas", "1", "-", "-", "0.988", "1235.5"]
    assert table[3].split() == ["cacas", "365", "0.123", "1.000", "0.988", "1599.5"]
    assert table[-1].split() == ["sac-user-data", "365", "-", "-", "0.988", "1599.5"]


@pytest.mark.parametrize("jobs, cores, gb, runs, says", [
    # more workers than cores: run as asked, and said (they take turns: no faster)
    (["--jobs", "6"], 2, 64, 6, ["--jobs 6: 6 worker processes on 2 cores take turns, so the run is not faster"]),
    # more than the memory holds (0.8 GB each): as many as it holds, and said
    (["--jobs", "6"], 8, 2.5, 3, ["--jobs 6: 6 worker processes need about 4.8 GB (0.8 GB each) and 2.5 GB of "
                                  "memory is available; running 3 (the results are the same"]),
    ([], 8, 2.5, 3, ["one worker process per core: 8 worker processes need about 6.4 GB"]),
    # one per participant at most, without a word; the default: one per core
    (["--jobs", "20"], 32, 64, 8, []),
    ([], 4, 64, 4, []),
    ([], 4, None, 4, []),  # the available memory unknown (not Linux): one per core
])
def test_jobs_beyond_the_cores_or_the_memory_are_said_or_capped(tmp_path, capsys, monkeypatch, jobs, cores, gb,
                                                                runs, says):
    """CLI audit: --jobs was bounded by the number of participants only; each worker process
    takes about 0.8 GB and a core, so --jobs 40 on a laptop was run (swapping, or killed for
    memory, losing the run) without a word."""
    import cacas.experiment
    import cacas.parallel

    asked = {}

    def study(people, **kw):
        asked.update(kw)
        return _study_of_every_method([1])

    monkeypatch.setattr(cacas.parallel, "cores", lambda: cores)
    monkeypatch.setattr(cacas.parallel, "available_memory", lambda: None if gb is None else int(gb * 2**30))
    monkeypatch.setattr(cacas.experiment, "simulate_study", study)
    people = {"participants": [dict(GOOD["participants"][0], id=f"P0{i}") for i in range(1, 9)]}
    assert main(["simulate", "--personas", str(write(tmp_path, people)), "--quiet", *jobs,
                 "--out", str(tmp_path / "o")]) == 0
    assert asked["jobs"] == runs
    notes = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(notes) == len(says)
    for note, said in zip(notes, says):
        assert note.startswith("cacas simulate: note: ") and said in note, note

