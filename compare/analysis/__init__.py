"""The analysis stage: figures from recorded runs, no words. Two runs diffed (:mod:`.diff`),
the verdict over both ensembles (:mod:`.verdict`), where the gap is born (:mod:`.events`), which
part parts first (:mod:`.parts`), outcome statistics (:mod:`.outcomes`). Imports the scenario and
run stages alone; the report stage words what it finds."""
