#!/usr/bin/env bash
# CI: `pvrsim view` in a real browser (tests/browser/test_viewer.py):
# Debian's chromium and chromium-driver (installed here when root and
# missing; no browser download), Selenium from pip in a fresh virtual
# environment. Skips with a message, exit 0, where there is no chromium and
# no root to install it (a developer's box). Needs target/release/pvrsim
# (`cargo build --release`, which `cargo test --release` leaves).
# PVRSIM_VIEWER_SCREENSHOT=docs/viewer.png also takes the page's screenshot.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v chromium >/dev/null || ! command -v chromedriver >/dev/null; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null
    else
        echo "ci-viewer: skipped: no chromium/chromedriver and not root to apt-get install them" >&2
        exit 0
    fi
fi
if ! python3 -c "import venv, ensurepip" 2>/dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
fi
[ -x target/release/pvrsim ] || timeout 2400 cargo build --release

venv="$PWD/target/ci-viewer-venv"
[ -x "$venv/bin/pip" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q selenium pytest

set +e
timeout 1200 "$venv/bin/python" -m pytest tests/browser -q -p no:cacheprovider -s
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
    echo "ci-viewer: pytest collected no test" >&2
    exit 1
fi
exit "$rc"
