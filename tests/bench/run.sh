#!/bin/sh
# run.sh — what `make bench` runs (issue 10): sweeps the knobs that buy
# accuracy on the trees in $SYLVA_DATA (default ../shared/data; the bundled
# example tree when absent), measures the peers and the floor, and writes
# bench/results/ and docs/benchmarks.md (tests/bench/bench.py).
#   SYLVA_BENCH=quick (default: 3 trees, 8 views, a few minutes)
#   SYLVA_BENCH=full  (5 trees, 24 views, wider sweep, ~30 minutes)
#   SYLVA_BENCH=all   (the full sweep on every tree, about an hour)
#   SYLVA_BENCH_TREES=dir1,dir2  only these data folders
# Bakes run one at a time (the machine is shared).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
: "${BUILD:=build}"
: "${SYLVA_DATA:=$root/../shared/data}"
export BUILD SYLVA_DATA
command -v python3 > /dev/null 2>&1 || { echo "bench: python3 missing (make deps)"; exit 1; }
command -v gnuplot > /dev/null 2>&1 || echo "bench: gnuplot missing (make deps installs gnuplot-nox): no plots"
cd "$root"
python3 "$here/bench.py"
# issue 18: every quad method at a budget, sveval beside our figure
python3 "$here/fidelity.py"
# issue 18: the same points on ez-tree presets made here, not in the data set (node, npm)
python3 "$here/unseen.py"
# issue 21: octahedral impostors against billboard clouds (IoU vs texels and time)
python3 "$here/octahedral.py"
# issue 19: a target search against one bake of its choice; the default chain
python3 "$here/target_cost.py"
# issue 40: the same on every shared and held-out tree, billboard clouds and leaf clusters (~30 min)
python3 "$here/target_cost.py" --sets
# issue 19: `{}` as it is on every shared tree (four levels or more each)
python3 "$here/default_chains.py"
# issue 24: every stochastic level against meshoptimizer at equal triangles (sveval)
python3 "$here/stochastic_peers.py"
# issue 40 item 3: every level of one default stochastic bake against sloppy, a twig tree too
python3 "$here/stochastic_sloppy.py" --twig --doc
# issue 40: the held-out set (ez-tree, Sapling, sweethome3d-furniture; tests/bench/heldout.py)
# beside the shared set: chains, chain rules, levels against sveval, cutoffs, stochastic vs sloppy
python3 "$here/heldout_figures.py" --shared
# issue 40 item 7: every shared tree moved by 10^7 units bakes to the same stand-ins (~15 min)
python3 "$here/far_origin_sets.py"
# issue 41: every level's brightness under sveval's colour, the shared and the held-out set (~20 min)
python3 "$here/brightness.py"
python3 "$here/brightness.py" --heldout
# issue 20 item 5: each method's default against the floor, the one-triangle bake, peak RSS
python3 "$here/speed.py"
# issue 20 item 1: daemon jobs per minute with and without the worker pool
python3 "$here/pool.py"
