#!/bin/sh
# clean_checkout.sh [DIR] — the acceptance of a fresh clone (docs/testing.md
# "What a test may write"): after the build, `make demo`'s README run and
# `make test`, nothing under the checkout but build/ may have changed: no
# modified or deleted tracked file, and no new file, ignored ones included
# (node_modules, out/, __pycache__). Prints each offender; exit 1 if any.
# .ci/run ends with it.
set -u
cd "${1:-$(dirname "$0")/../..}" || exit 1
bad=$(git status --porcelain --ignored --untracked-files=all | grep -v '^!! build/' | grep -v '^?? build/')
if [ -n "$bad" ]; then
    echo "clean_checkout: the checkout changed outside build/ (git status --porcelain --ignored):"
    echo "$bad"
    exit 1
fi
echo "clean_checkout: nothing outside build/ changed"
