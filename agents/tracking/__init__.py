"""What the multi-target point trackers share: gating and assignment, blob sharing at merges and the
sorting roll-out to the nozzle bar."""
