"""``cacas simulate``: a whole simulated study (design.md's contract; the persona file: docs/personas.md;
the researcher's help: :data:`DESCRIPTION`).

    cacas simulate --personas FILE [--days 7] [--interactions 15]
                   [--methods cacas,cacas-no-pr,orl,nn] [--seed 0] --out DIR [--plot DIR]

Writes DIR/daily.csv, DIR/interactions.csv and DIR/by_preference.csv (Fig. 4's accuracy per
described preference: which preferences each method learnt, day by day), prints the
per-method, per-day table of means, and with --plot writes Fig. 3, Fig. 4 and the accuracy by
preference as Plotly HTML.

The first method acts and every method adapts from its interactions (the paper's Fig. 4). With
--loop each, every method runs its own closed-loop study instead (its own interactions and
success rate; with more than one method, --plot also writes fig3_methods.html, Fig. 3 for every
method).
"""

from __future__ import annotations

import argparse
import sys

from cacas import records
from cacas.cli import types
from cacas.errors import CacasError, case_twin, visible
from cacas.parallel import GB, WORKER_MEMORY




#: The plotly.js the figures load from their folder (``include_plotlyjs="directory"``).
PLOTLY_JS = "plotly.min.js"


def figure_files(figures: dict, captions: dict | None = None) -> dict[str, bytes]:
    """The files ``figures`` (file name -> Plotly figure) are written as: each as HTML, under it its
    caption (``captions``: file name -> text, the app's words from :mod:`cacas.plots`), and the
    plotly.js they load (:data:`PLOTLY_JS`), this plotly's. Plotly's own ``write_html`` keeps any
    plotly.min.js already in the folder, whatever it holds (an older plotly's, a truncated copy),
    and the figures then load it; written with these files, it is replaced by this plotly's."""
    from plotly.offline import get_plotlyjs

    captions = captions or {}
    return {**{name: _whole_window(fig.to_html(include_plotlyjs="directory"), captions.get(name)).encode("utf-8")
               for name, fig in figures.items()},
            PLOTLY_JS: get_plotlyjs().encode("utf-8")}


#: Plotly's page style: the figure fills the window (its height 100 %)
_PAGE_STYLE = "<style>html, body {height: 100%;}</style>"
#: Plotly's element around a figure as tall as the window (a figure of a height of its own, the preference
#: heatmap's, has its height in px)
_FILLING = '<div style="height:100%; width:100%;">'
#: A page with a caption: a column, the figure taking the window less the caption's height (at least
#: :data:`SMALLEST_FIGURE` px: a lower window scrolls), the caption under it in grey, at the plot's left edge
#: (``plots``' left margin of 60 px), its lines no longer than 60 em (~120 characters) on a wide screen
SMALLEST_FIGURE = 360
_CAPTION_STYLE = ("body {display: flex; flex-direction: column;} body > div {flex: none;} "
                  f"body > div.figure {{flex: 1 1 0; min-height: {SMALLEST_FIGURE}px;}} "
                  ".caption {flex: none; order: 1; margin: 8px 30px 16px 60px; max-width: 60em; color: #555; "
                  "font: 14px/1.45 'Open Sans', verdana, arial, sans-serif;}")


def _whole_window(page: str, caption: str | None = None) -> str:
    """A figure's page (Plotly's ``to_html``) without the browser's 8-px body margin: with it the
    figure, as tall as the window, began 8 px down and its bottom 8 px (Fig. 3's and Fig. 4's legend,
    :func:`cacas.plots.legend_block`) were below the window. With a ``caption``, the figure takes the
    window less the caption's height, and the caption is under it, in view without scrolling (walk2: the
    app's figures said what their hollow points, dashed line and band are; these pages did not)."""
    if _PAGE_STYLE not in page or page.count("<body>") != 1:
        raise AssertionError("plotly's page has changed: see _whole_window")
    style = "html, body {height: 100%; margin: 0;}"
    if caption:
        import html

        style += " " + _CAPTION_STYLE
        page = page.replace(_FILLING, _FILLING.replace("<div ", '<div class="figure" '), 1)
        # before the figure in the page, drawn under it (order): in place when plotly.js sizes the figure, which
        # it does once (and again on a window's resize); a caption after the figure's script came too late, and
        # the figure, sized to the whole window, ran under it
        page = page.replace("<body>", f'<body>\n    <p class="caption">{html.escape(caption)}</p>', 1)
    return page.replace(_PAGE_STYLE, f"<style>{style}</style>", 1)


def other_plotly_js(folder, script: bytes) -> bool:
    """Whether ``folder`` holds a plotly.min.js other than ``script`` (that writing the figures
    replaces)."""
    earlier = folder / PLOTLY_JS
    return earlier.is_file() and earlier.read_bytes() != script


#: The printed table's columns (:func:`cacas.experiment.summary_table`'s, daily.csv's names) as
#: two-line headings, and each one's decimals: with its names on one line it was 91 columns wide
#: and wrapped in an 80-column terminal (CLI audit).
SUMMARY_COLUMNS = {"method": ("", "method", None), "day": ("", "day", None),
                   "success_rate": ("success", "rate", 3), "success_ceiling": ("success", "ceiling", 3),
                   "preference_accuracy": ("preference", "accuracy", 3),
                   "cumulative_feedback": ("cumulative", "feedback", 1)}


def summary_text(table) -> str:
    """``table`` (:func:`cacas.experiment.summary_table`: means per method and day) as the lines
    ``cacas simulate`` prints: a two-line heading naming daily.csv's columns, the method on the
    left, numbers right-aligned, an empty mean (no closed loop, no interaction) as ``-``. At most
    60 columns for every method and up to 365 days, whatever the terminal (or a pipe, a log)."""
    import math

    columns = [c for c in SUMMARY_COLUMNS if c in table.columns]

    def cell(column, value) -> str:
        decimals = SUMMARY_COLUMNS[column][2]
        if decimals is None:
            return str(value)
        return "-" if value is None or math.isnan(value) else f"{value:.{decimals}f}"

    rows = [[SUMMARY_COLUMNS[c][0] for c in columns], [SUMMARY_COLUMNS[c][1] for c in columns],
            *([cell(c, row[c]) for c in columns] for row in table.to_dict("records"))]
    widths = [max(len(r[i]) for r in rows) for i in range(len(columns))]
    align = [str.ljust if c == "method" else str.rjust for c in columns]
    return "\n".join("  ".join(a(text, w) for text, w, a in zip(row, widths, align)).rstrip() for row in rows)


def choose_participants(people, codes: str, source) -> tuple[list, list[int]]:
    """The participants of ``people`` (a persona file's, in its order) that ``codes`` names
    (comma-separated, any order), in the file's order, and their places in it (their random
    streams' seeds: :func:`cacas.experiment.simulate_study`). A code the file lacks, one given
    twice, or none: a CacasError naming it and the valid codes."""
    wanted = [c.strip() for c in codes.split(",") if c.strip()]
    ids = [p.id for p in people]
    valid = f"valid: comma-separated codes of {source}: {', '.join(map(visible, ids))}"  # on the message's line
    if not wanted:
        raise CacasError(f"--participants {codes!r} names no participant; {valid}")
    unknown = [c for c in wanted if c not in ids]
    if unknown:
        meant = [case_twin(c, ids) for c in unknown]  # "p01" for "P01": a file's codes are unique in letter case
        hint = f"did you mean {', '.join(map(visible, meant))}? " if None not in meant else ""
        raise CacasError(f"--participants: {', '.join(map(visible, unknown))} "
                         f"{'is' if len(unknown) == 1 else 'are'} not in {source}; {hint}{valid}")
    twice = records.by_code({c for c in wanted if wanted.count(c) > 1})
    if twice:
        raise CacasError(f"--participants: {', '.join(map(visible, twice))} given twice; {valid}")
    places = [i for i, c in enumerate(ids) if c in wanted]
    return [people[i] for i in places], places


#: ``cacas simulate --help``'s text: for a researcher (the module's docstring is for developers),
#: its lines at most 79 columns wide (RawDescriptionHelpFormatter keeps them as written).
DESCRIPTION = """\
Run a simulated study: the participants of a persona file (its format:
docs/personas.md) act in the contexts their described preferences cover, about
--interactions times a day; the robot acts with the policy in force, and the
policy is adapted after each day (the paper's Fig. 3 and Fig. 4).

Writes DIR/daily.csv (one row per participant, method and day: success_rate,
preference_accuracy, cumulative_feedback, interactions, ...),
DIR/interactions.csv (every simulated interaction) and DIR/by_preference.csv
(Fig. 4's accuracy per described preference), and prints each method's mean
of each day. With --plot, also Fig. 3, Fig. 4 and the accuracy by preference
as Plotly HTML. The same --seed writes the same daily.csv.

The first method acts with the participants and every method adapts from the
same interactions (the paper's Fig. 4); with --loop each, every method runs a
closed-loop study of its own (with more than one method, --plot also writes
fig3_methods.html, Fig. 3 for every method)."""

EPILOG = """\
examples (from the project folder):
  cacas simulate --personas study_data/personas/example.json --out results
  cacas simulate --personas study_data/personas/example.json --days 3 \\
      --participants P01,P02 --methods cacas,nn --out results --plot results"""


def register(sub) -> None:
    p = sub.add_parser("simulate", help="run a simulated study (Fig. 3 / Fig. 4) from a persona file",
                       description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--personas", required=True, type=types.path, metavar="FILE", help="persona JSON file (its format: docs/personas.md)")
    p.add_argument("--participants", metavar="CODES",
                   help="comma-separated participant codes of the persona file to simulate (default: all); "
                        "each gets the rows the whole file's run gives them")
    # the ranges the command checks (cacas.experiment.study_argument_problems), said in the help
    default = records.SIMULATION_DEFAULTS
    p.add_argument("--days", type=types.integer, default=default["days"],
                   help=f"study days; valid: a whole number from 1 to {records.MAX_DAYS} (default {default['days']})")
    p.add_argument("--interactions", type=types.integer, default=default["interactions"],
                   help=f"interactions a day, about; valid: a whole number from 1 to {records.MAX_INTERACTIONS} "
                        f"(default {default['interactions']})")
    p.add_argument("--methods", default=",".join(default["methods"]),
                   help="comma-separated methods; the first runs in closed loop, or every one with --loop each; "
                        f"valid: {', '.join(records.METHOD_ORDER)}, each at most once (default "
                        f"{','.join(default['methods'])}, the paper's four)")
    p.add_argument("--seed", type=types.integer, default=default["seed"],
                   help=f"random seed (same seed, same daily.csv); valid: a whole number from 0 to "
                        f"{records.MAX_SEED} (default {default['seed']})")
    p.add_argument("--no-response-rate", type=types.share, default=default["no_response_rate"], metavar="RATE",
                   help="share of robot actions the simulated participant does not answer; valid: 0 <= rate < 1 "
                        f"(default {default['no_response_rate']:g})")
    p.add_argument("--ask-after-reject", type=types.share, default=default["ask_after_reject"], metavar="RATE",
                   help="share of wrong robot actions the simulated participant answers by asking for the "
                        "preferred action instead (as the tablet allows); valid: 0 <= rate <= 1 (default "
                        f"{default['ask_after_reject']:g}: only when the robot does nothing)")
    p.add_argument("--loop", default=default["loop"], metavar="{first,each}",
                   help="first: the first method acts, every method adapts from its interactions (the paper's "
                        "Fig. 4; default); each: every method acts and adapts in a closed loop of its own")
    p.add_argument("--d4a", type=types.path, metavar="FILE", help="a D4A pairs CSV of your own (default: study_data/d4a.csv)")
    p.add_argument("--out", required=True, type=types.path, metavar="DIR",
                   help="folder for daily.csv, interactions.csv and by_preference.csv")
    p.add_argument("--plot", type=types.path, metavar="DIR",
                   help="also write Fig. 3, Fig. 4 and Fig. 4 by described preference as Plotly HTML here: the "
                        "--out folder, or one holding no tables (not a study's export, nor another run's)")
    p.add_argument("--jobs", type=types.integer, default=None, metavar="N",
                   help="worker processes, participants side by side, each holding about "
                        f"{WORKER_MEMORY / GB:.1f} GB; valid: a whole number >= 1 (default: one per core); at "
                        "most one per participant and as many as the available memory holds (fewer are run, "
                        "with a note); more than the cores is run, with a note (no faster); the results do "
                        "not depend on it")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def say_initial_policy_training(d4a) -> None:
    """One line on stderr when the initial policy of ``d4a`` (CACAA step 1) is to be trained first: without a
    terminal the progress bar draws nothing, and a new D4A table's ~30-45 s of training went unsaid (walk3)."""
    from cacas.adaptation import initial_policy_path

    path = initial_policy_path(d4a)
    if not path.exists():
        print(f"cacas simulate: training the initial policy for {d4a.source or 'the D4A table'} first (CACAA step 1, "
              f"about half a minute; once: it is kept as {path})", file=sys.stderr, flush=True)


def run(args) -> int:
    from cacas.experiment import check_loop, check_methods, check_study_arguments

    check_study_arguments(args.days, args.interactions, args.no_response_rate, args.ask_after_reject, args.seed)
    args.loop = check_loop(args.loop)
    if args.jobs is not None and args.jobs < 1:
        raise CacasError(f"--jobs {args.jobs} is invalid; valid: a whole number >= 1")
    try:
        methods = check_methods(args.methods.split(","))
    except CacasError as exc:
        raise CacasError(f"--methods {args.methods}: {exc}") from None

    from cacas.cli.progress import ProgressBar
    from cacas.d4a import load_d4a
    from cacas.experiment import simulate_study, summary_table
    from cacas.parallel import plan_jobs
    from cacas.export import SIMULATION_FIGURES, SIMULATION_TABLES, check_output_folder
    from cacas.preferences import load_personas
    from cacas.store import files
    from cacas.store import validate as v

    people = load_personas(args.personas)
    places = None
    if args.participants is not None:
        people, places = choose_participants(people, args.participants, args.personas)
    for person in people:  # read as it is (the researcher's file), but the study database would refuse it
        try:
            v.new_code(person.id)
        except CacasError as exc:
            print(f"cacas simulate: note: {args.personas}: {exc}; the study database refuses such codes",
                  file=sys.stderr)
    d4a = load_d4a(args.d4a) if args.d4a else load_d4a()
    jobs, notes = plan_jobs(args.jobs, len(people))
    for note in notes:
        print(f"cacas simulate: note: {note}", file=sys.stderr)
    # the output folders are checked before the (long) simulation, not after it; a refused --plot
    # leaves no --out folder behind, nor the folders above it that it created
    made = [folder for f in (args.out, args.plot) if f for folder in files.missing_folders(f)]
    progress = None
    check_output_folder(args.out, "simulation", f"--out {args.out}")
    if args.plot and args.plot.resolve() != args.out.resolve():  # figures beside their own tables are fine
        check_output_folder(args.plot, "figures", f"--plot {args.plot}")
    each_fig3 = args.loop == "each" and len(methods) > 1  # Fig. 3 of every method beside Fig. 3 of the first
    figure_names = [*(n for n in SIMULATION_FIGURES if n != "fig3_methods.html" or each_fig3), PLOTLY_JS,
                    files.CHECKSUMS]
    try:
        # checked, not made: a new folder is put in place whole, or not at all (files.write_all)
        together = args.plot is not None and args.plot.resolve() == args.out.resolve()  # (a link to it, say)
        out = files.writable_folder(args.out, f"--out {args.out}", create=False,
                                    names=[*SIMULATION_TABLES, files.CHECKSUMS, *(figure_names if together else [])])
        plot_dir = args.plot if together or not args.plot else \
            files.writable_folder(args.plot, f"--plot {args.plot}", create=False, names=figure_names)
        progress = None if args.quiet else ProgressBar("simulate")
        if progress is not None and not progress.on_terminal:  # logs, pipes: no bar, a line a tenth once 10 s have passed
            say_initial_policy_training(d4a)
        result = simulate_study(people, days=args.days, interactions=args.interactions, methods=methods,
                                seed=args.seed, no_response_rate=args.no_response_rate, progress=progress, d4a=d4a,
                                jobs=jobs, ask_after_reject=args.ask_after_reject,
                                loop=args.loop, places=places)
    except BaseException:  # a refused --plot, Ctrl-C, a failure: no empty folder of ours is left behind
        files.remove_empty(made)
        raise
    finally:  # the bar's line ended however the run stopped: "cacas: interrupted" starts a line of its own
        if progress is not None:
            progress.done()
    # everything the run writes is made before any of it is: Ctrl-C or a failure while the figures
    # are drawn leaves the folders as they were (the tables were written first, and stayed beside
    # an earlier run's figures)
    tables = {"daily.csv": records.csv_bytes(result.daily),
              "interactions.csv": records.csv_bytes(result.interactions),
              "by_preference.csv": records.csv_bytes(result.by_preference)}
    figures: dict = {}
    captions: dict = {}  # under each figure, the app's words
    if plot_dir is not None:
        from cacas import plots

        daily, by_preference = result.daily, result.by_preference
        figures = {"fig3_success.html": plots.success_figure(daily, methods[0]),
                   "fig4_methods.html": plots.methods_figure(daily),
                   "fig4_by_preference.html": plots.preference_methods_figure(by_preference)}  # the last day's
        captions = {"fig3_success.html": plots.success_caption(daily, methods[0]),
                    "fig4_methods.html": plots.METHODS_CAPTION,
                    "fig4_by_preference.html": plots.preferences_caption(int(by_preference["day"].max()))}
        if each_fig3:
            figures["fig3_methods.html"] = plots.success_methods_figure(daily)
            captions["fig3_methods.html"] = plots.success_methods_caption(daily)
    drawn = figure_files(figures, captions) if figures else {}
    replaced = plot_dir is not None and other_plotly_js(plot_dir, drawn[PLOTLY_JS])
    # an earlier run's figures beside these tables would show other results: taken away in the same
    # change as the folder's new files (files.write_all's remove: a kill cannot leave one unlisted
    # beside them), and said. The folders compared as resolved: --plot may name --out another way
    # (absolute, x/../out, a link), and the figures written there are this run's
    # (every figure name not drawn there is given to remove: a killed run's hidden copy of one goes too)
    together = plot_dir is not None and plot_dir.resolve() == out.resolve()
    stale_out = [n for n in SIMULATION_FIGURES if not (together and n in figures)]
    stale_plot = [n for n in SIMULATION_FIGURES if n not in figures] if plot_dir is not None and not together else []
    stale = [d / n for d, names in ((out, stale_out), (plot_dir, stale_plot)) for n in names if (d / n).is_file()]
    table = summary_table(result.daily)
    from cacas.cli import signals_held

    # put in place as one change, and said: Ctrl-C or SIGTERM from here on stops the command after it
    with signals_held():
        remains = [files.remains(out, [*tables, *(drawn if together else ()), *SIMULATION_FIGURES, PLOTLY_JS])]
        if plot_dir is not None and not together:
            remains.append(files.remains(plot_dir, [*drawn, *SIMULATION_FIGURES]))
        if together:  # tables and figures replace an earlier run's together, or not at all
            written = files.write_all(out, {**tables, **drawn}, checksums=True, remove=stale_out)
        else:  # the three tables replace an earlier run's together, or not at all; then the figures
            written = files.write_all(out, tables, checksums=True, remove=stale_out)
            if plot_dir is not None:
                try:  # a folder of figures checked as one too
                    files.write_all(plot_dir, drawn, checksums=True, remove=stale_plot)
                except CacasError as exc:
                    raise CacasError(f"{exc}; the tables were written in {out}") from None
        for note in filter(None, remains):
            print(f"cacas simulate: note: {note}", file=sys.stderr)
        print(summary_text(table))
        print("wrote " + ", ".join(str(written[name]) for name in tables))
        if plot_dir is not None:
            print("wrote " + ", ".join(str(plot_dir / name) for name in figures) + f" and {plot_dir / PLOTLY_JS}, "
                  "the plotly.js they load (keep it beside them)")
            if replaced:
                print(f"replaced an earlier {plot_dir / PLOTLY_JS}: it was not the plotly.js these figures need")
        if stale:
            print("removed an earlier run's " + ", ".join(str(p) for p in stale)
                  + (" (it no longer matches these tables)" if len(stale) == 1 else " (they no longer match these tables)"))
    return 0
