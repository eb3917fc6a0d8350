"""Multi-person pose trackers: the constant-velocity baseline and the SMC pose tracker of Okada et
al. (2020)."""
