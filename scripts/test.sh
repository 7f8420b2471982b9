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
# (pytest-xdist; at most 4: each process holds ~0.6 GB of imports); the browser tests then run one at a time,
# each driving a Streamlit server and Chromium, which use every core. Two at a time (-n 2 --dist loadfile) took
# 596 s instead of ~700 on a 2-core machine, but at load 7-10 a page was read before it had settled (one
# failure in two clean-clone runs): not worth a red CI. The slowest tests of each part are listed at its end:
# the suite is kept well under 15 minutes on CI.
workers=$(python3 -c "import os; print(max(1, min(4, len(os.sched_getaffinity(0)))))")
status=0
python3 -m pytest -q --durations=15 -n "$workers" -m "not browser" "$@" || status=$?
browser=0
python3 -m pytest -q --durations=15 -m browser "$@" || browser=$?
# 5: no test of that part among the ones asked for (bash scripts/test.sh tests/test_records.py)
[ "$status" -eq 5 ] && status=0
[ "$browser" -eq 5 ] && browser=0
[ "$status" -ne 0 ] && exit "$status"
exit "$browser"
