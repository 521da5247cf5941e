#!/usr/bin/env bash
# CI: the Python module (python/, docs/python.md). In a fresh virtual
# environment, installs the package exactly as the docs say
# (`pip install ./python`, maturin building the crate in release: it reuses
# the pvrsim library that `cargo test --release` left in target/, so only
# pyo3 and the module compile), then runs the pytest suite python/tests.
# pytest's exit code 5 (no test collected) fails the step.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! python3 -c "import venv, ensurepip" 2>/dev/null; then
    # Debian ships venv's pip bootstrap separately (CI runs as root).
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
fi

venv="$PWD/target/ci-python-venv"
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q ./python pytest pandas matplotlib

# The module imports from any folder (not only from the repository).
(cd / && "$venv/bin/python" -c "import pvrsim; print('pvrsim', pvrsim.__version__, 'imports')")

set +e
"$venv/bin/python" -m pytest python/tests -q -p no:cacheprovider
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
    echo "ci-python: pytest collected no test" >&2
    exit 1
fi
exit "$rc"
