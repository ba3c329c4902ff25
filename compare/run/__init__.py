"""The run stage: a scenario on one engine, every step recorded (:mod:`.trajectory`), the
quantities runs are compared in (:mod:`.quantities`), what happens in one run (:mod:`.events`,
:mod:`.outcomes`), each engine's ensemble from perturbed spawn poses (:mod:`.ensemble`) and the
one-step resync between engines (:mod:`.resync`). Imports the scenario stage alone."""
