"""The probabilistic pose predictor of Okada et al. (2020): network, batched predictor and training recipe."""
