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
# The tests without a browser run one torch thread each (tests/conftest.py), so they run in a process a core
# (pytest-xdist; at most 4: each process holds ~0.6 GB of imports); the browser tests then run two at a time,
# a test file to each (--dist loadfile: a file's tests share their Streamlit server), each driving a server and
# Chromium, which keep both cores busy (vmstat: idle ~0) (on a 2-core AMD EPYC: 496-581 s two at a time, the servers
# forked from one process that imported the heavy modules once: tests/browser/server_zygote.py; the pages of one
# Chromium profile whose cache keeps Streamlit's frontend compiled: tests/browser/conftest.py, Chromium; ~700 s one
# at a time before both). They read a page once every element is drawn (headless.drawn: at load 7-10 a page was once read
# while some of its elements still waited for their code). The slowest tests of each part are listed at its end:
# the aim is well under 15 minutes on CI (about 15 on that EPYC, 2026-11-28: 349-384 + 510-562 s of pytest in five
# clean clones).
# The suite's processes keep what Python compiles (__pycache__, ignored by git): with PYTHONDONTWRITEBYTECODE set (as
# in this project's sandbox) every process compiled cacas anew (each CLI test's, each worker's, each spawned one's) and
# pytest rewrote every test module again: the part without a browser took 605 s of CPU against 571 (371 s against 353).
unset PYTHONDONTWRITEBYTECODE
workers=$(python3 -c "import os; print(max(1, min(4, len(os.sched_getaffinity(0)))))")
browsers=$(( workers < 2 ? workers : 2 ))
status=0
python3 -m pytest -q --durations=15 -n "$workers" -m "not browser" "$@" || status=$?
browser=0
python3 -m pytest -q --durations=15 -n "$browsers" --dist loadfile -m browser "$@" || browser=$?
# 5: no test of that part among the ones asked for (bash scripts/test.sh tests/test_records.py)
[ "$status" -eq 5 ] && status=0
[ "$browser" -eq 5 ] && browser=0
[ "$status" -ne 0 ] && exit "$status"
exit "$browser"
