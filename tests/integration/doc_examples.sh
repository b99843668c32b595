#!/bin/sh
# Every example of the user docs runs (issue 23): `make install` into a
# DESTDIR, then tests/integration/doc_examples.py runs README.md's and
# docs/*.md's sh blocks in order against a real daemon (README's own example
# starts it) with the installed programs first on PATH, checks every spec
# example with `sylva-bake check-spec` and every output example's keys against
# the real document, and builds docs/client.md's C program against the
# installed libsylva (pkg-config; shared and static) and bakes with it.
# Then the installed files themselves: header, libraries, soname, exports,
# pkg-config version, man pages.
# sylva-test: no-sanitize (docs and the installed files; the C paths they run are in the other tests) cost=110
set -u
. "$(dirname "$0")/lib.inc"
[ -f "$data/eztree_aspen_small/aspen_small.obj" ] || { echo "skipped: no shared data"; exit 77; }
W=$(mktemp -d "${TMPDIR:-/tmp}/sylva-docs.XXXXXX")
trap 'pkill -f -- "--store $W/" 2>/dev/null; [ "$fails" -eq 0 ] && rm -rf "$W"' EXIT
rel=${BUILD:-build}
make -s -C "$root" install BUILD="$rel" DESTDIR="$W/root" PREFIX=/usr/local > "$W/install.log" 2>&1 ||
    { cat "$W/install.log"; fail "make install DESTDIR=$W/root"; }
P=$W/root/usr/local

# the installed files
for f in bin/sylva bin/sylvad bin/sylva-bake lib/sylva/libsvimage.so include/sylva.h lib/libsylva.a lib/libsylva.so \
         lib/pkgconfig/sylva.pc share/man/man1/sylva.1 share/man/man1/sylvad.1 \
         share/man/man1/sylva-bake.1; do
    [ -e "$P/$f" ] && ok "installed $f" || bad "installed $f"
done
# the guides the --help texts point to, where they say
for f in "$root"/docs/*.md "$root"/docs/methods/*.md; do
    rel_doc=${f#"$root"/docs/}
    [ -f "$P/share/doc/sylva/$rel_doc" ] || bad "installed share/doc/sylva/$rel_doc"
done
for prog in sylva sylvad sylva-bake; do
    "$P/bin/$prog" --help 2>&1 | grep -q "/usr/local/share/doc/sylva" &&
        ok "$prog --help names the installed guides" || bad "$prog --help names no installed guide"
done
ver=$(sed -n 's/^#define SYLVA_VERSION "\(.*\)"/\1/p' "$root/client/sylva.h")
check "libsylva.so.0 is the soname" "libsylva.so.0" \
    "$(objdump -p "$P/lib/libsylva.so" | awk '/SONAME/ {print $2}')"
check "pkg-config finds sylva $ver in the DESTDIR" "$ver" \
    "$(PKG_CONFIG_PATH=$P/lib/pkgconfig pkg-config --modversion sylva)"
others=$(nm -D --defined-only "$P/lib/libsylva.so" | awk '$2 == "T" && $3 !~ /^sylva_/' | head -n 3)
check "libsylva.so exports only sylva_* functions" "" "$others"
grep -l '@[A-Z]*@' "$P"/share/man/man1/*.1 "$P/lib/pkgconfig/sylva.pc" > "$W/left" 2>/dev/null
check "no @PLACEHOLDER@ left in the installed pages and sylva.pc" "" "$(cat "$W/left")"

# the man pages: written by hand (deploy/man/), so check what --help cannot:
# groff reads them without a warning, each has the sections a user looks
# for, and every option its program's --help names is described.
for prog in sylva sylvad sylva-bake; do
    page=$P/share/man/man1/$prog.1
    w=$(groff -man -Tutf8 -ww -z "$page" 2>&1)
    check "$prog.1: groff has no warning" "" "$w"
    text=$(groff -man -Tascii -P-cbou -rLL=250n "$page" 2>/dev/null)
    for sec in NAME SYNOPSIS DESCRIPTION OPTIONS "EXIT STATUS" ENVIRONMENT FILES EXAMPLES "SEE ALSO"; do
        printf '%s\n' "$text" | grep -q "^$sec\$" || bad "$prog.1 has no $sec section"
    done
    missing=""
    for opt in $("$build/$prog" --help 2>&1 | grep -o -- '--[a-z][a-z-]*' | sort -u); do
        printf '%s\n' "$text" | grep -q -- "$opt" || missing="$missing $opt"
    done
    check "$prog.1 describes every option of $prog --help" "" "$missing"
done
for key in $(sed -n 's/^| `\([a-z_]*\)` |.*/\1/p' "$root/docs/operations.md"); do
    grep -q "$key" "$P/share/man/man1/sylvad.1" || bad "sylvad.1 does not name the setting $key"
done

# the examples
if python3 "$here/doc_examples.py" --root "$root" --build "$build" --data "$data" \
    --work "$W/work" --prefix "$P"; then ok "every doc example"; else bad "doc examples"; fi

# what the C example built and baked
[ -s "$W/work/lc/model.glb" ] && ok "docs/client.md's C program baked into lc/" ||
    bad "docs/client.md's C program baked into lc/"
case "$(LD_LIBRARY_PATH=$P/lib ldd "$W/work/bake_one" 2>/dev/null | grep libsylva)" in
    *"$P/lib/libsylva.so.0"*) ok "bake_one uses the installed libsylva.so.0" ;;
    *) bad "bake_one uses the installed libsylva.so.0" ;;
esac
if ldd "$W/work/bake_one_static" 2>/dev/null | grep -q libsylva; then
    bad "bake_one_static needs no libsylva.so"
else ok "bake_one_static needs no libsylva.so"; fi
[ "$fails" -eq 0 ] || exit 1
