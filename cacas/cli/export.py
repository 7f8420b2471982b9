"""``cacas export`` and ``cacas import``: a study database to CSV tables + zip, and back.

    cacas export --db PATH --out DIR [--study NAME] [--tables-only]
    cacas import --bundle ZIP --db NEWPATH

``export`` opens the database read-only after checking it is a study database, so a missing
file or any other file exits 2 with one line and creates nothing (not even DIR). ``import``
refuses an existing NEWPATH, and prints a note for each cell it kept as the study held it although
the forms refuse it in new data (a code like a phone number or a date, contact details in text).
See :mod:`cacas.export`.
"""

from __future__ import annotations

import argparse
import sys

from cacas.cli import types
from cacas.export import BUNDLE_NAME, export_study, import_bundle
from cacas.store import StudyStore
from cacas.store.files import writable_file


def register(subparsers) -> None:
    p = subparsers.add_parser("export", help="write a study database as CSV tables and one zip",
                              description="Write interactions.csv, daily.csv, by_preference.csv, "
                                          "participants.csv, questionnaire.csv, adaptations.csv (and the "
                                          f"tables needed to move the study) into DIR, and all of them as "
                                          f"DIR/{BUNDLE_NAME}. DIR may be new, empty or an earlier export's "
                                          "(its files are replaced; other files there are left as they "
                                          "are), not a simulation's (its tables or its figures).")
    p.add_argument("--db", required=True, type=types.path, metavar="FILE",
                   help="the study database (.sqlite; the app's: study_data/cacas.sqlite, or $CACAS_DB)")
    p.add_argument("--out", required=True, type=types.path, metavar="DIR", help="output folder (created if missing)")
    p.add_argument("--study", default=None, metavar="NAME", help="export the study of this name only (default: every "
                                                                 "study in the database)")
    p.add_argument("--tables-only", action="store_true",
                   help=f"write the CSV tables without {BUNDLE_NAME} (which needs every policy file); "
                        "an earlier export's zip in DIR is kept if it holds these same tables, else removed")
    p.set_defaults(func=run_export)

    q = subparsers.add_parser("import", help="load an exported bundle into a new study database",
                              description=f"Load a {BUNDLE_NAME} written by `cacas export` into a new "
                                          "database file (an existing file is never overwritten).")
    q.add_argument("--bundle", required=True, type=types.path, metavar="ZIP", help=f"the {BUNDLE_NAME} to import")
    q.add_argument("--db", required=True, type=types.database_file, metavar="FILE",
                   help="the NEW database file to create (open it with CACAS_DB=FILE streamlit run app.py)")
    q.set_defaults(func=run_import)


def run_export(args: argparse.Namespace) -> int:
    result = export_study(args.db, args.out, study=args.study, bundle=not args.tables_only)
    if result.remains:
        print(f"cacas export: note: {result.remains}", file=sys.stderr)
    for name, path in result.tables.items():
        print(f"wrote {path}")
    if result.bundle is not None:
        print(f"wrote {result.bundle}")
    for path in result.removed:
        print(f"removed an earlier export's {path} ({result.removed_why})")
    if result.kept is not None:
        print(f"kept an earlier export's {result.kept}: it holds these same tables and the policy files they name")
    return 0


def run_import(args: argparse.Namespace) -> int:
    writable_file(args.db, "--db")  # named as the user gave it, not the temporary file built beside it
    restored = import_bundle(args.bundle, args.db)
    for note in restored.notes:
        print(f"cacas import: note: {args.bundle}: {note}", file=sys.stderr)
    with StudyStore(args.db, readonly=True) as store:
        people = len(store.list_participants())
    n = restored.interactions
    print(f"imported {people} participant{'' if people == 1 else 's'} and {n} interaction{'' if n == 1 else 's'} "
          f"into {args.db}")
    return 0
