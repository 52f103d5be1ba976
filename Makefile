# Makefile - builds libradiosity.a, the `radiosity` program, the tests, the
# benchmarks and the tools, in a release flavour (build/release) and an
# AddressSanitizer + UndefinedBehaviorSanitizer flavour (build/asan).
#
#   make deps    install missing Debian packages (apt-get)
#   make demo    install missing packages, build, solve and render the Cornell box
#   make test    build and run every test (release and sanitizer builds, CLI, fuzz);
#                checks the packages but never installs them
#   make bench   print the benchmark tables
#   make report  write report/accuracy.md (issue 4)
#   make fuzz    run each fuzz target for FUZZ_SECONDS (default 60)

NPROC   := $(shell nproc 2>/dev/null || echo 2)
CC      ?= cc
CXX     ?= c++
MODE    ?= release
B       ?= build/$(MODE)

WARN     := -Wall -Wextra -Werror
CPPFLAGS := -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L -I/usr/include/OpenEXR -I/usr/include/Imath -MMD -MP
CFLAGS_release := -O2 -g
CFLAGS_asan    := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
CFLAGS   := -std=c11 $(WARN) $(CFLAGS_$(MODE))
# tinygltf is header-only C++; its own code draws warnings we do not own.
CXXFLAGS := -std=c++17 -Wall -Wextra -Werror -Wno-unused-parameter $(CFLAGS_$(MODE))
LDFLAGS  := $(CFLAGS_$(MODE))
LDLIBS   := -lOpenEXRCore-3_1 -lpng -lembree3 -lstdc++ -lm -lpthread

CLI_C    := $(wildcard radiosity/cli/*.c)
LIB_C    := $(filter-out $(CLI_C),$(wildcard radiosity/*/*.c hemicube/*.c solver/*.c render/*.c))
LIB_CXX  := $(wildcard radiosity/*/*.cpp)
LIB_OBJ  := $(LIB_C:%.c=$(B)/obj/%.o) $(LIB_CXX:%.cpp=$(B)/obj/%.o)
LIB      := $(B)/libradiosity.a
PROG     := $(B)/radiosity

TEST_SRC := $(wildcard test/test_*.c)
TEST_BIN := $(TEST_SRC:test/%.c=$(B)/test/%)
BENCH_SRC:= $(wildcard bench/bench_*.c)
BENCH_BIN:= $(BENCH_SRC:bench/%.c=$(B)/bench/%)
# Programs in tools/: the reference path tracer, built with the benchmarks
# and run by hand (its output is shipped in bench/data/, which bench_cornell
# reads; bench/run_bench.sh runs bench_* only), and the accuracy report's
# generator, built by `make report` (tools/make_report.sh).  tools/hall.c is
# no program: bench_scale's scene generator.
TOOL_BIN := $(B)/tools/pathtrace

.PHONY: all lib prog tests benches demo test fuzz bench report deps check-deps print-objects clean

all: prog

lib: $(LIB)
prog: $(PROG)
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

$(PROG): $(CLI_C:%.c=$(B)/obj/%.o) $(LIB)
	@echo "LD  $(MODE) $@"
	@$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

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
	@$(MAKE) --no-print-directory -j$(NPROC) MODE=release prog tests
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

# The library's and the program's objects, for tools/check-structure.sh.
print-objects:
	@echo $(LIB_OBJ) $(CLI_C:%.c=$(B)/obj/%.o)

clean:
	rm -rf build out

-include $(shell find $(B) -name '*.d' 2>/dev/null)
