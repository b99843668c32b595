# sylva — one non-recursive Makefile. `make` builds everything into build/,
# `make test` runs every test, `make sanitize` the unit and functional tests
# under ASan+UBSan (build/asan/), `make sanitize-full` every test there
# (docs/testing.md).
# User CFLAGS are added after the project's flags, never replacing them.

BUILD    ?= build
CC       ?= cc
CXX      ?= c++
PKGS     := assimp OpenImageIO osmesa libcjson libmicrohttpd libcurl libcrypto cmocka libseccomp
# Foreign headers as -isystem so -Werror applies to our code only.
# Evaluated lazily, once, at the first recipe that uses them: on a fresh
# machine the packages (and their .pc files) only exist after $(DEPS_STAMP)
# has run, which is after this Makefile was read.
PKG_CFLAGS = $(eval PKG_CFLAGS := $(shell pkg-config --cflags $(PKGS) 2>/dev/null | sed 's/-I/-isystem /g'))$(PKG_CFLAGS)
# Programs link every package but OpenImageIO, whose 261 libraries cost
# ~0.7 s and ~130 MB at every start: the decoding plugin libsvimage.so links
# it and is dlopen'ed on the first decode of a format other than PNG and JPEG
# (core/io/image_plugin.c); PNGs are written and read with libpng, JPEGs read
# with libjpeg (core/io/image_decode.c).
PKGS_LINK  := $(filter-out OpenImageIO,$(PKGS)) libpng libjpeg
PKG_LIBS   = $(eval PKG_LIBS := $(shell pkg-config --libs $(PKGS_LINK) 2>/dev/null) -lmeshoptimizer)$(PKG_LIBS)

ifeq ($(SANITIZE),1)
SAN_FLAGS := -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
endif
OPT      ?= -O2 -g
WARN     := -Wall -Wextra -Werror
# Each part sees only the headers it may use (docs/design.md, "Source
# layout"): the client its own and common/ (never core), core's folders
# their own and those below them, the server its own and the parts of core
# it links (io, methods' schemas, spec); tests and tools everything. Inside
# core, a folder's headers sit beside its sources and a folder compiles with
# the -I of the folders it may use, so an include of a folder it may not use
# does not compile (tests/integration/boundary.sh checks one):
#   core/*.c (sv, mesh, image, scene, stand_in): core/include only;
#   io, geom: that and their own; render: also geom and io (it writes the
#     preview and evaluation PNGs);
#   methods/<name>/: base, geom, render and methods/ (method.h, level.h),
#     never io, spec or pipeline: a method makes geometry, the pipeline
#     reads and writes files;
#   spec: base, io (strict JSON), methods (each method checks its settings);
#   pipeline and cli: every folder of core.
I_BASE      := -Icore/include -Icommon
I_METHODS   := -Icore/geom -Icore/render -Icore/methods
I_CORE      := $(I_BASE) -Icore/io $(I_METHODS) -Icore/spec -Icore/pipeline
INC_ALL    := $(I_CORE) -Icore $(patsubst %/,-I%,$(wildcard core/methods/*/)) -Iserver -Iclient
INC         = $(INC_ALL)
CPPFLAGS_SV = $(INC) -isystem /usr/include/stb -MMD -MP $(PKG_CFLAGS) -DSYLVA_DOC_DIR=\"$(DOCDIR)\"
# INC of the objects of core folder $(1) (plain, position-independent, fuzz);
# the most specific pattern wins.
define core_inc
$$(BUILD)/core/$(1)%.o $$(BUILD)/pic/core/$(1)%.o $$(BUILD)/fuzz/obj/core/$(1)%.o: INC = $(2)
endef
$(eval $(call core_inc,,$(I_BASE)))
$(eval $(call core_inc,io/,$(I_BASE) -Icore/io))
$(eval $(call core_inc,geom/,$(I_BASE) -Icore/geom))
$(eval $(call core_inc,render/,$(I_BASE) -Icore/io -Icore/geom -Icore/render))
$(eval $(call core_inc,methods/,$(I_BASE) $(I_METHODS)))
$(eval $(call core_inc,spec/,$(I_BASE) -Icore/io -Icore/methods -Icore/spec))
$(eval $(call core_inc,pipeline/,$(I_CORE)))
$(eval $(call core_inc,cli/,$(I_CORE)))
$(BUILD)/client/%.o $(BUILD)/pic/client/%.o: INC = -Iclient -Icommon
$(BUILD)/server/%.o $(BUILD)/fuzz/obj/server/%.o: INC = -Iserver $(I_BASE) -Icore/io -Icore/methods -Icore/spec
SV_CFLAGS   := -std=c11 $(WARN) $(OPT) -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE $(SAN_FLAGS)
SV_CXXFLAGS := -std=c++17 $(WARN) $(OPT) $(SAN_FLAGS)
LDLIBS_SV   = $(PKG_LIBS) -lpthread -lm
# sylva-bake links what core uses, not the daemon's, the client's or the tests'
LDLIBS_BAKE = $(eval LDLIBS_BAKE := $(shell pkg-config --libs assimp osmesa libcjson libseccomp libpng libjpeg \
              2>/dev/null) -lmeshoptimizer -lpthread -lm)$(LDLIBS_BAKE)


# core/ in folders that follow a bake (docs/design.md, "Source layout"):
# core/*.c beside io/, geom/, methods/<name>/, render/, pipeline/; core/cli/ is
# the sylva-bake program's own code, not part of the library. The one C++
# file, the OpenImageIO shim, is not in the library either: it is the
# image-decoding plugin libsvimage.so (core/io/image_plugin.c loads it), with
# the two pure files it calls into, position-independent.
CORE_SRC := $(wildcard core/*.c core/*/*.c core/*/*/*.c)
CORE_C   := $(filter-out core/cli/%,$(CORE_SRC))
CLI_C    := $(wildcard core/cli/*.c)
CORE_OBJ := $(CORE_C:%.c=$(BUILD)/%.o)
PLUGIN   := $(BUILD)/libsvimage.so
SERVER_LIB_C := $(filter-out server/sylvad.c,$(wildcard server/*.c))
# libsylva (installed: sylva.h, libsylva.a, libsylva.so, sylva.pc) is the
# client's public API only; client/cli.c is the `sylva` command's own code.
CLIENT_LIB_C := client/libsylva.c client/key.c
SERVER_OBJ := $(SERVER_LIB_C:%.c=$(BUILD)/%.o)
CLIENT_OBJ := $(CLIENT_LIB_C:%.c=$(BUILD)/%.o)
CLIENT_PIC := $(CLIENT_LIB_C:%.c=$(BUILD)/pic/%.o)
SYLVA_VER  := $(shell sed -n 's/^\#define SYLVA_VERSION "\(.*\)"/\1/p' client/sylva.h)
SYLVA_SOMAJOR := $(firstword $(subst ., ,$(SYLVA_VER)))

LIBCORE   := $(BUILD)/libsvcore.a
LIBSERVER := $(BUILD)/libsvserver.a
LIBSYLVA  := $(BUILD)/libsylva.a
LIBSYLVA_SO := $(BUILD)/libsylva.so.$(SYLVA_VER)
LIBCLI    := $(BUILD)/libsylvacli.a

BINS := $(BUILD)/sylva-bake
ifneq ($(wildcard server/sylvad.c),)
BINS += $(BUILD)/sylvad
endif
ifneq ($(wildcard client/sylva.c),)
BINS += $(BUILD)/sylva
endif

UNIT_SRC  := $(wildcard tests/unit/test_*.c)
UNIT_BINS := $(UNIT_SRC:tests/unit/%.c=$(BUILD)/tests/%)
TOOL_SRC  := $(wildcard tests/tools/*.c)
TOOL_BINS := $(TOOL_SRC:tests/tools/%.c=$(BUILD)/tools/%)

DEPS_STAMP := $(BUILD)/.deps-ok

# The viewer page sylvad serves (GET /v1/bakes/{key}/view, docs/runtime.md):
# our page and shaders (server/viewer/) beside three.js, installed by npm from
# server/viewer/package-lock.json (never a copy in the repo) and reduced to
# the module and the loaders the page imports. sylvad finds it as
# dirname(sylvad)/viewer in the build tree, $(PREFIX)/share/sylva/viewer
# when installed (setting viewer_dir, docs/operations.md).
VIEWER_SRC   := $(wildcard server/viewer/*.html server/viewer/*.js server/viewer/*.glsl server/viewer/*.css)
VIEWER_DIR   := $(BUILD)/viewer
VIEWER_STAMP := $(VIEWER_DIR)/.stamp
THREE_NPM    := $(BUILD)/viewer-npm/node_modules/three

.PHONY: all deps bench-deps test unit integration sanitize sanitize-full sanitize-build ci-build demo bench same-outputs reliability soak clean install
# keep object files of tests, tools and fuzz targets (make would delete them
# as intermediates). Named, not a bare .SECONDARY: that makes every target
# secondary, the empty rules -MP writes for headers too, and a header a .d
# names that has since moved or gone then no longer makes its object stale:
# the object kept the old header's code and the incremental build failed.
# (the fuzz targets' objects: beside FUZZ_SRC below)
.SECONDARY: $(UNIT_SRC:%.c=$(BUILD)/%.o) $(TOOL_SRC:%.c=$(BUILD)/%.o)
all: $(BINS) $(PLUGIN) $(LIBSYLVA) $(LIBSYLVA_SO) $(UNIT_BINS) $(TOOL_BINS) $(VIEWER_STAMP)

# Installs missing Debian packages (non-interactive). Every build depends on it.
deps:
	@./deploy/install-deps.sh
$(DEPS_STAMP): deploy/apt-packages.txt deploy/install-deps.sh
	@./deploy/install-deps.sh
	@mkdir -p $(@D) && touch $@

$(BUILD)/%.o: %.c | $(DEPS_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_SV) $(SV_CFLAGS) $(CFLAGS) -c $< -o $@
$(BUILD)/%.o: %.cpp | $(DEPS_STAMP)
	@mkdir -p $(@D)
	$(CXX) $(CPPFLAGS_SV) $(SV_CXXFLAGS) $(CXXFLAGS) -c $< -o $@

$(LIBCORE): $(CORE_OBJ)
	@rm -f $@
	ar rcs $@ $^
$(LIBSERVER): $(SERVER_OBJ)
	@rm -f $@
	ar rcs $@ $^
$(LIBSYLVA): $(CLIENT_OBJ)
	@rm -f $@
	ar rcs $@ $^
$(LIBCLI): $(BUILD)/client/cli.o
	@rm -f $@
	ar rcs $@ $^
# The shared library: position-independent objects, soname libsylva.so.MAJOR,
# only the sylva_* API exported (client/libsylva.map).
$(BUILD)/pic/%.o: %.c | $(DEPS_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CPPFLAGS_SV) $(SV_CFLAGS) -fPIC $(CFLAGS) -c $< -o $@
$(BUILD)/pic/%.o: %.cpp | $(DEPS_STAMP)
	@mkdir -p $(@D)
	$(CXX) $(CPPFLAGS_SV) $(SV_CXXFLAGS) -fPIC $(CXXFLAGS) -c $< -o $@
$(PLUGIN): $(BUILD)/pic/core/io/image_oiio.o $(BUILD)/pic/core/image.o $(BUILD)/pic/core/sv.o
	$(CXX) $(SV_CXXFLAGS) $(LDFLAGS) -shared -Wl,--no-undefined -o $@ $^ \
	    $(shell pkg-config --libs OpenImageIO) -lpthread -lm
$(LIBSYLVA_SO): $(CLIENT_PIC) client/libsylva.map
	$(CC) $(SV_CFLAGS) $(LDFLAGS) -shared -Wl,-soname,libsylva.so.$(SYLVA_SOMAJOR) \
	    -Wl,--version-script,client/libsylva.map -Wl,--no-undefined -o $@ $(CLIENT_PIC) \
	    $(shell pkg-config --libs libcurl libcjson libcrypto)
	ln -sf $(notdir $@) $(BUILD)/libsylva.so.$(SYLVA_SOMAJOR)
	ln -sf $(notdir $@) $(BUILD)/libsylva.so

# server/openapi.json as C string literals, one per line, compiled into sylvad (server/openapi.c)
$(BUILD)/server/openapi.o: INC = -Iserver -Icore/include -Icommon -I$(BUILD)/gen
$(BUILD)/server/openapi.o: $(BUILD)/gen/openapi_json.inc
$(BUILD)/gen/openapi_json.inc: server/openapi.json
	@mkdir -p $(@D)
	sed -e 's/\\/\\\\/g' -e 's/"/\\"/g' -e 's/^/"/' -e 's/$$/\\n"/' $< > $@
# The daemon links no GL and no assimp: only libsvserver and the pure parts of core.
$(BUILD)/sylvad: $(BUILD)/server/sylvad.o $(LIBSERVER) $(LIBCORE)
	$(CC) $(SV_CFLAGS) $(LDFLAGS) -o $@ $^ $(shell pkg-config --libs libmicrohttpd libcjson libcrypto) -lpthread -lm
# The client links libsylva statically and nothing of core.
$(BUILD)/sylva: $(BUILD)/client/sylva.o $(LIBCLI) $(LIBSYLVA)
	$(CC) $(SV_CFLAGS) $(LDFLAGS) -o $@ $^ $(shell pkg-config --libs libcurl libcjson libcrypto) -lm
# the image plugin with it: a sylva-bake without libsvimage.so beside it cannot decode a texture
$(BUILD)/sylva-bake: $(CLI_C:%.c=$(BUILD)/%.o) $(LIBCORE) | $(PLUGIN)
	$(CXX) $(SV_CXXFLAGS) $(LDFLAGS) -o $@ $^ $(LDLIBS_BAKE)

$(BUILD)/tests/%: $(BUILD)/tests/unit/%.o $(LIBSERVER) $(LIBCLI) $(LIBSYLVA) $(LIBCORE)
	@mkdir -p $(@D)
	$(CXX) $(SV_CXXFLAGS) $(LDFLAGS) -o $@ $^ $(LDLIBS_SV)
$(BUILD)/tools/%: $(BUILD)/tests/tools/%.o $(LIBSERVER) $(LIBCLI) $(LIBSYLVA) $(LIBCORE)
	@mkdir -p $(@D)
	$(CXX) $(SV_CXXFLAGS) $(LDFLAGS) -o $@ $^ $(LDLIBS_SV)

# Every test: unit (cmocka) and integration/render scripts, SYLVA_TEST_JOBS at
# a time (default 2). Fails on any failure and on any skip not expected
# (SYLVA_EXPECT_SKIP; none with CI=true). tests/run.sh, docs/testing.md.
test: all
	@BUILD=$(BUILD) ./tests/run.sh

unit: all
	@BUILD=$(BUILD) ./tests/run.sh unit

integration: all
	@BUILD=$(BUILD) ./tests/run.sh integration

# ASan+UBSan in build/asan/: `sanitize` runs the unit tests and the functional
# integration tests on the small trees (tests/run.sh sanitize: every C path,
# not every tree); `sanitize-full` runs every test on every tree (not in CI).
SAN_MAKE = $(MAKE) BUILD=build/asan SANITIZE=1 OPT="-O1 -g"
sanitize-build:
	+$(SAN_MAKE) all

sanitize: sanitize-build
	@BUILD=build/asan ./tests/run.sh sanitize

sanitize-full: sanitize-build
	@BUILD=build/asan ./tests/run.sh all

# CI's build step: the plain tree, the ASan tree and the fuzz targets at the
# same time, sharing the -j slots (`make -j2 ci-build`).
ci-build: all sanitize-build fuzz-build

$(BUILD)/viewer-npm/.stamp: server/viewer/package.json server/viewer/package-lock.json | $(DEPS_STAMP)
	@mkdir -p $(@D)
	cp server/viewer/package.json server/viewer/package-lock.json $(@D)/
	cd $(@D) && npm ci --no-audit --no-fund --loglevel=error
	@touch $@
$(VIEWER_STAMP): $(VIEWER_SRC) $(BUILD)/viewer-npm/.stamp
	@rm -rf $(VIEWER_DIR) && mkdir -p $(VIEWER_DIR)/three/addons/libs
	cp $(VIEWER_SRC) $(VIEWER_DIR)/
	cp $(THREE_NPM)/build/three.module.js $(THREE_NPM)/LICENSE $(VIEWER_DIR)/three/
	cp -r $(THREE_NPM)/examples/jsm/loaders $(THREE_NPM)/examples/jsm/utils \
	    $(THREE_NPM)/examples/jsm/curves $(THREE_NPM)/examples/jsm/controls $(VIEWER_DIR)/three/addons/
	cp $(THREE_NPM)/examples/jsm/libs/fflate.module.js \
	    $(THREE_NPM)/examples/jsm/libs/meshopt_decoder.module.js $(VIEWER_DIR)/three/addons/libs/
	@touch $@

# DEMO_OUT: where the outputs go (default out/demo; tests give a temporary folder)
DEMO_OUT ?= $(CURDIR)/out/demo
demo: all
	@./examples/demo.sh $(BUILD) $(DEMO_OUT)

# What only the bench needs (the held-out trees' sources, issue 40): not in
# deploy/apt-packages.txt, so neither `make deps` nor CI installs it.
bench-deps:
	@./deploy/install-deps.sh deploy/apt-packages-bench.txt

bench: all bench-deps
	@BUILD=$(BUILD) ./tests/bench/run.sh

# Byte-identity of two revisions (a refactor changes no output): builds
# sylva-bake at A and B (git revisions, or paths of sylva-bake binaries), bakes
# four shared trees (ALL=1: every one; TREES=dir,dir: those) with a spec per method, the default
# chain, a target and dynamic lighting (SPECS=name,name: those specs only),
# and compares every output's sha256
# (report.json without "times"). tests/tools/same_outputs.sh, docs/testing.md.
A ?= main
B ?= HEAD
same-outputs:
	@./tests/tools/same_outputs.sh $(if $(filter 1,$(ALL)),--all) $(if $(TREES),--trees $(TREES)) $(if $(SPECS),--specs $(SPECS)) $(A) $(B)

# Issue 12's fault, bad-input and load suites with their figures
# (docs/reliability.md); RELIABILITY_LONG=1 for the long forms. `make soak` is
# the 30-minute soak (SOAK_SECONDS) on its own.
reliability: all
	@BUILD=$(BUILD) sh ./tests/reliability/run.sh

soak: all
	@BUILD=$(BUILD) sh ./tests/reliability/soak.sh

# Installs the binaries, libsylva (sylva.h, libsylva.a, libsylva.so.*, sylva.pc),
# the default config (kept if one exists: the new one goes beside it as
# sylvad.conf.new), the man pages (deploy/man/, written by hand), the guides
# (docs/*.md and docs/methods/ into $(DOCDIR), the path the --help texts
# name: they are built with -DSYLVA_DOC_DIR of the same PREFIX),
# the systemd unit + sysusers entry and the nginx example (docs/deploy.md).
# PREFIX and DESTDIR are honoured; LIBDIR and INCLUDEDIR may be set apart.
# The config lives in $(PREFIX)/etc/sylva/, or /etc/sylva/ when PREFIX=/usr.
PREFIX ?= /usr/local
DESTDIR ?=
ifeq ($(PREFIX),/usr)
SYSCONFDIR ?= /etc
else
SYSCONFDIR ?= $(PREFIX)/etc
endif
BINDIR := $(PREFIX)/bin
LIBDIR ?= $(PREFIX)/lib
INCLUDEDIR ?= $(PREFIX)/include
DOCDIR := $(PREFIX)/share/doc/sylva
VIEWERDIR := $(PREFIX)/share/sylva/viewer
MANDIR := $(PREFIX)/share/man/man1
UNITDIR := $(PREFIX)/lib/systemd/system
SYSUSERSDIR := $(PREFIX)/lib/sysusers.d
MAN_SED := -e 's\#@SYSCONFDIR@\#$(SYSCONFDIR)\#g' -e 's\#@DOCDIR@\#$(DOCDIR)\#g' \
           -e 's\#@VERSION@\#$(SYLVA_VER)\#g'
install: $(BINS) $(PLUGIN) $(LIBSYLVA) $(LIBSYLVA_SO) $(VIEWER_STAMP)
	install -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(SYSCONFDIR)/sylva $(DESTDIR)$(DOCDIR)/nginx \
	    $(DESTDIR)$(MANDIR) $(DESTDIR)$(UNITDIR) $(DESTDIR)$(SYSUSERSDIR) \
	    $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(INCLUDEDIR)
	install -m 755 $(BINS) $(DESTDIR)$(BINDIR)/
	install -d $(DESTDIR)$(PREFIX)/lib/sylva
	install -m 755 $(PLUGIN) $(DESTDIR)$(PREFIX)/lib/sylva/
	install -m 644 client/sylva.h $(DESTDIR)$(INCLUDEDIR)/
	install -m 644 $(LIBSYLVA) $(DESTDIR)$(LIBDIR)/
	install -m 755 $(LIBSYLVA_SO) $(DESTDIR)$(LIBDIR)/
	ln -sf libsylva.so.$(SYLVA_VER) $(DESTDIR)$(LIBDIR)/libsylva.so.$(SYLVA_SOMAJOR)
	ln -sf libsylva.so.$(SYLVA_SOMAJOR) $(DESTDIR)$(LIBDIR)/libsylva.so
	sed -e 's#@PREFIX@#$(PREFIX)#' -e 's#@LIBDIR@#$(LIBDIR)#' -e 's#@INCLUDEDIR@#$(INCLUDEDIR)#' \
	    -e 's#@VERSION@#$(SYLVA_VER)#' client/sylva.pc.in > $(DESTDIR)$(LIBDIR)/pkgconfig/sylva.pc
	@if [ -e $(DESTDIR)$(SYSCONFDIR)/sylva/sylvad.conf ]; then \
	    echo "keeping $(DESTDIR)$(SYSCONFDIR)/sylva/sylvad.conf; new default: sylvad.conf.new"; \
	    install -m 644 deploy/sylvad.conf $(DESTDIR)$(SYSCONFDIR)/sylva/sylvad.conf.new; \
	else install -m 644 deploy/sylvad.conf $(DESTDIR)$(SYSCONFDIR)/sylva/sylvad.conf; fi
	set -e; for b in $(notdir $(BINS)); do \
	    sed $(MAN_SED) deploy/man/$$b.1 > $(DESTDIR)$(MANDIR)/$$b.1; done
	install -d $(DESTDIR)$(DOCDIR)/methods
	install -m 644 docs/*.md $(DESTDIR)$(DOCDIR)/
	install -m 644 docs/methods/*.md $(DESTDIR)$(DOCDIR)/methods/
	install -d $(DESTDIR)$(DOCDIR)/engines
	install -m 644 examples/engines/unreal_import_lods.py examples/engines/godot_lod_ranges.gd \
	    $(DESTDIR)$(DOCDIR)/engines/
	install -m 644 deploy/nginx/sylva.conf deploy/nginx/sylva-nodes.conf $(DESTDIR)$(DOCDIR)/nginx/
	sed -e 's#/usr/local/bin#$(BINDIR)#g' -e 's#/usr/local/etc/sylva#$(SYSCONFDIR)/sylva#g' \
	    -e 's#/usr/local/share/doc/sylva#$(DOCDIR)#g' deploy/sylvad.service \
	    > $(DESTDIR)$(UNITDIR)/sylvad.service
	install -m 644 deploy/sylva.sysusers $(DESTDIR)$(SYSUSERSDIR)/sylva.conf
	rm -rf $(DESTDIR)$(VIEWERDIR) && install -d $(DESTDIR)$(VIEWERDIR)
	cp -R $(VIEWER_DIR)/. $(DESTDIR)$(VIEWERDIR)/ && rm -f $(DESTDIR)$(VIEWERDIR)/.stamp
	@if [ -z "$(DESTDIR)" ] && [ "$$(id -u)" = 0 ] && command -v ldconfig >/dev/null; then ldconfig; fi

# libFuzzer targets (tests/fuzz/fuzz_*.c) under ASan+UBSan, built with clang into
# $(BUILD)/fuzz/ (the core and the multipart parser recompiled with coverage);
# `make fuzz` runs each for FUZZ_SECONDS from tests/fuzz/corpus/<target>/ and
# fails on any finding (crash inputs go to $(BUILD)/fuzz/artifacts/). It
# explores: a random seed each run. FUZZ_LIMIT replaces the time limit and
# FUZZ_WORK the directory new inputs go to: tests/integration/fuzz_short.sh
# (CI) passes a fixed seed, a run count and a fresh directory, so CI replays
# the same inputs every time and a finding there is reproducible.
# Library objects get -Wall -Wextra without -Werror (clang may warn where gcc
# does not); the fuzz targets themselves are -Werror.
FUZZ_CC      ?= clang
FUZZ_CXX     ?= clang++
FUZZ_SECONDS ?= 60
FUZZ_LIMIT   ?= -max_total_time=$(FUZZ_SECONDS)
FUZZ_WORK    ?= $(BUILD)/fuzz/work
FUZZ_DIR     := $(BUILD)/fuzz
FUZZ_SAN     := -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
FUZZ_CFLAGS  := -std=c11 -Wall -Wextra -O1 -g -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE \
                -fsanitize=fuzzer-no-link $(FUZZ_SAN)
FUZZ_SRC     := $(wildcard tests/fuzz/fuzz_*.c)
FUZZ_BINS    := $(FUZZ_SRC:tests/fuzz/%.c=$(FUZZ_DIR)/%)
.SECONDARY: $(FUZZ_SRC:%.c=$(FUZZ_DIR)/obj/%.o)
FUZZ_LIB     := $(FUZZ_DIR)/libfuzzcore.a
FUZZ_LIB_OBJ := $(CORE_C:%.c=$(FUZZ_DIR)/obj/%.o) \
                $(FUZZ_DIR)/obj/server/multipart.o

$(FUZZ_DIR)/obj/%.o: %.c | $(DEPS_STAMP)
	@mkdir -p $(@D)
	$(FUZZ_CC) $(CPPFLAGS_SV) $(FUZZ_CFLAGS) -c $< -o $@
$(FUZZ_DIR)/obj/%.o: %.cpp | $(DEPS_STAMP)
	@mkdir -p $(@D)
	$(FUZZ_CXX) $(CPPFLAGS_SV) -std=c++17 -Wall -Wextra -O1 -g -fsanitize=fuzzer-no-link $(FUZZ_SAN) -c $< -o $@
$(FUZZ_DIR)/obj/tests/fuzz/%.o: tests/fuzz/%.c | $(DEPS_STAMP)
	@mkdir -p $(@D)
	$(FUZZ_CC) $(CPPFLAGS_SV) $(FUZZ_CFLAGS) -Werror -c $< -o $@
$(FUZZ_LIB): $(FUZZ_LIB_OBJ)
	@rm -f $@
	ar rcs $@ $^
$(FUZZ_DIR)/fuzz_%: $(FUZZ_DIR)/obj/tests/fuzz/fuzz_%.o $(FUZZ_LIB)
	$(FUZZ_CXX) -fsanitize=fuzzer $(FUZZ_SAN) -o $@ $^ $(LDLIBS_SV)

fuzz-build: $(FUZZ_BINS)

fuzz: fuzz-build
	@set -e; for f in $(FUZZ_BINS); do \
	    t=$$(basename $$f); mkdir -p $(FUZZ_WORK)/$$t $(FUZZ_DIR)/artifacts; \
	    echo "== $$t: $(FUZZ_LIMIT)"; \
	    $$f $(FUZZ_LIMIT) -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
	        -artifact_prefix=$(FUZZ_DIR)/artifacts/$$t- $(FUZZ_WORK)/$$t tests/fuzz/corpus/$$t \
	        > $(FUZZ_DIR)/$$t.log 2>&1 || { tail -n 60 $(FUZZ_DIR)/$$t.log; echo "FUZZ FINDING: $$t"; exit 1; }; \
	    grep -E '^stat::number_of_executed_runs|^#[0-9]+.*DONE' $(FUZZ_DIR)/$$t.log | tail -n 2; \
	done; echo "fuzz: 0 findings"

clean:
	rm -rf build

-include $(shell find $(BUILD) -path '$(BUILD)/test-tmp' -prune -o -name '*.d' -type f -print 2>/dev/null)
