"""Joint probabilistic data association (Fortmann, Bar-Shalom, Scheffe: Sonar tracking of multiple
targets using joint probabilistic data association, 1983): gating clusters and the marginal
association probabilities of tracks and detections."""
