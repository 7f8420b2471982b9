#!/usr/bin/env bash
# Installs everything the test suite needs on a fresh machine, then runs the whole suite.
# Used by the README's test command and by .ci/run.
set -euo pipefail
cd "$(dirname "$0")/.."
# the browser tests drive /usr/bin/chromium (tests/browser/conftest.py): another chromium on the PATH (a snap's) is not it
if [ ! -x /usr/bin/chromium ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium >/dev/null
fi
python3 -m pip install -q -e ".[dev]"
# The whole suite runs at once, in a test process a core (pytest-xdist; at most 4: each holds ~0.6 GB of imports); the
# tests without a browser run one torch thread each (tests/conftest.py); each browser test file is one group
# (--dist loadgroup: its tests share their Streamlit server; tests/conftest.py), and drives a server and Chromium,
# which keep a core busy (vmstat: idle ~0). Its servers are forked from one process that imported the heavy modules
# once (tests/browser/server_zygote.py), its pages are of one Chromium profile whose cache keeps Streamlit's frontend
# compiled (tests/browser/conftest.py: Chromium). They read a page once every element is drawn (headless.drawn: at
# load 7-10 a page was once read while some of its elements still waited for their code). The slowest tests are
# listed at the end: the aim is well under 15 minutes on CI (TIMES on that EPYC, 2026-11-28).
workers=$(python3 -c "import os; print(max(1, min(4, len(os.sched_getaffinity(0)))))")
status=0
python3 -m pytest -q --durations=25 -n "$workers" --dist loadgroup "$@" || status=$?
# 5: no test among the ones asked for
[ "$status" -eq 5 ] && status=0
exit "$status"
