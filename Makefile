# One flat Makefile: explicit object lists, everything built under build/.
# `make run` and `make test` first install what is missing (tools/install-deps.sh).

CC       := gcc
BUILD    := build
# `make test SAN=1`: everything built again under build/san with ASan + UBSan
# and the suites run there (README "Tests").
SAN      ?=
SANFLAGS :=
ifeq ($(SAN),1)
BUILD    := build/san
SANFLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
endif
SAN_ENV  := $(if $(filter 1,$(SAN)),ASAN_OPTIONS=detect_leaks=1:abort_on_error=0 UBSAN_OPTIONS=print_stacktrace=1,)
VENV     := .venv
PY       := $(VENV)/bin/python
# One flavour for every target: Open MPI and the parallel HDF5 built on it
# (Debian's libhdf5-openmpi-dev, pkg-config hdf5-openmpi, headers in
# /usr/include/hdf5/openmpi). The serial HDF5 (hdf5-serial) is never
# included or linked, so the two cannot collide. A process not started by
# mpirun never initialises MPI and runs as before (fluid/decomp.c).
HDF5     := hdf5-openmpi
MPI      := ompi-c
PKGS     := $(HDF5) $(MPI) libcyaml yaml-0.1 cunit
WERROR   ?= $(if $(CI),-Werror,)
CFLAGS   := -std=c11 -D_POSIX_C_SOURCE=200809L -O3 -march=native -g -fopenmp -fPIC \
            -Wall -Wextra -Wpedantic $(WERROR) $(SANFLAGS) $(shell pkg-config --cflags $(PKGS) 2>/dev/null)
# SUNDIALS 6 on bookworm ships no pkg-config file; libsundials_cvode holds the
# dense/SPGMR linear solvers and the fixed-point solver too.
LDLIBS   := $(shell pkg-config --libs $(PKGS) 2>/dev/null) -lsundials_cvode -lsundials_nvecserial -lm
SCENE    ?= models/sinking_sphere.yaml

COMMON_SRC  := common/status.c common/initial_profile.c common/scene.c common/scene_schema.c common/scene_report.c common/scene_override.c \
               common/scene_build.c common/scene_check.c common/coupling.c common/big_alloc.c common/file_held.c
FLUID_SRC   := fluid/decomp.c fluid/sphere_halo.c fluid/kernel.c fluid/kernel_single.c fluid/walls.c fluid/walls_build.c fluid/units.c fluid/boundary.c fluid/refill.c \
               fluid/spheres.c fluid/sphere_links.c fluid/sphere_others.c fluid/sphere_fill.c fluid/state.c fluid/fluid.c fluid/step.c fluid/kernel_skip.c fluid/diagnostics.c fluid/scan.c \
               fluid/moments.c fluid/kernel_moments.c
RIGID_SRC   := rigid/rigid.c rigid/rigid_config.c rigid/implicit.c rigid/body.c rigid/forces.c rigid/contact.c \
               rigid/integrator_verlet.c rigid/integrator_cvode.c rigid/connection.c rigid/topology.c rigid/state.c \
               rigid/rigid_scene.c rigid/pairs.c rigid/lubrication.c rigid/contact_watch.c
# the FMUs' models (their variable lists: the coupler exports them; the tests check them)
MODEL_SRC   := common/fmi_vars.c common/h5fields.c common/h5_cause.c fluid/fluid_fmi.c rigid/rigid_fmi.c
COUPLER_SRC := coupler/main.c coupler/mpi_env.c coupler/check_ranks.c coupler/bench.c coupler/run.c coupler/signals.c coupler/run_checkpoint.c coupler/fmu.c coupler/output.c coupler/export.c coupler/checkpoint.c coupler/summary.c coupler/resources.c \
               $(MODEL_SRC)
TEST_SRC    := tests/run_tests.c tests/fluid/test_util.c tests/fluid/test_lattice.c tests/fluid/test_boundary.c tests/fluid/test_kernel.c tests/fluid/test_layouts.c tests/fluid/test_moments.c tests/fluid/test_schedules.c \
               tests/fluid/test_flows.c tests/fluid/sphere_harness.c tests/fluid/drag_report.c tests/fluid/test_spheres.c tests/fluid/test_sphere_motion.c \
               tests/fluid/approach_harness.c tests/fluid/test_wall_approach.c tests/common/scene_harness.c tests/common/test_scene.c \
               tests/common/test_scene_refused.c tests/common/test_scene_bad.c tests/common/test_exact_sum.c tests/common/test_h5fields.c tests/common/test_big_alloc.c tests/common/test_fmi_vars.c \
               tests/rigid/test_rigid_main.c tests/rigid/test_body.c tests/rigid/test_dynamics.c \
               tests/rigid/test_connection.c tests/rigid/test_contact.c tests/rigid/test_topology.c \
               tests/rigid/test_input.c tests/rigid/test_lubrication.c tests/rigid/test_walls.c

# The field writer on its own with MPI, for tests/python/test_h5fields_mpi.py
# (parallel HDF5: each process its block, the file the same as one writes).
H5MPI_SRC   := tests/mpi/h5fields_mpi.c common/h5fields.c common/h5_cause.c common/status.c common/file_held.c

obj = $(patsubst %.c,$(BUILD)/obj/%.o,$(1))
LIB_OBJ     := $(call obj,$(COMMON_SRC) $(FLUID_SRC) $(RIGID_SRC))

.PHONY: all run test validate bench bench-mpi report approach-report drag-report fmus clean deps fuzz
all: $(BUILD)/coupler $(BUILD)/run_tests $(BUILD)/fmu/fluid.so $(BUILD)/fmu/rigid.so $(BUILD)/h5fields_mpi

deps:
	@tools/install-deps.sh

$(BUILD)/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/coupler: $(LIB_OBJ) $(call obj,$(COUPLER_SRC))
	$(CC) $(CFLAGS) $^ -o $@ $(LDLIBS)

$(BUILD)/run_tests: $(LIB_OBJ) $(call obj,$(MODEL_SRC) $(TEST_SRC))
	$(CC) $(CFLAGS) $^ -o $@ $(LDLIBS)

$(BUILD)/h5fields_mpi: $(call obj,$(H5MPI_SRC))
	$(CC) $(CFLAGS) $^ -o $@ $(shell pkg-config --libs $(HDF5) $(MPI) 2>/dev/null)

run: deps
	@$(MAKE) --no-print-directory all
	@mkdir -p $(BUILD)/out
	$(BUILD)/coupler run $(SCENE) -o $(BUILD)/out/$(basename $(notdir $(SCENE))).h5
	$(PY) coupler/plot.py $(BUILD)/out/$(basename $(notdir $(SCENE))).h5
	$(PY) models/checks/check.py $(BUILD)/out/$(basename $(notdir $(SCENE))).h5

# SAN=1 runs the CUnit suites only: pytest drives build/coupler and loads the
# FMUs into Python, which would need libasan preloaded (README "Tests").
test: deps
	@$(MAKE) --no-print-directory all
	$(SAN_ENV) OMP_NUM_THREADS=2 $(BUILD)/run_tests
	$(if $(filter 1,$(SAN)),@echo "SAN=1: pytest not run (see README Tests)",$(PY) -m pytest -q -m "not validate" tests/python)

validate: deps
	@$(MAKE) --no-print-directory all
	OMP_NUM_THREADS=2 $(BUILD)/run_tests --validate
	$(PY) -m pytest -q -m validate tests/python

# The kernel against the memory bandwidth, and a coupled run against the fluid
# alone (coupler bench). The strong scaling over MPI ranks and OpenMP threads,
# with the halo model for a cluster: `make bench-mpi` (tools/mpi_scaling.py,
# about a minute on 2 cores; CSV in $(BUILD)/bench).
bench: deps
	@$(MAKE) --no-print-directory all
	@uptime
	$(BUILD)/coupler bench --size 128 --size 256
	$(BUILD)/coupler bench --coupled models/dual_star_shear.yaml --steps 200

bench-mpi: deps
	@$(MAKE) --no-print-directory all
	$(PY) tools/mpi_scaling.py --coupler $(BUILD)/coupler --out $(BUILD)/bench

$(BUILD)/rigid_report: $(LIB_OBJ) $(call obj,tests/rigid/rigid_report.c)
	$(CC) $(CFLAGS) $^ -o $@ $(LDLIBS)

$(BUILD)/sphere_report: $(LIB_OBJ) $(call obj,tests/fluid/sphere_report.c tests/fluid/sphere_harness.c \
                         tests/fluid/drag_report.c tests/fluid/approach_harness.c tests/fluid/test_util.c)
	$(CC) $(CFLAGS) $^ -o $@ $(LDLIBS)

# build/report/report.md with its figures and CSV (tools/report.py, README
# "Report"): under an hour on 2 cores; QUICK=1 the same from shorter sweeps in
# under 10 minutes. The close-approach curves: `make approach-report`.
report: deps
	@$(MAKE) --no-print-directory all $(BUILD)/rigid_report $(BUILD)/sphere_report
	$(PY) tools/report.py $(BUILD)/report $(if $(QUICK),--quick,)

approach-report: deps
	@$(MAKE) --no-print-directory $(BUILD)/sphere_report
	mkdir -p $(BUILD)/report
	$(BUILD)/sphere_report approach $(BUILD)/report
	$(PY) tools/plot_approach.py $(BUILD)/report

# Drag of a fixed sphere at many positions in its cell (issue 11), every
# scheme at radius 3 4 5 6 8 and tau 0.6 1 1.5: many hours on 2 cores;
# QUICK=1: cli and multireflection at radius 4, tau 1 (~5 min). DRAG_ARGS
# overrides the plan (e.g. DRAG_ARGS="schemes=cli radii=8 taus=1 positions=8").
DRAG_ARGS ?= $(if $(QUICK),schemes=cli,multireflection radii=4 taus=1,)
drag-report: deps
	@$(MAKE) --no-print-directory $(BUILD)/sphere_report
	mkdir -p $(BUILD)/report
	$(BUILD)/sphere_report drag $(BUILD)/report $(DRAG_ARGS)

# FMUs: the same sources built again with hidden visibility, so that a
# shared library exports the fmi2* entry points only; of the generic FMI
# layer (common/fmi_internal.h) common/fmi_adapter.c is compiled once per
# model (-DFMI_MODEL), the rest once. The fluid links Open MPI and the
# parallel HDF5 for its field snapshots (common/h5fields.c); it uses MPI only
# when its master has initialised it (fluid/decomp.c).
FMI_SRC       := common/fmi_instance.c common/fmi_values.c common/fmi_state.c
FMU_FLUID_SRC := $(COMMON_SRC) common/fmi_vars.c $(FMI_SRC) common/h5fields.c common/h5_cause.c \
                 $(filter-out fluid/kernel.c fluid/kernel_single.c fluid/scan.c fluid/kernel_moments.c,$(FLUID_SRC)) \
                 fluid/kernel_dispatch.c fluid/fluid_fmi.c
FMU_RIGID_SRC := $(COMMON_SRC) common/fmi_vars.c $(FMI_SRC) $(RIGID_SRC) rigid/rigid_fmi.c
# FMUs travel to other machines: the x86-64 baseline (SSE2) instead of
# -march=native (the kernel is memory-bound; see README "FMUs").
FMU_ARCH      := $(if $(filter x86_64,$(shell uname -m)),-march=x86-64 -mtune=generic,)
FMU_CFLAGS    := $(filter-out -march=native,$(CFLAGS)) $(FMU_ARCH) -fvisibility=hidden
FMU_LDFLAGS   := -shared -Wl,-z,defs -Wl,-z,nodelete
FMU_FLUID_LIBS := $(shell pkg-config --libs $(HDF5) $(MPI) libcyaml yaml-0.1 2>/dev/null) -lm
FMU_RIGID_LIBS := $(shell pkg-config --libs libcyaml yaml-0.1 2>/dev/null) -lsundials_cvode -lsundials_nvecserial -lm
fmu_obj = $(patsubst %.c,$(BUILD)/fmu/obj/%.o,$(1))

$(call obj,coupler/export.c coupler/fmu.c): CFLAGS += $(shell pkg-config --cflags libxml-2.0 libzip 2>/dev/null)
# the link scan's and the fill's ray tests are a vector loop with square
# roots (fluid/spheres_internal.h spheres_rays); nothing there reads errno
$(call obj,fluid/sphere_links.c fluid/sphere_fill.c): CFLAGS += -fno-math-errno
$(call fmu_obj,fluid/sphere_links.c fluid/sphere_fill.c): FMU_CFLAGS += -fno-math-errno
$(BUILD)/coupler: LDLIBS += $(shell pkg-config --libs libxml-2.0 libzip 2>/dev/null)

$(BUILD)/fmu/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(CC) $(FMU_CFLAGS) -MMD -MP -c $< -o $@

$(BUILD)/fmu/obj/fmi_adapter_fluid.o $(BUILD)/fmu/obj/fmi_adapter_rigid.o: $(BUILD)/fmu/obj/fmi_adapter_%.o: common/fmi_adapter.c
	@mkdir -p $(dir $@)
	$(CC) $(FMU_CFLAGS) -DFMI_MODEL=$*_fmi_model -MMD -MP -c $< -o $@

# the fluid kernels (double and single storage) and the grid scan (fluid/
# scan.c) twice, for the x86-64 baseline and for x86-64-v3 (AVX2, FMA);
# fluid/kernel_dispatch.c picks one by the CPU at run time
$(BUILD)/fmu/obj/kernel_base.o $(BUILD)/fmu/obj/kernel_single_base.o $(BUILD)/fmu/obj/scan_base.o \
$(BUILD)/fmu/obj/kernel_moments_base.o: $(BUILD)/fmu/obj/%_base.o: fluid/%.c
	@mkdir -p $(dir $@)
	$(CC) $(FMU_CFLAGS) -DKERNEL_VARIANT=base -DKERNEL_PRIMARY -MMD -MP -c $< -o $@
$(BUILD)/fmu/obj/kernel_v3.o $(BUILD)/fmu/obj/kernel_single_v3.o $(BUILD)/fmu/obj/scan_v3.o \
$(BUILD)/fmu/obj/kernel_moments_v3.o: $(BUILD)/fmu/obj/%_v3.o: fluid/%.c
	@mkdir -p $(dir $@)
	$(CC) $(FMU_CFLAGS) $(if $(FMU_ARCH),-march=x86-64-v3,) -DKERNEL_VARIANT=v3 -MMD -MP -c $< -o $@

$(BUILD)/fmu/fluid.so: $(call fmu_obj,$(FMU_FLUID_SRC)) $(BUILD)/fmu/obj/fmi_adapter_fluid.o \
                       $(BUILD)/fmu/obj/kernel_base.o $(BUILD)/fmu/obj/kernel_v3.o \
                       $(BUILD)/fmu/obj/kernel_single_base.o $(BUILD)/fmu/obj/kernel_single_v3.o \
                       $(BUILD)/fmu/obj/scan_base.o $(BUILD)/fmu/obj/scan_v3.o \
                       $(BUILD)/fmu/obj/kernel_moments_base.o $(BUILD)/fmu/obj/kernel_moments_v3.o
	$(CC) $(FMU_CFLAGS) $(FMU_LDFLAGS) $^ -o $@ $(FMU_FLUID_LIBS)

$(BUILD)/fmu/rigid.so: $(call fmu_obj,$(FMU_RIGID_SRC)) $(BUILD)/fmu/obj/fmi_adapter_rigid.o
	$(CC) $(FMU_CFLAGS) $(FMU_LDFLAGS) $^ -o $@ $(FMU_RIGID_LIBS)

fmus: $(BUILD)/fmu/fluid.so $(BUILD)/fmu/rigid.so

# Fuzzing the scene reader (README "Tests"): clang + libFuzzer with ASan and
# UBSan, objects of its own under build/fuzz/ (never mixed with gcc's). New
# corpus entries go to build/fuzz/corpus (seeded with models/*.yaml and
# tests/fuzz/corpus), crashes/leaks/timeouts to build/fuzz/.
FUZZ_SECONDS ?= 600
FUZZ_CC      := clang
FUZZ_SAN     := -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer
FUZZ_CFLAGS  := -std=c11 -D_POSIX_C_SOURCE=200809L -O1 -g $(FUZZ_SAN) -Wall -Wextra -Wpedantic $(WERROR) \
                $(shell pkg-config --cflags libcyaml yaml-0.1 2>/dev/null)
FUZZ_SRC     := common/status.c common/scene.c common/scene_schema.c common/scene_report.c common/scene_override.c \
                common/scene_build.c common/scene_check.c
fuzz_obj = $(patsubst %.c,$(BUILD)/fuzz/obj/%.o,$(1))

$(BUILD)/fuzz/obj/%.o: %.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer-no-link -MMD -MP -c $< -o $@

$(BUILD)/fuzz/fuzz_scene: $(call fuzz_obj,$(FUZZ_SRC) tests/fuzz/fuzz_scene.c)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer $^ -o $@ $(shell pkg-config --libs libcyaml yaml-0.1 2>/dev/null) -lm

fuzz:
	@tools/install-deps.sh fuzz
	@$(MAKE) --no-print-directory $(BUILD)/fuzz/fuzz_scene
	@mkdir -p $(BUILD)/fuzz/corpus
	@cp models/*.yaml $(BUILD)/fuzz/corpus/   # the scenes as seeds, beside tests/fuzz/corpus
	$(BUILD)/fuzz/fuzz_scene -max_total_time=$(FUZZ_SECONDS) -timeout=10 -rss_limit_mb=2048 -max_len=16384 \
	    -dict=tests/fuzz/scene.dict -artifact_prefix=$(BUILD)/fuzz/ -print_final_stats=1 \
	    $(BUILD)/fuzz/corpus tests/fuzz/corpus

clean:
	rm -rf $(BUILD)

-include $(shell find $(BUILD)/obj -name '*.d' 2>/dev/null)
-include $(shell find $(BUILD)/fmu/obj -name '*.d' 2>/dev/null)
-include $(shell find $(BUILD)/fuzz/obj -name '*.d' 2>/dev/null)
