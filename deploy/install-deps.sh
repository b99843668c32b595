#!/bin/sh
# Installs the Debian packages listed in deploy/apt-packages.txt (or in the list
# file given as $1, e.g. deploy/apt-packages-bench.txt) that are missing.
# Non-interactive; runs `apt-get update` only when something is missing; uses
# sudo when not root. Prints what it does.
set -eu
list="${1:-$(dirname "$0")/apt-packages.txt}"
missing=""
for p in $(grep -v '^#' "$list" | grep -v '^[[:space:]]*$'); do
    # node/npm may come from elsewhere (NodeSource bundles npm): a working command counts.
    case "$p" in
        nodejs) command -v node >/dev/null 2>&1 && continue ;;
        npm) command -v npm >/dev/null 2>&1 && continue ;;
    esac
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing="$missing $p"
    fi
done
if [ -z "$missing" ]; then
    exit 0
fi
echo "sylva: installing missing Debian packages:$missing"
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
# shellcheck disable=SC2086
$SUDO apt-get install -y -q --no-install-recommends $missing
