# mpmsim: `make run` and `make test` are the two commands in the README.
# Both create .venv if it is missing and install mpmsim (with test extras) into it.

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
DECK   ?= inputs/disks.yaml

.PHONY: run test validate bench fuzz bench-fem bench-fem-3d bench-rings-paper bench-impact3d-fine bench-contact bench-shock bench-interfaces bench-hertz bench-hertz-pair80 bench-hertz-sphere bench-hertz-fem bench-hertz-reference bench-oblique-fem bench-scaling examples docs clean-cache sweeps stability-table figures

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || \
		{ echo "mpmsim needs Python 3.11 or newer ($(PYTHON) is older)"; exit 1; }
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,cholmod]' 2>/dev/null || \
		{ echo "scikit-sparse (CHOLMOD) did not install: the implicit step will use its own LDL^T (apt install libsuitesparse-dev for CHOLMOD)"; \
		  $(BIN)/python -m pip install --quiet -e '.[test]'; }
	@touch $(STAMP)

run: $(STAMP)
	$(BIN)/mpmsim compile $(DECK)
	$(BIN)/mpmsim run $(DECK)

# The suite's two tiers (tests/tiers.py, docs/architecture.md "The test suite"), each on every core
# (pytest-xdist; TEST_WORKERS=0 for one process), each test module whole on one worker (its shared
# runs made once), the costliest modules first; the kernel cache filled first by two processes
# compiling disjoint halves (tests/warm.py); both close with the 20 slowest.
# make test: every code path, every deck stepped, the fingerprints, faults, and each validation at
# the coarsest resolution that still fails the wrong method (what CI runs; 12 minutes on 2 cores).
# make validate: the papers' resolutions, reference-code comparisons, convergence studies; writes
# the report results/validation.md (case, bound, measured, time) and prints it.
TEST_WORKERS ?= auto
PYTEST := $(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadscope --durations=20
test: $(STAMP)
	$(BIN)/python -m tests.warm
	$(PYTEST) -m "not validation"

validate: $(STAMP)
	$(BIN)/python -m tests.warm
	$(PYTEST) -m validation

bench: $(STAMP)
	$(BIN)/python bench/coldstart.py
	$(BIN)/python bench/checkpoint.py
	$(BIN)/python bench/contention.py
	$(BIN)/python bench/calibrate.py
	$(BIN)/python bench/compile_costs.py
	$(BIN)/python bench/column.py
	$(BIN)/python bench/column.py --deck bench/two_blocks.yaml --matrix-steps 0
	$(BIN)/python bench/traffic.py
	$(BIN)/python bench/fem_contact.py speed
	$(BIN)/python bench/implicit.py

# thread scaling of the explicit step, 1, 2, 4, ... threads up to the machine's cores, whole and
# per task, on the 1M, 256k and 16k columns, the 256k LR two-block column and the 640k 3D column
# (docs/performance.md); minutes on a many-core machine, long on two cores
bench-scaling: $(STAMP)
	$(BIN)/python bench/scaling.py --json scaling.json

# deck fuzzing: 5000 decks of inputs/ with one thing broken through check and run; the table of
# outcomes (docs/reliability.md), failures listed; about 8 minutes on one core
fuzz: $(STAMP)
	$(BIN)/python bench/fuzz.py --cases 5000 --seed 1 --out results/fuzz.csv

# FEM bodies with APIC augury and field contact: two blocks (conservation, gap, energy), the ramp 2D and 3D, where
# contact fails (charts in docs/figures/), speed; about 40 minutes on one core
bench-fem: $(STAMP)
	$(BIN)/python bench/fem_contact.py all

# the 3D ramp (the paper's Fig. 11 in 3D): augury APIC/PIC and field contact, h = 0.5, 0.25, three
# friction coefficients; about 15 minutes on one core (also part of bench-fem)
bench-fem-3d: $(STAMP)
	$(BIN)/python bench/fem_contact.py ramp3d

# the BFEMP paper's rings at its size (section 6.1: 20,109 particles on h = 8.66 mm, 3462 triangles), the whole
# 0.2 s run on 1 and 2 threads: seconds per step and the run's time (docs/bfemp.md); about 5 minutes
bench-rings-paper: $(STAMP)
	$(BIN)/python bench/implicit.py --paper-rings --threads 1 2

# the 3D impact (a 20 m/s MPM cube on a held FEM slab) at dt = T/10^4: 30,000 backward Euler steps over the whole
# impact, every step checked for particles or nodes inside a tetrahedron and for the momentum balance; about
# two hours on one core (docs/bfemp.md)
bench-impact3d-fine: $(STAMP)
	$(BIN)/python bench/implicit.py --impact3d 1e-4

# contact methods on the LR paper's problems: Fig. 5 errors, cost, charts in docs/figures/
# (about 10 minutes on 2 cores; `python bench/contact.py ellipses` adds full-size Fig. 6)
bench-contact: $(STAMP)
	$(BIN)/python bench/contact.py all

# the oblique impact without particles (docs/contact.md, "Friction from a touching start"): both bodies as
# finite elements, four levels, frictionless and mu = 0.3 (about 10 minutes on one core)
bench-oblique-fem: $(STAMP)
	$(BIN)/python bench/oblique_fem.py run --levels 0 1 2 3 --mu 0.3 0
	$(BIN)/python bench/oblique_fem.py table

# the LR paper's shock example: Hugoniot table, energy balance (incl. 0.125 mm cells), Fig. 7;
# figures in docs/figures/ (about 5 minutes on one core)
bench-shock: $(STAMP)
	$(BIN)/python bench/shock.py all

# Hertz contact (docs/contact.md): the ring-seeded cylinder on a rigid flat at R/h = 20, 40, 80, two cylinders at
# R/h = 20 and 40, the table and the chart (docs/figures/hertz_pressure.png); about 50 minutes on one core
bench-hertz: $(STAMP)
	$(BIN)/python bench/hertz.py run --rh 20 40 80 --seeding rings
	$(BIN)/python bench/hertz.py run --rh 20 40 --seeding rings --pair --end 0.9
	$(BIN)/python bench/hertz.py table --tags rh20_rings rh40_rings rh80_rings pair_rh20_rings pair_rh40_rings
	$(BIN)/python bench/hertz.py chart --tags rh20_rings rh40_rings rh80_rings

# two Hertz cylinders at R/h = 80, seeded in rings and in half-step rings, and the cylinder on the flat in
# half-step rings (about 16 + 16 + 5 minutes on one core each)
bench-hertz-pair80: $(STAMP)
	$(BIN)/python bench/hertz.py run --rh 80 --seeding rings --pair --end 0.9 --threads 1
	$(BIN)/python bench/hertz.py run --rh 80 --seeding rings_half_step --pair --end 0.9 --threads 1
	$(BIN)/python bench/hertz.py run --rh 80 --seeding rings_half_step --threads 1
	$(BIN)/python bench/hertz.py table --tags pair_rh80_rings pair_rh80_rings_half_step rh80_rings_half_step

# a quarter Hertz sphere on a rigid flat, R/h = 20, lattice-seeded and seeded in shells (3D; about 6 + 10 minutes
# on one core)
bench-hertz-sphere: $(STAMP)
	$(BIN)/python bench/hertz.py run --rh 20 --sphere
	$(BIN)/python bench/hertz.py run --rh 20 --sphere --seeding shells

# the Hertz cylinder through the FEM contact families: an FEM cylinder on an FEM block by augury contact
# (R/h = 20, 40; h_c = 2h and h), an MPM cylinder on it by the implicit barrier contact (R/h = 20, 40, 80);
# about 10 minutes on one core
bench-hertz-fem: $(STAMP)
	$(BIN)/python bench/hertz.py run --augury --rh 20 40 --threads 1
	$(BIN)/python bench/hertz.py run --augury --rh 20 --hc 1 --threads 1
	$(BIN)/python bench/hertz.py run --barrier --rh 20 40 80 --threads 1

# the finite-element reference of the Hertz cylinder (the same half-disk and gravity load, exact frictionless
# contact; docs/contact.md): small-strain (contact along the normal or vertical, circle or parabola gap) at four
# levels, the finite-strain laws at three (four for hypo_log and neo_hookean), a/R = 0.2 and 0.05; the two stacked
# cylinders (small strain at four levels, hypo_log at two); the sphere in r-z (a/R = 0.1: small strain, both contact
# forms, four levels; hypo_log at three); about 40 minutes on one core
bench-hertz-reference: $(STAMP)
	$(BIN)/python bench/hertz_reference.py run --levels 0 1 2 3 --a 2
	$(BIN)/python bench/hertz_reference.py run --levels 0 1 2 3 --a 2 --direction vertical
	$(BIN)/python bench/hertz_reference.py run --levels 0 1 2 3 --a 2 --gap parabola
	$(BIN)/python bench/hertz_reference.py run --levels 0 1 2 3 --a 2 --gap parabola --direction vertical
	$(BIN)/python bench/hertz_reference.py run --levels 0 1 2 --a 0.5
	$(BIN)/python bench/hertz_reference.py run --levels 0 1 2 --a 0.5 --direction vertical
	for m in hypo_log neo_hookean; do $(BIN)/python bench/hertz_reference.py run --levels 0 1 2 3 --a 2 --model $$m || exit 1; done
	for m in svk hencky; do $(BIN)/python bench/hertz_reference.py run --levels 0 1 2 --a 2 --model $$m || exit 1; done
	for m in hypo_log neo_hookean; do $(BIN)/python bench/hertz_reference.py run --levels 0 1 2 --a 0.5 --model $$m || exit 1; done
	$(BIN)/python bench/hertz_reference.py run --pair --direction vertical --a 2 --levels 0 1 2 3
	$(BIN)/python bench/hertz_reference.py run --axisymmetric --a 1 --levels 0 1 2 3
	$(BIN)/python bench/hertz_reference.py run --axisymmetric --a 1 --levels 0 1 2 3 --direction vertical
	$(BIN)/python bench/hertz_reference.py run --axisymmetric --a 1 --levels 0 1 2 --model hypo_log
	$(BIN)/python bench/hertz_reference.py run --pair --direction vertical --a 0.5 --levels 0 1 2
	$(BIN)/python bench/hertz_reference.py run --pair --direction vertical --a 2 --levels 0 1 --model hypo_log
	$(BIN)/python bench/hertz_reference.py run --pair --direction vertical --a 2 --levels 0 --model hypo_log --segment
	$(BIN)/python bench/hertz_reference.py table

# imperfect interfaces: the 2013 paper's specimens swept (hours on 2 cores; resumes), the chart
# in docs/figures/interfaces.png, and the cost of an interface
bench-interfaces: $(STAMP)
	$(BIN)/python bench/interfaces.py all --workers 2
	$(BIN)/python bench/interfaces.py cost

# every deck in inputs/, as a batch; a summary line per deck
examples: $(STAMP)
	@status=0; for deck in inputs/*.yaml; do \
		printf '%-40s ' "$$deck"; \
		if $(BIN)/mpmsim run "$$deck" --quiet; then echo ok; else echo "FAILED (exit $$?)"; status=1; fi; \
	done; exit $$status

# error against cost: every sweep in inputs/sweeps/ (resumes; results/sweeps/<name>/), its CSV
# and charts copied to docs/figures/sweep_<name>*
JOBS   ?= 2
SWEEPS := column bar augury side_by_side side_by_side_rings
sweeps: $(STAMP)
	@for s in $(SWEEPS); do \
		NUMBA_NUM_THREADS=1 $(BIN)/mpmsim sweep inputs/sweeps/$$s.yaml --jobs $(JOBS) || exit 1; \
		for f in results/sweeps/$$s/$$s*.png results/sweeps/$$s/$$s.csv; do \
			cp "$$f" "docs/figures/sweep_$$(basename $$f)"; done; \
	done

# the stability suite's table (docs/stability-suite.md), measured
stability-table: $(STAMP)
	NUMBA_NUM_THREADS=1 $(BIN)/python -m tests.stability.report docs/stability-suite.md

# every PNG in docs/ from the decks and sweeps; one target per figure group, so a new
# figure is one more entry in FIGURES and one more rule
FIGURES := figure-contact figure-sweeps figure-column-history figure-shock figure-interfaces figure-buckling figure-gallery figure-tutorial
figures: $(FIGURES)
.PHONY: $(FIGURES)

figure-contact: bench-contact

figure-sweeps: sweeps

figure-shock: bench-shock

# the interface sweeps resume from results/bench_interfaces/; a first run takes hours
figure-interfaces: bench-interfaces

# the stacked semicircular rings for three friction coefficients (about 7 minutes on one core)
figure-buckling: $(STAMP)
	$(BIN)/python bench/implicit.py --buckling

# the gallery's pictures (docs/gallery.md) and the README's: disks, oblique_impact, taylor_bar_rz,
# fem_ramp_2d and sphere_composite_rz run on one thread into results/gallery/ (reused when complete),
# frames drawn to docs/figures/gallery_*.png; under a minute to about three a deck on one core
figure-gallery: $(STAMP)
	NUMBA_NUM_THREADS=1 $(BIN)/python bench/gallery.py

# the tutorial's pictures (docs/tutorial.md), made by running the tutorial as written in a temporary
# folder (needs ParaView's pvbatch and xvfb-run): docs/figures/tutorial_paraview.png and
# tutorial_energy.png; about a minute
figure-tutorial: $(STAMP)
	NUMBA_NUM_THREADS=1 $(BIN)/python bench/tutorial_figures.py

figure-column-history: $(STAMP)
	$(BIN)/mpmsim run inputs/column.yaml --quiet --out results/column
	$(BIN)/mpmsim run inputs/two_blocks.yaml --quiet --out results/two_blocks
	$(BIN)/mpmsim plot results/column/column_history.csv results/two_blocks/two_blocks_history.csv \
		--x "-u_platen_y / 100" --xlabel "axial strain (platen displacement / 100 mm)" \
		--y syy --ylabel "syy [MPa]" --out docs/figures/column_syy.png

docs: $(STAMP)
	$(BIN)/python -m mpmsim.deck.reference > docs/deck-reference.md

# numba caches kernels next to the sources (emptied by mpmsim itself when its sources change); clear by hand
clean-cache:
	find mpmsim -name '*.nbi' -delete -o -name '*.nbc' -delete
