# bench/bench.mk - the benchmarks' make rules, included by the top Makefile after its
# library, reader and test rules (they use its B, CC, CFLAGS, LDLIBS, LIB_SRC, CLI_SRC,
# DATA and deps).  Every benchmark measures ratios run side by side on the same machine
# (docs/performance.md); none is part of `make test`, which builds picvr-bench-error only
# for its --self-test.  `make help` lists the targets.
.PHONY: bench-speed bench-scheduler bench-long-run bench-hit-rate bench-sampling bench-sampling-paper bench-paths bench-frames \
        bench-field

# ---- programs ---------------------------------------------------------------------------
# The programs read raw and NRRD files alone: IO_RAW_SRC, without niftilib, GDCM and OpenVDB.
$(B)/picvr-bench-speed: bench/bench_speed.c $(CLI_SRC) $(IO_RAW_SRC) $(IO_HDR) reference/cpu_reference.h $(B)/cpu_reference.o $(B)/libpicvr.a
	$(CC) $(CFLAGS) -fopenmp -Icli -o $@ bench/bench_speed.c cli/cli.c $(IO_RAW_SRC) $(B)/cpu_reference.o $(B)/libpicvr.a $(LDLIBS) -lz

$(B)/picvr-bench-sampling: bench/bench_sampling.c $(CLI_SRC) $(IO_RAW_SRC) $(IO_HDR) cli/presets.c cli/presets.h $(B)/libpicvr.a
	$(CC) $(CFLAGS) -Icli -o $@ bench/bench_sampling.c cli/cli.c $(IO_RAW_SRC) cli/presets.c $(B)/libpicvr.a $(LDLIBS) -lz
# ---- side-by-side benchmarks ------------------------------------------------------------
bench-speed: deps $(B)/picvr-bench-speed
	$(B)/picvr-bench-speed --volume $(DATA)/bonsai_256x256x256_uint8.raw.gz

bench-scheduler: deps $(B)/picvr-render
	DATA=$(DATA) sh bench/scheduler.sh $(SECS)

bench-long-run: deps $(B)/picvr-render
	DATA=$(DATA) sh bench/long_run.sh $(SECS)

bench-hit-rate: deps $(B)/picvr-render
	DATA=$(DATA) sh bench/hit_rate.sh $(SECS)

# The sampling family (docs/sampling.md, "The family"): the forced point
# (PICVR_DISTANCE_FORCED) against the default sampler (MIS with equiangular sampling
# alone), side by side, on the thin medium at optical depths 0.1, 1 and 10 under each family
# light (point lights at 1.2, 2, 4 and 8 bounding-sphere radii, a sphere, a rect, the
# sun, a white sky, an environment map), then on the data sets, single and multiple
# scattering (~35 min on the 2-core machine).
FAMILY_SCENES := $(foreach d,0.1 1 10,$(foreach l,pt1.2 pt2 pt4 pt8 sphere rect sun sky env,fam-$(d)-$(l)))
comma := ,
empty :=
space := $(empty) $(empty)
bench-sampling: deps $(B)/picvr-bench-sampling
	$(B)/picvr-bench-sampling --data $(DATA) --before mis --after forced --size 128x128 --time 8000 --ref-time 32000 \
	    --scenes $(subst $(space),$(comma),$(FAMILY_SCENES)) --out bench/results/sampling/family
	$(B)/picvr-bench-sampling --data $(DATA) --before mis --after forced --size 128x128 --time 15000 --ref-time 60000 \
	    --scenes bonsai,engine,cloud,cloud-sky --out bench/results/sampling/family-data

# The paper's sampler (delta tracking, ratio tracking) against the defaults, on the thin
# medium at 256x256 and the data sets at 128x128 (~25 min).
bench-sampling-paper: deps $(B)/picvr-bench-sampling
	$(B)/picvr-bench-sampling --data $(DATA) --scenes thin --size 256x256 --time 90000 \
	    --ref-time 320000 --out bench/results/sampling/thin
	$(B)/picvr-bench-sampling --data $(DATA) --scenes bonsai,bonsai-paper4,engine,engine-paper1,cloud \
	    --size 128x128 --time 30000 --ref-time 120000 --out bench/results/sampling/data

# The engine's case: orbiting real-time frames of the cloud, temporal reuse off and on,
# true error at three frames (docs/engines.md; ~6 min on lavapipe).
# The light field (docs/field.md): per grid ratio and D, build and rebuild times (a sun
# move, a transfer-function change), frame times at three sizes and the error against
# a converged Monte-Carlo image, on the cloud under sun-sky (unlimited bounces) and the
# bonsai and the aneurism (~20 min on the 2-core machine).
bench-field: deps $(B)/picvr-bench-sampling
	$(B)/picvr-bench-sampling --data $(DATA) --scenes cloud-sky,bonsai,aneurism --size 320x180 \
	    --field 8:32,8:64,4:32 --time 60000 --ref-time 90000 --ref-chunks 6 --out bench/results/field

bench-frames: deps $(B)/picvr-bench-sampling
	$(B)/picvr-bench-sampling --data $(DATA) --scenes cloud-sky --size 320x180 --frames 30 --frame-ms 16 \
	  --orbit 1 --checkpoints 3 --ref-time 90000 --ref-chunks 3 --out bench/results/frames

# The path tracer: error against run time with 0, 1, 4 and unlimited bounces, each
# against its own reference (docs/paths.md; ~25 min).
bench-paths: deps $(B)/picvr-bench-sampling
	$(B)/picvr-bench-sampling --data $(DATA) --scenes cloud-sky,bonsai --size 128x128 --time 30000 \
	    --ref-time 120000 --bounces 0,1,4,unlimited --out bench/results/paths

# ---- error against run time ---------------------------------------------------------
# bench/error/ (main.c says what it measures); scenes in bench/scenes.txt; references
# in bench/refs/ (committed: luminance only, compressed, a few MB); results (CSV,
# Markdown, gnuplot scripts and PNGs) in bench/results/ for `make bench`,
# bench/results/full/ for `make bench-full`, bench/results/best/ for `make bench-best` and
# bench/results/auto/ for `make bench-auto`, bench/results/ms/ for `make bench-ms`.
# Both resume: finished runs (bench/results/**/runs/) and reference chunks are reused.
# Exit status 3: a reference was not converged enough and its scene was left out.
.PHONY: bench bench-full bench-best bench-bias bench-auto bench-ms
BENCH_NICE ?= nice -n 15
BENCH_OUT ?= bench/results
BENCH_ARGS ?= --datasets bonsai --lights paper1 --size 128x128 --time 10000 --slice 200 \
              --repeats 3 --rotate 4000 --after 6000 --conditions plain,object,auto \
              --ref-chunk 30000 --ref-factor 3 --ref-max-chunks 40
# The reduced matrix of this machine: every dataset x the three light set-ups x
# background off/on (24 scenes) at 320x180, plain against the object-space cache and the
# automatic mode, 30 s, one seed; references of 4 chunks of 30 s, at least 1.5x below the
# runs' error (their own variance is taken out of every error, so a reference that close
# still gives an unbiased error): about 1.7 hours on 2 cores.
BENCH_FULL_OUT ?= bench/results/full
BENCH_FULL_ARGS ?= --size 320x180 --time 30000 --slice 500 --repeats 1 --rotate 8000 \
              --after 22000 --fig10 bonsai --conditions plain,object,auto --ref-chunk 30000 --ref-factor 1.5 \
              --ref-max-chunks 12 --bias none
# The paper's best case on this machine: large intense lights with a background light
# (bonsai, paper3-bg), 300 s per run at 320x180, plain, the object-space cache and the
# automatic mode; the reference (16 chunks, 910 s; committed) is rendered before the
# runs, so that it need not grow after them.  About 16 minutes with the committed
# reference, 30 without.
BENCH_BEST_OUT ?= bench/results/best
BENCH_BEST_ARGS ?= --datasets bonsai --lights paper3-bg --size 320x180 --time 300000 \
              --slice 2000 --repeats 1 --rotate 0 --conditions plain,object,auto --ref-chunk 60000 \
              --ref-min-chunks 16 --ref-factor 1.5 --ref-max-chunks 40 --bias none

# The automatic mode against plain over the reduced matrix with five seeds (the first is
# bench-full's, its run files reused): the worst ratio is taken at the geometric mean of
# the seeds' errors, so that one run's stall on this shared machine weighs a fifth in a
# row's worst.  About 1.7 hours after bench-full.
BENCH_AUTO_OUT ?= bench/results/auto
BENCH_AUTO_ARGS ?= --size 320x180 --time 30000 --slice 500 --repeats 5 --rotate 0 \
              --conditions plain,auto --ref-chunk 30000 --ref-factor 1.5 --ref-max-chunks 12 --bias none

# The multiply scattered cache (bench/scenes_ms.txt: the cloud as its preset renders it,
# albedo 0.99, g 0.8, unlimited bounces, sun and sky): plain path tracing against the
# object-space cache looked up at a path's first scatter event (object) and at its second
# (object-k2, cache.lookup_event 2), 60 s per run at 320x180, two seeds; bench/results/ms_cache.csv
# sums it up (bench/ms_cache_csv.py).
BENCH_MS_OUT ?= bench/results/ms
BENCH_MS_ARGS ?= --scenes bench/scenes_ms.txt --size 320x180 --time 60000 --slice 1000 --repeats 2 \
              --rotate 0 --conditions plain,object,object-k2 --ref-chunk 60000 --ref-factor 1.5 \
              --ref-max-chunks 30 --bias cloud-ms,bonsai-ms,engine-ms

# The library's sources as one checksum: the bench's run files carry it, so that a run
# made with other library code is never reused (bench/error/runs.c, run_signature).
BENCH_BUILD = $(shell cat $(LIB_SRC) shaders/*.glsl shaders/*.comp | cksum | cut -d' ' -f1)
BENCH_ERROR_SRC := $(wildcard bench/error/*.c)
$(B)/picvr-bench-error: $(BENCH_ERROR_SRC) bench/error/bench_error.h $(CLI_SRC) $(IO_RAW_SRC) $(IO_HDR) cli/presets.c cli/presets.h $(B)/libpicvr.a
	$(CC) $(CFLAGS) -Wno-format-truncation -Icli -DPICVR_BENCH_BUILD='"$(BENCH_BUILD)"' -o $@ $(BENCH_ERROR_SRC) cli/cli.c $(IO_RAW_SRC) cli/presets.c $(B)/libpicvr.a $(LDLIBS) -lz

$(B)/picvr-bench-fig9: bench/bench_fig9.c $(CLI_SRC) shaders/cache_math.glsl reference/cache_math_host.h | $(B)/.deps
	$(CC) $(CFLAGS) -Icli -o $@ bench/bench_fig9.c cli/cli.c -lm

# gnuplot only for the benchmark plots, so `make test` does not need it.
$(B)/.bench-deps: tools/install-deps.sh | $(B)/.deps
	@sh tools/install-deps.sh gnuplot-nox
	@touch $@

# $(1): arguments, $(2): output folder.  Plots are drawn even when a scene was refused.
define run_bench
	$(B)/picvr-bench-error --self-test && mkdir -p $(2) && \
	$(BENCH_NICE) $(B)/picvr-bench-fig9 --out $(2) && \
	$(BENCH_NICE) $(B)/picvr-bench-error --data $(DATA) $(1) --out $(2); rc=$$?; \
	for f in $(2)/*.gp; do [ -f "$$f" ] && (cd $(2) && gnuplot $$(basename $$f)); done; \
	echo "results in $(2)"; exit $$rc
endef

bench: deps $(B)/.bench-deps $(B)/picvr-bench-error $(B)/picvr-bench-fig9
	@$(call run_bench,$(BENCH_ARGS),$(BENCH_OUT))

bench-full: deps $(B)/.bench-deps $(B)/picvr-bench-error $(B)/picvr-bench-fig9
	@$(call run_bench,$(BENCH_FULL_ARGS),$(BENCH_FULL_OUT))

bench-best: deps $(B)/.bench-deps $(B)/picvr-bench-error $(B)/picvr-bench-fig9
	@$(call run_bench,$(BENCH_BEST_ARGS),$(BENCH_BEST_OUT))

bench-ms: deps $(B)/.bench-deps $(B)/picvr-bench-error $(B)/picvr-bench-fig9
	@$(call run_bench,$(BENCH_MS_ARGS),$(BENCH_MS_OUT))
	python3 bench/ms_cache_csv.py $(BENCH_MS_OUT) > bench/results/ms_cache.csv

bench-auto: deps $(B)/.bench-deps $(B)/picvr-bench-error $(B)/picvr-bench-fig9
	@mkdir -p $(BENCH_AUTO_OUT)/runs && cp -u $(BENCH_FULL_OUT)/runs/*_plain_r0.csv $(BENCH_FULL_OUT)/runs/*_auto_r0.csv $(BENCH_AUTO_OUT)/runs/ 2>/dev/null; \
	$(call run_bench,$(BENCH_AUTO_ARGS),$(BENCH_AUTO_OUT))

# The bias of a full cache (issue 3): bonsai, paper1, 128x128; plain (the control) and
# both lockings from an empty cache for 30 s, and both lockings after a 90 s warm-up at a
# 0.85 creation share (--bias-warm), 3 seeds each; with the library's defaults (the
# medium model on: bias.md/.csv in bench/results/cache/), the paper's Eq. 6, 7 literally
# (bench/results/cache-paper/) and the curvature limit on the paper's model
# (bench/results/cache-curvature/).  About 55 minutes on 2 cores (the reference is
# shared with `make bench`).
BENCH_BIAS_ARGS ?= --datasets bonsai --lights paper1 --size 128x128 --conditions plain \
              --repeats 3 --time 10000 --slice 200 --rotate 0 --bias bonsai --bias-time 30000 \
              --bias-warm 90000 --ref-chunk 120000 --ref-max-chunks 40
bench-bias: deps $(B)/picvr-bench-error
	mkdir -p bench/results/cache bench/results/cache-paper bench/results/cache-curvature
	$(BENCH_NICE) $(B)/picvr-bench-error --data $(DATA) $(BENCH_BIAS_ARGS) --out bench/results/cache
	$(BENCH_NICE) $(B)/picvr-bench-error --data $(DATA) $(BENCH_BIAS_ARGS) --medium off \
	    --out bench/results/cache-paper
	$(BENCH_NICE) $(B)/picvr-bench-error --data $(DATA) $(BENCH_BIAS_ARGS) --medium off \
	    --curvature on --out bench/results/cache-curvature
