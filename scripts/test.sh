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
# the slowest tests listed at the end: the suite is kept well under 15 minutes on CI
python3 -m pytest -q --durations=15 "$@"
