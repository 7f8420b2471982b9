"""Print the README's table of the shipped example personas (covered states, twists vs D4A).

    python3 scripts/persona_table.py [PERSONA_FILE] [--d4a FILE]

``--d4a``: the differing preferences counted against a D4A table of your own, as ``cacas simulate
--d4a`` trains on it (default: the shipped study_data/d4a.csv).
"""

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one

from cacas.cli import types  # noqa: E402
from cacas.d4a import load_d4a, persona_summary  # noqa: E402
from cacas.errors import CacasError  # noqa: E402
from cacas.paths import study_data_dir  # noqa: E402
from cacas.preferences import load_personas  # noqa: E402


def markdown(path, d4a_path=None) -> str:
    """The table of the persona file at ``path``, its differing preferences counted against the D4A
    table at ``d4a_path`` (None: the shipped one)."""
    frame = persona_summary(load_personas(path), load_d4a(d4a_path))
    lines = ["| participant | preferences | covered S1-S4 states | differing from D4A |", "|---|---|---|---|"]
    for row in frame.itertuples(index=False):
        lines.append(f"| {row.participant} | {row.preferences} | {row.covered_states} | {row.differing_from_d4a} |")
    # means to 2 decimals at most (walk3: 3 participants read '2.33333'); the README's 5 and 3.75 as they are
    lines.append(f"| mean | {round(frame.preferences.mean(), 2):g} | {frame.covered_states.mean():.1f} | "
                 f"{round(frame.differing_from_d4a.mean(), 2):g} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Print the table; a bad persona file is one line naming what is wrong (as ``cacas simulate``
    says it) and exit code 2, not a traceback."""
    parser = argparse.ArgumentParser(description="Print a persona file's table: covered states, twists vs D4A.")
    parser.add_argument("persona_file", nargs="?", default=str(study_data_dir() / "personas" / "example.json"),
                        help="a persona file (default: the shipped example personas)")
    # walk3: always against the shipped D4A, so a lab with its own table read the wrong count
    parser.add_argument("--d4a", type=types.path, metavar="FILE",
                        help="a D4A pairs CSV of your own, as cacas simulate --d4a (default: study_data/d4a.csv)")
    args = parser.parse_args(argv)
    try:
        table = markdown(args.persona_file, args.d4a)
    except CacasError as exc:
        print(f"persona_table: {exc}", file=sys.stderr)
        return 2
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
