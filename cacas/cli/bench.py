"""``cacas bench``: how long participants and researchers wait (issue 6), as a table.

    cacas bench [--json FILE] [--quick] [--repeats N] [--threads N]

Measures, after warm-up and as medians over repeats: training the initial policy, one day's
CACAS adaptation, one robot decision, recognising a 1-s clip, a whole simulated study (8
participants x 7 days x 4 methods), SAC updates per second of the project's implementation and
of a plain reference (interleaved in the same run) and MFCC throughput. --json FILE also writes
the figures and the machine (cores, torch version). --quick is a smoke run (fewer repeats, a
1-participant x 2-day study, one simulated day of step 1): its figures are not the benchmark.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from cacas.cli import types
from cacas.errors import CacasError

#: the most torch threads --threads takes (more than any laptop or lab machine has cores)
MAX_THREADS = 256


#: ``cacas bench --help``'s text (the module's docstring is for developers), lines of at most 79
#: columns (RawDescriptionHelpFormatter keeps them as written).
DESCRIPTION = """\
Measure how long participants and researchers wait, and print a table of
medians over repeats, each after a warm-up call: training the initial policy
(CACAA step 1), one day's CACAS adaptation, one robot decision, recognising a
1-s clip, a whole simulated study (8 participants x 7 days x 4 methods), SAC
updates per second of the project's implementation and of a plain reference
(interleaved in the same run), and MFCC throughput. A full run takes several
minutes.

--json FILE also writes the figures and the machine (cores, CPU, torch
version). --quick is a smoke run (fewer repeats, a 1-participant x 2-day
study, one simulated day of step 1): its figures are not the benchmark."""


def register(sub) -> None:
    p = sub.add_parser("bench", help="measure decision, adaptation, recognition, training and simulation times",
                       description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", type=types.path, metavar="FILE", help="also write the figures and the machine as JSON")
    p.add_argument("--quick", action="store_true",
                   help="smoke run: fewer repeats (one of the long measurements, at least 3 of the short ones), "
                        "a 1 x 2-day study, 1 simulated day of initial training")
    p.add_argument("--repeats", type=types.integer, default=None, metavar="N", help="timed repeats of the short measurements; valid: a whole number >= 1 (default 5, fewer "
                        "with --quick)")
    p.add_argument("--threads", type=types.integer, default=1, metavar="N",
                   help=f"torch threads; valid: a whole number from 1 to {MAX_THREADS} (default 1: best for these small "
                        "networks)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    if args.repeats is not None and args.repeats < 1:
        raise CacasError(f"--repeats {args.repeats} is invalid; valid: a whole number >= 1")
    if not 1 <= args.threads <= MAX_THREADS:  # torch took 99999999999999999999 with a traceback (CLI audit)
        raise CacasError(f"--threads {args.threads} is invalid; valid: a whole number from 1 to {MAX_THREADS}")
    out = Path(args.json) if args.json else None
    if out is not None:  # checked before the minutes of measuring, in the user's words
        from cacas.store.files import writable_file

        writable_file(out, "--json", create_folders=False)

    from cacas.bench import BenchConfig, run_bench
    from cacas.cli.progress import ProgressBar

    cfg = BenchConfig.quick() if args.quick else BenchConfig()
    if args.repeats is not None:
        cfg.repeats = args.repeats
    cfg.threads = args.threads
    result = run_bench(cfg, None if args.quiet else ProgressBar("bench"))
    print(result.table())
    if out is not None:
        tmp = out.with_name(f".{out.name}.tmp")
        try:
            tmp.write_text(json.dumps(result.to_json(), indent=2) + "\n", encoding="utf-8")
            tmp.replace(out)
        except OSError as exc:  # e.g. the disk filled up meanwhile: name the user's file, not ours
            tmp.unlink(missing_ok=True)
            raise CacasError(f"--json {out}: cannot be written ({exc.strerror or exc})") from None
        print(f"wrote {out}")
    return 0
