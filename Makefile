# spraycoat build.  `make` builds build/spraycoat; see README.md for the other targets.
# Sources are discovered by folder: add a .c file to core/, dem/, mpm/, render/, coupling/ or app/ and it is built;
# add tests/test_NAME.c and it becomes a test program; tests/test_NAME.sh is a shell test.

# `make CUDA=1`: the impact stage's step on an NVIDIA GPU as well (mpm/cuda/*.cu, nvcc, FP64, CUDA_ARCH), in
# build-cuda/ by default; `[run] device = gpu` or `--device gpu` picks it at run time (docs/gpu.md).  Without
# CUDA=1 nothing of it is built and mpm/gpu_stub.c answers that the build has no GPU step.
CUDA      ?= 0
NVCC      ?= $(or $(shell command -v nvcc 2>/dev/null),/usr/local/cuda/bin/nvcc)
CUDA_ARCH ?= sm_90
ifeq ($(CUDA),1)
BUILD     ?= build-cuda
CPPFLAGS  += -DSPRAYCOAT_CUDA
endif

# `make MPI=1`: the OpenMPI build (mpicc, HDF5's OpenMPI flavour, SPRAYCOAT_MPI), in build-mpi/ by default.
MPI      ?= 0
ifeq ($(MPI),1)
BUILD    ?= build-mpi
CC       := mpicc
HDF5_PKG := hdf5-openmpi
CPPFLAGS += -DSPRAYCOAT_MPI
else
BUILD    ?= build
CC       ?= gcc
HDF5_PKG := hdf5-serial
endif
PREFIX   ?= /usr/local
OPT      ?= -O2 -march=x86-64-v2
VERSION  := $(shell git describe --always --dirty --tags 2>/dev/null || echo unknown)
# the semantic version (README, "The commands", says how it grows): the file VERSION, one line MAJOR.MINOR.PATCH
SEMVER   := $(shell cat VERSION 2>/dev/null || echo 0.0.0)
# The sources whose code computes results (every layer but render/ and the tests): their digest is each output's
# root attribute sources_id, and an output or checkpoint of other sources is not taken as up to date or resumed
# (docs/architecture.md "Another build").  git describe alone misses uncommitted edits.
RESULT_SRC := $(sort $(wildcard core/*.[ch] dem/*.[ch] mpm/*.[ch] mpm/cuda/*.cu mpm/cuda/*.h coupling/*.[ch] \
                                app/*.[ch]))
SOURCES_ID ?= $(shell cat $(RESULT_SRC) | sha256sum | cut -c1-16)

# OSMesa's headers only: render/gl.c loads the library when it first renders (dlopen), so that llvmpipe is not
# loaded into every process
PKGS     := $(HDF5_PKG) inih cairo
CPPFLAGS += -I. $(shell pkg-config --cflags $(PKGS) osmesa 2>/dev/null)
# -ffp-contract=off: no fused multiply-adds the source does not write, so results are bit-identical across
# compilers and -march levels (gcc's -std=c17 implies it already; the flag states it rather than rely on that).
CFLAGS   += -std=c17 -ffp-contract=off -Wall -Wextra -Werror -g $(OPT) -fopenmp -D_DEFAULT_SOURCE \
            -D_POSIX_C_SOURCE=200809L
LDLIBS   += $(shell pkg-config --libs $(PKGS) 2>/dev/null) -ldl -lsundials_cvode -lsundials_nvecserial \
            -lsundials_sunlinsoldense -lsundials_sunmatrixdense -ludunits2 -lm
LDFLAGS  += -fopenmp

LIB_SRC  := $(wildcard core/*.c dem/*.c mpm/*.c render/*.c coupling/*.c) $(filter-out app/main.c,$(wildcard app/*.c))
LIB_OBJ  := $(LIB_SRC:%.c=$(BUILD)/%.o)
# --fmad=false: no fused multiply-adds, as -ffp-contract=off on the host (docs/gpu.md, "Bits"); static cudart: the
# binary needs only the driver (libcuda) where it runs.
ifeq ($(CUDA),1)
CUDA_HOME := $(patsubst %/bin/nvcc,%,$(NVCC))
CUDA_SRC  := $(wildcard mpm/cuda/*.cu)
LIB_OBJ   += $(CUDA_SRC:%.cu=$(BUILD)/%.o)
NVCCFLAGS := -std=c++17 -O3 -g -arch=$(CUDA_ARCH) --fmad=false -Werror all-warnings -Xcompiler -Wall,-Wextra \
             -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L
LDLIBS    += -L$(CUDA_HOME)/lib64 -lcudart_static -lrt -lpthread -lstdc++
endif
# The GPU step emulated on the CPU (docs/gpu.md, "The emulation"): BUILD/cuda-emu/spraycoat is spraycoat with
# mpm/cuda/step.cu compiled by the host's C++ compiler against tests/cuda_emu (the CUDA runtime and CUB calls the
# step makes, on the host: a kernel's threads run one after the other), so that tests/test_gpu_emulated.sh runs the
# device's code with `device = gpu` and compares it with the CPU step on every machine.  Not in a CUDA=1 build.
ifneq ($(CUDA),1)
EMU_BIN   := $(BUILD)/cuda-emu/spraycoat
EMU_FLAGS := -std=c++17 -ffp-contract=off -Wall -Wextra -Werror -g $(OPT) -D_DEFAULT_SOURCE \
             -D_POSIX_C_SOURCE=200809L -Itests/cuda_emu
endif
MAIN_OBJ := $(BUILD)/app/main.o
TEST_SRC := $(wildcard tests/test_*.c)
TEST_BIN := $(TEST_SRC:tests/%.c=$(BUILD)/tests/%)
BIN      := $(BUILD)/spraycoat
# spraycoat as if built from other sources (its sources_id alone differs): tests/test_build_identity.sh runs it
# beside BIN
OTHER_BIN := $(BUILD)/tests/spraycoat-other-sources
# The builds that test, asan, bench, run and validate start use every core unless the caller gave -j (a plain
# `make test` built one file at a time: 3 of its 10 minutes on 2 cores); evaluated in the recipe, where MAKEFLAGS
# holds -j.
NPROC    := $(shell getconf _NPROCESSORS_ONLN 2>/dev/null || echo 1)
JOBS      = $(if $(filter -j%,$(MAKEFLAGS)),,-j$(NPROC))

.PHONY: all test asan bench run validate install clean format format-check deps test-deps fuzz fuzz-build docs FORCE
all: $(BIN) $(TEST_BIN) $(EMU_BIN) $(OTHER_BIN)

deps:
	@scripts/bootstrap --mpi

# `make test` also installs ParaView's Python, so that tests/test_paraview.sh runs rather than skips (scripts/bootstrap
# says what it costs); `make run` and the others do without it.
test-deps:
	@scripts/bootstrap --mpi --paraview

# Per-file optimisation (after $(OPT), so it wins; no floating-point option changes, so no value changes).
# The loops over a block's lanes in the DEM integrator, the MPM stress update and the fastmath test vectorise
# only at -O3, whatever OPT is.  The integrator's loops over particles call sqrt: without errno (nothing there
# reads it) the correctly rounded instruction vectorises, where a call that may set errno keeps the loop scalar.
# And no library calls for its loops that copy (memcpy for a block's 256-byte copies cost more than inline moves).
# (Patterns: they hold for the objects of every instruction-set level below too.)
INTEGRATE_CFLAGS     := -O3 -fno-tree-loop-distribute-patterns -fno-math-errno
STRESS_UPDATE_CFLAGS := -O3
# (the single build's integrate.o, and the per-level integrate.vN.raw.o: a pattern's % never matches nothing)
$(BUILD)/dem/integrate.o $(BUILD)/dem/integrate%.o: private CFLAGS += $(INTEGRATE_CFLAGS)
$(BUILD)/mpm/stress_update.o $(BUILD)/mpm/stress_update%.o: private CFLAGS += $(STRESS_UPDATE_CFLAGS)
$(BUILD)/tests/test_fastmath.o: CFLAGS += -O3

# One build, fast on every x86-64 (docs/performance.md, "One build for every x86-64"): the hot kernels, the
# impact's transfers, grid-to-points and stress update and the spray's integration and contacts, are compiled
# once per instruction-set level (ISA_LEVELS: x86-64-v2, -v3 with AVX2, -v4 with AVX-512) into
# $(BUILD)/M/F.vN.o, whose external functions objcopy renames NAME -> NAME_vN (calls between the kernel files
# too); app/isa_dispatch.c defines each NAME as a jump to the level core/isa.c chooses before main (the best the
# CPU runs, or SPRAYCOAT_ISA=v2|v3|v4).  Every other file is compiled once, with $(OPT).  Needs gcc >= 12 on
# x86-64 (__builtin_cpu_supports("x86-64-v3")); elsewhere, or with `make ISA_LEVELS=`, one build as before.
ISA_KERNEL_SRC := mpm/grid.c mpm/solver.c mpm/stress_update.c dem/integrate.c dem/broadphase.c
ISA_CFLAGS     := -O3
ISA_LEVELS     ?= v2 v3 v4
ISA_COMPILER   := $(shell printf '\043if defined(__x86_64__) && !defined(__clang__) && __GNUC__ >= 12\nyes\n\043endif\n' | \
                    $(CC) -E -P - 2>/dev/null)
ifneq ($(ISA_COMPILER),yes)
ISA_LEVELS     :=
endif
ifneq ($(strip $(ISA_LEVELS)),)
ISA_RAW_OBJ    := $(foreach v,$(ISA_LEVELS),$(ISA_KERNEL_SRC:%.c=$(BUILD)/%.$(v).raw.o))
LIB_OBJ        := $(filter-out $(ISA_KERNEL_SRC:%.c=$(BUILD)/%.o),$(LIB_OBJ)) \
                  $(foreach v,$(ISA_LEVELS),$(ISA_KERNEL_SRC:%.c=$(BUILD)/%.$(v).o))
$(BUILD)/core/isa.o: private CPPFLAGS += -DSPRAYCOAT_ISA_VARIANTS
$(BUILD)/app/isa_dispatch.o: private CPPFLAGS += -DSPRAYCOAT_ISA_KERNELS -I$(BUILD)/isa
$(BUILD)/app/isa_dispatch.o: $(BUILD)/isa/kernels.list
# the kernel functions, from the level-2 objects (scripts/isa_kernels.sh), and each level's renaming
$(BUILD)/isa/kernels.list: $(ISA_KERNEL_SRC:%.c=$(BUILD)/%.$(firstword $(ISA_LEVELS)).raw.o) scripts/isa_kernels.sh
	@mkdir -p $(dir $@)
	scripts/isa_kernels.sh $@ $(BUILD)/isa/isa_kernels.h $(filter %.o,$^)
$(BUILD)/isa/%.syms: $(BUILD)/isa/kernels.list
	awk '{ print $$1, $$1 "_$*" }' $< > $@
define ISA_RULES
$(BUILD)/%.$(1).raw.o: %.c $(BUILD)/flags.stamp
	@mkdir -p $$(dir $$@)
	$$(CC) $$(CPPFLAGS) $$(CFLAGS) $(ISA_CFLAGS) -march=x86-64-$(1) -MMD -MP -c $$< -o $$@
$(BUILD)/%.$(1).o: $(BUILD)/%.$(1).raw.o $(BUILD)/isa/$(1).syms
	objcopy --redefine-syms=$(BUILD)/isa/$(1).syms $$< $$@
endef
$(foreach v,$(ISA_LEVELS),$(eval $(call ISA_RULES,$(v))))
.SECONDARY: $(ISA_RAW_OBJ) $(foreach v,$(ISA_LEVELS),$(BUILD)/isa/$(v).syms)
ISA_FILE_FLAGS := ; per level, chosen at run time ($(ISA_KERNEL_SRC)): $(ISA_CFLAGS) -march=x86-64-$(subst $() ,|,$(strip $(ISA_LEVELS)))
endif

# The build record of every output's /code group (core/version.c): the flags every file is compiled with
# (CPPFLAGS without its -I paths, CFLAGS) and the per-file additions of the program.
BUILD_FLAGS := $(strip $(filter-out -I%,$(CPPFLAGS)) $(CFLAGS))$(if $(filter 1,$(CUDA)), | nvcc $(NVCCFLAGS))
FILE_FLAGS  := dem/integrate.c: $(INTEGRATE_CFLAGS); mpm/stress_update.c: $(STRESS_UPDATE_CFLAGS)$(ISA_FILE_FLAGS)
# TEXT as the contents of a C string literal inside a shell word in single quotes
c_string = $(subst ','\'',$(subst ",\",$(subst \,\\,$(1))))

$(BUILD)/%.o: %.c $(BUILD)/flags.stamp
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS) $(CFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/mpm/cuda/%.o: mpm/cuda/%.cu $(BUILD)/flags.stamp
	@mkdir -p $(dir $@)
	$(NVCC) $(filter -I% -D%,$(CPPFLAGS)) $(NVCCFLAGS) -MMD -MP -c $< -o $@

# the emulation: the launches' <<<grid, block>>> become EMU_LAUNCH(kernel, grid, block), the source's only change
# (a launch on one line); its objects before the library, whose GPU stubs are then not linked
$(BUILD)/cuda-emu/%.cc: mpm/cuda/%.cu
	@mkdir -p $(dir $@)
	{ printf '#line 1 "%s"\n' $<; sed -E 's/([A-Za-z_][A-Za-z0-9_]*)<<<(.*)>>>\(/EMU_LAUNCH(\1, \2)(/' $<; } > $@.tmp
	@! grep -n '<<<' $@.tmp || { echo "$<: a launch the emulation cannot rewrite (one a line)"; exit 1; }
	mv $@.tmp $@
.SECONDARY: $(BUILD)/cuda-emu/step.cc
$(BUILD)/cuda-emu/step.o: $(BUILD)/cuda-emu/step.cc $(BUILD)/flags.stamp
	$(CXX) $(filter -I% -D%,$(CPPFLAGS)) $(EMU_FLAGS) -MMD -MP -c $< -o $@
$(BUILD)/cuda-emu/emu.o: tests/cuda_emu/emu.cc $(BUILD)/flags.stamp
	@mkdir -p $(dir $@)
	$(CXX) $(EMU_FLAGS) -MMD -MP -c $< -o $@
$(EMU_BIN): $(MAIN_OBJ) $(BUILD)/cuda-emu/step.o $(BUILD)/cuda-emu/emu.o $(BUILD)/libspraycoat.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -lstdc++ -o $@

# Only core/version.c sees the version and the flags; it is rebuilt when `git describe` changes, and every
# object is rebuilt when the compiler or the flags change (so that /code tells how each object was built).
$(BUILD)/version.stamp: FORCE
	@mkdir -p $(dir $@)
	@echo '$(VERSION) $(SOURCES_ID)' | cmp -s - $@ || echo '$(VERSION) $(SOURCES_ID)' > $@
$(BUILD)/flags.stamp: FORCE
	@mkdir -p $(dir $@)
	@printf '%s\n' '$(subst ','\'',$(CC) | $(BUILD_FLAGS) | $(FILE_FLAGS))' | cmp -s - $@ || \
	    printf '%s\n' '$(subst ','\'',$(CC) | $(BUILD_FLAGS) | $(FILE_FLAGS))' > $@
$(BUILD)/core/version.o: $(BUILD)/version.stamp VERSION
$(BUILD)/core/version.o: CPPFLAGS += -DSPRAYCOAT_VERSION='"$(VERSION)"' -DSPRAYCOAT_SEMVER='"$(SEMVER)"' \
    -DSPRAYCOAT_SOURCES_ID='"$(SOURCES_ID)"' \
    -DSPRAYCOAT_FLAGS='"$(call c_string,$(BUILD_FLAGS))"' -DSPRAYCOAT_FILE_FLAGS='"$(call c_string,$(FILE_FLAGS))"'
FORCE:
$(BUILD)/tests/version-other-sources.o: core/version.c $(BUILD)/version.stamp $(BUILD)/flags.stamp VERSION
	@mkdir -p $(dir $@)
	$(CC) $(CPPFLAGS) -DSPRAYCOAT_VERSION='"$(VERSION)"' -DSPRAYCOAT_SEMVER='"$(SEMVER)"' \
	    -DSPRAYCOAT_SOURCES_ID='"0ther0s0urces000"' -DSPRAYCOAT_FLAGS='"$(call c_string,$(BUILD_FLAGS))"' \
	    -DSPRAYCOAT_FILE_FLAGS='"$(call c_string,$(FILE_FLAGS))"' $(CFLAGS) -c $< -o $@
$(OTHER_BIN): $(MAIN_OBJ) $(BUILD)/tests/version-other-sources.o $(BUILD)/libspraycoat.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/libspraycoat.a: $(LIB_OBJ)
	@rm -f $@
	ar rcs $@ $^

$(BIN): $(MAIN_OBJ) $(BUILD)/libspraycoat.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/tests/%: $(BUILD)/tests/%.o $(BUILD)/libspraycoat.a
	$(CC) $(LDFLAGS) $^ $(LDLIBS) -o $@

# The suite also runs the MPI build (tests/test_mpi.sh compares `mpirun -np 2` with one process); every
# instruction-set level of the kernels this CPU runs is compared with level 2 (tests/test_native_build.sh).
test: test-deps format-check
	$(MAKE) $(JOBS) all
	$(MAKE) $(JOBS) MPI=1 BUILD=build-mpi build-mpi/spraycoat $(if $(filter 1,$(CUDA)),,build-mpi/cuda-emu/spraycoat)
	SPRAYCOAT_MPI_BIN=build-mpi/spraycoat tests/run_tests.sh $(BUILD)

# AddressSanitizer + UndefinedBehaviorSanitizer build of everything, then the whole suite.
asan: deps
	$(MAKE) $(JOBS) BUILD=build-asan OPT='-O1 -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all' \
	        LDFLAGS='-fopenmp -fsanitize=address,undefined' all
	ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan-mesa.supp UBSAN_OPTIONS=print_stacktrace=1 \
	    SPRAYCOAT_SANITIZED=1 tests/run_tests.sh build-asan

# The performance tables, of the build users get: the default build, its kernels at the level this CPU runs
# (scripts/bench.sh prints which).
bench: deps
	$(MAKE) $(JOBS) all
	BENCH_COMMAND='make bench' scripts/bench.sh $(BUILD)

run: deps
	$(MAKE) $(JOBS) $(BIN)
	$(BIN) run cases/demo.ini -o runs/demo

# VALIDATE_ONLY=PART runs one part of scripts/validate.sh: table1, bonding, fuzz, calibrate_coarse,
# calibrate_medium, calibrate_fine, vcrit_coarse, vcrit_medium, vcrit_fine, calibrate_vcrit, calibrate_vcrit_coarse,
# calibrate_vcrit_fine, calibrate_vcrit_conduction, vcrit_al, vcrit_al_fine, interface_strain,
# vcrit_al_temperature, two_particles (docs/validation.md).
validate: deps
	$(MAKE) $(JOBS) all
	scripts/validate.sh $(BUILD)

# `make fuzz`: the libFuzzer harnesses of the case reader and the two CSV readers (tests/fuzz/), built with clang,
# AddressSanitizer and UBSan into FUZZ_BUILD, each run for FUZZ_SECONDS from its kept corpus tests/fuzz/corpus/.
# Needs clang (Debian's package ships libFuzzer); tests/test_fuzz.sh runs them briefly in the suite.
FUZZ_BUILD   ?= build-fuzz
FUZZ_SECONDS ?= 600
FUZZ_CC      ?= clang
FUZZ_CFLAGS  := -std=c17 -g -O1 -march=x86-64-v2 -fno-omit-frame-pointer -fopenmp -D_DEFAULT_SOURCE \
                -D_POSIX_C_SOURCE=200809L -fsanitize=address,undefined -fno-sanitize-recover=all
FUZZ_OBJ     := $(patsubst %.c,$(FUZZ_BUILD)/%.o,$(wildcard core/*.c dem/*.c mpm/*.c))
FUZZ_BIN     := $(FUZZ_BUILD)/fuzz_case $(FUZZ_BUILD)/fuzz_particles_csv $(FUZZ_BUILD)/fuzz_bodies_csv

$(FUZZ_BUILD)/%.o: %.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(CPPFLAGS) $(FUZZ_CFLAGS) -fsanitize=fuzzer-no-link -MMD -MP -c $< -o $@

$(FUZZ_BUILD)/fuzz_%: tests/fuzz/fuzz_%.c tests/fuzz/fuzz_common.h $(FUZZ_OBJ)
	$(FUZZ_CC) $(CPPFLAGS) $(FUZZ_CFLAGS) -fsanitize=fuzzer $< $(FUZZ_OBJ) $(LDLIBS) -o $@

fuzz-build: $(FUZZ_BIN)
.SECONDARY: $(FUZZ_OBJ)

fuzz: fuzz-build
	FUZZ_BUILD=$(FUZZ_BUILD) FUZZ_SECONDS=$(FUZZ_SECONDS) tests/fuzz/run.sh

# `make docs`: the generated documents, from the program itself: docs/keys.md (`spraycoat keys`) and the man
# page spraycoat.1 (its help text); tests/test_keys_doc.sh fails when the committed ones are stale.
docs: $(BIN)
	$(BIN) keys > docs/keys.md
	scripts/make_man.sh $(BIN) > spraycoat.1

install: $(BIN)
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/share/spraycoat/cases $(DESTDIR)$(PREFIX)/share/man/man1
	install -m 755 $(BIN) $(DESTDIR)$(PREFIX)/bin/spraycoat
	install -m 644 spraycoat.1 $(DESTDIR)$(PREFIX)/share/man/man1/spraycoat.1
	install -m 644 cases/*.ini cases/*.csv $(DESTDIR)$(PREFIX)/share/spraycoat/cases/
	install -m 755 cases/*.sh $(DESTDIR)$(PREFIX)/share/spraycoat/cases/

# Every C file of the repository, in the style of .clang-format; `make test` (and so CI) fails on unformatted code.
C_FILES   = $(shell git ls-files '*.c' '*.h' 2>/dev/null)
format:
	clang-format -i $(C_FILES)

format-check:
	@clang-format --dry-run -Werror $(C_FILES) && echo "format-check: $(words $(C_FILES)) C files formatted"

clean:
	rm -rf build build-asan build-bench build-mpi build-fuzz build-cuda

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
-include $(shell find $(FUZZ_BUILD) -name '*.d' 2>/dev/null)
