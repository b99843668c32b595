#!/bin/sh
# fuzz_short.sh — the CI form of `make fuzz`, a smoke: builds the libFuzzer
# targets (tests/fuzz/, clang, ASan+UBSan, in $BUILD/fuzz; .ci/run builds
# them with the ASan tree, in the background) and runs each on the seed corpus of tests/fuzz/corpus/ and
# then FUZZ_RUNS (default 2000) mutations from the fixed seed FUZZ_SEED
# (default 1), writing new inputs to a fresh directory: the same inputs every
# run, so CI passes or fails for a reason that reproduces (a timed random run
# failed CI once on an input nobody had seen before). Exploring is `make fuzz`
# (random seed, 60 s per target); what it finds goes into the corpus and the
# pre-checks. Fails on any finding. Skipped (77) only when clang is missing.
# sylva-test: sanitize-only (its targets are clang ASan+UBSan builds whatever the pass: it runs once, in the sanitizer pass, whose tree CI builds them with) cost=40
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=${SYLVA_ROOT:-$(cd "$here/../.." && pwd)}
build=${BUILD:-build}
# The fuzz targets are ASan+UBSan builds whatever the build directory, so
# they run in one pass only: the sanitizer pass (BUILD=build/asan).
command -v clang > /dev/null 2>&1 || { echo "skipped: clang missing (deploy/apt-packages.txt lists it)"; exit 77; }
# make from inside `make test`: forget the outer make's flags (SANITIZE=1 would
# add gcc's sanitizer flags nowhere here, but keep the environment clean).
unset MAKEFLAGS MFLAGS SANITIZE
cd "$root" || exit 1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT INT TERM
make --no-print-directory BUILD="$build" -j2 FUZZ_WORK="$work" \
    FUZZ_LIMIT="-seed=${FUZZ_SEED:-1} -runs=${FUZZ_RUNS:-2000}" fuzz
