# Makefile - builds libradiosity.a, the `radiosity` program, the tests, the
# benchmarks and the tools, in a release flavour (build/release) and an
# AddressSanitizer + UndefinedBehaviorSanitizer flavour (build/asan).
#
#   make deps    install missing Debian packages (apt-get) and test/browser's npm packages (npm ci)
#   make demo    install missing packages, build, solve and render the Cornell box
#   make test    build and run every test (release and sanitizer builds, CLI, fuzz);
#                checks the packages but never installs them
#   make bench   print the benchmark tables
#   make report  write report/accuracy.md (issue 4)
#   make fuzz    run each fuzz target for FUZZ_SECONDS (default 60)
#   make install PREFIX=/usr/local DESTDIR=   the program, libradiosity.a and .so,
#                the headers (include/radiosity/), radiosity.pc and radiosity(1)
#   make uninstall   removes exactly what install put there (tools/install.sh)

NPROC   := $(shell nproc 2>/dev/null || echo 2)
CC      ?= cc
CXX     ?= c++
MODE    ?= release
B       ?= build/$(MODE)

WARN     := -Wall -Wextra -Werror
CPPFLAGS := -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L -I/usr/include/OpenEXR -I/usr/include/Imath -MMD -MP
CFLAGS_release := -O2 -g
CFLAGS_asan    := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
# Every object is position-independent, so that one set of objects makes
# both libradiosity.a and libradiosity.so; no semantic interposition keeps
# the optimiser free to inline the library's own global functions.
PIC      := -fPIC -fno-semantic-interposition
CFLAGS   := -std=c11 $(WARN) $(PIC) $(CFLAGS_$(MODE))
# tinygltf is header-only C++; its own code draws warnings we do not own.
CXXFLAGS := -std=c++17 -Wall -Wextra -Werror -Wno-unused-parameter $(PIC) $(CFLAGS_$(MODE))
LDFLAGS  := $(CFLAGS_$(MODE))
LDLIBS   := -lOpenEXRCore-3_1 -lpng -lembree3 -lstdc++ -lm -lpthread

# radiosity-mpi (issue 38): the program again, with the MPI row producer
# (hemicube/mpi_ranks.c, the one file that includes mpi.h) and its own main
# (program_mpi.c), built with mpicc's flags; `radiosity` runs it when mpirun
# started it, so neither the plain program nor the library needs MPI's
# libraries at run time.
MPI_C    := hemicube/mpi_ranks.c
MPI_MAIN := radiosity/cli/program_mpi.c
MPI_INC  := $(patsubst -I%,-isystem %,$(shell mpicc --showme:compile 2>/dev/null || pkg-config --cflags ompi-c))
MPI_LIBS := $(shell mpicc --showme:link 2>/dev/null || pkg-config --libs ompi-c)
PROG_MPI := $(B)/radiosity-mpi
CLI_C    := $(filter-out $(MPI_MAIN),$(wildcard radiosity/cli/*.c))
LIB_C    := $(filter-out $(CLI_C) $(MPI_C) $(MPI_MAIN),$(wildcard radiosity/*/*.c hemicube/*.c solver/*.c render/*.c))
LIB_CXX  := $(wildcard radiosity/*/*.cpp)
LIB_OBJ  := $(LIB_C:%.c=$(B)/obj/%.o) $(LIB_CXX:%.cpp=$(B)/obj/%.o)
LIB      := $(B)/libradiosity.a
PROG     := $(B)/radiosity
# The shared library: soname libradiosity.so.MAJOR, the file named by the
# full version (RAD_VERSION_STRING in radiosity/core/rad.h).
VERSION  := $(shell sed -n 's/^\#define RAD_VERSION_STRING "\(.*\)"/\1/p' radiosity/core/rad.h)
SONAME   := libradiosity.so.$(firstword $(subst ., ,$(VERSION)))
SHLIB    := $(B)/libradiosity.so.$(VERSION)
# The public headers (each module's one; the folders' other headers are
# private), installed as include/radiosity/NAME.h, each including the
# others as <radiosity/NAME.h> (tools/install.sh headers).
PUB_H    := $(filter-out %_internal.h radiosity/cli/% radiosity/scene/gltf_% radiosity/scene/tinygltf_%,\
              $(wildcard radiosity/*/*.h)) hemicube/hemicube.h solver/solver.h render/render.h
INC_DIR  := $(B)/include/radiosity
PREFIX   ?= /usr/local
DESTDIR  ?=

TEST_SRC := $(wildcard test/test_*.c)
TEST_BIN := $(TEST_SRC:test/%.c=$(B)/test/%)
BENCH_SRC:= $(wildcard bench/bench_*.c)
BENCH_BIN:= $(BENCH_SRC:bench/%.c=$(B)/bench/%)
# Programs in tools/: the reference path tracer, built with the benchmarks
# and run by hand (its output is shipped in bench/data/, which bench_cornell
# reads, and in test/data/room_reference.json, which test_room reads:
# `pathtrace --objects`; bench/run_bench.sh runs bench_* only), and the accuracy report's
# generator, built by `make report` (tools/make_report.sh).  tools/hall.c is
# no program: bench_scale's scene generator.
TOOL_BIN := $(B)/tools/pathtrace
# tools/mc_vs3.c: the Monte Carlo references of test/data/view3d/ (issue 39),
# run by hand like the path tracer.
TOOL_BIN += $(B)/tools/mc_vs3

.PHONY: all lib shlib headers prog tests benches demo test fuzz bench report deps check-deps print-objects print-headers clean \
        install uninstall

all: prog

lib: $(LIB) $(SHLIB)
shlib: $(SHLIB)
headers: $(INC_DIR)/.stamp
prog: $(PROG) $(PROG_MPI)
tests: $(TEST_BIN)
benches: $(BENCH_BIN) $(TOOL_BIN)

$(B)/obj/%.o: %.c
	@mkdir -p $(dir $@)
	@echo "CC  $(MODE) $<"
	@$(CC) $(CPPFLAGS) $(CFLAGS) -c $< -o $@

$(B)/obj/%.o: %.cpp
	@mkdir -p $(dir $@)
	@echo "CXX $(MODE) $<"
	@$(CXX) $(CPPFLAGS) $(CXXFLAGS) -c $< -o $@

$(LIB): $(LIB_OBJ)
	@mkdir -p $(dir $@)
	@rm -f $@
	@echo "AR  $(MODE) $@"
	@ar rcs $@ $^

$(SHLIB): $(LIB_OBJ)
	@mkdir -p $(dir $@)
	@echo "LD  $(MODE) $@"
	@$(CC) -shared -Wl,-soname,$(SONAME) $(LDFLAGS) $^ $(LDLIBS) -o $@
	@ln -sf $(notdir $@) $(B)/$(SONAME)
	@ln -sf $(notdir $@) $(B)/libradiosity.so

$(INC_DIR)/.stamp: $(PUB_H) tools/install.sh
	@bash tools/install.sh headers $(INC_DIR) $(PUB_H)
	@touch $@

$(PROG): $(CLI_C:%.c=$(B)/obj/%.o) $(LIB)
	@echo "LD  $(MODE) $@"
	@$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(B)/obj/$(MPI_C:.c=.o): CPPFLAGS += $(MPI_INC)

$(PROG_MPI): $(filter-out $(B)/obj/radiosity/cli/program.o,$(CLI_C:%.c=$(B)/obj/%.o)) \
             $(B)/obj/$(MPI_MAIN:.c=.o) $(B)/obj/$(MPI_C:.c=.o) $(LIB)
	@echo "LD  $(MODE) $@"
	@$(CC) $(LDFLAGS) $^ $(LDLIBS) $(MPI_LIBS) -o $@

# bench_mpi measures MPI itself (report/mpi.md)
$(B)/obj/bench/bench_mpi.o: CPPFLAGS += $(MPI_INC)
$(B)/bench/bench_mpi: $(B)/obj/bench/bench_mpi.o $(LIB)
	@mkdir -p $(dir $@)
	@$(CC) $(LDFLAGS) $^ $(LDLIBS) $(MPI_LIBS) -o $@

$(B)/test/%: $(B)/obj/test/%.o $(LIB)
	@mkdir -p $(dir $@)
	@$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(B)/bench/%: $(B)/obj/bench/%.o $(LIB)
	@mkdir -p $(dir $@)
	@$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

# test_render reads its EXR files back with test/exr_read.c (test-only)
$(B)/test/test_render: $(B)/obj/test/exr_read.o

# bench_scale writes its scene with tools/hall.c
$(B)/bench/bench_scale: $(B)/obj/tools/hall.o $(B)/obj/tools/scene_gltf.o
# bench_atrium writes the atrium (tools/atrium.c) and the hall
$(B)/bench/bench_atrium: $(B)/obj/tools/atrium.o $(B)/obj/tools/hall.o $(B)/obj/tools/scene_gltf.o

# test_regions and bench_disks write issue 36's disk pair (tools/disks.c);
# test_regions also an export split in four (tools/scene_gltf.c)
$(B)/test/test_regions: $(B)/obj/tools/disks.o $(B)/obj/tools/scene_gltf.o
$(B)/bench/bench_disks: $(B)/obj/tools/disks.o

# test_room writes issue 36's closed room (tools/room.c)
$(B)/test/test_room: $(B)/obj/tools/room.o $(B)/obj/tools/scene_gltf.o

# bench_bake bakes the same hall
$(B)/bench/bench_bake: $(B)/obj/tools/hall.o $(B)/obj/tools/scene_gltf.o

$(B)/tools/%: $(B)/obj/tools/%.o $(LIB)
	@mkdir -p $(dir $@)
	@$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

# ------------------------------------------------------------------ commands

deps:
	@bash tools/install-deps.sh

check-deps:
	@bash tools/install-deps.sh --check

demo: deps
	@$(MAKE) --no-print-directory -j$(NPROC) MODE=release prog
	@mkdir -p out
	build/release/radiosity solve models/cornell.rad -o out/cornell.sol
	build/release/radiosity render out/cornell.sol -o out/cornell.exr --png out/cornell.png
	build/release/radiosity report out/cornell.sol
	@echo "demo: wrote out/cornell.exr and out/cornell.png"

test: check-deps
	@$(MAKE) --no-print-directory -j$(NPROC) MODE=release prog tests lib headers
	@$(MAKE) --no-print-directory -j$(NPROC) MODE=asan prog tests
	@bash test/run_tests.sh

bench: check-deps
	@$(MAKE) --no-print-directory -j$(NPROC) MODE=release prog benches
	@bash bench/run_bench.sh

report: check-deps
	@$(MAKE) --no-print-directory -j$(NPROC) MODE=release prog
	@bash tools/make_report.sh

fuzz: check-deps
	@bash test/fuzz/run_fuzz.sh $${FUZZ_SECONDS:-60}

# The program, both libraries, the headers, radiosity.pc and the man page
# under $(DESTDIR)$(PREFIX); uninstall removes exactly those files.
INSTALL_ENV = PUB_HEADERS="$(notdir $(PUB_H))" LIBS_PRIVATE="$(LDLIBS)"
install: prog lib headers
	@$(INSTALL_ENV) bash tools/install.sh install "$(DESTDIR)" "$(PREFIX)" $(B) $(VERSION)

uninstall:
	@$(INSTALL_ENV) bash tools/install.sh uninstall "$(DESTDIR)" "$(PREFIX)" $(B) $(VERSION)

# The library's and the program's objects, for tools/check-structure.sh.
print-objects:
	@echo $(LIB_OBJ) $(CLI_C:%.c=$(B)/obj/%.o) $(B)/obj/$(MPI_C:.c=.o)

# The public headers, for test/cli/install.sh.
print-headers:
	@echo $(PUB_H)

clean:
	rm -rf build out

-include $(shell find $(B) -name '*.d' 2>/dev/null)
