#!/bin/sh
# fuzz_short.sh — the CI form of `make fuzz`, a smoke: builds the libFuzzer
# targets (tests/fuzz/, clang, ASan+UBSan; CI builds them beforehand with
# `make ci-build`) and runs each for FUZZ_SECONDS (default 5: the seed corpus
# of tests/fuzz/corpus/ replayed, then a few seconds of mutation) so the
# targets and their seeds stay working. Real fuzzing is `make fuzz` (60 s per
# target). Fails on any finding. Skipped (77) only when clang is missing.
# sylva-test: no-sanitize (its targets are clang ASan+UBSan builds already) cost=40
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=${SYLVA_ROOT:-$(cd "$here/../.." && pwd)}
build=${BUILD:-build}
# The fuzz targets are ASan+UBSan builds whatever the build directory: the
# plain pass of `make test` runs them; the sanitizer pass would only repeat it.
command -v clang > /dev/null 2>&1 || { echo "skipped: clang missing (deploy/apt-packages.txt lists it)"; exit 77; }
# make from inside `make test`: forget the outer make's flags (SANITIZE=1 would
# add gcc's sanitizer flags nowhere here, but keep the environment clean).
unset MAKEFLAGS MFLAGS SANITIZE
cd "$root" || exit 1
make --no-print-directory BUILD="$build" -j2 FUZZ_SECONDS="${FUZZ_SECONDS:-5}" fuzz
