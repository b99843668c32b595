#!/bin/sh
# help2man.sh BINARY NAME SUMMARY [CONFDIR DOCDIR] > NAME.1 — a man page made
# from `BINARY --help`.
# `make install` runs it on every installed binary, so the page always says what
# that very binary's --help says (no hand-written copy to drift). The guides
# (docs/*.md) are installed beside it in share/doc/sylva/.
set -eu
bin=$1 name=$2 summary=$3
confdir=${4:-PREFIX/etc/sylva} docdir=${5:-PREFIX/share/doc/sylva}
help=$("$bin" --help) || { echo "help2man.sh: '$bin --help' failed" >&2; exit 1; }
upper=$(printf '%s' "$name" | tr '[:lower:]' '[:upper:]')
# roff: escape backslashes, and protect lines starting with . or ' (requests).
body=$(printf '%s\n' "$help" | sed -e 's/\\/\\e/g' -e "s/^\\([.']\\)/\\\\\\&\\1/")
cat <<MAN
.TH $upper 1 "" "sylva" "sylva manual"
.SH NAME
$name \\- $summary
.SH SYNOPSIS
.nf
$body
.fi
.SH FILES
.TP
.I $confdir/sylvad.conf
daemon configuration (docs/operations.md)
.SH SEE ALSO
sylva(1), sylvad(1), sylva-bake(1);
$docdir/: operations.md, api.md, client.md, spec.md, deploy.md
MAN
