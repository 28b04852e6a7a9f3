# MaterialFusion in C — build, test and benchmark entry points.
#   make deps        install the Debian packages (non-interactive, idempotent)
#   make             build build/libmf.a and build/mf
#   make test        build and run the test suite (last line: N passed, N failed, N skipped)
#   make asan        the test suite under AddressSanitizer + UBSan
#   make bench-render  renderer throughput vs a bare Embree loop -> reports/perf/
#   make bench-nn      conv / residual block vs OpenBLAS sgemm -> reports/perf/ (bench-nn-onednn: vs oneDNN)
# BUILD=dir selects the build folder (default build; asan uses build-asan; NATIVE=1 build-native).
#   make NATIVE=1    compile for this machine's CPU (-march=native) into build-native/ (below)
#   make DNNL=0      the network's convolutions on OpenBLAS alone (no oneDNN), into build-blas/ (below)

DEB_PACKAGES := build-essential pkg-config libembree-dev libopenimageio-dev libopenexr-dev \
  libgsl-dev libcjson-dev libopenblas-dev povray blender-data python3-skimage python3-numpy \
  gnuplot-nox libmeshoptimizer-dev libdnnl-dev slurm-wlm munge jq

# NATIVE=1: -march=native (this CPU's AVX2 / AVX-512 in our own loops) in its own folder. Such a
# build runs only on CPUs with the same instructions, so it is never the default and never
# shipped: $(BUILD)/cpu holds the flags gcc's -march=native resolves to here, and a NATIVE build
# on a machine whose flags differ (a shared checkout, a copied folder) starts from scratch.
# The default build targets plain x86-64 (-march=x86-64), so its binaries run on any x86-64 CPU.
NATIVE   ?= 0
# DNNL=1 (the default): the network's convolutions through oneDNN (Debian's libdnnl-dev, which make
# deps installs; mf/nn/mf_nn_dnnl.c), compiled with -DMF_HAVE_DNNL and linked with -ldnnl; it measured
# 0.81-0.83 of sgemm on the prior's convolutions and 0.71-0.79 on its residual blocks, against
# 0.70-0.72 and 0.64-0.65 for the OpenBLAS im2col path (reports/perf/nn-*.md). DNNL=0 builds
# without oneDNN into its own folder (build-blas, or build-native-blas with NATIVE=1), so objects of
# the two builds never mix; $(BUILD)/backend records which one a folder holds, and a folder built
# the other way (an older checkout's build/) is rebuilt.
# MF_NN_BACKEND=blas|dnnl picks the backend at run time in a DNNL build.
DNNL     ?= 1
DNNL_SUFFIX := $(if $(filter 1,$(DNNL)),,-blas)
ifeq ($(NATIVE),1)
BUILD    ?= build-native$(DNNL_SUFFIX)
ARCH     := -march=native
NATIVE_CPU := $(shell $(CC) -march=native -E -v - </dev/null 2>&1 | grep -m1 cc1 | grep -o -- '-m[a-z0-9=.-]*' | sort | md5sum | cut -c1-32)
$(shell mkdir -p $(BUILD) && { [ "$$(cat $(BUILD)/cpu 2>/dev/null)" = "$(NATIVE_CPU)" ] || { rm -rf $(BUILD)/obj $(BUILD)/*.a $(BUILD)/mf $(BUILD)/mf_tests; echo "$(NATIVE_CPU)" > $(BUILD)/cpu; }; })
else
BUILD    ?= build$(DNNL_SUFFIX)
ARCH     := -march=x86-64
endif
# OpenMP threads sleep instead of spinning between parallel regions, so they do not fight
# OpenBLAS's threads on 2 cores (measured: up to 10x slower conv/sgemm with spinning threads).
export OMP_WAIT_POLICY ?= passive
CC       ?= gcc
CXX      ?= g++
OPT      ?= -O2
SAN      ?=
WARN     := -Wall -Wextra -Wno-unused-parameter
INCLUDES := -Imf -I. -I$(BUILD)/gen -I/usr/include/OpenEXR -I/usr/include/Imath -I/usr/include/cjson \
            -I/usr/include/x86_64-linux-gnu/openblas-pthread
CFLAGS   += -std=c17 $(OPT) $(ARCH) -g $(WARN) -fopenmp -D_GNU_SOURCE $(SAN) $(INCLUDES) -MMD -MP
CXXFLAGS += -std=c++17 $(OPT) $(ARCH) -g $(WARN) $(SAN) $(INCLUDES) -MMD -MP
LDLIBS   := -lembree3 -lOpenImageIO -lOpenImageIO_Util -lOpenEXRCore-3_1 -lImath-3_1 \
            -lcjson -lgsl -lmeshoptimizer -L/usr/lib/x86_64-linux-gnu/openblas-pthread -lopenblas \
            -lstdc++ -lm -lpthread
LDFLAGS  += -fopenmp $(SAN)
$(shell mkdir -p $(BUILD) && { [ "$$(cat $(BUILD)/backend 2>/dev/null)" = "dnnl=$(DNNL)" ] || { rm -rf $(BUILD)/obj/mf/nn $(BUILD)/*.a $(BUILD)/mf $(BUILD)/mf_tests; echo "dnnl=$(DNNL)" > $(BUILD)/backend; }; })
ifeq ($(DNNL),1)
ifeq ($(wildcard /usr/include/oneapi/dnnl/dnnl.h)$(filter deps deps-node clean,$(MAKECMDGOALS)),)
$(error oneDNN not found (/usr/include/oneapi/dnnl/dnnl.h): run make deps (or apt-get install libdnnl-dev), or build without it: make DNNL=0)
endif
LDLIBS   += -ldnnl
$(BUILD)/obj/mf/nn/%.o: CFLAGS += -DMF_HAVE_DNNL
endif

LIB_C    := $(sort $(filter-out mf/cli/%,$(wildcard mf/*/*.c)) $(wildcard eval/*.c datasets/*.c baselines/*.c))
LIB_CXX  := $(sort $(wildcard mf/*/*.cpp))
CLI_C    := $(sort $(wildcard mf/cli/*.c))
# the fuzz harnesses (tests/fuzz/) are compiled into the test binary too, which replays them
FUZZ_NAMES := obj scene transforms image ckpt prior opts gltf
FUZZ_C   := $(FUZZ_NAMES:%=tests/fuzz/fuzz_%.c) tests/fuzz/mf_fuzz_util.c
TEST_C   := $(sort $(wildcard tests/*.c)) $(FUZZ_C)

LIB_OBJ  := $(LIB_C:%.c=$(BUILD)/obj/%.o) $(LIB_CXX:%.cpp=$(BUILD)/obj/%.o)
CLI_OBJ  := $(CLI_C:%.c=$(BUILD)/obj/%.o)
TEST_OBJ := $(TEST_C:%.c=$(BUILD)/obj/%.o)

.PHONY: FORCE all deps deps-node deps-fuzz bench-asset fuzz fuzz-lib fuzz-seeds test check-deps asan bench-geom bench-hull bench-render profile-render bench-nn bench-nn-onednn bench-baseline bench-prior prior-objects train-prior-ft train-prior-bounce prior-bounce-curve prior-bounce-views prior-curve train-prior-datasize prior-datasize bench-sds-cost bench-quick bench bench-split bench-split-now bench-runs bench-summary bench-external recon-runs train-prior train-prior-wide eval-prior calibrate-trust sweep-guidance bench-domain bench-matrix bench-cycles-3d bench-stability bench-stability-stops test-slurm clean
all: $(BUILD)/mf $(BUILD)/mf_tests

deps:
	@missing=$$(for p in $(DEB_PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing:" $$missing; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -q && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -q --no-install-recommends $$missing; \
	else echo "make deps: all Debian packages present"; fi
	@$(MAKE) --no-print-directory deps-node

# The Khronos glTF validator (npm package, pinned) for make test's .glb checks, into .deps/node.
# Optional: without node/npm or the registry, make test skips that check and says so.
GLTF_VALIDATOR_VERSION := 2.0.0-dev.3.10
deps-node:
	@if [ -f .deps/node/node_modules/gltf-validator/package.json ]; then echo "make deps: gltf-validator present (.deps/node)"; \
	elif command -v npm >/dev/null 2>&1; then \
	  mkdir -p .deps/node && npm install --prefix .deps/node --no-audit --no-fund --no-save gltf-validator@$(GLTF_VALIDATOR_VERSION) >/dev/null 2>&1 \
	  && echo "make deps: installed gltf-validator $(GLTF_VALIDATOR_VERSION) into .deps/node" \
	  || echo "make deps: npm install gltf-validator failed; make test will skip the Khronos .glb check"; \
	else echo "make deps: no npm; make test will skip the Khronos .glb check"; fi

$(BUILD)/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -c $< -o $@

$(BUILD)/obj/%.o: %.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CXXFLAGS) -c $< -o $@

# The git revision, for run.json; rewritten only when it changes, so nothing rebuilds needlessly.
$(BUILD)/gen/mf_build_info.h: FORCE
	@mkdir -p $(dir $@)
	@echo "#define MF_GIT_REV \"$$(git rev-parse --short HEAD 2>/dev/null || echo unknown)$$(git diff --quiet HEAD 2>/dev/null || echo -dirty)\"" > $@.tmp
	@cmp -s $@.tmp $@ || mv $@.tmp $@; rm -f $@.tmp
# only the two files that include it (a new revision then recompiles two objects, not every CLI one)
$(BUILD)/obj/mf/cli/cli_run_info.o $(BUILD)/obj/mf/cli/cmd_eval.o: $(BUILD)/gen/mf_build_info.h

$(BUILD)/libmf.a: $(LIB_OBJ)
	@rm -f $@
	ar rcs $@ $^

# linked to a temporary name and renamed: a benchmark running build/mf keeps its binary, and the
# next run it starts gets the new one whole (the linker rewriting it in place made execs fail)
$(BUILD)/mf: $(CLI_OBJ) $(BUILD)/libmf.a
	$(CC) $(LDFLAGS) -o $@.tmp $(CLI_OBJ) $(BUILD)/libmf.a $(LDLIBS)
	mv -f $@.tmp $@

$(BUILD)/mf_tests: $(TEST_OBJ) $(BUILD)/libmf.a
	$(CC) $(LDFLAGS) -o $@ $(TEST_OBJ) $(BUILD)/libmf.a $(LDLIBS)

# ---- fuzzing (tests/fuzz/mf_fuzz.h) ----
# Seed corpora: written by build/fuzz_seeds (the project's own writers and literal text), so no
# binary seeds live in git. make test replays them and tests/fuzz/regress/ (past crashes).
$(BUILD)/fuzz_seeds: $(BUILD)/obj/tests/fuzz/fuzz_seeds.o $(BUILD)/obj/tests/fuzz/mf_fuzz_util.o $(BUILD)/libmf.a
	$(CC) $(LDFLAGS) -o $@ $^ $(LDLIBS)
$(BUILD)/fuzz-seeds/.done: $(BUILD)/fuzz_seeds
	rm -rf $(dir $@) && ./$(BUILD)/fuzz_seeds $(dir $@) && touch $@
fuzz-seeds: $(BUILD)/fuzz-seeds/.done

# make fuzz FUZZ_S=N: each libFuzzer harness for N seconds under ASan + UBSan (clang; the
# optional packages of make deps-fuzz), one after another, growing fuzz/corpus/<name>/ from the
# seeds; crashes land in fuzz/crashes/<name>/ (copy them to tests/fuzz/regress/<name>/ once
# fixed). FUZZ_NAMES=... picks harnesses, FUZZ_ARGS adds libFuzzer flags. The library is built
# with clang in build-fuzz/ (coverage instrumented, sanitizers on).
FUZZ_S        ?= 60
FUZZ_ARGS     ?=
# the harnesses write each input to a file: on tmpfs that is about 10x faster than on disk
FUZZ_TMPDIR   ?= $(if $(wildcard /dev/shm/.),/dev/shm,/tmp)
FUZZ_BUILD    := build-fuzz
FUZZ_SAN      := -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer
# functions whose coverage hooks cost time and give no feedback (checksum loops): see the file
FUZZ_COV      := -fsanitize=fuzzer-no-link -fsanitize-coverage-ignorelist=$(abspath tests/fuzz/coverage-ignore.txt)
deps-fuzz:
	@dpkg-query -W -f='$${Status}\n' clang 2>/dev/null | grep -q 'install ok installed' && dpkg-query -W -f='$${Status}\n' libomp-dev 2>/dev/null | grep -q 'install ok installed' \
	  && echo "make deps-fuzz: clang and libomp-dev present" \
	  || { SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); $$SUDO apt-get update -q && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -q --no-install-recommends clang libomp-dev; }
# one sub-make builds the instrumented library before any harness links (safe with -j)
fuzz-lib:
	@command -v clang >/dev/null || { echo "make fuzz: clang not found (make deps-fuzz installs Debian's clang)"; exit 1; }
	@if [ tests/fuzz/coverage-ignore.txt -nt $(FUZZ_BUILD)/libmf.a ]; then rm -rf $(FUZZ_BUILD)/obj; fi # the list changes how every object is built
	$(MAKE) --no-print-directory BUILD=$(FUZZ_BUILD) CC=clang CXX=clang++ OPT=-O1 SAN="$(FUZZ_SAN) $(FUZZ_COV)" $(FUZZ_BUILD)/libmf.a
$(FUZZ_BUILD)/fuzz_%: tests/fuzz/fuzz_%.c tests/fuzz/mf_fuzz_util.c tests/fuzz/mf_fuzz.h tests/fuzz/coverage-ignore.txt fuzz-lib
	@mkdir -p $(FUZZ_BUILD)/fz
	clang -std=c17 -O1 -g $(WARN) -D_GNU_SOURCE -DMF_LIBFUZZER -fopenmp $(FUZZ_SAN) $(FUZZ_COV) $(INCLUDES) -c tests/fuzz/fuzz_$*.c -o $(FUZZ_BUILD)/fz/fuzz_$*.o
	clang -std=c17 -O1 -g $(WARN) -D_GNU_SOURCE -DMF_LIBFUZZER -fopenmp $(FUZZ_SAN) $(FUZZ_COV) $(INCLUDES) -c tests/fuzz/mf_fuzz_util.c -o $(FUZZ_BUILD)/fz/mf_fuzz_util.o
	clang++ -fopenmp $(FUZZ_SAN) -fsanitize=fuzzer -o $@ $(FUZZ_BUILD)/fz/fuzz_$*.o $(FUZZ_BUILD)/fz/mf_fuzz_util.o $(FUZZ_BUILD)/libmf.a $(LDLIBS)
fuzz: $(FUZZ_NAMES:%=$(FUZZ_BUILD)/fuzz_%) fuzz-seeds
	@for n in $(FUZZ_NAMES); do \
	  mkdir -p fuzz/corpus/$$n fuzz/crashes/$$n; \
	  echo "== fuzz $$n: $(FUZZ_S) s"; \
	  LSAN_OPTIONS=suppressions=$(abspath tests/lsan.supp):print_suppressions=0 OMP_NUM_THREADS=1 TMPDIR=$(FUZZ_TMPDIR) \
	  ./$(FUZZ_BUILD)/fuzz_$$n -max_total_time=$(FUZZ_S) -print_final_stats=1 -artifact_prefix=fuzz/crashes/$$n/ $(FUZZ_ARGS) \
	    fuzz/corpus/$$n $(BUILD)/fuzz-seeds/$$n || exit 1; \
	done

# The tests find the mf binary through MF_BIN and ../shared through MF_SHARED. The .glb files
# they write are checked with the Khronos glTF validator when node and the npm package
# gltf-validator are present (`make deps` installs it into .deps/node; or NODE_PATH, or
# GLTF_VALIDATOR_MODULES=<dir>/node_modules); otherwise that check is skipped with a message.
GLTF_VALIDATOR_MODULES ?= $(abspath .deps/node/node_modules)
test: check-deps $(BUILD)/mf $(BUILD)/mf_tests $(BUILD)/fuzz-seeds/.done
	@NODE_PATH="$(GLTF_VALIDATOR_MODULES)$${NODE_PATH:+:$$NODE_PATH}"; export NODE_PATH; \
	if command -v node >/dev/null 2>&1 && node -e "require('gltf-validator')" >/dev/null 2>&1; then \
	  export MF_GLTF_VALIDATOR="node $(abspath tests/gltf_validate.js)"; \
	else echo "gltf-validator: node or the npm package gltf-validator not found; .glb files are not checked by the Khronos validator (see GLTF_VALIDATOR_MODULES in the Makefile)"; fi; \
	echo MF_BIN=$(abspath $(BUILD)/mf) MF_SHARED=$(abspath ../shared) OMP_NUM_THREADS=$${OMP_NUM_THREADS:-2} ./$(BUILD)/mf_tests $(T); \
	MF_BIN=$(abspath $(BUILD)/mf) MF_SHARED=$(abspath ../shared) MF_FUZZ_SEEDS=$(abspath $(BUILD)/fuzz-seeds) OMP_NUM_THREADS=$${OMP_NUM_THREADS:-2} ./$(BUILD)/mf_tests $(T)

# Layering rules of README "Layout" (which folder may include which) and the mf/cli function
# length limit, checked by grep/awk; part of `make test`.
check-deps:
	@sh tests/check_deps.sh

asan: export LSAN_OPTIONS = suppressions=$(abspath tests/lsan.supp):print_suppressions=0
asan:
	$(MAKE) BUILD=build-asan$(DNNL_SUFFIX) OPT=-O1 SAN="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined" test

bench-render: $(BUILD)/mf
	./$(BUILD)/mf bench-render -o reports/perf/render.md

# Where the renderer's time goes outside the rays (perf profile of bench-render; needs linux-perf)
profile-render: $(BUILD)/mf
	tools/profile_render.sh ./$(BUILD)/mf reports/perf/render-profile.md

# The network's convolution and residual block against OpenBLAS sgemm at the prior's denoiser
# shapes (batch 16, 8 groups; mf/prior/weights/prior.mfck), on one thread: ratios of CPU seconds
# are then not disturbed by the other processes of a shared machine. In a build with oneDNN (the
# default) each measurement runs under both conv backends, interleaved round by round.
NN_1THREAD := OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
bench-nn: $(BUILD)/mf
	$(NN_1THREAD) ./$(BUILD)/mf bench-nn --batch 16 --channels 64 --size 16 --groups 8 --reps 30 -o reports/perf/nn-c64-16x16.md
	$(NN_1THREAD) ./$(BUILD)/mf bench-nn --batch 16 --channels 128 --size 8 --groups 8 --reps 30 -o reports/perf/nn-c128-8x8.md
# oneDNN's convolution in the plain NCHW layout against ours (tools/onednn_conv_bench.c; needs
# Debian's libdnnl-dev, which make deps installs).
bench-nn-onednn: $(BUILD)/libmf.a
	@[ -f /usr/include/oneapi/dnnl/dnnl.h ] || { echo "bench-nn-onednn: oneDNN not found (apt-get install libdnnl-dev)"; exit 1; }
	$(CC) $(CFLAGS) -o $(BUILD)/onednn_conv_bench tools/onednn_conv_bench.c $(BUILD)/libmf.a $(LDLIBS) -ldnnl
	$(NN_1THREAD) ./$(BUILD)/onednn_conv_bench > reports/perf/nn-onednn.md.tmp && mv reports/perf/nn-onednn.md.tmp reports/perf/nn-onednn.md

# ---- data sets and benchmarks (generated data in $(DATA), method outputs in $(RESULTS)) ----
DATA        ?= data
RESULTS     ?= results
BENCH_SPLIT ?= test-3d
MF          := $(abspath $(BUILD)/mf)
ifeq ($(BENCH_FULL),1)
RECON_CONFIG ?= baselines/nvdiffrecmc_full.json
else
RECON_CONFIG ?= baselines/nvdiffrecmc.json
endif


# One command per split: generate and render it (resumable: rerunning continues). A split name
# with GEN_ARGS_<name> is a variant of a named split: test-3d-pov64 is test-3d-diffuse (POV-Ray
# ground truth) with 24 training views at 64 px, cheap enough to render on 2 cores (~1 CPU-min
# per scene) — the cross-renderer check of the prior.
GEN_ARGS_test-3d-pov64 := --split test-3d-diffuse --train 24 --width 64
# val-3d: test-3d's recipe with another seed (other objects of the same families, other materials
# and probes' draws) — the split on which the SDS weights may be chosen, never test-3d itself.
GEN_ARGS_val-3d := --split test-3d --seed 2
# val-3d-pov64: test-3d-pov64's recipe with val-3d's seed (the 64 px cross-renderer split's validation twin)
GEN_ARGS_val-3d-pov64 := --split test-3d-diffuse --train 24 --width 64 --seed 2
$(DATA)/%/.rendered: | $(BUILD)/mf
	$(MF) gen $(or $(GEN_ARGS_$*),--split $*) -o $(DATA)/$* --render
	touch $@

.PRECIOUS: $(DATA)/%/.rendered
data-%: $(DATA)/%/.rendered ;

# Per-scene reconstruction jobs: resumable (--resume), parallel with make -j. A method is the
# baseline or MaterialFusion with ablation flags (paper Table 5).
METHOD        ?= nvdiffrecmc
BENCH_METHODS ?= nvdiffrecmc materialfusion mf-trust mf-gamma-const mf-no-rgb mf-no-latent
# the splits where only the method and its trust weightings are compared
BENCH_METHODS_SHORT := nvdiffrecmc materialfusion mf-trust mf-chtrust
FLAGS_nvdiffrecmc    := --method nvdiffrecmc
FLAGS_materialfusion := --method materialfusion
FLAGS_mf-trust       := --method materialfusion --sds-weight conflict
FLAGS_mf-coverage    := --method materialfusion --sds-weight coverage
# channel trust: the flags that `make calibrate-trust` measured (reports/prior/trust.md)
FLAGS_mf-chtrust      = --method materialfusion $(or $(shell sed -n 's/^Flags[^`]*`\([^`]*\)`.*/\1/p' reports/prior/trust.md 2>/dev/null),$(error mf-chtrust: reports/prior/trust.md has no Flags line (make calibrate-trust writes it)))
# the same with guidance 1 in the prior's DDIM targets (the conditional prediction; the paper: 3)
FLAGS_mf-chtrust-g1   = $(FLAGS_mf-chtrust) --guidance 1
# and the mean of 2 noise draws per target, each element weighted by the draws' agreement
FLAGS_mf-spread       = $(FLAGS_mf-chtrust-g1) --sds-draws 2 --sds-weight spread
# or the prior's mean prediction per view (4 samples from pure noise), held for the run, as the target
FLAGS_mf-mean         = $(FLAGS_mf-chtrust-g1) --sds-target mean
# and with the channel trust measured at guidance 1 (make sweep-guidance's g1 cells, the smaller value per channel)
# $(call trust-flags,TABLE2D_JSONS): the --sds-trust-* flags from eval-prior tables, the smaller value
# per channel floored to 0.01 (empty when there is none)
trust-flags = $(shell jq -s '"--sds-trust-rough \(map(.trust_roughness) | min * 100 | floor / 100) --sds-trust-metal \(map(.trust_metallic) | min * 100 | floor / 100)"' -r $(1) 2>/dev/null)
TRUST_G1 = $(call trust-flags,$(wildcard $(GUIDANCE_REPORT)/g1/*/table2d.json))
FLAGS_mf-mean-g1trust = --method materialfusion --guidance 1 --sds-target mean $(or $(TRUST_G1),$(error mf-mean-g1trust: no $(GUIDANCE_REPORT)/g1/*/table2d.json (make sweep-guidance writes them)))
# and with the multi-view prior (StableMaterialMV) making each view's target jointly with 3 other views
FLAGS_mf-mean-g1trust-mv = $(FLAGS_mf-mean-g1trust) --sds-mv 1
# and the channel trust measured at the mean targets' own sampling (reports/prior/mean-targets: 0 / 0)
FLAGS_mf-mean-cal    := --method materialfusion --guidance 1 --sds-target mean --sds-trust-rough 0 --sds-trust-metal 0
# the mean targets with the prior trained on (mf/prior/weights/prior-ft.mfck = make train-prior-ft's
# prior-4000.mfck) and its channel trust measured at the targets' own sampling on the 2D validation
# splits (reports/prior/curve/ft-4000; the smaller value per channel, floored to 0.01)
TRUST_FT = $(call trust-flags,$(wildcard reports/prior/curve/ft-4000/val-2d*/table2d.json))
FLAGS_mf-ft-cal = --method materialfusion --guidance 1 --sds-target mean --prior-weights mf/prior/weights/prior-ft.mfck \
  $(or $(TRUST_FT),$(error mf-ft-cal: no reports/prior/curve/ft-4000/val-2d*/table2d.json (make prior-curve writes them)))
# the default method with the prior trained on interreflection (mf/prior/weights/prior-bounce.mfck =
# make train-prior-bounce's prior-4000.mfck; reports/prior/bounce)
FLAGS_mf-bounce      := --method materialfusion --prior-weights mf/prior/weights/prior-bounce.mfck
# and with the same recipe's direct-light prior (mf/prior/weights/prior-ft.mfck), its control; since
# the switch (docs/analyses/prior.md) the default prior, named here for the reports made before it
FLAGS_mf-ft          := --method materialfusion --prior-weights mf/prior/weights/prior-ft.mfck
# the first wave's prior (mf/prior/weights/prior.mfck), the default before the switch
FLAGS_mf-v1          := --method materialfusion --prior-weights mf/prior/weights/prior.mfck
FLAGS_mf-gamma-const := --method materialfusion --gamma-const 1
FLAGS_mf-no-rgb      := --method materialfusion --lambda-rgb 0
FLAGS_mf-no-latent   := --method materialfusion --lambda-latent 0
SCENE_LIMIT   ?= 1000
SCENES = $(wordlist 1,$(SCENE_LIMIT),$(notdir $(patsubst %/,%,$(dir $(wildcard $(DATA)/$(BENCH_SPLIT)/*/transforms_test.json)))))
recon-runs: $(foreach s,$(SCENES),$(RESULTS)/$(BENCH_SPLIT)/$(METHOD)/$(s)/run.json)
# scene-major order: every method of a scene runs back to back, so the per-scene time ratios
# (eval's time_x) compare runs made under the same machine load
bench-runs: $(foreach s,$(SCENES),$(foreach m,$(BENCH_METHODS),$(RESULTS)/$(BENCH_SPLIT)/$(m)/$(s)/run.json))
$(RESULTS)/$(BENCH_SPLIT)/%/run.json: | $(BUILD)/mf
	$(MF) recon $(DATA)/$(BENCH_SPLIT)/$(notdir $*) -o $(dir $@) $(FLAGS_$(patsubst %/,%,$(dir $*))) --config $(RECON_CONFIG) --resume $(RECON_EXTRA)

comma := ,
EVAL_ARGS = --dataset $(BENCH_SPLIT) --trivial --scenes $(subst $(eval) ,$(comma),$(strip $(SCENES)))
EVAL = $(MF) eval $(DATA)/$(BENCH_SPLIT) --results $(RESULTS)/$(BENCH_SPLIT) $(EVAL_ARGS)

# SCHED=slurm: bench-split submits its runs as one Slurm job array (a task per scene x method,
# complete ones skipped) and mf eval as a job after it; the other steps of bench are one job each
# (tools/slurm-bench.sh; README "Running the full table on a cluster"). SCHED=local runs here.
SCHED ?= local
ifeq ($(SCHED),slurm)
SCHED_MISSING := $(shell $(SHELL) tools/slurm-bench.sh check 2>&1)
$(if $(SCHED_MISSING),$(error $(SCHED_MISSING)))
else ifneq ($(SCHED),local)
$(error SCHED=$(SCHED): expected local or slurm)
endif
sched-job = $(if $(filter slurm,$(SCHED)),sh tools/slurm-bench.sh job $(1) $(RESULTS) --)

bench-baseline: $(BUILD)/mf $(DATA)/$(BENCH_SPLIT)/.rendered
	$(MAKE) --no-print-directory recon-runs METHOD=nvdiffrecmc
	$(EVAL) --methods nvdiffrecmc -o reports/baseline

# The full table reproduction: every method on test-3d (our renderer's ground truth) and
# test-3d-diffuse (POV-Ray's); the baseline, MaterialFusion and its trust weighting on the splits
# where a prior must matter (8 training views; 4 training views all on the +x side of the object,
# so its far side is seen by none; POV-Ray images at 64 px with 24 views; test-3d-ambig: material
# ambiguity); test-3d lit by Blender Cycles where blender exists (bench-cycles-3d); then the 2D prior table. BENCH_FULL=1: the published budget.
# Its splits, one report folder reports/bench/NAME each: NAME's data split (BENCH_DATA_NAME,
# default NAME), results folder (BENCH_RESULTS_NAME, default RESULTS), extra recon flags
# (BENCH_EXTRA_NAME, default RECON_EXTRA) and methods (BENCH_METHODS_NAME, default BENCH_METHODS).
BENCH_SPLITS := test-3d test-3d-diffuse views8 test-3d-pov64 views4side test-3d-ambig
BENCH_DATA_views8 := test-3d
BENCH_RESULTS_views8 = $(RESULTS)/views8
BENCH_EXTRA_views8 := --max-views 8
BENCH_METHODS_views8 = $(BENCH_METHODS_SHORT)
BENCH_METHODS_test-3d-pov64 = $(BENCH_METHODS_SHORT)
BENCH_DATA_views4side := test-3d
BENCH_RESULTS_views4side = $(RESULTS)/views4side
BENCH_EXTRA_views4side := --max-views 4 --side +x
BENCH_METHODS_views4side = $(BENCH_METHODS_SHORT)
BENCH_METHODS_test-3d-ambig = $(BENCH_METHODS_SHORT)
bench: $(BUILD)/mf
	$(foreach n,$(BENCH_SPLITS),$(MAKE) --no-print-directory bench-split BENCH_SPLIT=$(or $(BENCH_DATA_$n),$n) \
	  RESULTS=$(or $(BENCH_RESULTS_$n),$(RESULTS)) RECON_EXTRA="$(or $(BENCH_EXTRA_$n),$(RECON_EXTRA))" BENCH_METHODS="$(or $(BENCH_METHODS_$n),$(BENCH_METHODS))" \
	  REPORT=reports/bench/$n &&) true
	$(MAKE) --no-print-directory bench-cycles-3d
	$(if $(filter slurm,$(SCHED)),@echo "bench: run make bench-summary BENCH_SUMMARY_SPLITS=\"$(BENCH_SPLITS_CANONICAL)\" when the jobs are done",$(MAKE) --no-print-directory bench-summary BENCH_SUMMARY_SPLITS="$(BENCH_SPLITS_CANONICAL)")
	$(call sched-job,bench-external) $(MAKE) --no-print-directory bench-external REPORT=reports/bench
	$(call sched-job,eval-prior) $(MAKE) --no-print-directory eval-prior
	$(call sched-job,bench-stability) $(MAKE) --no-print-directory bench-stability
	$(call sched-job,bench-stability-stops) $(MAKE) --no-print-directory bench-stability-stops

# One table over the splits (issue 12 item 5): each method minus the baseline, read from each report's
# paired.csv and runs.md (eval/bench_summary.py) -> reports/bench/README.md. The default list is the
# newest committed report of each split (the *-ft ones: made with the default prior since the switch;
# test-3d-pov64-auto: the default --sds-every 0, beside -ft's fixed interval 4);
# make bench passes the folders it has just written.
BENCH_SPLITS_CANONICAL = $(foreach n,$(BENCH_SPLITS),$n=reports/bench/$n) test-3d-cyc=$(CYC3D_REPORT)/test-3d-cyc
BENCH_SUMMARY_SPLITS ?= test-3d=reports/bench/test-3d-ft views8=reports/bench/views8-ft \
  test-3d-pov64=reports/bench/test-3d-pov64-auto test-3d-pov64=reports/bench/test-3d-pov64-ft \
  test-3d-ambig=reports/bench/test-3d-ambig-ft \
  test-3d-cyc=$(CYC3D_REPORT)/test-3d-cyc-bounce test-3d-diffuse=reports/bench/test-3d-diffuse-ft \
  views4side=reports/bench/views4side-ft
bench-summary:
	python3 eval/bench_summary.py -o reports/bench/README.md $(foreach p,$(BENCH_SUMMARY_SPLITS),--split $(subst =, ,$(p)))

# The 3D renderer cell of issue 12's matrix: test-3d's objects, cameras and probes lit by Blender
# Cycles (test-3d-cyc: training and relit views by Cycles, 3 relighting lights; GT albedo/ORM are
# the same AOVs as test-3d's) beside the same objects by our renderer (test-3d), the baseline and
# MaterialFusion run on both with this binary, each split scored by mf eval, then per scene
# "cycles minus ours" for each method and for MF - baseline (eval/cycles3d_compare.sh) ->
# CYC3D_REPORT. Needs blender (skipped, exit 0, without it); measured here: 99 min of Cycles
# rendering (864 views) and about an hour of reconstruction, the 2 cores shared.
CYC3D_METHODS ?= nvdiffrecmc materialfusion
CYC3D_REPORT  ?= reports/generalisation/cycles-3d
CYC3D_RESULTS ?= $(RESULTS)/cyc3d
bench-cycles-3d: $(BUILD)/mf
	@if ! command -v blender >/dev/null 2>&1; then echo "bench-cycles-3d: skipped (no blender on this machine)"; else \
	  $(MAKE) --no-print-directory bench-split BENCH_SPLIT=test-3d-cyc BENCH_METHODS="$(CYC3D_METHODS)" RESULTS=$(CYC3D_RESULTS) \
	    REPORT=$(CYC3D_REPORT)/test-3d-cyc && \
	  $(MAKE) --no-print-directory bench-split BENCH_SPLIT=test-3d BENCH_METHODS="$(CYC3D_METHODS)" RESULTS=$(CYC3D_RESULTS) \
	    REPORT=$(CYC3D_REPORT)/test-3d && \
	  sh eval/cycles3d_compare.sh $(MF) $(CYC3D_REPORT)/test-3d/scenes.csv $(CYC3D_REPORT)/test-3d-cyc/scenes.csv \
	    $(firstword $(CYC3D_METHODS)) $(word 2,$(CYC3D_METHODS)) $(CYC3D_REPORT)/renderer; fi

# A glTF asset through the whole pipeline (issue 15): `mf gen --split test-3d --asset` renders it
# like a test-3d scene (its textures are the ground truth), then baseline and MaterialFusion
# reconstruct it and eval scores them -> reports/bench/asset-<name>. ASSET=path/to/Model.glb for
# your own (one material, UVs); the default is made by Blender's modelling, unwrapping and glTF
# exporter (datasets/blender_asset.py; needs blender).
ASSET      ?= $(DATA)/assets/suzanne.glb
ASSET_NAME := $(basename $(notdir $(ASSET)))
GEN_ARGS_asset-$(ASSET_NAME) := --split test-3d --asset $(abspath $(ASSET))
$(DATA)/assets/suzanne.glb:
	@command -v blender >/dev/null 2>&1 || { echo "bench-asset: no blender on this machine to make $@; pass ASSET=your.glb" >&2; exit 1; }
	@mkdir -p $(dir $@)
	blender -b --factory-startup -P datasets/blender_asset.py -- $@.tmp.glb --tex 512 --seed 1 && mv $@.tmp.glb $@
bench-asset: $(ASSET) $(BUILD)/mf
	$(MAKE) --no-print-directory bench-split BENCH_SPLIT=asset-$(ASSET_NAME) BENCH_METHODS="nvdiffrecmc materialfusion" \
	  REPORT=reports/bench/asset-$(ASSET_NAME)

# The numerical-stability grid (issue 18; eval/ev_stability.c) on the tiny split -> reports/stability.
STAB_WORK ?= $(RESULTS)/stability
bench-stability: $(BUILD)/mf
	rm -rf $(STAB_WORK)
	$(MF) bench-stability --mf $(MF) --work $(STAB_WORK) -o reports/stability --iters 200 --mem-iters 10000 --seeds 5
# Issue 18's exposure sweep below the grid's -4 stops: the seed row alone (both methods, the
# reference and the 8-bit images darkened STAB_STOPS stops, and the same values brought back, at
# recon seeds 1..5) -> reports/stability/stops.
STAB_STOPS ?= 1,2,3
bench-stability-stops: $(BUILD)/mf
	rm -rf $(STAB_WORK)-stops
	$(MF) bench-stability --mf $(MF) --work $(STAB_WORK)-stops -o reports/stability/stops --iters 200 --seeds 5 \
	  --seed-row-only --seed-stops $(STAB_STOPS)

# Geometry recovery (issue 14): the visual hull of every test-3d scene (64 masks at 128 px,
# 128^3 grid), scored against the GT mesh (Stanford-ORB Chamfer x1e3, normal error), beside the
# Chamfer the issue quotes for the same setting. Meshes go to $(RESULTS)/geometry/<scene>/vhull.obj.
# (bench-geom below reconstructs materials on these hulls.)
GEOM_REPORT ?= reports/bench/geometry
GEOM_ISSUE_CHAMFER := cup=1.9 vase=0.18 bottle=0.12 bowl=3.8 box=0.15 superquadric=0.09 torus=0.06 mug=2.5 clock=0.37
bench-hull: $(DATA)/test-3d/.rendered | $(BUILD)/mf
	@mkdir -p $(GEOM_REPORT)
	@echo "scene,views,res,tris,hull_s,chamfer,normal_deg,normal_1mcos,view_normal_deg,view_normal_1mcos,mask_iou" > $(GEOM_REPORT)/.hull.csv.tmp
	@for d in $(sort $(dir $(wildcard $(DATA)/test-3d/*/transforms_train.json))); do s=$$(basename $$d); \
	  mkdir -p $(RESULTS)/geometry/$$s; \
	  $(MF) hull $${d%/} -o $(RESULTS)/geometry/$$s/vhull.obj --eval >> $(GEOM_REPORT)/.hull.csv.tmp || exit 1; done
	@mv $(GEOM_REPORT)/.hull.csv.tmp $(GEOM_REPORT)/hull.csv
	@cfg=$$($(MF) hull --print-config | tr -d ' \t,'); opt() { echo "$$cfg" | sed -n "s/^\"$$1\"://p"; }; \
	awk -F, -v issue="$(GEOM_ISSUE_CHAMFER)" -v res="$$(opt res)" -v smooth="$$(opt smooth)" -v tris="$$(opt target_tris)" \
	  'BEGIN { n = split(issue, kv, " "); for (i = 1; i <= n; i++) { split(kv[i], p, "="); q[p[1]] = p[2] } \
	  print "# Visual hull on test-3d\n"; \
	  print "Made by `make bench-hull` (`mf hull DATA --eval`: 64 training masks at 128 px, " res "^3 grid, marching tets,"; \
	  print "weld and clean-up, " smooth " Taubin iterations, meshoptimizer decimation to " tris " triangles). Chamfer: Stanford-ORB"; \
	  print "(GT vertices vs 30k area samples, mean squared nearest distance each way, averaged, x1e3; object extent 1)."; \
	  print "Normals, points: mean angle between GT vertex normals and hull face normals of the same nearest pairs"; \
	  print "(counts hidden surfaces: inner walls). Normals, views: mean angle between the two meshes shading normals"; \
	  print "over the test views pixels that show both (as Stanford-ORB scores normal maps), with the mask IoU."; \
	  print "Issue: the Chamfer quoted in issue 14 for the same setting. hull s: wall seconds from loaded masks to mesh.\n"; \
	  print "| scene | triangles | hull s | Chamfer x1e3 | issue | normals, points deg | normals, views deg | views 1 - cos | mask IoU |"; \
	  print "|---|---|---|---|---|---|---|---|---|" } \
	  NR > 1 { f = $$1; sub(/^[0-9]+_/, "", f); printf "| %s | %d | %.2f | %.3f | %s | %.1f | %.1f | %.4f | %.4f |\n", $$1, $$4, $$5, $$6, (f in q) ? q[f] : "-", $$7, $$9, $$10, $$11 }' \
	  $(GEOM_REPORT)/hull.csv > $(GEOM_REPORT)/.README.md.tmp
	@printf '\nMarching tets (`mf bench-tets`, sphere, unit grid, deformation on): %s\n' "$$($(MF) bench-tets --res 64)" >> $(GEOM_REPORT)/.README.md.tmp
	@mv $(GEOM_REPORT)/.README.md.tmp $(GEOM_REPORT)/README.md
	@cat $(GEOM_REPORT)/README.md

# Geometry recovery inside mf recon (issue 14 items 10 and 12): per test-3d scene (bench-split's
# SCENES / SCENE_LIMIT pick a subset), the baseline on the given mesh (nvdiffrecmc: the same runs
# as bench-split's), on the visual hull of its training masks, unwrapped (nvdiffrecmc-vhull: mf
# recon --geometry vhull), and on DMTet's pass 1 from that hull (nvdiffrecmc-dmtet: --geometry
# dmtet), all with $(RECON_CONFIG); mf eval scores them (geometry.md against the GT mesh,
# relight.md, materials.md, paired.md: each minus given; paired-vs-vhull/: each minus the hull)
# and eval/bench_geom_report.sh writes REPORT/README.md (default reports/bench/geometry-recon)
# with the geometry seconds and the vessel choice from run.json, and the cavities' Chamfer against
# bench-hull's closed hull ($(GEOM_REPORT)/hull.csv).
FLAGS_nvdiffrecmc-vhull := --method nvdiffrecmc --geometry vhull
FLAGS_nvdiffrecmc-dmtet := --method nvdiffrecmc --geometry dmtet
bench-geom: REPORT ?= reports/bench/geometry-recon
bench-geom: $(DATA)/test-3d/.rendered | $(BUILD)/mf
	$(MAKE) --no-print-directory bench-split BENCH_SPLIT=test-3d BENCH_METHODS="nvdiffrecmc nvdiffrecmc-vhull nvdiffrecmc-dmtet" REPORT=$(REPORT)
	$(MF) compare $(REPORT)/scenes.csv --ref nvdiffrecmc-vhull -o $(REPORT)/paired-vs-vhull
	sh eval/bench_geom_report.sh $(RESULTS)/test-3d $(REPORT) "$(strip $(SCENES))" \
	  'make bench-geom$(if $(filter command line,$(origin SCENES)), SCENES="$(strip $(SCENES))")' $(GEOM_REPORT)/hull.csv > $(REPORT)/.README.md.tmp
	mv $(REPORT)/.README.md.tmp $(REPORT)/README.md
	@cat $(REPORT)/README.md

# Speed/error frontier (issue 16): relit/albedo/ORM PSNR against wall time over a ladder of budgets
# for the baseline and MaterialFusion on 3 test-3d scenes, and the budget flags of mf recon ->
# reports/frontier/ (eval/bench_frontier.sh; resumable). The default ladder is the one the
# committed snapshot ran: the baseline at 64 and 128 px x spp 1, 2, 4 x 50-800 iterations,
# MaterialFusion at spp 2 (64 and 128 px) x 50-400 iterations, the budget flags at the default
# budget (128 px, spp 2, 400 iterations); BENCH_FULL=1 runs the ladder up to the published budget
# (baselines/nvdiffrecmc_full.json: 128 px, spp 8, 5000 iterations; days on 2 cores). F_RES,
# F_SPP, F_ITERS, F_MF_ITERS, F_MF_LINES, SCENES override the ladder.
.PHONY: bench-frontier
bench-frontier: $(BUILD)/mf $(DATA)/test-3d/.rendered
	MF=$(MF) DATA=$(DATA)/test-3d RESULTS=$(RESULTS)/frontier OUT=reports/frontier \
	  $(if $(filter 1,$(BENCH_FULL)),F_RES="64 128" F_SPP="2 4 8" F_ITERS="100 400 1000 2000 5000" F_MF_ITERS="100 400 1000 2000 5000" F_MF_LINES= F_CONFIG=baselines/nvdiffrecmc_full.json F_DEFAULT=none) \
	  sh eval/bench_frontier.sh

# Issue 16's adaptive default: the baseline at its default budget with and without the budget
# flags on every val-3d scene (where a default may be chosen) and test-3d scene (where it is
# checked) -> reports/adaptive/ (resumable; A_CONFIGS="name=flags;..." for other flag sets).
.PHONY: bench-adaptive
# ADAPTIVE_SPLITS, A_CONFIGS ("name=flags;...") and ADAPTIVE_OUT run other flag sets on some splits into
# a report of their own (e.g. the iteration count: A_CONFIGS="i800=--iters 800" ADAPTIVE_SPLITS=val-3d
# ADAPTIVE_OUT=reports/adaptive/iters800, with a default re-run beside them).
ADAPTIVE_OUT ?= reports/adaptive
bench-adaptive: $(BUILD)/mf $(DATA)/val-3d/.rendered $(DATA)/test-3d/.rendered
	MF=$(MF) DATA=$(DATA) RESULTS=$(RESULTS)/adaptive$(if $(filter-out reports/adaptive,$(ADAPTIVE_OUT)),-$(notdir $(ADAPTIVE_OUT))) \
	  OUT=$(ADAPTIVE_OUT) $(if $(ADAPTIVE_SPLITS),SPLITS="$(ADAPTIVE_SPLITS)") $(if $(A_CONFIGS),A_CONFIGS="$(A_CONFIGS)") \
	  sh eval/bench_adaptive.sh

# The same tables on a reduced setting (3 scenes, 64 px training, 100 iterations).
bench-quick: $(BUILD)/mf
	$(MAKE) --no-print-directory bench-split BENCH_SPLIT=test-3d SCENE_LIMIT=3 RESULTS=$(RESULTS)/quick \
	  RECON_CONFIG=baselines/quick.json RECON_EXTRA="--res 64" REPORT=reports/quick
	$(call sched-job,eval-prior) $(MAKE) --no-print-directory eval-prior

# The runs and eval go through a sub-make: this make's $(wildcard) cache predates the split's
# generation, so SCENES would be empty the first time a split is made.
bench-split: $(DATA)/$(BENCH_SPLIT)/.rendered
	$(MAKE) --no-print-directory bench-split-now
bench-split-now:
ifeq ($(SCHED),slurm)
	sh tools/slurm-bench.sh submit --name $(notdir $(REPORT)) --mf $(MF) --data $(DATA)/$(BENCH_SPLIT) --results $(RESULTS)/$(BENCH_SPLIT) \
	  --report $(REPORT) --scenes "$(SCENES)" $(foreach m,$(BENCH_METHODS),--method "$(m)=$(FLAGS_$(m))") \
	  --recon-args "--config $(RECON_CONFIG) --resume $(RECON_EXTRA)" --eval-args "$(EVAL_ARGS)"
else
	$(MAKE) --no-print-directory bench-runs
	$(EVAL) --methods $(shell echo $(BENCH_METHODS) | tr ' ' ',') -o $(REPORT)
endif

# A one-node Slurm on localhost runs the tiny bench; its report must equal a local run's (skipped,
# exit 0, where the daemons cannot start). CI runs it after make test.
test-slurm: $(BUILD)/mf
	sh tests/test_slurm.sh

# Public data sets, when the user points at a local copy: NERF_SYNTHETIC=/path/nerf_synthetic,
# NERFACTOR=..., STANFORD_ORB=... A scene folder with mesh.obj (UVs) is reconstructed on it; one
# without (NeRF-Synthetic and NeRFactor ship none) on the visual hull of its masks, unwrapped
# (`mf recon`'s default without a mesh, --geometry vhull).
bench-external:
	@for v in NERF_SYNTHETIC NERFACTOR STANFORD_ORB; do \
	  eval d=\$$$$v; if [ -z "$$d" ]; then echo "bench: $$v not set: skipped (point it at a local copy of the data set)"; \
	  elif ! ls -d $$d/*/ >/dev/null 2>&1; then echo "bench: $$v=$$d holds no scene folders: skipped"; \
	  else for s in $$d/*/; do n=$$(basename $$s); \
	    [ -f $$s/mesh.obj ] || echo "bench: $$v/$$n has no mesh.obj: geometry from the visual hull (--geometry vhull)"; \
	    $(foreach m,$(BENCH_METHODS),{ [ -f $(RESULTS)/$$v/$(m)/$$n/run.json ] || $(MF) recon $$s -o $(RESULTS)/$$v/$(m)/$$n $(FLAGS_$(m)) --config $(RECON_CONFIG) --resume || exit 1; };) \
	  done; $(MF) eval $$d --results $(RESULTS)/$$v --dataset $$v -o $(REPORT)/$$v || exit 1; fi; done

# ---- the material prior: training data, training (resumable), 2D table, speed ----
# train-prior reproduces the first wave's weights (v1, docs/analyses/prior.md) and copies them to
# PRIOR_WEIGHTS; train-prior-ft continues them into PRIOR_FT_WEIGHTS, the default prior of `mf recon`,
# `mf prior` and `mf eval-prior` (MF_PRIOR_WEIGHTS_DEFAULT in mf/prior/mf_prior.h).
PRIOR_DATA       ?= $(DATA)/prior-train
PRIOR_CKPT       ?= $(DATA)/prior-ckpt
PRIOR_WEIGHTS    ?= mf/prior/weights/prior.mfck
PRIOR_GEN_ARGS   ?= --count 12060 --seed 1
PRIOR_TRAIN_ARGS ?= --ae-steps 500 --steps 4000 --batch 16 --seed 1 --dn-samples 6000
$(PRIOR_DATA)/manifest.json: | $(BUILD)/mf
	$(MF) gen --split prior-train -o $(PRIOR_DATA) $(PRIOR_GEN_ARGS)
train-prior: $(BUILD)/mf $(PRIOR_DATA)/manifest.json
	$(MF) train-prior $(PRIOR_DATA) -o $(PRIOR_CKPT) $(PRIOR_TRAIN_ARGS) --loss-csv reports/prior/loss.csv --resume
	@mkdir -p $(dir $(PRIOR_WEIGHTS)) && cp $(PRIOR_CKPT)/prior.mfck $(PRIOR_WEIGHTS)
# test-2d and its variants: each `mf gen --split test-2d` with its GEN2D_ARGS_<name> (one table,
# one rule): the renderer axis of the generalisation matrix (bench-domain), the validation splits of
# calibrate-trust (another seed, never the test split) and the content x renderer matrix
# (bench-matrix: 32 objects filtered by content; in = none of the held-out families/recipes, held =
# only objects with one). Other manifests (prior-train, ...) have rules of their own.
GEN2D_ARGS_test-2d              :=
GEN2D_ARGS_test-2d-diffuse      := --diffuse 1
GEN2D_ARGS_test-2d-pov          := --diffuse 1 --renderer povray
# the same with POV-Ray's radiosity count 1000 (default 200): how much of the POV-Ray gap is its own sampling error
GEN2D_ARGS_test-2d-pov1000      := --diffuse 1 --renderer povray --pov-radiosity 1000
GEN2D_ARGS_val-2d               := --seed 2
GEN2D_ARGS_val-2d-cyc           := --seed 2 --renderer cycles
GEN2D_ARGS_test-2d-in           := --count 32 --content train
GEN2D_ARGS_test-2d-held         := --count 32 --content heldout
GEN2D_ARGS_test-2d-in-diffuse   := --count 32 --content train --diffuse 1
GEN2D_ARGS_test-2d-held-diffuse := --count 32 --content heldout --diffuse 1
GEN2D_ARGS_test-2d-in-pov       := --count 32 --content train --diffuse 1 --renderer povray
GEN2D_ARGS_test-2d-held-pov     := --count 32 --content heldout --diffuse 1 --renderer povray
GEN2D_ARGS_test-2d-in-wide      := --count 32 --content train --widen 1
GEN2D_ARGS_test-2d-held-wide    := --count 32 --content heldout --widen 1
GEN2D_ARGS_test-2d-in-cyc       := --count 32 --content train --renderer cycles
GEN2D_ARGS_test-2d-held-cyc     := --count 32 --content heldout --renderer cycles
GEN2D_SPLITS := test-2d test-2d-diffuse test-2d-pov test-2d-pov1000 val-2d val-2d-cyc \
                test-2d-in test-2d-held test-2d-in-diffuse test-2d-held-diffuse test-2d-in-pov test-2d-held-pov \
                test-2d-in-wide test-2d-held-wide test-2d-in-cyc test-2d-held-cyc
$(GEN2D_SPLITS:%=$(DATA)/%/manifest.json): $(DATA)/%/manifest.json: | $(BUILD)/mf
	$(MF) gen $(strip --split test-2d $(GEN2D_ARGS_$*)) -o $(DATA)/$*
eval-prior: $(BUILD)/mf $(DATA)/test-2d/manifest.json $(PRIOR_DATA)/manifest.json
	$(MF) eval-prior $(DATA)/test-2d --train $(PRIOR_DATA) -o reports/prior
bench-prior: $(BUILD)/mf
	$(NN_1THREAD) $(MF) bench-prior -o reports/perf/prior.md

# The prior's own accuracy on the objects of the 3D splits (issue 12): eval-prior on each object's
# 4 held-out test views of val-3d, test-3d and test-3d-ambig, at the mean targets' setting (4
# samples x 10 DDIM steps, guidance 1) -> reports/prior/objects/<split>/; then against the 3D gain of
# those targets on the same objects (the committed reports/bench/val-3d-mv, views8-mv and
# test-3d-ambig-mv) -> reports/prior/objects/README.md.
PRIOR_OBJ_ARGS := --train $(PRIOR_DATA) --views 4 --samples 4 --steps 10 --guidance 1
prior-objects: $(BUILD)/mf $(DATA)/test-3d/.rendered $(DATA)/val-3d/.rendered $(DATA)/test-3d-ambig/.rendered \
  $(PRIOR_DATA)/manifest.json
	for s in val-3d test-3d test-3d-ambig; do $(MF) eval-prior $(DATA)/$$s -o reports/prior/objects/$$s $(PRIOR_OBJ_ARGS) || exit 1; done
	python3 eval/prior_vs_gain.py -o reports/prior/objects/README.md \
	  --pair val-3d reports/prior/objects/val-3d/objects.csv reports/bench/val-3d-mv/scenes.csv mf-mean-g1trust-mv nvdiffrecmc \
	  --pair test-3d reports/prior/objects/test-3d/objects.csv reports/bench/views8-mv/scenes.csv mf-mean-g1trust-mv nvdiffrecmc \
	  --pair test-3d-ambig reports/prior/objects/test-3d-ambig/objects.csv reports/bench/test-3d-ambig-mv/scenes.csv \
	  mf-mean-g1trust-mv nvdiffrecmc

# Training on from v1 (issue 12 item 2): the denoiser continues from its weights for PRIOR_FT_STEPS
# more steps on every sample of prior-train (v1's run saw 6000), the learning rate falling along a
# cosine; the weights kept every 1000 steps (PRIOR_FT_CKPT/prior-<step>.mfck), the last copied to
# PRIOR_FT_WEIGHTS (the default prior since it was chosen on val-3d, docs/analyses/prior.md).
PRIOR_FT_CKPT  ?= $(DATA)/prior-ft
PRIOR_FT_WEIGHTS ?= mf/prior/weights/prior-ft.mfck
PRIOR_FT_STEPS ?= 4000
PRIOR_FT_ARGS  ?= --init $(PRIOR_WEIGHTS) --ae-steps 0 --steps $(PRIOR_FT_STEPS) --dn-samples 0 --batch 16 --seed 2 \
  --lr-cosine --keep-every 1000
train-prior-ft: $(BUILD)/mf $(PRIOR_DATA)/manifest.json
	$(MF) train-prior $(PRIOR_DATA) -o $(PRIOR_FT_CKPT) $(PRIOR_FT_ARGS) --loss-csv reports/prior/curve/ft-loss.csv --resume
	cp $(PRIOR_FT_CKPT)/prior-$(PRIOR_FT_STEPS).mfck $(PRIOR_FT_WEIGHTS)
# The prior's held-out curve over training steps (issue 12 item 2): eval-prior at the mean targets'
# setting (PRIOR_OBJ_ARGS) on the validation splits (never a test split) for each point of
# CURVE_POINTS (label=denoiser steps=weights), then per-object means, paired over objects against the
# first point (eval/prior_curve.py, mf compare) -> reports/prior/curve/. val-2d-cyc only with Blender.
CURVE_REPORT ?= reports/prior/curve
CURVE_SPLITS ?= val-2d $(if $(shell command -v blender 2>/dev/null)$(wildcard $(DATA)/val-2d-cyc/manifest.json),val-2d-cyc) val-3d
CURVE_POINTS ?= v1=4000=$(PRIOR_WEIGHTS) $(foreach k,1 2 3 4,ft-$(k)000=$(k)000+4000=$(PRIOR_FT_CKPT)/prior-$(k)000.mfck)
# how every point of the prior's held-out curves is scored (prior-curve, prior-bounce-curve, prior-datasize)
CURVE_SCORING := Every point scored by mf eval-prior $(PRIOR_OBJ_ARGS) (each view's prediction the mean of 4 DDIM samples of 10 steps at guidance 1; SM = StableMaterial, views alone; MV = StableMaterialMV, an object's 4 views jointly) on validation splits only: val-2d (test-2d's recipe with --seed 2, our renderer, direct light), val-2d-cyc (the same objects lit by Blender Cycles, where present) and val-3d (each 3D validation object's first 4 held-out test views, our renderer). **Masked PSNR** (inside the GT mask; albedo aligned per channel, ORM = roughness and metallic). Each view's score is averaged per object first, so the CIs and tests are over objects.
CURVE_CAPTION ?= Generated by \`make prior-curve\`; do not edit. Points: v1 = the first wave's prior (mf/prior/weights/prior.mfck, 4000 denoiser steps on 6000 samples); ft-N = \`make train-prior-ft\` after N more steps (its --init is v1: the same autoencoder and latent scale; all 12060 prior-train samples, batch 16, lr 3e-4 with 100 warm-up steps and a cosine to 0 at 4000; loss per step in ft-loss.csv). $(CURVE_SCORING)
curve-point = --point $(word 1,$(subst =, ,$(1))) $(word 2,$(subst =, ,$(1))) $(CURVE_REPORT)/$(word 1,$(subst =, ,$(1)))
prior-curve: $(BUILD)/mf $(foreach s,$(CURVE_SPLITS),$(DATA)/$(s)/$(if $(filter val-3d,$(s)),.rendered,manifest.json)) $(PRIOR_DATA)/manifest.json
	@for p in $(CURVE_POINTS); do w=$${p##*=}; d=$(CURVE_REPORT)/$${p%%=*}; \
	  [ -f "$$w" ] || { echo "prior-curve: $$w missing (make train-prior-ft makes the ft-* weights)" >&2; exit 1; }; \
	  for s in $(CURVE_SPLITS); do [ -f $$d/$$s/table2d.csv ] && [ $$d/$$s/table2d.csv -nt $$w ] || \
	    $(MF) eval-prior $(DATA)/$$s -o $$d/$$s --weights $$w $(PRIOR_OBJ_ARGS) || exit 1; done; done
	python3 eval/prior_curve.py -o $(CURVE_REPORT) $(addprefix --split ,$(CURVE_SPLITS)) \
	  $(foreach p,$(CURVE_POINTS),$(call curve-point,$(p)))
	for s in $(CURVE_SPLITS); do for m in StableMaterial StableMaterialMV; do \
	  $(MF) compare $(CURVE_REPORT)/objects.csv --dataset $$s --ref $$m@$(word 1,$(subst =, ,$(word 1,$(CURVE_POINTS)))) \
	    -o $(CURVE_REPORT)/$$s/$$m >/dev/null || exit 1; done; done
	python3 eval/prior_curve.py -o $(CURVE_REPORT) --readme-only $(addprefix --split ,$(CURVE_SPLITS)) \
	  $(foreach p,$(CURVE_POINTS),$(call curve-point,$(p))) --caption "$(CURVE_CAPTION)"

# The prior trained on with interreflection (issue 12 item 2): prior-train's objects and views (the same
# seed) rendered with indirect light (`mf gen --bounces 2`, 16 pixel samples against prior-train's 4, for
# the bounces' noise), then train-prior-ft's recipe on them, so that only the training images' light
# transport differs from prior-ft.mfck; prior-bounce-curve scores v1, ft-4000 and this run's weights on the
# validation splits (prior-curve's protocol), paired against v1 and against ft-4000 -> reports/prior/bounce.
PRIOR_BOUNCE_DATA     ?= $(DATA)/prior-train-bounce2
PRIOR_BOUNCE_CKPT     ?= $(DATA)/prior-ft-bounce2
PRIOR_BOUNCE_GEN_ARGS ?= $(PRIOR_GEN_ARGS) --bounces 2 --pixel-samples 16
$(PRIOR_BOUNCE_DATA)/manifest.json: | $(BUILD)/mf
	$(MF) gen --split prior-train -o $(PRIOR_BOUNCE_DATA) $(PRIOR_BOUNCE_GEN_ARGS)
train-prior-bounce: $(BUILD)/mf $(PRIOR_BOUNCE_DATA)/manifest.json
	@mkdir -p reports/prior/bounce
	$(MF) train-prior $(PRIOR_BOUNCE_DATA) -o $(PRIOR_BOUNCE_CKPT) $(PRIOR_FT_ARGS) --loss-csv reports/prior/bounce/ft-loss.csv --resume
	cp $(PRIOR_BOUNCE_CKPT)/prior-4000.mfck mf/prior/weights/prior-bounce.mfck
prior-bounce-curve: train-prior-bounce
	$(MAKE) prior-curve CURVE_REPORT=reports/prior/bounce \
	  CURVE_POINTS="v1=4000=$(PRIOR_WEIGHTS) ft-4000=4000+4000=mf/prior/weights/prior-ft.mfck ftb-4000=4000+4000=mf/prior/weights/prior-bounce.mfck" \
	  CURVE_CAPTION="Generated by make prior-bounce-curve; do not edit. Points: v1 = the first wave's prior (mf/prior/weights/prior.mfck); ft-4000 = make train-prior-ft (mf/prior/weights/prior-ft.mfck: v1 trained on for 4000 steps on the 12060 prior-train samples, direct light only); ftb-4000 = make train-prior-bounce (mf/prior/weights/prior-bounce.mfck: the same recipe, seed and steps on the same objects and views rendered with 2 indirect bounces, mf gen --bounces 2 --pixel-samples 16; loss per step in ft-loss.csv). $(CURVE_SCORING)"
	for s in $(CURVE_SPLITS); do for m in StableMaterial StableMaterialMV; do \
	  $(MF) compare reports/prior/bounce/objects.csv --dataset $$s --ref $$m@ft-4000 -o reports/prior/bounce/$$s/$$m-vs-ft-4000 >/dev/null || exit 1; done; done
# The same three priors' roughness and metallic on the metal cup's training views 0, 8, ..., 56 (views
# 24-40 look into it), from our renderer's and Blender Cycles' images (test-3d-cyc where present), as `mf
# prior` prints them at SDS's sampling (4 samples of 10 DDIM steps, guidance 3) -> reports/prior/bounce/cup-views.md
BOUNCE_VIEW_SPLITS = test-3d $(if $(wildcard $(DATA)/test-3d-cyc/000_cup),test-3d-cyc)
prior-bounce-views: $(BUILD)/mf $(DATA)/test-3d/.rendered
	{ echo "# The priors on the metal cup's views (issue 12)"; echo; \
	  echo "Generated by \`make prior-bounce-views\` (tools/prior_views.sh; \`mf prior --samples 4 --steps 10\`, guidance 3). Mean over each view's mask; splits: $(BOUNCE_VIEW_SPLITS)."; echo; \
	  sh tools/prior_views.sh $(MF) $(DATA) 000_cup "$(BOUNCE_VIEW_SPLITS)" "000 008 016 024 032 040 048 056" \
	    "$(PRIOR_WEIGHTS) mf/prior/weights/prior-ft.mfck mf/prior/weights/prior-bounce.mfck" --samples 4 --steps 10; } > reports/prior/bounce/cup-views.md.tmp
	mv reports/prior/bounce/cup-views.md.tmp reports/prior/bounce/cup-views.md

# The prior's held-out curve over data size (issue 12 item 2): denoisers trained from random weights
# on N samples of prior-train spread evenly (--dn-samples N), DATASIZE_STEPS steps each, with the
# v1's autoencoder and latent scale (--init ... --fresh-denoiser; that autoencoder saw all
# of prior-train) and its recipe otherwise (batch 16, lr 3e-4 after 100 warm-up steps, constant,
# seed 1), the weights kept every 1000 steps (DATASIZE_STEPS: a multiple of 1000; a larger one goes on
# from the last checkpoint); then prior-curve's evaluation of each point, paired against the largest
# N -> DATASIZE_REPORT (the loss curves stay in reports/prior/datasize). One rule per N, so `make -j2`
# trains two at once. (The caption holds no backquotes: the sub-make's shell would run them.)
DATASIZE_N      ?= 12060 6000 3000 1500 750
DATASIZE_STEPS  ?= 2000
DATASIZE_CKPT   ?= $(DATA)/prior-datasize
DATASIZE_REPORT ?= reports/prior/datasize
# A point is n<N>[-w<C1>x<C2>][-s<K>]: N samples, the denoiser's channels C1/C2 (default 64/128),
# seed K (default 1). DATASIZE_RESEED adds the first and the last N again with seed 2 (the run-to-run
# spread the other differences are read against, and the extreme sizes at a second seed); DATASIZE_WIDE a wider denoiser on the first N at both seeds
# (the model-size question).
DATASIZE_RESEED ?= $(word 1,$(DATASIZE_N))-s2 $(lastword $(DATASIZE_N))-s2
DATASIZE_WIDE   ?= $(word 1,$(DATASIZE_N))-w96x192 $(word 1,$(DATASIZE_N))-w96x192-s2
# DATASIZE_EMA=D: the runs keep a moving average of the denoiser's weights (mf train-prior --ema D) from
# the step they start or resume at; prior-<steps>.mfck is then the average, prior-<steps>-raw.mfck the weights.
DATASIZE_EMA    ?=
DATASIZE_PTS     = $(DATASIZE_N) $(DATASIZE_RESEED) $(DATASIZE_WIDE)
ds-n    = $(word 1,$(subst -, ,$(1)))
ds-seed = $(or $(patsubst s%,%,$(filter s%,$(subst -, ,$(1)))),1)
ds-wide = $(subst x, ,$(patsubst w%,%,$(filter w%,$(subst -, ,$(1)))))
$(DATASIZE_PTS:%=$(DATASIZE_CKPT)/n%/prior-$(DATASIZE_STEPS).mfck): $(DATASIZE_CKPT)/n%/prior-$(DATASIZE_STEPS).mfck: \
  $(PRIOR_DATA)/manifest.json | $(BUILD)/mf
	@mkdir -p reports/prior/datasize
	$(MF) train-prior $(PRIOR_DATA) -o $(DATASIZE_CKPT)/n$* --init $(PRIOR_WEIGHTS) --fresh-denoiser --ae-steps 0 \
	  --steps $(DATASIZE_STEPS) --dn-samples $(call ds-n,$*) --batch 16 --seed $(call ds-seed,$*) --keep-every 1000 \
	  $(if $(call ds-wide,$*),--unet-c1 $(word 1,$(call ds-wide,$*)) --unet-c2 $(word 2,$(call ds-wide,$*))) \
	  $(if $(DATASIZE_EMA),--ema $(DATASIZE_EMA)) --loss-csv reports/prior/datasize/loss-n$*.csv --resume
train-prior-datasize: $(DATASIZE_PTS:%=$(DATASIZE_CKPT)/n%/prior-$(DATASIZE_STEPS).mfck)
prior-datasize: train-prior-datasize
	$(MAKE) prior-curve CURVE_REPORT=$(DATASIZE_REPORT) \
	  CURVE_POINTS="$(foreach n,$(DATASIZE_PTS),n$(n)=$(DATASIZE_STEPS)=$(DATASIZE_CKPT)/n$(n)/prior-$(DATASIZE_STEPS).mfck)" \
	  CURVE_CAPTION="Generated by make prior-datasize; do not edit. Points: nN = a denoiser trained from random weights for $(DATASIZE_STEPS) steps on N of the 12060 prior-train samples, spread evenly, seed 1 (mf train-prior --init $(PRIOR_WEIGHTS) --fresh-denoiser --dn-samples N: every point has v1's autoencoder and latent scale, trained on all 12060 samples, so only the denoiser's data changes; batch 16, lr 3e-4 after 100 warm-up steps, constant; loss per step in loss-nN.csv); nN-sK = the same with seed K (its difference to nN: the run-to-run spread); nN-wC1xC2 = a wider denoiser, C1/C2 channels at its two levels instead of 64/128 (mf train-prior --unet-c1 C1 --unet-c2 C2). For scale: v1 is 4000 steps on 6000 samples (reports/prior/curve, v1). $(CURVE_SCORING)"

# The prior term's cost (issue 12 item 7; tools/sds_cost.sh): the baseline and MaterialFusion back
# to back on test-3d/000_cup (made in $(SDS_COST_DATA) when missing), $(SDS_COST_ITERS) iterations,
# 1 thread, 2 repetitions; MaterialFusion's wall and CPU time by stage -> reports/perf/sds-cost.md.
# SDS_COST_VARIANTS="label=path/to/other/mf[:extra flags] ..." adds MaterialFusion runs to compare
# (SDS_COST_NOTE: a sentence for the report saying what they are).
SDS_COST_DATA  ?= $(DATA)/sds-cost
SDS_COST_ITERS ?= 100
bench-sds-cost: $(BUILD)/mf
	ITERS=$(SDS_COST_ITERS) REPEATS=2 THREADS=1 NOTE="$(SDS_COST_NOTE)" sh tools/sds_cost.sh $(MF) $(SDS_COST_DATA) $(RESULTS)/sds-cost \
	  reports/perf/sds-cost.md $(SDS_COST_VARIANTS)

# ---- the 2D prior's generalisation matrix, renderer axis (issue 12, Deliver item 1) ----
# test-2d (our renderer, the standard objects), test-2d-diffuse (ours, the same objects made diffuse:
# metallic 0, roughness >= 0.6) and test-2d-pov (POV-Ray's lit views of those diffuse objects: same
# seed, so the same cameras and lights, view for view; GT albedo/ORM are our AOVs in both), each
# scored by mf eval-prior with the default prior (the committed tables: v1, made before the
# switch); then one table (mf domain-table, eval/ev_domain.h).
# DOMAIN_TRAIN: the first 240 samples of prior-train (seed 1), read only for eval-prior's
# training-set-mean ORM baseline (not in the matrix). DOMAIN_EVAL_ARGS: samples per view and no
# multi-view pass (the committed reports/prior table: 10 samples and MV), so it fits a shared 2-core
# machine. Rerunning redoes only what is missing or out of date.
DOMAIN_REPORT    ?= reports/generalisation
DOMAIN_SPLITS    := test-2d test-2d-diffuse test-2d-pov test-2d-pov1000
DOMAIN_TRAIN     ?= $(DATA)/prior-train-mean
DOMAIN_EVAL_ARGS ?= --samples 10 --no-mv
DOMAIN_WEIGHTS   ?= mf/prior/weights/prior-ft.mfck
$(DOMAIN_TRAIN)/manifest.json: | $(BUILD)/mf
	$(MF) gen --split prior-train --count 240 --seed 1 -o $(DOMAIN_TRAIN)
# $(call eval-prior-2d,REPORT,FILE[,FLAGS]): the rule REPORT/<split>/FILE <- mf eval-prior on
# DATA/<split> with the settings above (and FLAGS), into REPORT/<split>/ (table2d.csv, table2d.json,
# ...); for the domain cells here, calibrate-trust's splits and the guidance sweep below.
define eval-prior-2d
$(1)/%/$(2): $$(DATA)/%/manifest.json $$(DOMAIN_TRAIN)/manifest.json | $$(BUILD)/mf
	$$(MF) eval-prior $$(DATA)/$$* --train $$(DOMAIN_TRAIN) $$(DOMAIN_EVAL_ARGS) $(3) -o $(1)/$$*
endef
$(eval $(call eval-prior-2d,$(DOMAIN_REPORT),table2d.csv,--weights $(DOMAIN_WEIGHTS)))
# the input images' own gap: masked PSNR of POV-Ray's lit view against ours, per view
$(DOMAIN_REPORT)/input_gap_%.csv: $(DATA)/test-2d-diffuse/manifest.json $(DATA)/%/manifest.json | $(BUILD)/mf
	@echo "method,dataset,scene,metric,value" > $@.tmp
	@for f in $(DATA)/$*/rgb/*.png; do n=$$(basename $$f .png); \
	  v=$$($(MF) metrics $$f $(DATA)/test-2d-diffuse/rgb/$$n.png --mask alpha --align none | awk '$$1 == "psnr_masked" {print $$2}'); \
	  [ -n "$$v" ] || exit 1; echo "POV-Ray vs ours,test-2d,$$n,rgb_psnr,$$v" >> $@.tmp; done
	@mv $@.tmp $@
DOMAIN_CYCLES = Cycles: not in this table; \`make bench-matrix\` (reports/generalisation/matrix/) has the Cycles cells (in-cyc, held-cyc: \`mf gen --split test-2d --renderer cycles\`) beside the content axis, where blender exists$(if $(shell command -v blender 2>/dev/null),, (not on this machine))
bench-domain: $(BUILD)/mf $(foreach s,$(DOMAIN_SPLITS),$(DOMAIN_REPORT)/$(s)/table2d.csv) $(DOMAIN_REPORT)/input_gap_test-2d-pov.csv $(DOMAIN_REPORT)/input_gap_test-2d-pov1000.csv
	$(MF) domain-table -o $(DOMAIN_REPORT)/README.md --csv $(DOMAIN_REPORT)/matrix.csv \
	  --cell ours-standard=$(DOMAIN_REPORT)/test-2d/table2d.csv --cell ours-diffuse=$(DOMAIN_REPORT)/test-2d-diffuse/table2d.csv \
	  --cell POV-Ray-diffuse=$(DOMAIN_REPORT)/test-2d-pov/table2d.csv --cell POV-Ray-diffuse-r1000=$(DOMAIN_REPORT)/test-2d-pov1000/table2d.csv \
	  --pair POV-Ray-diffuse,ours-diffuse --pair POV-Ray-diffuse-r1000,ours-diffuse --pair ours-diffuse,ours-standard \
	  --caption "# Generalisation matrix of the 2D prior: renderer axis (issue 12, Deliver item 1)" \
	  --caption "" \
	  --caption "Generated by \`make bench-domain\`; do not edit. **Every PSNR in these tables is MASKED**: computed inside the GT mask only (mf eval-prior: albedo aligned per channel by the ratio of means inside the mask in linear space, then sRGB; ORM = roughness and metallic). Mean over the 32 views (8 held-out objects x 4 views, 64 px) ± the 95% CI half-width (Student t)." \
	  --caption "" \
	  --caption "Cells: **ours-standard** = test-2d (our renderer, the standard held-out objects); **ours-diffuse** = test-2d --diffuse 1 (the same objects, cameras and lights; metallic 0, roughness >= 0.6); **POV-Ray-diffuse** = test-2d --diffuse 1 --renderer povray (the lit view rendered by POV-Ray 3.7 from the same diffuse objects, cameras and lights: env maps through radiosity, count 200 (POV-Ray-diffuse-r1000: count 1000, otherwise the same), hidden from the camera; sun and point lights as POV-Ray lights; GT albedo/ORM are our renderer's AOVs, byte-identical to ours-diffuse's). Prior: $(DOMAIN_WEIGHTS) (the default prior; until 2026-11-28 this table was of the first prior, prior.mfck, scored before a fix in mf eval-prior)." \
	  --note "Input gap (the images the prior sees): masked PSNR of POV-Ray's lit view against ours on the same view, $$(awk -F, 'NR == 2 {lo = hi = $$5} NR > 1 {s += $$5; n++; if ($$5 < lo) lo = $$5; if ($$5 > hi) hi = $$5} END {printf "mean %.2f dB over %d views, from %.2f to %.2f dB", s / n, n, lo, hi}' $(DOMAIN_REPORT)/input_gap_test-2d-pov.csv) with radiosity count 200, $$(awk -F, 'NR == 2 {lo = hi = $$5} NR > 1 {s += $$5; n++; if ($$5 < lo) lo = $$5; if ($$5 > hi) hi = $$5} END {printf "mean %.2f dB, from %.2f to %.2f dB", s / n, lo, hi}' $(DOMAIN_REPORT)/input_gap_test-2d-pov1000.csv) with 1000 (per view: input_gap_<split>.csv; mf metrics --mask alpha --align none). POV-Ray is Lambertian (ours adds the F0 = 0.04 GGX lobe) and gathers env light by radiosity, which misses small bright regions of some probes (ds_povray.h; reports/datasets), so the POV-Ray cell mixes a renderer change with POV-Ray's own approximation error." \
	  --note "" \
	  --note "Content axis (held-out shape families and material recipes): not in this table; \`make bench-matrix\` (reports/generalisation/matrix/, docs/analyses/generalisation-matrix.md) scores in- and held-out content per renderer, for the widened prior (trained without the held-out content) and for this one (whose training data had it). MF - baseline in 3D per cell is not part of this table (make bench: test-3d, test-3d-diffuse, test-3d-pov64; the Cycles split: make bench-cycles-3d)." \
	  --note "" \
	  --note "$(DOMAIN_CYCLES)." \
	  --note "" \
	  --note "Settings: mf eval-prior $(DOMAIN_EVAL_ARGS) (each view's prediction the mean of that many DDIM samples, 50 steps, guidance 3; StableMaterial single-view only, no multi-view pass) to fit the shared 2-core machine; the committed reports/prior table (10 samples, with the multi-view pass) has StableMaterial albedo 20.63 dB on the same test-2d. Training-free baselines: Input image and Retinex (albedo); the best of the two per cell is shown." \
	  --note "" \
	  --note "Commands (from the repository root): \`make bench-domain\`, i.e. \`mf gen --split test-2d -o data/test-2d\`; \`mf gen --split test-2d --diffuse 1 -o data/test-2d-diffuse\`; \`mf gen --split test-2d --diffuse 1 --renderer povray -o data/test-2d-pov\`; \`mf gen --split prior-train --count 240 --seed 1 -o data/prior-train-mean\`; for each split S: \`mf eval-prior data/S --train data/prior-train-mean $(DOMAIN_EVAL_ARGS) --weights $(DOMAIN_WEIGHTS) -o $(DOMAIN_REPORT)/S\`; then \`mf domain-table\` (this file and matrix.csv). When the --diffuse/--renderer options were added, test-2d regenerated with the defaults by the builds before and after had equal manifest checksums (all 96 files); the test ds_gen_test2d_diffuse checks that the diffuse variant keeps every albedo file's bytes (no new random draw)."

# The prior's channel trust for SDS (issue 12 item 3; --sds-trust-rough/--sds-trust-metal):
# mf eval-prior on validation splits — test-2d objects drawn with another seed (--seed 2), never the
# test split — by our renderer and, where blender exists, by Cycles; each table2d.json holds
# trust = 1 - MSE(StableMaterial) / MSE(training-mean constant) per channel; the flags to use are
# the smaller value per channel over the splits -> reports/prior/trust.md.
TRUST_REPORT ?= reports/prior/trust
TRUST_SPLITS := val-2d $(if $(shell command -v blender 2>/dev/null),val-2d-cyc)
$(eval $(call eval-prior-2d,$(TRUST_REPORT),table2d.json))
calibrate-trust: $(foreach s,$(TRUST_SPLITS),$(TRUST_REPORT)/$(s)/table2d.json)
	@{ echo "# The prior's channel trust (generated by \`make calibrate-trust\`; do not edit)"; echo; \
	  echo "trust = 1 - MSE(StableMaterial) / MSE(training-set mean), per channel inside the GT mask, over the validation views (mf eval-prior $(DOMAIN_EVAL_ARGS); the default prior). Validation splits: test-2d objects with --seed 2 (not the test split). $(if $(filter val-2d-cyc,$(TRUST_SPLITS)),,Cycles split skipped: no blender.)"; echo; \
	  echo "| split | views | roughness trust | metallic trust | StableMaterial ORM PSNR (masked) |"; echo "|---|---:|---:|---:|---:|"; \
	  for s in $(TRUST_SPLITS); do j=$(TRUST_REPORT)/$$s/table2d.json; \
	    echo "| $$s | $$(jq '.objects * .views' $$j) | $$(jq -r '.trust_roughness' $$j) | $$(jq -r '.trust_metallic' $$j) | $$(awk -F, '$$1 == "StableMaterial" && $$4 == "orm_psnr" {s += $$5; n++} END {printf "%.2f", s / n}' $(TRUST_REPORT)/$$s/table2d.csv) |"; done; \
	  echo; printf 'Flags (the smaller value per channel): `--sds-trust-rough %s --sds-trust-metal %s`\n' \
	    $$(jq -s 'map(.trust_roughness) | min * 100 | floor / 100' $(foreach s,$(TRUST_SPLITS),$(TRUST_REPORT)/$(s)/table2d.json)) \
	    $$(jq -s 'map(.trust_metallic) | min * 100 | floor / 100' $(foreach s,$(TRUST_SPLITS),$(TRUST_REPORT)/$(s)/table2d.json)); \
	} > $(TRUST_REPORT).md.tmp && mv $(TRUST_REPORT).md.tmp $(TRUST_REPORT).md && cat $(TRUST_REPORT).md
# The prior's classifier-free guidance, chosen on the validation splits (issue 12): mf eval-prior
# at each guidance of GUIDANCE_SWEEP on TRUST_SPLITS (guidance 3, the paper's and eval-prior's
# default, is calibrate-trust's cells), then one table with the guidance pairs on the same views
# (mf domain-table) and each cell's channel trust -> reports/prior/guidance.md.
GUIDANCE_REPORT ?= reports/prior/guidance
GUIDANCE_SWEEP  := 1 2
$(foreach g,$(GUIDANCE_SWEEP),$(eval $(call eval-prior-2d,$(GUIDANCE_REPORT)/g$(g),table2d.json,--guidance $(g))))
guidance-cell = $(if $(filter 3,$(1)),$(TRUST_REPORT)/$(2),$(GUIDANCE_REPORT)/g$(1)/$(2))
sweep-guidance: $(foreach g,$(GUIDANCE_SWEEP),$(foreach s,$(TRUST_SPLITS),$(GUIDANCE_REPORT)/g$(g)/$(s)/table2d.json)) \
                $(foreach s,$(TRUST_SPLITS),$(TRUST_REPORT)/$(s)/table2d.json)
	$(MF) domain-table -o $(GUIDANCE_REPORT).md.tmp --csv $(GUIDANCE_REPORT).csv \
	  $(foreach s,$(TRUST_SPLITS),$(foreach g,$(GUIDANCE_SWEEP) 3,--cell $(s)-g$(g)=$(call guidance-cell,$(g),$(s))/table2d.csv)) \
	  $(foreach s,$(TRUST_SPLITS),$(foreach g,$(GUIDANCE_SWEEP),--pair $(s)-g$(g),$(s)-g3)) \
	  --caption "# The prior's guidance, chosen on the validation splits (generated by \`make sweep-guidance\`; do not edit)" \
	  --caption "" \
	  --caption "StableMaterial (the default prior) at classifier-free guidance G = $(GUIDANCE_SWEEP) and 3 (the paper's; 1 is the conditional prediction alone), mf eval-prior $(DOMAIN_EVAL_ARGS) --guidance G on the validation splits (test-2d objects with --seed 2, never the test split: val-2d by our renderer$(if $(filter val-2d-cyc,$(TRUST_SPLITS)),$(comma) val-2d-cyc by Blender Cycles,; Cycles skipped: no blender)). **Masked PSNR** (inside the GT mask). Cell names: <split>-g<guidance>." \
	  --note "Channel trust (1 - MSE / MSE of the training-set mean, per channel; calibrate-trust's measure) per cell, roughness / metallic: $(foreach s,$(TRUST_SPLITS),$(foreach g,$(GUIDANCE_SWEEP) 3,$(s)-g$(g) $$(jq -r '"\(.trust_roughness) / \(.trust_metallic)"' $(call guidance-cell,$(g),$(s))/table2d.json);))"
	mv $(GUIDANCE_REPORT).md.tmp $(GUIDANCE_REPORT).md && cat $(GUIDANCE_REPORT).md
# ---- the widened prior and the renderer x content matrix (issue 12, Deliver items 1 and 2) ----
# prior-wide: the widened recipe (datasets/ds_widen.h: POV-Ray lit views for ~10% of the objects,
# field of view and distance, UV overlays, exposure +-2 stops, tone curves, resolution drop, noise;
# probes and procedural skies/rooms) without the held-out content (families superquadric and
# displaced, recipes rubber and checker). train-prior-wide trains it from scratch with the committed
# prior's schedule, the denoiser in 1000-step segments (the learning rate is constant after warm-up,
# so a resumed segment is bit-identical), keeping each segment's weights for the steps curve.
PRIOR_WIDE_DATA     ?= $(DATA)/prior-wide
PRIOR_WIDE_CKPT     ?= $(DATA)/prior-wide-ckpt
PRIOR_WIDE_GEN_ARGS ?= --count 8064 --seed 1 --widen 1 --content train --train-lights both
PRIOR_WIDE_SEGMENTS ?= 1000 2000 3000 4000
PRIOR_WIDE_REPORT   ?= reports/prior-wide
$(PRIOR_WIDE_DATA)/manifest.json: | $(BUILD)/mf
	$(MF) gen --split prior-train -o $(PRIOR_WIDE_DATA) $(PRIOR_WIDE_GEN_ARGS)
train-prior-wide: $(BUILD)/mf $(PRIOR_WIDE_DATA)/manifest.json
	@mkdir -p $(PRIOR_WIDE_REPORT)
	@for n in $(PRIOR_WIDE_SEGMENTS); do \
	  $(MF) train-prior $(PRIOR_WIDE_DATA) -o $(PRIOR_WIDE_CKPT) --ae-steps 500 --steps $$n --batch 16 --seed 1 --dn-samples 6000 \
	    --ckpt-every 200 --loss-csv $(PRIOR_WIDE_REPORT)/loss.csv --resume || exit 1; \
	  cp $(PRIOR_WIDE_CKPT)/prior.mfck $(PRIOR_WIDE_CKPT)/prior-$$n.mfck; done

# The matrix: test-2d objects filtered by content (in = none of the held-out families/recipes,
# held = only objects with one), lit views by our renderer, POV-Ray (diffuse objects), Blender Cycles
# (when blender exists) and ours through the widened imaging (exposure, tone, noise, resolution);
# each scored with each prior of MATRIX_PRIORS (LABEL=WEIGHTS).
MATRIX_REPORT  ?= reports/generalisation/matrix
MATRIX_PRIORS  ?= v1=mf/prior/weights/prior.mfck wide=mf/prior/weights/prior-wide.mfck ft=mf/prior/weights/prior-ft.mfck
MATRIX_HAVE_BLENDER := $(if $(shell command -v blender 2>/dev/null),1,)
MATRIX_SPLITS  := test-2d-in test-2d-held test-2d-in-diffuse test-2d-in-pov test-2d-held-diffuse test-2d-held-pov test-2d-in-wide test-2d-held-wide \
                  $(if $(MATRIX_HAVE_BLENDER),test-2d-in-cyc test-2d-held-cyc)
matrix-label = $(word 1,$(subst =, ,$(1)))
# compare.md: each later prior minus the first (the reference) on the cells without a -diffuse twin
MATRIX_REF     = $(call matrix-label,$(word 1,$(MATRIX_PRIORS)))
MATRIX_PAIRED  = $(filter-out %-diffuse,$(MATRIX_SPLITS))
matrix-weights = $(word 2,$(subst =, ,$(1)))
matrix-cells = $(foreach s,$(2),--cell $(call matrix-label,$(1)):$(s:test-2d-%=%)=$(MATRIX_REPORT)/$(call matrix-label,$(1))/$(s)/table2d.csv)
bench-matrix: $(BUILD)/mf $(foreach s,$(MATRIX_SPLITS),$(DATA)/$(s)/manifest.json) $(DOMAIN_TRAIN)/manifest.json
	@for p in $(MATRIX_PRIORS); do l=$${p%%=*}; w=$${p#*=}; for s in $(MATRIX_SPLITS); do \
	  [ -f $(MATRIX_REPORT)/$$l/$$s/table2d.csv ] || MF_PRIOR_WEIGHTS=$$w $(MF) eval-prior $(DATA)/$$s --train $(DOMAIN_TRAIN) $(DOMAIN_EVAL_ARGS) \
	    -o $(MATRIX_REPORT)/$$l/$$s || exit 1; done; done
	$(foreach p,$(MATRIX_PRIORS),$(MF) domain-table -o $(MATRIX_REPORT)/$(call matrix-label,$(p)).md --csv $(MATRIX_REPORT)/$(call matrix-label,$(p)).csv \
	  $(call matrix-cells,$(p),$(MATRIX_SPLITS)) \
	  --pair $(call matrix-label,$(p)):in-pov,$(call matrix-label,$(p)):in-diffuse --pair $(call matrix-label,$(p)):held-pov,$(call matrix-label,$(p)):held-diffuse \
	  $(if $(MATRIX_HAVE_BLENDER),--pair $(call matrix-label,$(p)):in-cyc$(comma)$(call matrix-label,$(p)):in --pair $(call matrix-label,$(p)):held-cyc$(comma)$(call matrix-label,$(p)):held) \
	  --caption "# The 2D prior '$(call matrix-label,$(p))' ($(call matrix-weights,$(p))) across renderers and content (issue 12)" --caption "" \
	  --caption "Generated by \`make bench-matrix\`; do not edit. Every PSNR is MASKED (inside the GT mask). Mean over 32 views (8 objects x 4 views, 64 px) ± 95% CI half-width. Cells: in = test-2d objects with none of the held-out content, held = only objects with held-out content (families superquadric, displaced; recipes rubber, checker: datasets/ds_widen.h); pov = lit view by POV-Ray (diffuse objects, paired with the same diffuse objects rendered by ours), wide = ours through the widened imaging (exposure, tone curve, noise, resolution; the widened recipe also changes object draws, so wide cells are not paired with plain ones), cyc = Blender Cycles (full path tracing, Principled BSDF; datasets/ds_cycles.py). Settings: mf eval-prior $(DOMAIN_EVAL_ARGS)." &&) true
	$(MF) domain-table -o $(MATRIX_REPORT)/compare.md --csv $(MATRIX_REPORT)/compare.csv \
	  $(foreach p,$(MATRIX_PRIORS),$(call matrix-cells,$(p),$(MATRIX_PAIRED))) \
	  $(foreach p,$(wordlist 2,$(words $(MATRIX_PRIORS)),$(MATRIX_PRIORS)),$(foreach s,$(MATRIX_PAIRED),--pair $(call matrix-label,$(p)):$(s:test-2d-%=%),$(MATRIX_REF):$(s:test-2d-%=%))) \
	  --caption "# Each prior against the first ($(MATRIX_REF)), per cell (issue 12)" --caption "" \
	  --caption "Generated by \`make bench-matrix\`; do not edit. Same cells and settings as $(MATRIX_REF).md; the pairs compare two priors on the same views (masked PSNR)."

clean:
	rm -rf build build-asan build-*

-include $(LIB_OBJ:.o=.d) $(CLI_OBJ:.o=.d) $(TEST_OBJ:.o=.d)
