"""The revision of the solver's results, per forcing quadrature: the promise "same case id, same data".

A study reuses a finished case when its id matches, and the id hashes the case's parameters,
settings and output request, not the code. So whenever a change of the code changes any result
of a run at the same parameters and settings (not a refactoring that keeps them bit for bit),
the revision of the rule whose runs changed is bumped here: cases stored under an older
revision get new ids and are recomputed, never reused.

A bump is not left to memory: tests/test_results_revision.py runs a fixed set of cases (both
rules; adaptive, fixed-step, RK4, DOP853, bottoming, crack onsets, finite depth, a free body,
off-centre, viscoelastic, a wedge, a free floe) and compares a hash of every output array with
the fingerprint recorded on the same machine (tests/data/results_fingerprint.json; results are
bit for bit reproducible on one machine with one set of libraries). A change of results at an
unchanged revision fails it; after a bump, ``make fingerprint`` records the new fingerprint.

History: paper 0 (its case ids carry no revision); gauss 2 (2026-11-25: the energy guard allows a
step's work only from first touch; contact changes placed on the continuous plate); paper 1 and
gauss 3 (2026-11-27: max_force and max_compression located inside the steps,
solver.observe.layer_maxima; every other output bit for bit); floe 1 (2026-11-27: a free floe's
results have a revision of their own, which its case ids carry beside the rule's: its modal sums
O(N) a point from the dry modes' coefficients, its norms in closed form; the contact-resolving
rule on a floe); floe 2 (2026-11-27: a floe's tension maxima located on the dense output,
solver.observe.dense_maxima); paper 2, gauss 4 and floe 3 (2026-11-27: the impact zone sampled on
the dense output in every step that does not resolve the modes or in which its peak changes,
as a floe's was, for its tension records (crack onset in the zone): the walls' zone maxima at the
zone's edge move to DOP853's, 1.9e-7 from it where they were 2e-4; every other output bit for bit);
dop853 1 (2026-11-28: the DOP853 reference runs the kernels' own observers on its dense output,
solver.scipy_reference: its tension records, crack onsets, contact record and zone maxima change;
its runs carry this revision beside their rule's, and no run of the kernels changed);
paper 3, gauss 5, floe 4 and dop853 2 (2026-11-28: the contact's reach peaks between the ends of
steps that resolve the modes located, solver.observe.reach.peak_at_end: contact_extent and the
impact zone's values that its ends move change; a floe's reach 1.9e-8 from DOP853's at a fixed
step of 2.5e-4 t_sc, now 7.7e-11); smoothness 1 (2026-11-28: etd34's smoothness control, the
default from then, with the error norm's floor at solver.control.SMOOTH_FLOOR = 0.01 of the
embedded control's and a free body's velocity judged by it too; its runs carry this revision
beside their rule's; the embedded control's runs unchanged, at its own default tolerance 1e-9,
solver.settings.DEFAULT_TOLERANCE); breaking 1 (2026-11-29: a run that breaks, fracture = "break",
carries this revision beside its rule's: a broken plate's part edges within the contact bound
(solver.model.contact.edges_reachable), its contacts strictly between two points seen
(solver.model.contact_edges._island), a restarted run's energy residuals relative to the energy
it starts with plus its largest work; no unbroken run changed); breaking 2 and dop853 3 (2026-12-06:
a run that breaks counts the whole plate's parts right (the centre's break and a pair at +-x make
4 parts, not 6: max_parts ends runs later), its tension records end at the yield strain at each
break (crack onset at eps_Y = yield_strain is the break, it was NaN), each break's energy split
into the plate's and the layer's; DOP853's energy residuals taken at every step's end from the
energy it starts with (a later stage's were taken at the output times from the first one's:
6.7e-2 where the identity held to 1.5e-12); no run of the kernels that does not break changed);
breaking 3 (2026-12-06: a run that breaks takes each diagnostic by the join solver.outputs declares
for it: the impact zone's at-edge flags are the stage's whose zone maximum is the run's, not the
last stage's; no other value changed, make bit-for-bit BASE=f0ab5a4 on five breaking runs);
breaking 4 (2026-12-06: a broken plate's added mass sums 2048 cosines and its tail to second
order, 1.1e-13 of its largest entry where 16384 cosines and the first order's mean gave 2.2e-12;
make bit-for-bit BASE=715892f: break times and places within 6e-9, the strain within 4e-7 of its
largest, the removed energy within 3e-6, the runs' own error; no unbroken run changed);
breaking 5 (2026-12-07: a run that breaks samples every step whose peak is within half the break
level, searches the global peak at the samples, arms a surface at a sample below the level, and
scans a located break at the observer's largest tension (solver.observe.tension.watch_level,
solver.observe.events.locate_event): breaks a step hid are found, the runs where one was change;
make bit-for-bit BASE=3d3d27b: all 30 cases, the 5 that break included, bit for bit); breaking 6
(2026-12-07: a surface not yet armed is scanned for its break at its largest tension after its
first sample below the level, not at the step's largest (the overshoot at the step's start);
make bit-for-bit BASE=503afef: all 30 cases bit for bit); breaking 7 (2026-12-07: a broken
plate's tables and carries run BLAS on one thread (solver.blas.blas_alone): their round-off
no longer depends on how many threads BLAS takes on the machine; make bit-for-bit BASE=29e6175:
the whole plate's breaking case within 9e-9 of its largest values (its strain field; break times 4e-10), the other 29 bit for bit);
breaking 8 (2026-12-07: a broken plate's modes at a point take a part's evenly spaced
wavenumbers by rotation and their exponentials by products, solver.model.points._part_sums;
make bit-for-bit BASE=8b40335: the 5 breaking cases within 6.1e-9 of their largest values, the
25 others bit for bit); breaking 9 (2026-12-07: a broken plate's tables and carries take the parts'
mode values from the kernels' table (solver.model.points.parts_table: a part's evenly spaced
wavenumbers by rotation, within 2e-13 of numpy's direct values, solver.model.parts.part_values);
make bit-for-bit BASE=6625207: the 5 breaking cases within 3.9e-9 of their largest values, break
times within 1.2e-11, the 25 others bit for bit); breaking 10 (2026-12-07: a stage whose cracks open at
once grows its steps by the PI control, its GROWTH cap counted from the run's first touch,
solver.breaking._growth_from: another step sequence, within the runs' tolerance); breaking 11
(2026-12-07: a broken plate's modes' means over their parts in closed form, parts.mode_means;
make bit-for-bit BASE=17c6cd2: the 5 breaking cases within 1.1e-7 of their largest values, the
25 others bit for bit); breaking 12 (2026-12-07: where the tension reaches the yield strain at a
wall the ice breaks off it and the run goes on (docs/model.md, "A break at a wall"; it ended
wall_break), a plate broken everywhere within its crack spacing breaks no more, and places whose
tension reaches the yield strain together (within 1e-9) break at one instant (solver.breaking.
_racing): the runs where any of these happened change; make bit-for-bit BASE=8218cbd and
BASE=3bbd6a8: the 30 cases bit for bit); breaking 13 (2026-12-07: a broken plate with edge shapes
keeps the edge shapes its parts' modes and the shapes before them do not nearly span, each at unit
mass, and takes the volume constraint by eliminating amplitudes (solver.model.broken.shaped_span,
eliminated): its slowest wet modes were up to 2.5 % off, now as on the parts' modes alone within
1e-11; a part too short for a whole-part shape at beta_max takes none; edge_shapes > 0 needs a
crack spacing with cracks that open over a time too: the runs with edge shapes change, no other);
paper 4 and gauss 6 (2026-12-07: the tension's global peak at a step's ends and where a break is
scanned refines every local peak of the nodes within the most a peak between nodes can stand above
them, solver.model.peak_margin.competing, not only those within 2 % of the largest node: on the reference case that breaks the 2 % missed
the global peak at 2 of 7200 samples at N = 60 and 136 of 3600 at N = 120, by up to 12.7 %; a run
where a step's global peak was missed changes, under either rule (and so every floe, DOP853,
smoothness and breaking run's id, which carry the rule's revision); make bit-for-bit BASE=187f4a3:
all 30 cases bit for bit, and the reference case unbroken at N = 120 and 240 and breaking at 120);
breaking 14 (2026-12-08: a broken plate's cosine integrals near resonance in a closed form that keeps
its digits, solver.model.resonance, not Gauss-Legendre mode by mode (within 7e-14 of it), and its
hat weights the wet modes' combination of each part's dry ones: its tables 3 times faster at N = 240,
every breaking run moved at round-off; make bit-for-bit BASE=97ed0fa: the 5 breaking cases within
1.9e-7 of their largest values (the off-centre case's strain after its fourth break), break times
within 5.9e-9, the 25 others bit for bit).
"""

#: quadrature -> revision of the results of runs under it; "floe": of a free floe's runs (under
#: either rule, in addition to the rule's); "dop853": of the DOP853 reference's runs (in addition);
#: "smoothness": of etd34's adaptive runs under the smoothness control (in addition); "breaking":
#: of the runs in which the ice breaks (in addition)
RESULTS_REVISION = {"paper": 4, "gauss": 6, "floe": 4, "dop853": 3, "smoothness": 1, "breaking": 14}
