"""The multi-target point tracker and what its trackers share: the core (:mod:`.tracker`: track
table, life cycle, velocity prior, report), the association components (:mod:`.associator`: the
protocol and registry; :mod:`.gated`, :mod:`.second_chance`, :mod:`.merges`), gating and
assignment, and the sorting roll-out to the nozzle bar."""
